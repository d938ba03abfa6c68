//! The unknowns of a fit: location errors `E?0k`, spindle errors `E?S`, and the thermal
//! coefficient of either for one declared input, `EC0Y.per_kelvin.hall` (docs/model.md, "Thermal
//! terms": `v(T) = value + Σ_s per_kelvin_s · (T_s − reference_C)`); how each is read from and
//! written into a machine, and into its file.

use toml_edit::{DocumentMut, InlineTable, Item, TableLike, Value};

use super::toml_number as number;

use crate::model::inputs::Dependent;
use crate::model::perturbation::{ErrorTarget, SPINDLE_NAMES};
use crate::model::{AxisLetter, ErrorFunction, Machine, COMPONENT_NAMES};

/// One unknown of a fit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unknown {
    /// A location or spindle error.
    pub target: ErrorTarget,
    /// `None`: the error's value (at `reference_C`); `Some((n, input))`: its coefficient per
    /// kelvin of input `n` of `[thermal].inputs`.
    pub per_kelvin: Option<(usize, String)>,
}

/// The error a name without its `.per_kelvin.INPUT` part names: `EC0Y` or `EZS`.
fn target_of(name: &str) -> Option<ErrorTarget> {
    if let Some(index) = SPINDLE_NAMES.iter().position(|n| *n == name) {
        return Some(ErrorTarget::Spindle { index });
    }
    match name.chars().collect::<Vec<_>>()[..] {
        ['E', component, '0', axis] => COMPONENT_NAMES
            .iter()
            .position(|n| *n == component)
            .zip(AxisLetter::from_char(axis))
            .map(|(index, axis)| ErrorTarget::Location { axis, index }),
        _ => None,
    }
}

impl Unknown {
    /// `EC0Y`, `EX0C`, `EZS`, or any of them followed by `.per_kelvin.INPUT`; the reason it
    /// is not one where it is not.
    pub fn parse(name: &str, machine: &Machine) -> Result<Unknown, String> {
        let name = name.trim();
        let mut parts = name.split('.');
        let error = parts.next().unwrap_or_default();
        let target = target_of(error).ok_or_else(|| {
            format!(
                "`{name}` is not a location error or a spindle error (a location error is E, then X Y Z A B C, then 0, then the axis: EC0Y, EX0C; a spindle error EXS EYS EZS EAS EBS; either may be followed by .per_kelvin.INPUT)"
            )
        })?;
        if let ErrorTarget::Location { axis, .. } = target {
            if machine.axis(axis).is_none() {
                return Err(format!(
                    "`{name}`: the machine (chain {}) has no {axis} axis",
                    machine.chain.hwang_notation()
                ));
            }
        }
        let rest: Vec<&str> = parts.collect();
        let per_kelvin = match rest[..] {
            [] => None,
            ["per_kelvin", input] => {
                let declared: &[String] = machine.thermal.as_ref().map_or(&[], |t| &t.inputs);
                let n = declared.iter().position(|d| d == input).ok_or_else(|| {
                    format!(
                        "`{name}`: `{input}` is not a thermal input of the machine ({})",
                        declared_inputs(machine)
                    )
                })?;
                Some((n, input.to_string()))
            }
            _ => {
                return Err(format!(
                    "`{name}`: after the error's name only `.per_kelvin.INPUT` may follow"
                ))
            }
        };
        Ok(Unknown { target, per_kelvin })
    }

    /// The error's own name: `EC0Y`, `EZS`.
    pub fn error_name(&self) -> String {
        match self.target {
            ErrorTarget::Location { axis, index } => format!("E{}0{axis}", COMPONENT_NAMES[index]),
            ErrorTarget::Spindle { index } => SPINDLE_NAMES[index].to_string(),
            ErrorTarget::Component { axis, index } => format!("E{}{axis}", COMPONENT_NAMES[index]),
        }
    }

    /// As the fit file names it: `EC0Y`, `EC0Y.per_kelvin.hall`.
    pub fn name(&self) -> String {
        match &self.per_kelvin {
            None => self.error_name(),
            Some((_, input)) => format!("{}.per_kelvin.{input}", self.error_name()),
        }
    }

    /// As the machine file's `[covariance]` names it: `axes.Y.EC0Y`, `spindle.EZS`,
    /// `axes.Y.EC0Y.per_kelvin.hall`.
    pub fn quantity(&self) -> String {
        match &self.per_kelvin {
            None => self.target.key(),
            Some((_, input)) => format!("{}.per_kelvin.{input}", self.target.key()),
        }
    }

    /// mm or rad, per kelvin for a thermal coefficient.
    pub fn unit(&self) -> &'static str {
        match (self.target.is_angular(), self.per_kelvin.is_some()) {
            (false, false) => "mm",
            (true, false) => "rad",
            (false, true) => "mm/K",
            (true, true) => "rad/K",
        }
    }

    /// The step of the central differences: 0.1 µm or 0.1 µrad of the error itself (for a
    /// coefficient, over the largest temperature difference `span_k` of its input).
    pub fn step(&self, span_k: f64) -> f64 {
        let base = if self.target.is_angular() { 1e-7 } else { 1e-4 };
        match self.per_kelvin {
            None => base,
            Some(_) => base / span_k.max(1.0),
        }
    }

    fn dependent<'m>(&self, machine: &'m Machine) -> Option<&'m Dependent> {
        machine.dependent.iter().find(|d| d.target == self.target)
    }

    /// The unknown's value in `machine`.
    pub fn get(&self, machine: &Machine) -> f64 {
        match &self.per_kelvin {
            None => match self.dependent(machine) {
                Some(d) => d.value.eval(0.0),
                None => plain_value(machine, self.target),
            },
            Some((n, _)) => self
                .dependent(machine)
                .and_then(|d| d.per_kelvin.iter().find(|(i, _)| i == n))
                .map_or(0.0, |(_, f)| f.eval(0.0)),
        }
    }

    /// Sets the unknown in `machine`: the value where the machine keeps it at the default
    /// inputs and in its input-dependent form, a coefficient in that form (made where the
    /// error had none).
    pub fn set(&self, machine: &mut Machine, value: f64) {
        match &self.per_kelvin {
            None => {
                set_plain_value(machine, self.target, value);
                if let Some(d) = machine
                    .dependent
                    .iter_mut()
                    .find(|d| d.target == self.target)
                {
                    d.value = ErrorFunction::Constant(value);
                }
            }
            Some((n, _)) => {
                let position = machine
                    .dependent
                    .iter()
                    .position(|d| d.target == self.target);
                let d = match position {
                    Some(p) => &mut machine.dependent[p],
                    None => {
                        let base = plain_value(machine, self.target);
                        machine.dependent.push(Dependent {
                            target: self.target,
                            value: ErrorFunction::Constant(base),
                            reverse: None,
                            per_kelvin: Vec::new(),
                        });
                        machine.dependent.last_mut().expect("just pushed")
                    }
                };
                match d.per_kelvin.iter_mut().find(|(i, _)| i == n) {
                    Some((_, f)) => *f = ErrorFunction::Constant(value),
                    None => d.per_kelvin.push((*n, ErrorFunction::Constant(value))),
                }
            }
        }
    }
}

/// `it declares hall, spindle` or `it declares none: no [thermal] section`.
pub(crate) fn declared_inputs(machine: &Machine) -> String {
    match &machine.thermal {
        Some(t) if !t.inputs.is_empty() => format!("it declares {}", t.inputs.join(", ")),
        _ => "it declares none: no [thermal] section".to_string(),
    }
}

fn plain_value(machine: &Machine, target: ErrorTarget) -> f64 {
    match target {
        ErrorTarget::Location { axis, index } => {
            machine.axis(axis).map_or(0.0, |a| a.location[index])
        }
        ErrorTarget::Spindle { index } => machine.spindle[index],
        ErrorTarget::Component { .. } => 0.0,
    }
}

fn set_plain_value(machine: &mut Machine, target: ErrorTarget, value: f64) {
    match target {
        ErrorTarget::Location { axis, index } => {
            if let Some(a) = machine.axis_mut(axis) {
                a.location[index] = value;
            }
        }
        ErrorTarget::Spindle { index } => machine.spindle[index] = value,
        ErrorTarget::Component { .. } => {}
    }
}

/// Sets `key` of a table to `value`, keeping the comments and spacing around the old one.
fn set(table: &mut dyn TableLike, key: &str, value: Value) {
    match table.get_mut(key).and_then(Item::as_value_mut) {
        Some(old) => {
            let decor = old.decor().clone();
            *old = value;
            *old.decor_mut() = decor;
        }
        None => {
            table.insert(key, Item::Value(value));
        }
    }
}

/// A constant with its standard uncertainty: `{ value = …, u = … }`.
fn with_u(value: f64, u: f64) -> Value {
    let mut form = InlineTable::new();
    form.insert("value", number(value));
    form.insert("u", number(u));
    Value::InlineTable(form)
}

/// Writes the unknowns' values and standard uncertainties `(unknown, value, u)` into the machine
/// file, keeping everything else as it is: each error as `{ value = …, u = … }`, or in the form
/// `{ value = …, u = …, per_kelvin = { input = { value = …, u = … } } }` where it has (or had in the
/// file) a thermal coefficient; coefficients of other inputs stay.
pub fn write_into(
    document: &mut DocumentMut,
    unknowns: &[(Unknown, f64, f64)],
) -> Result<(), String> {
    for (unknown, value, u) in unknowns {
        let key = unknown.error_name();
        let section: &mut dyn TableLike = match unknown.target {
            ErrorTarget::Location { axis, .. } => document
                .get_mut("axes")
                .and_then(|a| a.get_mut(axis.to_string().as_str()))
                .and_then(Item::as_table_like_mut)
                .ok_or_else(|| format!("the machine file has no [axes.{axis}] section"))?,
            ErrorTarget::Spindle { .. } => document
                .entry("spindle")
                .or_insert(Item::Table(toml_edit::Table::new()))
                .as_table_like_mut()
                .ok_or_else(|| "the machine file's `spindle` is not a section".to_string())?,
            ErrorTarget::Component { .. } => continue,
        };
        let general = section
            .get(&key)
            .is_some_and(|item| item.as_table_like().is_some());
        match (&unknown.per_kelvin, general) {
            (None, false) => set(section, &key, with_u(*value, *u)),
            (None, true) => {
                let form = section
                    .get_mut(&key)
                    .and_then(Item::as_table_like_mut)
                    .expect("checked");
                // A `value = { value = …, u = … }` becomes a number: the u stands beside it.
                set(form, "value", number(*value));
                set(form, "u", number(*u));
            }
            (Some((_, input)), _) => {
                if !general {
                    // A number (or nothing) becomes `{ value = number, per_kelvin = {} }`.
                    let old = section
                        .get(&key)
                        .and_then(Item::as_value)
                        .and_then(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
                        .unwrap_or(0.0);
                    let mut form = InlineTable::new();
                    form.insert("value", number(old));
                    section.insert(&key, Item::Value(Value::InlineTable(form)));
                }
                let form = section
                    .get_mut(&key)
                    .and_then(Item::as_table_like_mut)
                    .expect("a table now");
                if form.get("per_kelvin").is_none() {
                    form.insert(
                        "per_kelvin",
                        Item::Value(Value::InlineTable(InlineTable::new())),
                    );
                }
                let per_kelvin = form
                    .get_mut("per_kelvin")
                    .and_then(Item::as_table_like_mut)
                    .ok_or_else(|| {
                        format!("`{key}.per_kelvin` in the machine file is not a table")
                    })?;
                set(per_kelvin, input, with_u(*value, *u));
            }
        }
    }
    Ok(())
}

/// Writes `pairs` (`"NAME NAME"`, covariance) into the file's `[covariance]`, made where the file
/// has none, after dropping the pairs it gave that name any of `estimated`.
pub fn write_covariance(
    document: &mut DocumentMut,
    estimated: &[String],
    pairs: &[(String, f64)],
) -> Result<(), String> {
    if pairs.is_empty() && document.get("covariance").is_none() {
        return Ok(());
    }
    let table = document
        .entry("covariance")
        .or_insert(Item::Table(toml_edit::Table::new()))
        .as_table_like_mut()
        .ok_or_else(|| "the machine file's `covariance` is not a table".to_string())?;
    let stale: Vec<String> = table
        .iter()
        .map(|(key, _)| key.to_string())
        .filter(|key| {
            key.split_whitespace()
                .any(|n| estimated.iter().any(|e| e == n))
        })
        .collect();
    for key in stale {
        table.remove(&key);
    }
    for (key, c) in pairs {
        table.insert(key, Item::Value(number(*c)));
    }
    Ok(())
}
