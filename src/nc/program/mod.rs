//! Reading a program as the control runs it, before anything is compensated. The reader
//! produces:
//!
//! - the blocks the control runs ([`as_run`]): the file's blocks read into words (`parse`),
//!   subprogram calls whose body is in the file run in place (`subprograms`), canned drilling
//!   cycles turned into their rapid and feed moves (`cycles`) and coordinate rotations (G68)
//!   applied to the moves they turn (`rotation`); what volmap does not follow under
//!   tool-centre-point control (G43.4, G43.5, G234) refused (`tcpm`);
//! - codes that set coordinates and move nothing (G10, G52, G92) applied to the offsets
//!   (`settings`), and the axes a block volmap does not follow leaves unknown (`unknown`);
//! - the modal state before the first block and after each block (`modal`, `reader`): motion,
//!   plane, distance, units, work offset and tool, where the program has the tool, and whether
//!   the block moves it and where to;
//! - the intended path of each move, straight or an arc, as a function of the fraction of the
//!   move (`toolpath`), and the direction each axis approaches every point of it in, the move
//!   cut where an axis turns (`approach`).
//!
//! Nothing here knows the compensation: the compensation (the rest of `nc`) reads programs
//! through these.

pub(super) mod approach;
mod cycles;
pub(super) mod modal;
pub(super) mod offsets;
pub mod parse;
pub(super) mod reader;
mod rotation;
pub(super) mod settings;
mod subprograms;
pub(super) mod tcpm;
pub(super) mod toolpath;
pub(super) mod unknown;

pub use cycles::MAX_PECKS;
pub use subprograms::MAX_EXPANDED_WORDS;

use crate::nc::error::NcError;
use cycles::expand_cycles;
use parse::{parse_program, Line};
use rotation::apply_rotations;
use subprograms::{expand_subprograms, Room};

/// The program as the control runs it: its blocks read, subprogram calls and canned cycles
/// expanded, coordinate rotations applied; and the number of cycle holes expanded. The work
/// offsets carry a cycle's initial level over a change of offset.
pub(super) fn as_run(
    program: &[u8],
    path: &str,
    pass_unknown: bool,
    work_offsets: &offsets::WorkOffsets,
) -> Result<(Vec<Line>, usize), NcError> {
    let read = parse_program(program, path, pass_unknown)?;
    let own_blocks = read.len();
    // What calls and cycles together may add, and what rotating the blocks they add takes.
    let mut room = Room::new();
    let lines = expand_subprograms(read, path, pass_unknown, &mut room)?;
    tcpm::check_program(&lines, path)?;
    let (lines, holes) = expand_cycles(lines, path, pass_unknown, work_offsets, &mut room)?;
    Ok((apply_rotations(lines, path, own_blocks, &mut room)?, holes))
}
