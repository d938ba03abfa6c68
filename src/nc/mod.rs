//! Offline NC program compensation (Dobariya, Patel and Jani 2015): the coordinates of an ISO 6983 /
//! Fanuc-style part program are rewritten so that the real tool tip lands where the program
//! wants it.
//!
//! Frames: program coordinates are the work coordinate system of the active work offset
//! (G54–G59), in mm or inch; the machine is commanded at `q = program + work offset` (mm and
//! degrees), which is docs/model.md's commanded position. The programmed point is where the ideal
//! machine puts the tool tip, `ideal(q)`; the compensated command `q'` is the one whose real tool
//! tip lands there, `real(q') = ideal(q)` (workpiece frame), found by Newton steps with the ideal
//! machine's Jacobian in X, Y, Z (exact: the nominal tip is affine in them) until it agrees to
//! 1e-9 mm. Rotary axes stay as programmed: on a five-axis machine the tool tip is put back
//! where it belongs with the rotary axes where the program has them; the tool's orientation error
//! is not corrected (rotary words are never changed) unless the orientation is compensated too
//! (`orientation_tolerance_rad`, see `orientation`): then X, Y, Z and the two rotary axes are
//! solved together so that the real tool tip is the ideal one and the real tool axis is the ideal
//! one as far as a bounded turn of the rotary axes reaches (`max_rotary_correction_deg`; near a
//! singular pose what it leaves is reported, never refused), and the rotary words are rewritten
//! (with at least 6 decimals of a degree, 9e-9 rad).
//!
//! Between points the control interpolates the compensated commands. A feed move (G1, G2, G3) is
//! split until the real tool tip along every piece stays within the chord tolerance of the
//! intended path at the same fraction of the move (sampled along each piece); an arc stays an
//! arc (with compensated ends and centre) when that already keeps it within the tolerance, and
//! is split into compensated arcs otherwise (`arcs`). Every piece is planned and checked as the
//! output writes it (rounded). Rapid moves (G0) get compensated end points and are not split:
//! the control does not hold their path. `trace` samples the model along a program.
//!
//! Evaluation inputs (docs/model.md): the machine is at the options' temperatures for the whole
//! program; every point is compensated for the approach direction of each axis there, taken
//! from the programmed path (`approach`): the direction the axis moves in on the move, or at
//! that point of an arc, or of its last move where it does not move (the options' initial
//! directions before its first). Where an axis with a reversal error reverses, at the start of
//! a move or at an arc's turning point, a take-up piece moves the command from the point
//! compensated for the old direction to the same point compensated for the new one.
//!
//! Before any of this the program is read as the control runs it (`program`): subprogram calls
//! whose body is in the file are run in place and canned drilling cycles become the rapid and
//! feed moves the control makes of them, each then compensated like any move.
//!
//! Layout: `program` reads programs and knows nothing of the compensation; the compensation
//! builds on it, each file on those below it: `kinematics` (the machine per tool), `orientation`
//! (the tool axis solved with the rotary axes), `tcpm` (the nominal kinematics of programs written
//! for tool-centre-point control: their points as machine commands and back, G43.5's tool vector
//! solved for the rotary axes), `write` (the output's words), `block` (one
//! block's points compensated), `walk` (the pieces of a move), `arcs` (arcs kept or split into compensated arcs),
//! `compensate` (the run over the program), `trace` (the model along a program), `untraced` (the
//! moves left alone after blocks volmap does not follow), `check` (the written program read back
//! and walked beside the original, knowing nothing of the rest). `error`,
//! `options` and `report` hold what the whole module shares.

mod arcs;
mod block;
mod check;
mod compensate;
mod error;
mod kinematics;
mod options;
mod orientation;
mod program;
mod report;
mod residual;
mod standing;
mod tcpm;
mod trace;
mod untraced;
mod walk;
mod write;

pub use check::{check_written, CheckBounds, CheckError};
pub use compensate::{check_written_options, compensate, compensate_with_progress};
pub use error::{NcError, NcOption};
pub use options::{
    check_work_offsets, parse_work_offset, read_work_offsets, Options, ToolLengths,
    DEFAULT_ANGULAR_TOLERANCE_RAD, DEFAULT_MAX_ROTARY_CORRECTION_DEG, MAX_CHORD_TOLERANCE_MM,
    MAX_ROTARY_CORRECTION_DEG,
};
pub use program::{parse, MAX_EXPANDED_WORDS, MAX_PECKS};
pub use report::{Compensated, LeftMove, OrientationLeft, PassedBlock, Report, ReportInputs};
pub use residual::{expanded_uncertainty_at, residual, Residual};
pub use trace::{
    trace, trace_compensated, trace_compensated_each, trace_each, trace_path, PerBlock, TracePoint,
    TraceSample,
};
pub use untraced::moves_left_alone;
pub use write::with_note;

/// The blocks of `program` (its bytes; `path` names it in errors) as the control runs them:
/// subprogram calls and canned cycles expanded, coordinate rotations (G68) applied. With
/// `pass_unknown`, blocks volmap does not follow pass as they are. Work offsets are taken as
/// zero here (a cycle's initial level after a change of offset is carried over as `compensate`
/// does with the options' offsets).
pub fn blocks_as_run(
    program: &[u8],
    path: &str,
    pass_unknown: bool,
) -> Result<Vec<parse::Line>, NcError> {
    program::as_run(program, path, pass_unknown, &Default::default()).map(|(lines, _)| lines)
}
