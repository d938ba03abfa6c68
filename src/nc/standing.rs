//! Axes standing at a machine position (G53, `G53 G0 Z0.` before a tool change): the reader has
//! them where the G53 block sent them (`program::reader`), and the output writes no word for them
//! until a block names them, so they stay uncorrected there. A rapid gets its other axes corrected
//! for the error where they stand; a feed move that starts with such an axis is copied as it is
//! and listed (its error cannot be taken out, nor the chord tolerance held), and an arc there is
//! refused (the control takes its centre from the start the output has).

use super::error::NcError;
use super::program::approach::line_directions;
use super::program::modal::{AxisSet, Motion, State, AXIS_LETTERS};
use super::program::parse::Line;
use super::program::unknown::follow_passed;
use super::report::{PassedBlock, Report};

/// The axes standing at a machine position at the start of a block: the line of their G53 block.
pub(super) fn standing(state: &State) -> [Option<usize>; 6] {
    std::array::from_fn(|d| match (state.set[d], state.unknown[d]) {
        (AxisSet::Reference(at), None) => Some(at),
        _ => None,
    })
}

/// A feed move that starts with an axis standing at the machine position of a G53 block
/// (`standing`, before the line was taken): copied as it is and listed, an arc refused. `None`
/// where no axis stands.
pub(super) fn standing_feed(
    (path, line): (&str, &Line),
    standing: &[Option<usize>; 6],
    state: &mut State,
    report: &mut Report,
    out: &mut String,
) -> Result<Option<usize>, NcError> {
    if state.motion == Motion::Rapid {
        return Ok(None);
    }
    let Some((axis, at)) = (0..6).find_map(|d| standing[d].map(|at| (AXIS_LETTERS[d], at))) else {
        return Ok(None);
    };
    if state.motion != Motion::Linear {
        return Err(NcError::line(
            path,
            line.number,
            format!(
                "an arc (G{}) with {axis} at the machine position of G53 on line {at}: the output writes no {axis} word before a block names it, so the arc cannot be compensated; set {axis} before the arc",
                state.motion.code()
            ),
        ));
    }
    let before = state.position;
    follow_passed(line, state);
    state.approach = line_directions(&before, &state.position, &state.approach);
    state.programmed = line_directions(&before, &state.position, &state.programmed);
    state.written_motion = state.motion;
    report.not_compensated.push(PassedBlock {
        line: line.number,
        code: format!("a feed move with {axis} at the machine position of G53 on line {at}"),
    });
    out.push_str(&line.text);
    out.push_str(line.ending);
    Ok(Some(1))
}
