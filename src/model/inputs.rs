//! Evaluation inputs (docs/model.md, "Evaluation inputs" and "Thermal terms"): the approach
//! direction of every axis and the temperature of every declared thermal input, and the error
//! values that depend on them.
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
use crate::error::excerpt;

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
    #[error("`{}`: expected NAME=VALUE pairs separated by commas", excerpt(.0))]
    Syntax(String),
    #[error("`{}` is not a thermal input of this machine ({known})", excerpt(name))]
    UnknownInput { name: String, known: String },
    #[error("`{}={}`: the temperature is not a finite number of °C at or above absolute zero (-273.15 °C)", excerpt(name), excerpt(value))]
    Temperature { name: String, value: String },
    #[error("`{}={}`: more than {MAX_TEMPERATURE_CHANGE_K} K from the machine's reference_C ({reference_c} °C): no machine tool runs there, and a linear thermal term means nothing so far out", excerpt(name), excerpt(value))]
    TemperatureFar {
        name: String,
        value: String,
        reference_c: f64,
    },
    #[error("`{}` is not an axis of this machine (chain {chain})", excerpt(axis))]
    UnknownAxis { axis: String, chain: String },
    #[error(
        "`{}={}`: the approach direction is + or -",
        excerpt(axis),
        excerpt(value)
    )]
    Direction { axis: String, value: String },
    #[error("`{}` is given twice", excerpt(.0))]
    Twice(String),
    #[error("`{}`: temperatures without the reference temperature they are relative to", excerpt(.0))]
    NoReference(String),
}

crate::error::input_errors!(InputsError);

/// `NAME=VALUE` pairs, trimmed; an empty item (`x_scale=20,`) is refused, an empty list has none.
fn pairs(text: &str) -> Result<Vec<(&str, &str)>, InputsError> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    text.split(',')
        .map(str::trim)
        .map(|p| {
            p.split_once('=')
                .map(|(n, v)| (n.trim(), v.trim()))
                .ok_or_else(|| InputsError::Syntax(text.to_string()))
        })
        .collect()
}

/// What the inputs are checked against: the thermal inputs declared, the axes there are, and
/// the chain in words for messages.
struct Against<'a> {
    declared: &'a [String],
    /// `[thermal].reference_C` (none where no input is declared).
    reference_c: Option<f64>,
    axes: &'a [AxisLetter],
    chain: &'a str,
}

impl Inputs {
    /// Parses `x_scale=24.5,spindle=31` (°C) and `X=-,Y=+` against the machine: an input it
    /// does not declare, or an axis it lacks, is an error.
    pub fn parse(
        temperatures: &str,
        approach: &str,
        machine: &Machine,
    ) -> Result<Inputs, InputsError> {
        let axes: Vec<AxisLetter> = machine.chain.axes().collect();
        let against = Against {
            declared: machine.thermal.as_ref().map_or(&[], |t| &t.inputs),
            reference_c: machine.thermal.as_ref().map(|t| t.reference_c),
            axes: &axes,
            chain: &machine.chain.hwang_notation(),
        };
        Inputs::parse_against(temperatures, approach, &against)
    }

    /// Parses the inputs as [`Inputs::parse`] does, against what an output recorded: its axes
    /// and its thermal inputs (`chain` names the machine's chain in messages).
    pub fn parse_for(
        temperatures: &str,
        approach: &str,
        record: &InputsRecord,
        chain: &str,
    ) -> Result<Inputs, InputsError> {
        let axes: Vec<AxisLetter> = record.approach.iter().map(|(l, _)| *l).collect();
        let declared: Vec<String> = record
            .temperatures_c
            .iter()
            .map(|(n, _)| n.clone())
            .collect();
        let against = Against {
            declared: &declared,
            reference_c: record.reference_c,
            axes: &axes,
            chain,
        };
        Inputs::parse_against(temperatures, approach, &against)
    }

    fn parse_against(
        temperatures: &str,
        approach: &str,
        against: &Against,
    ) -> Result<Inputs, InputsError> {
        let mut inputs = Inputs::default();
        let declared = against.declared;
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
            let t = temperature(name, value)?;
            if let Some(reference_c) = against.reference_c {
                if (t - reference_c).abs() > MAX_TEMPERATURE_CHANGE_K {
                    return Err(InputsError::TemperatureFar {
                        name: name.to_string(),
                        value: value.to_string(),
                        reference_c,
                    });
                }
            }
            inputs.temperatures_c.push((name.to_string(), t));
        }
        let mut named = [false; 6];
        for (axis, value) in pairs(approach)? {
            let letter = match axis.chars().collect::<Vec<_>>()[..] {
                [c] => AxisLetter::from_char(c),
                _ => None,
            }
            .filter(|l| against.axes.contains(l))
            .ok_or_else(|| InputsError::UnknownAxis {
                axis: axis.to_string(),
                chain: against.chain.to_string(),
            })?;
            if std::mem::replace(&mut named[letter.index()], true) {
                return Err(InputsError::Twice(axis.to_string()));
            }
            inputs.approach[letter.index()] = direction(axis, value)?;
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
        self.record(machine).describe()
    }

    /// These inputs spelled out for every axis of `machine` and every input it declares.
    pub fn record(&self, machine: &Machine) -> InputsRecord {
        InputsRecord::defaults(machine.chain.axes(), machine.thermal.as_ref()).with(self)
    }
}

/// The lowest temperature there is, °C.
pub const ABSOLUTE_ZERO_C: f64 = -273.15;

/// The farthest a temperature given may lie from the machine's `reference_C`, K.
pub const MAX_TEMPERATURE_CHANGE_K: f64 = 200.0;

/// The highest `reference_C` a machine file may declare, °C.
pub const MAX_REFERENCE_C: f64 = 1000.0;

/// A temperature of input `name` in °C: a finite number, not below absolute zero.
fn temperature(name: &str, value: &str) -> Result<f64, InputsError> {
    value
        .parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t >= ABSOLUTE_ZERO_C)
        .ok_or_else(|| InputsError::Temperature {
            name: name.to_string(),
            value: value.to_string(),
        })
}

/// An approach direction: `+` or `-` (or `−`).
fn direction(axis: &str, value: &str) -> Result<Approach, InputsError> {
    match value {
        "+" => Ok(Approach::Positive),
        "-" | "−" => Ok(Approach::Negative),
        _ => Err(InputsError::Direction {
            axis: axis.to_string(),
            value: value.to_string(),
        }),
    }
}

/// The inputs of an evaluation spelled out for every axis of a machine and every thermal input
/// it declares, without the machine: what an output records (a field's header) and what is
/// compared with the inputs asked of it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct InputsRecord {
    /// Every axis of the chain, in the chain's order, with its approach direction.
    pub approach: Vec<(AxisLetter, Approach)>,
    /// Every declared thermal input, in the order `[thermal]` declares them, with its
    /// temperature in °C.
    pub temperatures_c: Vec<(String, f64)>,
    /// `[thermal].reference_C`; `None` where the machine declares no thermal input.
    pub reference_c: Option<f64>,
}

impl InputsRecord {
    /// The default inputs (every axis `+`, every input at `reference_C`) of a machine with these
    /// axes and this `[thermal]` section.
    pub fn defaults(
        axes: impl IntoIterator<Item = AxisLetter>,
        thermal: Option<&Thermal>,
    ) -> InputsRecord {
        InputsRecord {
            approach: axes.into_iter().map(|l| (l, Approach::Positive)).collect(),
            temperatures_c: thermal.map_or(Vec::new(), |t| {
                t.inputs
                    .iter()
                    .map(|i| (i.clone(), t.reference_c))
                    .collect()
            }),
            reference_c: thermal.map(|t| t.reference_c),
        }
    }

    /// The record of `inputs` over the same axes and thermal inputs: a direction or a
    /// temperature `inputs` does not give is the default (`+`, `reference_C`).
    pub fn with(&self, inputs: &Inputs) -> InputsRecord {
        let reference = self.reference_c.unwrap_or(0.0);
        InputsRecord {
            approach: self
                .approach
                .iter()
                .map(|&(l, _)| (l, inputs.approach[l.index()]))
                .collect(),
            temperatures_c: self
                .temperatures_c
                .iter()
                .map(|(n, _)| (n.clone(), inputs.temperature_c(n, reference)))
                .collect(),
            reference_c: self.reference_c,
        }
    }

    /// The approach directions as `--approach` takes them: `X=+,Y=-,Z=+`.
    pub fn approach_text(&self) -> String {
        let pairs: Vec<String> = self
            .approach
            .iter()
            .map(|(l, a)| format!("{l}={}", a.sign()))
            .collect();
        pairs.join(",")
    }

    /// The temperatures as `--temperatures` takes them, exact (shortest round-trip decimals):
    /// `x_scale=24.5,spindle=20`; empty where the machine declares no thermal input.
    pub fn temperatures_text(&self) -> String {
        let pairs: Vec<String> = self
            .temperatures_c
            .iter()
            .map(|(n, t)| format!("{n}={t}"))
            .collect();
        pairs.join(",")
    }

    /// Reads a record back from [`InputsRecord::approach_text`],
    /// [`InputsRecord::temperatures_text`] and the reference temperature.
    pub fn parse(
        approach: &str,
        temperatures: &str,
        reference_c: Option<f64>,
    ) -> Result<InputsRecord, InputsError> {
        let mut record = InputsRecord {
            reference_c,
            ..InputsRecord::default()
        };
        for (axis, value) in pairs(approach)? {
            let letter = match axis.chars().collect::<Vec<_>>()[..] {
                [c] => AxisLetter::from_char(c),
                _ => None,
            }
            .ok_or_else(|| InputsError::Syntax(approach.to_string()))?;
            if record.approach.iter().any(|(l, _)| *l == letter) {
                return Err(InputsError::Twice(axis.to_string()));
            }
            record.approach.push((letter, direction(axis, value)?));
        }
        for (name, value) in pairs(temperatures)? {
            if record.temperatures_c.iter().any(|(n, _)| n == name) {
                return Err(InputsError::Twice(name.to_string()));
            }
            record
                .temperatures_c
                .push((name.to_string(), temperature(name, value)?));
        }
        if !record.temperatures_c.is_empty() && reference_c.is_none() {
            return Err(InputsError::NoReference(temperatures.to_string()));
        }
        Ok(record)
    }

    /// The inputs in words: `approach X+ Y- Z+; temperatures x_scale=24.5 °C, spindle=20 °C
    /// (reference 20 °C)`.
    pub fn describe(&self) -> String {
        let approach: Vec<String> = self
            .approach
            .iter()
            .map(|(l, a)| format!("{l}{}", a.sign()))
            .collect();
        let mut text = format!("approach {}", approach.join(" "));
        if let Some(reference) = self.reference_c {
            let temperatures: Vec<String> = self
                .temperatures_c
                .iter()
                .map(|(n, t)| format!("{n}={} °C", crate::limits::number_words(*t)))
                .collect();
            text += &format!(
                "; temperatures {} (reference {reference} °C)",
                temperatures.join(", ")
            );
        }
        text
    }
}

impl Machine {
    /// The machine at the evaluation inputs `inputs`: every dependent error value resolved to
    /// `value` (or `reverse`) plus its per-kelvin terms, as plain error values, and the inputs
    /// kept in [`Machine::inputs`] (what a field of it records).
    pub fn at(&self, inputs: &Inputs) -> Machine {
        let deltas: Vec<f64> = self.thermal.as_ref().map_or(Vec::new(), |thermal| {
            thermal
                .inputs
                .iter()
                .map(|i| inputs.temperature_c(i, thermal.reference_c) - thermal.reference_c)
                .collect()
        });
        let mut machine = self.clone().resolve_all(inputs, &deltas);
        machine.inputs = inputs.clone();
        machine
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
