//! Sweeps of the rotary axes: a five-axis map covers the linear grid at every pose of a sweep.
//!
//! A sweep is written `B=-90:90:15,C=0:345:15`: each rotary axis takes one value (`C=30`) or an
//! inclusive range with a step (`START:STOP:STEP`, degrees). The poses are every combination,
//! the last axis written varying fastest; rotary axes not written stay at 0. Each pose is named
//! by every rotary axis of the machine in the order A, B, C: `B=-90,C=0`.

use super::grid::GridError;
use super::{AxisLetter, Command, Machine};

/// The most poses one sweep may hold.
pub const MAX_POSES: usize = 1 << 16;

/// The finest step of a sweep, degrees.
pub const MIN_STEP_DEG: f64 = 1e-6;

/// Parses a sweep against the machine's rotary axes and their ranges.
pub fn parse_sweep(text: &str, machine: &Machine) -> Result<Vec<Command>, GridError> {
    let mut axes: Vec<(AxisLetter, Vec<f64>)> = Vec::new();
    for (name, values) in named_values(text, || GridError::SweepSyntax(text.to_string()))? {
        let axis_err = |what: String| axis_error(name, what);
        let letter = rotary_letter(name, machine)?;
        if axes.iter().any(|(l, _)| *l == letter) {
            return Err(axis_err("named twice".into()));
        }
        let range = machine.axis(letter).map_or([0.0, 0.0], |a| a.range);
        let values = sweep_values(values.trim()).map_err(axis_err)?;
        if let Some(v) = values.iter().find(|v| **v < range[0] || **v > range[1]) {
            return Err(axis_err(format!(
                "{}°, outside its range [{}, {}]",
                crate::error::shown(*v),
                range[0],
                range[1]
            )));
        }
        axes.push((letter, values));
    }
    if axes.is_empty() {
        return Err(GridError::SweepSyntax(text.to_string()));
    }
    let count = axes
        .iter()
        .try_fold(1usize, |n, (_, v)| n.checked_mul(v.len()))
        .filter(|&n| n <= MAX_POSES)
        .ok_or_else(|| GridError::SweepSize {
            sweep: text.to_string(),
            most: MAX_POSES,
        })?;
    let mut poses = Vec::with_capacity(count);
    for index in 0..count {
        let mut pose = [0.0; 6];
        let mut rest = index;
        for (letter, values) in axes.iter().rev() {
            pose[letter.index()] = values[rest % values.len()];
            rest /= values.len();
        }
        poses.push(pose);
    }
    Ok(poses)
}

/// The `NAME=VALUE` pairs of a comma-separated list, each trimmed; `syntax` is the error for an
/// item without `=` (an empty item among them). An empty list has no pairs.
fn named_values(
    text: &str,
    syntax: impl Fn() -> GridError,
) -> Result<Vec<(&str, &str)>, GridError> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    // An empty item (`B=30,`, `,,`) is a comma too many or a value left out: refused.
    text.split(',')
        .map(str::trim)
        .map(|pair| {
            let (name, value) = pair.split_once('=').ok_or_else(&syntax)?;
            Ok((name.trim(), value.trim()))
        })
        .collect()
}

/// The error of axis `name`.
fn axis_error(name: &str, what: impl Into<String>) -> GridError {
    GridError::PoseAxis {
        axis: crate::error::excerpt(name).into_owned(),
        what: what.into(),
    }
}

/// The rotary axis `name` names (A, B or C), whatever the machine.
fn rotary_letter_of(name: &str) -> Result<AxisLetter, GridError> {
    let letter = match name.chars().collect::<Vec<_>>()[..] {
        [c] => AxisLetter::from_char(c),
        _ => None,
    }
    .ok_or_else(|| axis_error(name, "not an axis letter (A, B or C)"))?;
    if letter.is_linear() {
        return Err(axis_error(
            name,
            "a linear axis: a pose names the rotary axes (a map covers X, Y and Z over their travels)",
        ));
    }
    Ok(letter)
}

/// The rotary axis of `machine` a sweep or pose names.
fn rotary_letter(name: &str, machine: &Machine) -> Result<AxisLetter, GridError> {
    let letter = rotary_letter_of(name)?;
    if machine.axis(letter).is_none() {
        return Err(axis_error(
            name,
            format!(
                "not an axis of this machine (chain {})",
                machine.chain.hwang_notation()
            ),
        ));
    }
    Ok(letter)
}

/// A number of degrees.
fn degrees(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("`{}`, not a number of degrees", text.trim()))
}

/// `V` or `START:STOP:STEP` in degrees: START, START + STEP, … up to STOP inclusive.
fn sweep_values(text: &str) -> Result<Vec<f64>, String> {
    let number = degrees;
    let parts: Vec<&str> = text.split(':').collect();
    match parts[..] {
        [v] => Ok(vec![round_degrees(number(v)?)]),
        [start, stop, step] => {
            let (start, stop, step) = (number(start)?, number(stop)?, number(step)?);
            if step <= 0.0 {
                return Err(format!("`{text}`: the step must be positive"));
            }
            // Poses are rounded to 1e-9° and name the parts of a field: steps finer than this
            // would give two poses one name.
            if step < MIN_STEP_DEG {
                return Err(format!(
                    "`{text}`: the step must be at least {MIN_STEP_DEG}°"
                ));
            }
            if stop < start {
                return Err(format!("`{text}`: the sweep must not end before it starts"));
            }
            // A stop that the steps reach up to rounding is included.
            let steps = ((stop - start) / step + 1e-9).floor() as usize;
            if steps >= MAX_POSES {
                return Err(format!(
                    "a sweep of more than {MAX_POSES} values (`{}`)",
                    crate::error::excerpt(text)
                ));
            }
            Ok((0..=steps)
                .map(|i| round_degrees(start + i as f64 * step))
                .collect())
        }
        _ => Err(format!(
            "`{text}`: expected DEGREES or START:STOP:STEP, e.g. -90:90:15"
        )),
    }
}

/// Degrees rounded to 1e-9° so that a sweep's steps print as they were written (and −0 is 0).
fn round_degrees(v: f64) -> f64 {
    // Beyond 1e299° the scaled value overflows: such a value is kept (and refused by its range).
    if !(v * 1e9).is_finite() {
        return v;
    }
    let r = (v * 1e9).round() / 1e9;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// The name of a pose: every rotary axis of the machine, in the order A, B, C (`B=-90,C=0`).
pub fn pose_name(pose: &Command, machine: &Machine) -> String {
    let degrees = [pose[3], pose[4], pose[5]];
    name_of(degrees, &machine.rotary_axes())
}

/// The name of the pose `degrees` (A, B, C) of a machine whose rotary axes are `axes`: each of
/// them in the order A, B, C, `LETTER=DEGREES` separated by commas (`B=-90,C=0`); linear letters
/// among `axes` are passed by.
pub fn name_of(degrees: [f64; 3], axes: &[AxisLetter]) -> String {
    let mut letters: Vec<AxisLetter> = axes.iter().copied().filter(|l| !l.is_linear()).collect();
    letters.sort_by_key(|l| l.index());
    letters.dedup();
    letters
        .iter()
        .map(|l| format!("{l}={}", crate::error::shown(degrees[l.index() - 3])))
        .collect::<Vec<_>>()
        .join(",")
}

/// Parses `A=..,B=..,C=..` (degrees) against the machine's rotary axes and their ranges.
/// Rotary axes not named stay at 0.
pub fn parse_pose(text: &str, machine: &Machine) -> Result<Command, GridError> {
    let mut pose = [0.0; 6];
    let mut named = [false; 6];
    for (name, value) in named_values(text, || GridError::PoseSyntax(text.to_string()))? {
        let letter = rotary_letter(name, machine)?;
        if std::mem::replace(&mut named[letter.index()], true) {
            return Err(axis_error(name, "named twice"));
        }
        let range = machine.axis(letter).map_or([0.0, 0.0], |a| a.range);
        let degrees = degrees(value).map_err(|what| axis_error(name, what))?;
        if degrees < range[0] || degrees > range[1] {
            return Err(axis_error(
                name,
                format!("{degrees}°, outside its range [{}, {}]", range[0], range[1]),
            ));
        }
        pose[letter.index()] = degrees;
    }
    Ok(pose)
}

/// Parses a pose `A=..,B=..,C=..` (degrees) where no machine is at hand (a pose asked of a field
/// file, whose parts say which poses exist): the positions of A, B and C, those not named at 0.
pub fn parse_pose_degrees(text: &str) -> Result<[f64; 3], GridError> {
    let mut pose = [0.0; 3];
    let mut named = [false; 3];
    for (name, value) in named_values(text, || GridError::PoseSyntax(text.to_string()))? {
        let n = rotary_letter_of(name)?.index() - 3;
        if std::mem::replace(&mut named[n], true) {
            return Err(axis_error(name, "named twice"));
        }
        pose[n] = degrees(value).map_err(|what| axis_error(name, what))?;
    }
    if text.trim().is_empty() {
        return Err(GridError::PoseSyntax(text.to_string()));
    }
    Ok(pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_reach_a_stop_that_rounding_misses() {
        assert_eq!(sweep_values("0:0.3:0.1").unwrap(), vec![0.0, 0.1, 0.2, 0.3]);
        assert_eq!(
            sweep_values("-90:90:45").unwrap(),
            vec![-90.0, -45.0, 0.0, 45.0, 90.0]
        );
        assert_eq!(sweep_values("0:10:4").unwrap(), vec![0.0, 4.0, 8.0]);
        assert!(sweep_values("0:10:0").is_err());
        assert!(sweep_values("10:0:1").is_err());
        assert!(sweep_values("a:1:1").is_err());
        assert!(sweep_values("0:1:1e-9").is_err());
        assert_eq!(sweep_values("-0").unwrap(), vec![0.0]);
        assert!(sweep_values("-0").unwrap()[0].is_sign_positive());
    }

    #[test]
    fn names_list_the_rotary_axes_in_the_order_a_b_c() {
        use AxisLetter::*;
        assert_eq!(name_of([0.0, -90.0, 12.5], &[C, B]), "B=-90,C=12.5");
        assert_eq!(name_of([1.0, 2.0, 3.0], &[X, A]), "A=1");
        assert_eq!(name_of([1.0, 2.0, 3.0], &[]), "");
    }

    #[test]
    fn poses_without_a_machine() {
        assert_eq!(
            parse_pose_degrees("B=30, C=-45").unwrap(),
            [0.0, 30.0, -45.0]
        );
        assert_eq!(parse_pose_degrees("A=1").unwrap(), [1.0, 0.0, 0.0]);
        for bad in ["", "B", "X=1", "B=x", "B=1,B=2", "BC=1", "B=inf"] {
            assert!(parse_pose_degrees(bad).is_err(), "{bad}");
        }
    }
}
