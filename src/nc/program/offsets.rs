//! A change of work offset (G54–G59) moves nothing: the axes stand where they stood, so the
//! program coordinates of where they stand (in the program and in the output) become the old
//! ones plus the old offset minus the new one. Keeping the old program coordinates would make the
//! next move go the offsets' difference along every axis it does not name, and take each axis's
//! approach direction across the change from program coordinates, not from how the machine moves.
//!
//! Offsets are translations of every axis, A B C included (the control commands `program +
//! offset`, degrees for a rotary axis); an offset changed under a coordinate rotation (G68) or
//! tool-centre-point control is refused where those are read. An offset the options do not give
//! counts as zero here, as in the compensation (a move under a non-G54 one is refused there).

use std::collections::HashMap;

use super::modal::State;
use super::parse::Line;

/// Work offsets by number (54–59), mm and degrees.
pub(in crate::nc) type WorkOffsets = HashMap<u32, [f64; 6]>;

/// The offset `number` (zero where it is not given).
pub(in crate::nc) fn offset_of(offsets: &WorkOffsets, number: u32) -> [f64; 6] {
    offsets.get(&number).copied().unwrap_or([0.0; 6])
}

/// The work offset a line selects (G54–G59; the last one where it names several).
pub(super) fn selected(line: &Line) -> Option<u32> {
    line.words
        .iter()
        .rev()
        .find(|w| w.letter == 'G' && w.value.fract() == 0.0 && (54.0..=59.0).contains(&w.value))
        .map(|w| w.value as u32)
}

/// What to add to program coordinates in offset `from` to name the same machine position in
/// offset `to`.
pub(super) fn shift(offsets: &WorkOffsets, from: u32, to: u32) -> [f64; 6] {
    let (a, b) = (offset_of(offsets, from), offset_of(offsets, to));
    std::array::from_fn(|d| a[d] - b[d])
}

/// Makes offset `to` active: where the program and the output have the tool is carried over in
/// machine coordinates.
pub(super) fn change_offset(state: &mut State, to: u32) {
    let shift = shift(&state.work_offsets, state.offset, to);
    for (d, s) in shift.iter().enumerate() {
        state.position[d] += s;
        state.written[d] += s;
    }
    state.offset = to;
}
