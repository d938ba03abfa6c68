//! Codes that set coordinates and move nothing: G10 L2 / L20 (a work offset's values), G52 (a
//! local shift of the coordinates), G92 (the current point named anew) and G92.1 / G92.2 (that
//! shift cancelled). Their axis words are values, not a point to move to. volmap applies them
//! where their meaning is definite, so the moves after them are compensated where the machine
//! really stands; where it is not (tool data, an offset the control does not number alike,
//! a point volmap does not know), the block is refused, or passed as a code volmap does not
//! follow (`unknown`).
//!
//! The machine does not move: where a block changes the active offset or the shift by `δ`, the
//! program's coordinates of where the axes stand change by `−δ` (in the program and in the output
//! alike).

use super::modal::{AxisSet, State, AXIS_LETTERS, MM_PER_INCH};
use super::parse::Line;
use crate::nc::error::NcError;

fn g(line: &Line, code: f64) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'G' && w.value == code)
}

/// Whether the line is a G10, G52, G92, G92.1 or G92.2 block.
pub(in crate::nc) fn is_setting(line: &Line) -> bool {
    [10.0, 52.0, 92.0, 92.1, 92.2]
        .iter()
        .any(|&code| g(line, code))
}

/// Whether the line names the point where the tool stands anew (G92, G10 L20): the control
/// takes the point it has, so a compensated program must name it as written (`write_setting`).
pub(in crate::nc) fn names_current_point(line: &Line) -> bool {
    g(line, 92.0) || g(line, 10.0) && line.word('L').is_some_and(|w| w.value == 20.0)
}

/// The work offset (54–59) a G10 L2 / L20 sets, where the block is one whose meaning volmap
/// knows: P1–P6, no rotation R. Tool data (L1, L10, L11) and other offsets are not followed.
pub(in crate::nc) fn definite_g10(line: &Line) -> Option<u32> {
    let l = line.word('L')?.value;
    let p = line.word('P')?.value;
    let whole = p.fract() == 0.0 && (1.0..=6.0).contains(&p);
    (matches!(l as u32, 2 | 20) && l.fract() == 0.0 && whole && !line.has('R'))
        .then_some(53 + p as u32)
}

/// Why a setting block volmap does not follow is not followed, for the report and errors.
pub(in crate::nc) fn unknown_setting(line: &Line) -> Option<String> {
    if g(line, 10.0) && definite_g10(line).is_none() {
        let l = line
            .word('L')
            .map_or(String::new(), |w| format!(" L{}", line.text_of(w)));
        return Some(format!("G10{l}"));
    }
    None
}

/// Where a setting block with a code volmap does not follow is passed: what depends on it
/// becomes unknown (the offset it names, or tool data).
pub(in crate::nc) fn pass_setting(line: &Line, state: &mut State) {
    if !g(line, 10.0) {
        return;
    }
    match line.word('L').map(|w| w.value as u32) {
        Some(1 | 10 | 11) => {
            state.tool_data_unknown.get_or_insert(line.number);
        }
        _ => {
            let p = line.word('P').map(|w| w.value);
            match p.filter(|p| p.fract() == 0.0 && (1.0..=6.0).contains(p)) {
                Some(p) => {
                    state.offsets_unknown.insert(53 + p as u32, line.number);
                }
                // Another offset (P0: the active one on some controls): all of them.
                None => {
                    for n in 54..=59 {
                        state.offsets_unknown.insert(n, line.number);
                    }
                }
            }
        }
    }
}

/// The program's coordinates of where the axes stand move by `-delta` (mm, degrees); an axis not
/// set yet (or sent home) stands where the program next names it, in the coordinates then.
fn shift_position(state: &mut State, d: usize, delta: f64) {
    if state.set[d] != AxisSet::Yes {
        return;
    }
    state.position[d] -= delta;
    state.written[d] -= delta;
}

/// Takes a G10 L2/L20, G52, G92, G92.1 or G92.2 block (modal words already taken).
pub(in crate::nc) fn take_setting(
    line: &Line,
    state: &mut State,
    path: &str,
) -> Result<(), NcError> {
    let refuse = |why: String| Err(NcError::line(path, line.number, why));
    if line
        .words
        .iter()
        .any(|w| w.letter == 'G' && w.value < 4.0 && w.value.fract() == 0.0)
    {
        return refuse("a motion code (G0–G3) in a block that sets coordinates: its axis words are values, not a point; give the motion on a block of its own".into());
    }
    let value = |d: usize, v: f64| {
        if state.inch && d < 3 {
            v * MM_PER_INCH
        } else {
            v
        }
    };
    let axes: Vec<(usize, f64)> = AXIS_LETTERS
        .iter()
        .enumerate()
        .filter_map(|(d, &l)| line.word(l).map(|w| (d, value(d, w.value))))
        .collect();
    if g(line, 10.0) {
        let number = definite_g10(line).expect("a G10 volmap does not follow is passed before");
        let l = line.word('L').map_or(2, |w| w.value as u32);
        if !state.absolute {
            return refuse(format!("G10 L{l} in incremental distance (G91): controls read its values differently (added to the offset, or not); give them in G90"));
        }
        let base = match state.work_offsets.get(&number) {
            Some(&values) => Some(values),
            None if number == 54 => Some([0.0; 6]),
            None => None,
        };
        let mut values = base.unwrap_or([0.0; 6]);
        if base.is_none() && !(0..3).all(|d| axes.iter().any(|(a, _)| *a == d)) {
            return refuse(format!("G10 L{l} P{}: G{number}'s offset was not given, and this block sets only some of its X Y Z", number - 53));
        }
        let active = state
            .work_offsets
            .get(&state.offset)
            .copied()
            .unwrap_or([0.0; 6]);
        if l == 20 && state.offset != 54 && !state.work_offsets.contains_key(&state.offset) {
            return refuse(format!(
                "G10 L20 needs the machine position, and the active G{}'s offset was not given",
                state.offset
            ));
        }
        for &(d, v) in &axes {
            values[d] = if l == 20 {
                // The current point reads as `v` in this offset: machine = position + active,
                // the same in both (the shifts and the tool length alike).
                known(line, state, d, "G10 L20", path)?;
                state.position[d] + active[d] - v
            } else {
                v
            };
        }
        if number == state.offset {
            let old = state.work_offsets.get(&number).copied().unwrap_or([0.0; 6]);
            for &(d, _) in &axes {
                shift_position(state, d, values[d] - old[d]);
            }
        }
        state.work_offsets.insert(number, values);
        state.offsets_unknown.remove(&number);
        return Ok(());
    }
    if g(line, 52.0) {
        if axes.is_empty() {
            return refuse("G52 without axis words: give the shift of every axis it sets".into());
        }
        if !state.absolute {
            return refuse("G52 in incremental distance (G91): controls read its values differently; give them in G90".into());
        }
        if state.g92_shift.iter().any(|&s| s != 0.0) {
            return refuse("G52 while a G92 shift is in force: controls combine the two differently; cancel G92 (G92.1) first".into());
        }
        for &(d, v) in &axes {
            let delta = v - state.local_shift[d];
            state.local_shift[d] = v;
            shift_position(state, d, delta);
        }
        return Ok(());
    }
    if g(line, 92.0) {
        if axes.is_empty() {
            return refuse(
                "G92 without axis words: give the value of every axis it names anew".into(),
            );
        }
        if state.local_shift.iter().any(|&s| s != 0.0) {
            return refuse("G92 while a G52 shift is in force: controls combine the two differently; cancel G52 (G52 with zeros) first".into());
        }
        for &(d, v) in &axes {
            known(line, state, d, "G92", path)?;
            let delta = state.position[d] - v;
            state.g92_shift[d] += delta;
            shift_position(state, d, delta);
        }
        return Ok(());
    }
    // G92.1 and G92.2: the shift is cancelled.
    for d in 0..6 {
        let delta = -state.g92_shift[d];
        state.g92_shift[d] = 0.0;
        shift_position(state, d, delta);
    }
    Ok(())
}

/// Where axis `d` stands is known, for `code` (G10 L20, G92), which names that point anew.
fn known(line: &Line, state: &State, d: usize, code: &str, path: &str) -> Result<(), NcError> {
    let why = match (state.unknown[d], state.set[d]) {
        (Some(at), AxisSet::Reference(r)) if at == r => {
            format!("it went to the reference point (G28) on line {at}")
        }
        (Some(at), _) => format!("a block volmap does not follow on line {at} may have moved it"),
        (None, AxisSet::Never) => "the program has not set it yet".into(),
        (None, AxisSet::Reference(at)) => {
            format!("it went to the reference point or a machine position on line {at}")
        }
        (None, AxisSet::Yes) => return Ok(()),
    };
    Err(NcError::line(
        path,
        line.number,
        format!(
            "{code} needs where {} stands, which is not known here: {why}",
            AXIS_LETTERS[d]
        ),
    ))
}
