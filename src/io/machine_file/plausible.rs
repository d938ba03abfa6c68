//! The angular errors of a machine file checked against what any machine tool can have: a value
//! above [`MAX_PLAUSIBLE_ANGLE_RAD`] anywhere on its travel is a unit mistake (degrees, or µrad
//! written as rad), refused as bad input naming the key, on every device and command. The GPU's
//! own limit on error rotations (`gpu::chain::check_error_angles`) is then only a backstop for
//! machines that come from no file (drawn by Monte Carlo around tolerances).

use super::values::ValueSpec;
use super::MachineError;
use crate::model::errorfn::ErrorFunction;
use crate::model::{Axis, AxisLetter, Command};

/// The largest angular error (a component, location or spindle error, its reverse form, with its
/// thermal terms) any machine tool has, rad: real ones stay below 1e-3 rad.
pub const MAX_PLAUSIBLE_ANGLE_RAD: f64 = 0.01;

/// The largest temperature change from `reference_C` a thermal term is evaluated at, K: beyond
/// what a workshop or a running spindle reaches.
pub const PLAUSIBLE_TEMPERATURE_CHANGE_K: f64 = 50.0;

/// Positions along the own axis's travel at which a value is evaluated (besides table nodes).
const OWN_SAMPLES: usize = 65;
/// Positions along each other axis's travel, for values of other axes (`of`, `table2d`).
const OTHER_SAMPLES: usize = 9;

/// An angular error value as read, with the axis it belongs to (`None`: the spindle).
pub(super) struct AngularValue {
    pub key: String,
    pub axis: Option<AxisLetter>,
    pub spec: ValueSpec,
}

/// Refuses the first angular value that exceeds [`MAX_PLAUSIBLE_ANGLE_RAD`] over the travels.
pub(super) fn check_angles(
    file: &str,
    values: &[AngularValue],
    axes: &[Axis],
) -> Result<(), MachineError> {
    for value in values {
        let (largest, at) = largest_magnitude(value, axes);
        if largest > MAX_PLAUSIBLE_ANGLE_RAD {
            return Err(MachineError::Key {
                file: file.to_string(),
                key: value.key.clone(),
                message: format!(
                    "an angular error of {largest:.4} rad{at} is more than any machine tool has (at most {MAX_PLAUSIBLE_ANGLE_RAD} rad): angular errors are in rad, check the unit"
                ),
            });
        }
    }
    Ok(())
}

/// The largest |value| of an angular error over the travels (the value or its reverse form, plus
/// each thermal term at ±[`PLAUSIBLE_TEMPERATURE_CHANGE_K`] in the direction that adds), and
/// where, in words.
fn largest_magnitude(value: &AngularValue, axes: &[Axis]) -> (f64, String) {
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
fn commands(value: &AngularValue, axes: &[Axis]) -> Vec<Command> {
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
fn where_words(value: &AngularValue, axes: &[Axis], command: &Command) -> String {
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
