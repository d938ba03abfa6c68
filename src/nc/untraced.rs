//! The moves a program leaves alone: those that depend on an axis, a work offset or tool data a
//! block volmap does not follow may have changed (`program::unknown`). `compensate` lists them in
//! its report; `trace` does not trace them, and lists them with this.

use super::compensate::begin;
use super::error::NcError;
use super::options::Options;
use super::program::reader::{end_position, take_line, Step};
use super::report::LeftMove;
use crate::model::Machine;

/// The moves of `program` (its bytes; `path` names it in errors) that are neither compensated nor
/// traced, by line, with what they depend on that is not known.
pub fn moves_left_alone(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
) -> Result<Vec<LeftMove>, NcError> {
    let (lines, mut state, _, _) = begin(machine, program, path, options)?;
    let mut left = Vec::new();
    for (index, line) in lines.iter().enumerate() {
        if take_line(&lines, index, &mut state, path, options.pass_unknown)? == Step::Move {
            state.position = end_position(line, &state);
        }
        if let Some(alone) = state.left_alone.take() {
            left.push(LeftMove {
                line: alone.line,
                unknown: alone.axes,
                since_line: alone.since,
            });
        }
    }
    Ok(left)
}
