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
use crate::model::inputs::Inputs;
use crate::model::perturbation::ErrorTarget;
use crate::model::{Axis, AxisLetter, Command, Machine};

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

/// The largest |value| of an error over the travels (the value or its reverse form, plus each
/// thermal term at ±[`PLAUSIBLE_TEMPERATURE_CHANGE_K`] in the direction that adds), and where,
/// in words.
fn largest_magnitude(value: &ErrorValue, axes: &[Axis]) -> (f64, String) {
    largest_at(value, axes, None)
}

/// [`largest_magnitude`], or with `changes_k` (each thermal input's change from `reference_C`,
/// K) the largest |value| at those temperatures: `|form + Σ per_kelvin_s · ΔT_s|`.
fn largest_at(value: &ErrorValue, axes: &[Axis], changes_k: Option<&[f64]>) -> (f64, String) {
    let spec = &value.spec;
    let mut forms = vec![&spec.value];
    forms.extend(spec.reverse.as_ref());
    let mut largest = (0.0, String::new());
    for command in commands(value, axes) {
        let own = value.axis.map_or(0.0, |a| command[a.index()]);
        let thermal: f64 = spec
            .per_kelvin
            .iter()
            .map(|(input, form)| {
                let v = form.eval_at(own, &command);
                match changes_k {
                    None => v.abs() * PLAUSIBLE_TEMPERATURE_CHANGE_K,
                    Some(changes) => v * changes.get(*input).copied().unwrap_or(0.0),
                }
            })
            .sum();
        for form in &forms {
            let magnitude = match changes_k {
                None => form.eval_at(own, &command).abs() + thermal,
                Some(_) => (form.eval_at(own, &command) + thermal).abs(),
            };
            // NaN compares false: a non-finite value is refused as well.
            if magnitude.is_nan() || magnitude > largest.0 {
                largest = (magnitude, where_words(value, axes, &command));
            }
        }
    }
    largest
}

/// A machine's error value beyond what any machine tool has at the temperatures of a run (its
/// thermal terms are checked at ±50 K when the file is read; a run may ask for up to 200 K).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{at}: {key} of {machine} reaches {message}")]
pub struct ImplausibleAtInputs {
    /// The temperatures in words: `x_scale=220 °C (200 K from reference_C 20 °C)`.
    pub at: String,
    /// The machine's name.
    pub machine: String,
    pub key: String,
    pub message: String,
}

crate::error::input_errors!(ImplausibleAtInputs);

/// Refuses `machine` (as read, its thermal terms kept aside) at the temperatures of `inputs`
/// where an error value with thermal terms exceeds [`MAX_PLAUSIBLE_ANGLE_RAD`] or
/// [`MAX_PLAUSIBLE_LENGTH_MM`] anywhere on the travels: the same bounds as when the file is read,
/// at the run's temperatures instead of ±50 K, so that every engine maps what it accepts.
pub fn check_at_inputs(machine: &Machine, inputs: &Inputs) -> Result<(), ImplausibleAtInputs> {
    let Some(thermal) = &machine.thermal else {
        return Ok(());
    };
    let changes_k: Vec<f64> = thermal
        .inputs
        .iter()
        .map(|i| inputs.temperature_c(i, thermal.reference_c) - thermal.reference_c)
        .collect();
    for dependent in machine
        .dependent
        .iter()
        .filter(|d| !d.per_kelvin.is_empty())
    {
        let angular = dependent.target.is_angular();
        let value = ErrorValue {
            key: dependent.target.key(),
            axis: match dependent.target {
                ErrorTarget::Component { axis, .. } | ErrorTarget::Location { axis, .. } => {
                    Some(axis)
                }
                ErrorTarget::Spindle { .. } => None,
            },
            angular,
            spec: ValueSpec {
                value: dependent.value.clone(),
                reverse: dependent.reverse.clone(),
                per_kelvin: dependent.per_kelvin.clone(),
            },
        };
        let (largest, at) = largest_at(&value, &machine.axes, Some(&changes_k));
        let (most, unit) = if angular {
            (MAX_PLAUSIBLE_ANGLE_RAD, "rad")
        } else {
            (MAX_PLAUSIBLE_LENGTH_MM, "mm")
        };
        if largest.is_nan() || largest > most {
            let used: Vec<String> = dependent
                .per_kelvin
                .iter()
                .filter_map(|(input, _)| {
                    let name = thermal.inputs.get(*input)?;
                    Some(format!(
                        "{name}={} °C ({} K from reference_C {} °C)",
                        number_words(thermal.reference_c + changes_k[*input]),
                        number_words(changes_k[*input]),
                        number_words(thermal.reference_c)
                    ))
                })
                .collect();
            return Err(ImplausibleAtInputs {
                at: format!("at {}", used.join(", ")),
                machine: machine.name.clone(),
                key: value.key,
                message: format!(
                    "{} {unit}{at}, more than any machine tool has (at most {} {unit}): its thermal terms do not hold this far from reference_C",
                    crate::report::numbers::quantity(largest),
                    number_words(most)
                ),
            });
        }
    }
    Ok(())
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
