//! Tool-centre-point control (TCPM, RTCP) as the reader follows it: the codes that switch it on
//! (G43.4, FANUC's, with the rotary axes by their words, as LinuxCNC-style posts write it too;
//! Haas G234, the same; G43.5 with the tool axis as an I J K vector) and off (G49, or G43, of
//! the same modal group), the tool vector of a G43.5 block, and what a program may not do while
//! it is in force. Under TCPM, X Y Z are the tool tip in the workpiece frame and the control
//! solves the axes with its nominal kinematics (`nc::tcpm`).

use nalgebra::Vector3;

use super::modal::State;
use super::parse::Line;
use crate::nc::error::NcError;

/// How a program under tool-centre-point control gives the tool's orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::nc) enum Tcpm {
    /// G43.4 or G234: the rotary axes by their words.
    Rotary,
    /// G43.5: the tool axis (from the tip towards the spindle) by I J K.
    Vector,
}

fn is(g: f64, code: f64) -> bool {
    (g - code).abs() < 1e-9
}

/// What a G code does to tool-centre-point control: `Some(Some(mode))` switches it on,
/// `Some(None)` off (G43, G49: the same modal group), `None`: nothing.
pub(in crate::nc) fn mode_of(g: f64) -> Option<Option<Tcpm>> {
    if is(g, 43.4) || is(g, 234.0) {
        Some(Some(Tcpm::Rotary))
    } else if is(g, 43.5) {
        Some(Some(Tcpm::Vector))
    } else if is(g, 43.0) || is(g, 49.0) {
        Some(None)
    } else {
        None
    }
}

/// Whether a line switches tool-centre-point control on or off (or changes its tool length).
pub(in crate::nc) fn switches(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'G' && mode_of(w.value).is_some())
}

/// Whether a G43.5 block gives a tool vector: it moves even without axis words.
pub(in crate::nc) fn has_vector(line: &Line, state: &State) -> bool {
    state.tcpm == Some(Tcpm::Vector) && line.words.iter().any(|w| "IJK".contains(w.letter))
}

/// The tool vector of a G43.5 block, where it gives one: all of I J K, not all zero.
pub(in crate::nc) fn tool_vector(line: &Line, path: &str) -> Result<Option<Vector3<f64>>, NcError> {
    let words = ['I', 'J', 'K'].map(|l| line.word(l).map(|w| w.value));
    if words.iter().all(Option::is_none) {
        return Ok(None);
    }
    let [Some(i), Some(j), Some(k)] = words else {
        return Err(NcError::line(
            path,
            line.number,
            "G43.5: a tool vector needs all of I J K (a component left out is not known to stay)"
                .into(),
        ));
    };
    let v = Vector3::new(i, j, k);
    if !(v.norm() > 1e-9 && v.norm().is_finite()) {
        return Err(NcError::line(
            path,
            line.number,
            "G43.5: the tool vector I J K has no direction".into(),
        ));
    }
    Ok(Some(v / v.norm()))
}

/// The program as run (subprograms in place, before cycles are expanded) checked for what volmap
/// does not follow under tool-centre-point control, an error naming the line: machine-coordinate
/// and reference moves, canned cycles, coordinate rotation, cutter compensation, tool changes and
/// a change of work offset while it is in force; under G43.5 also rotary words (the vector gives
/// the orientation), arcs (I J K are the vector) and incremental distance.
pub(super) fn check_program(lines: &[Line], path: &str) -> Result<(), NcError> {
    let mut mode = None;
    let mut absolute = true;
    let mut motion = 0;
    let mut offset = 54;
    for line in lines {
        let was_on = mode.is_some();
        let mut offset_change = None;
        for w in line.words.iter().filter(|w| w.letter == 'G') {
            if let Some(m) = mode_of(w.value) {
                mode = m;
            }
            match w.value {
                g if is(g, 90.0) => absolute = true,
                g if is(g, 91.0) => absolute = false,
                g if g.fract() == 0.0 && g < 4.0 => motion = g as u32,
                g if g.fract() == 0.0 && (54.0..=59.0).contains(&g) && g as u32 != offset => {
                    offset = g as u32;
                    offset_change = Some(offset);
                }
                _ => {}
            }
        }
        let Some(mode) = mode else { continue };
        let code = match mode {
            Tcpm::Rotary => "tool-centre-point control (G43.4/G234)",
            Tcpm::Vector => "tool-centre-point control (G43.5)",
        };
        let refuse = |what: String| {
            Err(NcError::line(
                path,
                line.number,
                format!("{what} under {code} is not supported: cancel it (G49) first"),
            ))
        };
        for w in &line.words {
            let g = w.value;
            match w.letter {
                'G' if is(g, 28.0) || is(g, 53.0) || is(g, 30.0) => {
                    return refuse(format!(
                        "G{}, a move to a machine position,",
                        line.text_of(w)
                    ))
                }
                'G' if g.fract() == 0.0 && matches!(g as u32, 73 | 74 | 76 | 81..=89) => {
                    return refuse(format!("G{}, a canned cycle,", line.text_of(w)))
                }
                'G' if is(g, 68.0) || is(g, 68.2) || is(g, 68.4) => {
                    return refuse(format!("G{}, a coordinate rotation,", line.text_of(w)))
                }
                'G' if (41.0..43.0).contains(&g) => {
                    return refuse(format!("G{}, cutter compensation,", line.text_of(w)))
                }
                'M' if is(g, 6.0) => return refuse("a tool change (M6)".into()),
                'A' | 'B' | 'C' if mode == Tcpm::Vector => {
                    return refuse(format!(
                        "{}{}, a rotary word (the tool vector I J K gives the orientation),",
                        w.letter,
                        line.text_of(w)
                    ))
                }
                _ => {}
            }
        }
        if let Some(g) = offset_change.filter(|_| was_on) {
            return refuse(format!("G{g}, a change of work offset,"));
        }
        if mode == Tcpm::Vector {
            if motion >= 2 && line.words.iter().any(|w| "XYZIJKR".contains(w.letter)) {
                return refuse(format!("G{motion}, an arc (I J K are the tool vector),"));
            }
            if !absolute && line.words.iter().any(|w| "XYZIJK".contains(w.letter)) {
                return refuse("incremental distance (G91)".into());
            }
        }
    }
    Ok(())
}
