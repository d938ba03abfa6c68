//! Evaluation inputs (MODEL.md, "Evaluation inputs" and "Thermal terms"): the approach direction
//! of every axis and the temperature of every declared thermal input, and the error values that
//! depend on them.
//!
//! A machine file's error value may carry a `reverse` form (the value while its axis approaches
//! in the negative direction) and `per_kelvin` forms; the machine as loaded holds the value at
//! the default inputs (every axis `+`, every input at `reference_C`, which is the plain `value`)
//! and keeps the [`Dependent`] values aside. [`Machine::at`] gives the machine at other inputs:
//!
//! `v(q, T) = value(q) + Σ_s per_kelvin_s(q) · (T_s − reference_C)`, with `reverse` for `value`
//! where the error's axis approaches `−`.

use super::perturbation::ErrorTarget;
use super::{AxisLetter, ErrorFunction, Machine};

/// `[thermal]`: the declared temperature inputs and the temperature of the geometric model.
#[derive(Debug, Clone, PartialEq)]
pub struct Thermal {
    pub reference_c: f64,
    pub inputs: Vec<String>,
}

/// The direction an axis approaches its position in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Approach {
    #[default]
    Positive,
    Negative,
}

impl Approach {
    pub fn sign(self) -> char {
        match self {
            Approach::Positive => '+',
            Approach::Negative => '-',
        }
    }
}

/// The inputs of one evaluation of the model.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Inputs {
    /// Indexed by [`AxisLetter::index`].
    pub approach: [Approach; 6],
    /// `(input, °C)` for the inputs given; inputs not given are at `reference_C`.
    pub temperatures_c: Vec<(String, f64)>,
}

/// An error value that depends on the inputs: its `value`, `reverse` and `per_kelvin` forms
/// (for a location or spindle error, constants).
#[derive(Debug, Clone, PartialEq)]
pub struct Dependent {
    pub target: ErrorTarget,
    pub value: ErrorFunction,
    pub reverse: Option<ErrorFunction>,
    /// `(index of the input in [thermal].inputs, form)`.
    pub per_kelvin: Vec<(usize, ErrorFunction)>,
}

/// Why evaluation inputs do not fit a machine.
#[derive(Debug, thiserror::Error)]
pub enum InputsError {
    #[error("`{0}`: expected NAME=VALUE pairs separated by commas")]
    Syntax(String),
    #[error("`{name}` is not a thermal input of this machine ({known})")]
    UnknownInput { name: String, known: String },
    #[error("`{name}={value}`: the temperature is not a finite number of °C")]
    Temperature { name: String, value: String },
    #[error("`{axis}` is not an axis of this machine (chain {chain})")]
    UnknownAxis { axis: String, chain: String },
    #[error("`{axis}={value}`: the approach direction is + or -")]
    Direction { axis: String, value: String },
    #[error("`{0}` is given twice")]
    Twice(String),
}

crate::error::input_errors!(InputsError);

/// `NAME=VALUE` pairs, trimmed.
fn pairs(text: &str) -> Result<Vec<(&str, &str)>, InputsError> {
    text.split(',')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .map(|p| {
            p.split_once('=')
                .map(|(n, v)| (n.trim(), v.trim()))
                .ok_or_else(|| InputsError::Syntax(text.to_string()))
        })
        .collect()
}

impl Inputs {
    /// Parses `x_scale=24.5,spindle=31` (°C) and `X=-,Y=+` against the machine: an input it
    /// does not declare, or an axis it lacks, is an error.
    pub fn parse(
        temperatures: &str,
        approach: &str,
        machine: &Machine,
    ) -> Result<Inputs, InputsError> {
        let mut inputs = Inputs::default();
        let declared: &[String] = machine.thermal.as_ref().map_or(&[], |t| &t.inputs);
        for (name, value) in pairs(temperatures)? {
            if !declared.iter().any(|d| d == name) {
                return Err(InputsError::UnknownInput {
                    name: name.to_string(),
                    known: if declared.is_empty() {
                        "it declares none: no [thermal] section".to_string()
                    } else {
                        format!("it declares {}", declared.join(", "))
                    },
                });
            }
            if inputs.temperatures_c.iter().any(|(n, _)| n == name) {
                return Err(InputsError::Twice(name.to_string()));
            }
            let t = value
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| InputsError::Temperature {
                    name: name.to_string(),
                    value: value.to_string(),
                })?;
            inputs.temperatures_c.push((name.to_string(), t));
        }
        let mut named = [false; 6];
        for (axis, value) in pairs(approach)? {
            let letter = match axis.chars().collect::<Vec<_>>()[..] {
                [c] => AxisLetter::from_char(c),
                _ => None,
            }
            .filter(|&l| machine.axis(l).is_some())
            .ok_or_else(|| InputsError::UnknownAxis {
                axis: axis.to_string(),
                chain: machine.chain.hwang_notation(),
            })?;
            if std::mem::replace(&mut named[letter.index()], true) {
                return Err(InputsError::Twice(axis.to_string()));
            }
            inputs.approach[letter.index()] = match value {
                "+" => Approach::Positive,
                "-" | "−" => Approach::Negative,
                _ => {
                    return Err(InputsError::Direction {
                        axis: axis.to_string(),
                        value: value.to_string(),
                    })
                }
            };
        }
        Ok(inputs)
    }

    /// The temperature of input `name`, °C (`reference_c` where not given).
    pub fn temperature_c(&self, name: &str, reference_c: f64) -> f64 {
        self.temperatures_c
            .iter()
            .find(|(n, _)| n == name)
            .map_or(reference_c, |(_, t)| *t)
    }

    /// Whether these are the default inputs: every axis `+`, every input at `reference_C`.
    pub fn is_default(&self, machine: &Machine) -> bool {
        let reference = machine.thermal.as_ref().map_or(0.0, |t| t.reference_c);
        self.approach.iter().all(|&a| a == Approach::Positive)
            && self.temperatures_c.iter().all(|(_, t)| *t == reference)
    }

    /// The inputs in words, as a field file records them and `info` prints them:
    /// `approach X+ Y- Z+; temperatures x_scale=24.5 °C, spindle=20 °C (reference 20 °C)`.
    pub fn describe(&self, machine: &Machine) -> String {
        let approach: Vec<String> = machine
            .chain
            .axes()
            .map(|l| format!("{l}{}", self.approach[l.index()].sign()))
            .collect();
        let mut text = format!("approach {}", approach.join(" "));
        if let Some(thermal) = &machine.thermal {
            let temperatures: Vec<String> = thermal
                .inputs
                .iter()
                .map(|i| format!("{i}={} °C", self.temperature_c(i, thermal.reference_c)))
                .collect();
            text += &format!(
                "; temperatures {} (reference {} °C)",
                temperatures.join(", "),
                thermal.reference_c
            );
        }
        text
    }
}

impl Machine {
    /// The machine at the evaluation inputs `inputs`: every dependent error value resolved to
    /// `value` (or `reverse`) plus its per-kelvin terms, as plain error values.
    pub fn at(&self, inputs: &Inputs) -> Machine {
        let deltas: Vec<f64> = self.thermal.as_ref().map_or(Vec::new(), |thermal| {
            thermal
                .inputs
                .iter()
                .map(|i| inputs.temperature_c(i, thermal.reference_c) - thermal.reference_c)
                .collect()
        });
        self.clone().resolve_all(inputs, &deltas)
    }

    fn resolve_all(mut self, inputs: &Inputs, deltas: &[f64]) -> Machine {
        let dependent = std::mem::take(&mut self.dependent);
        for d in &dependent {
            let negative = match d.target {
                ErrorTarget::Component { axis, .. } => {
                    inputs.approach[axis.index()] == Approach::Negative
                }
                _ => false,
            };
            let base = match (&d.reverse, negative) {
                (Some(reverse), true) => reverse.clone(),
                _ => d.value.clone(),
            };
            let mut terms = vec![base];
            for (input, form) in &d.per_kelvin {
                let delta = deltas.get(*input).copied().unwrap_or(0.0);
                if delta != 0.0 {
                    terms.push(form.scaled(delta));
                }
            }
            let resolved = if terms.len() == 1 {
                terms.remove(0)
            } else {
                ErrorFunction::Sum(terms)
            };
            match d.target {
                ErrorTarget::Component { axis, index } => {
                    if let Some(axis) = self.axis_mut(axis) {
                        axis.components[index] = Some(resolved);
                    }
                }
                ErrorTarget::Location { axis, index } => {
                    if let Some(axis) = self.axis_mut(axis) {
                        axis.location[index] = resolved.eval(0.0);
                    }
                }
                ErrorTarget::Spindle { index } => self.spindle[index] = resolved.eval(0.0),
            }
        }
        self.dependent = dependent;
        self
    }

    /// Whether any error value reads the position of an axis other than its own.
    pub fn has_cross_axis_errors(&self) -> bool {
        self.axes.iter().any(|a| {
            a.components
                .iter()
                .flatten()
                .any(|f| !f.other_axes().is_empty())
        })
    }
}
