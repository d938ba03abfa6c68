//! The values of a machine file checked against what any machine tool can have, on every device
//! and command, each refused as bad input naming its key:
//! - an angular error above [`MAX_PLAUSIBLE_ANGLE_RAD`] anywhere on its travel is a unit mistake
//!   (degrees, or µrad written as rad); the GPU's own limit on error rotations
//!   (`gpu::chain::check_error_angles`) is then only a backstop for machines that come from no
//!   file (drawn by Monte Carlo around tolerances);
//! - a travel, an offset, the tool, or a translational error beyond [`MAX_PLAUSIBLE_LENGTH_MM`]
//!   (a kilometre; degrees for a rotary travel) belongs to no machine tool, and every map,
//!   sample, test and compensation of a machine within these bounds is a finite number.

use super::values::ValueSpec;
use super::MachineError;
use crate::limits::number_words;
use crate::model::errorfn::ErrorFunction;
use crate::model::{Axis, AxisLetter, Command};

/// The largest angular error (a component, location or spindle error, its reverse form, with its
/// thermal terms) any machine tool has, rad: real ones stay below 1e-3 rad.
pub const MAX_PLAUSIBLE_ANGLE_RAD: f64 = 0.01;

/// The largest magnitude of a travel's ends (mm, or degrees for a rotary axis), an axis offset, a
/// tool offset or a translational error value (mm) of a machine tool: a kilometre.
pub const MAX_PLAUSIBLE_LENGTH_MM: f64 = 1e6;

/// The largest temperature change from `reference_C` a thermal term is evaluated at, K: beyond
/// what a workshop or a running spindle reaches.
pub const PLAUSIBLE_TEMPERATURE_CHANGE_K: f64 = 50.0;

/// Positions along the own axis's travel at which a value is evaluated (besides table nodes).
const OWN_SAMPLES: usize = 65;
/// Positions along each other axis's travel, for values of other axes (`of`, `table2d`).
const OTHER_SAMPLES: usize = 9;

/// An error value as read, with the axis it belongs to (`None`: the spindle), angular (rad) or
/// translational (mm).
pub(super) struct ErrorValue {
    pub key: String,
    pub axis: Option<AxisLetter>,
    pub angular: bool,
    pub spec: ValueSpec,
}

/// Refuses the first travel, axis offset or tool offset beyond [`MAX_PLAUSIBLE_LENGTH_MM`].
pub(super) fn check_lengths(
    file: &str,
    axes: &[Axis],
    tool_offset_mm: &[f64; 3],
) -> Result<(), MachineError> {
    let mut lengths: Vec<(String, &[f64], &str)> = Vec::new();
    for axis in axes {
        let unit = if axis.letter.is_linear() { "mm" } else { "°" };
        lengths.push((format!("axes.{}.range", axis.letter), &axis.range, unit));
        lengths.push((
            format!("axes.{}.offset", axis.letter),
            &axis.offset_mm,
            "mm",
        ));
    }
    lengths.push(("tool.offset".to_string(), tool_offset_mm, "mm"));
    for (key, values, unit) in lengths {
        if let Some(v) = values
            .iter()
            .find(|v| v.is_nan() || v.abs() > MAX_PLAUSIBLE_LENGTH_MM)
        {
            return Err(MachineError::Key {
                file: file.to_string(),
                key,
                message: format!(
                    "{} {unit} is beyond any machine tool (at most {MAX_PLAUSIBLE_LENGTH_MM:e} in magnitude): check the unit",
                    number_words(*v)
                ),
            });
        }
    }
    Ok(())
}

/// Refuses the first error value that exceeds [`MAX_PLAUSIBLE_ANGLE_RAD`] (angular) or
/// [`MAX_PLAUSIBLE_LENGTH_MM`] (translational) over the travels.
pub(super) fn check_values(
    file: &str,
    values: &[ErrorValue],
    axes: &[Axis],
) -> Result<(), MachineError> {
    for value in values {
        let (largest, at) = largest_magnitude(value, axes);
        let message = if value.angular && (largest.is_nan() || largest > MAX_PLAUSIBLE_ANGLE_RAD) {
            format!(
                "an angular error of {largest:.4} rad{at} is more than any machine tool has (at most {MAX_PLAUSIBLE_ANGLE_RAD} rad): angular errors are in rad, check the unit"
            )
        } else if !value.angular && (largest.is_nan() || largest > MAX_PLAUSIBLE_LENGTH_MM) {
            format!(
                "a translational error of {} mm{at} is more than any machine tool has (at most {MAX_PLAUSIBLE_LENGTH_MM:e} mm): translational errors are in mm, check the unit",
                number_words(largest)
            )
        } else {
            continue;
        };
        return Err(MachineError::Key {
            file: file.to_string(),
            key: value.key.clone(),
            message,
        });
    }
    Ok(())
}

/// The largest |value| of an angular error over the travels (the value or its reverse form, plus
/// each thermal term at ±[`PLAUSIBLE_TEMPERATURE_CHANGE_K`] in the direction that adds), and
/// where, in words.
fn largest_magnitude(value: &ErrorValue, axes: &[Axis]) -> (f64, String) {
    let spec = &value.spec;
    let mut forms = vec![&spec.value];
    forms.extend(spec.reverse.as_ref());
    let mut largest = (0.0, String::new());
    for command in commands(value, axes) {
        let own = value.axis.map_or(0.0, |a| command[a.index()]);
        let thermal: f64 = spec
            .per_kelvin
            .iter()
            .map(|(_, form)| form.eval_at(own, &command).abs() * PLAUSIBLE_TEMPERATURE_CHANGE_K)
            .sum();
        for form in &forms {
            let magnitude = form.eval_at(own, &command).abs() + thermal;
            // NaN compares false: a non-finite value is refused as well.
            if magnitude.is_nan() || magnitude > largest.0 {
                largest = (magnitude, where_words(value, axes, &command));
            }
        }
    }
    largest
}

/// The commanded positions a value is evaluated at: its own axis over its travel (and at the
/// nodes of its tables), each other axis it reads over that axis's travel.
fn commands(value: &ErrorValue, axes: &[Axis]) -> Vec<Command> {
    let travel = |letter: AxisLetter| axes.iter().find(|a| a.letter == letter).map(|a| a.range);
    let mut read: Vec<AxisLetter> = value
        .spec
        .forms()
        .flat_map(|f| f.other_axes())
        .filter(|&a| Some(a) != value.axis)
        .collect();
    read.sort_by_key(|a| a.index());
    read.dedup();
    let mut commands = vec![[0.0; 6]];
    if let Some(own) = value.axis {
        if let Some(range) = travel(own) {
            let mut positions = spread(range, OWN_SAMPLES);
            for form in value.spec.forms() {
                positions.extend(
                    own_nodes(form)
                        .into_iter()
                        .filter(|q| (range[0]..=range[1]).contains(q)),
                );
            }
            commands = extend(&commands, own, &positions);
        }
    }
    for other in read {
        if let Some(range) = travel(other) {
            commands = extend(&commands, other, &spread(range, OTHER_SAMPLES));
        }
    }
    commands
}

/// Every command of `commands` with `axis` at each of `positions`.
fn extend(commands: &[Command], axis: AxisLetter, positions: &[f64]) -> Vec<Command> {
    commands
        .iter()
        .flat_map(|c| {
            positions.iter().map(move |&q| {
                let mut command = *c;
                command[axis.index()] = q;
                command
            })
        })
        .collect()
}

/// `n` evenly spaced positions over `range`, both ends included.
fn spread(range: [f64; 2], n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| range[0] + (range[1] - range[0]) * i as f64 / (n - 1) as f64)
        .collect()
}

/// The node positions of the tables of the own axis in `form` (where a linear table peaks).
fn own_nodes(form: &ErrorFunction) -> Vec<f64> {
    form.terms()
        .into_iter()
        .flat_map(|term| match term {
            ErrorFunction::Table(table) => table.nodes().map(|(q, _)| q).collect(),
            _ => Vec::new(),
        })
        .collect()
}

/// ` at X=… mm` for the axes the value reads, or nothing for a constant.
fn where_words(value: &ErrorValue, axes: &[Axis], command: &Command) -> String {
    let mut read: Vec<AxisLetter> = value.axis.into_iter().collect();
    read.extend(value.spec.forms().flat_map(|f| f.other_axes()));
    read.dedup();
    let varies = value
        .spec
        .forms()
        .any(|f| !matches!(f, ErrorFunction::Constant(_)));
    if !varies || value.axis.is_none() {
        return String::new();
    }
    let words: Vec<String> = axes
        .iter()
        .filter(|a| read.contains(&a.letter))
        .map(|a| {
            let unit = if a.letter.is_linear() { "mm" } else { "°" };
            format!("{}={:.3} {unit}", a.letter, command[a.letter.index()])
        })
        .collect();
    format!(" at {}", words.join(" "))
}

impl ValueSpec {
    /// The value, its reverse form and its thermal forms.
    fn forms(&self) -> impl Iterator<Item = &ErrorFunction> {
        std::iter::once(&self.value)
            .chain(self.reverse.as_ref())
            .chain(self.per_kelvin.iter().map(|(_, f)| f))
    }
}
