//! The evaluation inputs a field was computed for (docs/model.md, "Evaluation inputs"): the
//! approach direction of every axis and the temperature of every declared thermal input, recorded
//! in every header (every part of a multi-part file) and checked against the inputs a reader asks
//! for, as a field's pose is.
//!
//! Attributes: `volmap.approach` (`X=+,Y=-,Z=+`, every axis of the chain) and
//! `volmap.temperatures` (`x_scale=24.5,spindle=20`, every declared input in °C, exact decimals;
//! empty where the machine declares none), in the syntax of `--approach` and `--temperatures`;
//! `volmap.referenceTemperature` (double, °C: `[thermal].reference_C`, only where the machine
//! declares inputs); `volmap.inputs`, the same in words. A field written before fields recorded
//! their inputs has none of them and was computed at the default inputs: every axis `+` (the
//! axes of `volmap.chain`), every input of the machine file's `[thermal]` at its reference.

use super::{FieldError, FieldFile, FieldInfo};
use crate::model::inputs::{Inputs, InputsRecord, Thermal};
use crate::model::Chain;

pub(super) const APPROACH: &str = "volmap.approach";
pub(super) const TEMPERATURES: &str = "volmap.temperatures";
pub(super) const REFERENCE: &str = "volmap.referenceTemperature";
pub(super) const WORDS: &str = "volmap.inputs";

/// The input attributes of one header as read, before they are checked.
#[derive(Default)]
pub(super) struct RawInputs {
    pub approach: Option<String>,
    pub temperatures: Option<String>,
    pub reference_c: Option<f64>,
}

impl RawInputs {
    /// The record the attributes give, or the default inputs of the field's machine where the
    /// field has none (written before fields recorded them). `path` names the file in errors.
    pub fn record(self, info: &FieldInfo, path: &str) -> Result<InputsRecord, FieldError> {
        let bad = |attribute: &str, e: crate::model::inputs::InputsError| FieldError::Format {
            path: path.to_string(),
            what: format!("attribute {attribute}: {e}"),
        };
        let defaults = || {
            let axes: Vec<_> = Chain::parse(&info.chain)
                .map(|c| c.axes().collect())
                .unwrap_or_default();
            InputsRecord::defaults(axes, thermal_of(&info.machine_toml).as_ref())
        };
        let approach = match &self.approach {
            Some(text) => {
                InputsRecord::parse(text, "", None)
                    .map_err(|e| bad(APPROACH, e))?
                    .approach
            }
            None => defaults().approach,
        };
        let (temperatures_c, reference_c) = match &self.temperatures {
            Some(text) => {
                let record = InputsRecord::parse("", text, self.reference_c)
                    .map_err(|e| bad(TEMPERATURES, e))?;
                (record.temperatures_c, record.reference_c)
            }
            None => {
                let record = defaults();
                (record.temperatures_c, record.reference_c)
            }
        };
        Ok(InputsRecord {
            approach,
            temperatures_c,
            reference_c,
        })
    }
}

/// The `[thermal]` section of a machine file's text, where it has one that reads (a field's
/// machine file was read when the field was written; this asks nothing more of it).
fn thermal_of(machine_toml: &str) -> Option<Thermal> {
    if crate::error::toml_beyond_limits(machine_toml).is_some() {
        return None;
    }
    let table: toml::Table = toml::from_str(machine_toml).ok()?;
    let thermal = table.get("thermal")?.as_table()?;
    let inputs = thermal
        .get("inputs")?
        .as_array()?
        .iter()
        .map(|v| v.as_str().map(str::to_string))
        .collect::<Option<Vec<String>>>()?;
    let reference_c = match thermal.get("reference_C") {
        None => 20.0,
        Some(v) => v.as_float().or_else(|| v.as_integer().map(|i| i as f64))?,
    };
    Some(Thermal {
        reference_c,
        inputs,
    })
}

impl FieldFile {
    /// Checks that every part of the file was computed at `inputs` (every axis's direction and
    /// every declared input's temperature the same, inputs not given at their defaults): a field
    /// computed at other inputs is an error saying what the field holds and what was asked.
    pub fn check_inputs(&self, inputs: &Inputs) -> Result<(), FieldError> {
        for part in 0..self.parts() {
            let held = self.inputs(part);
            let asked = held.with(inputs);
            if &asked != held {
                let path = if self.is_multipart() {
                    format!("{} (part {})", self.path().display(), self.name(part))
                } else {
                    self.path().display().to_string()
                };
                return Err(FieldError::Inputs {
                    path,
                    held: held.describe(),
                    asked: asked.describe(),
                });
            }
        }
        Ok(())
    }
}
