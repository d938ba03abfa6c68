//! The fit file (TOML): the unknowns to estimate and the measured tests, each with its
//! parameters, its CSV file and the temperatures it was measured at.
//!
//! ```toml
//! estimate = ["EC0Y", "EC0Y.per_kelvin.hall"]
//! [[circular]]
//! plane = "XY"
//! csv = "xy-20.csv"
//! temperatures = { hall = 20.0 }
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::ballbar_figures::BallbarFigures;
use super::unknowns::{declared_inputs, Unknown};
use super::CalibrateError;
use crate::error::toml_message;
use crate::io::read_text;
use crate::io::source::{confined, Reach};
use crate::model::inputs::Inputs;
use crate::model::Machine;
use crate::standards::{CircularSpec, DiagonalSpec, PositioningSpec, RTestSpec};

/// The measurements file (TOML): what to estimate and the tests with their measured results.
#[derive(Debug, Clone)]
pub struct FitFile {
    /// The file as named, for messages.
    pub file: String,
    /// Unknowns to estimate, e.g. `["EC0Y", "EB0Z", "EA0Z", "EC0Y.per_kelvin.hall"]`.
    pub estimate: Vec<String>,
    pub positioning: Vec<Entry<PositioningSpec>>,
    pub diagonal: Vec<Entry<DiagonalSpec>>,
    pub circular: Vec<Entry<CircularSpec>>,
    pub rtest: Vec<Entry<RTestSpec>>,
    /// Circles given by their ballbar diagnostics.
    pub ballbar: Vec<Entry<BallbarFigures>>,
}

/// One measured test of the fit file: its parameters and the temperatures it was measured at.
#[derive(Debug, Clone)]
pub struct Entry<S> {
    pub spec: S,
    /// Where it is in the file: `[[circular]] number 2`.
    pub key: String,
    /// `(input, °C)` as the entry's `temperatures = { hall = 26.0 }` gives them; inputs not
    /// named were at the machine's `reference_C`.
    pub temperatures_c: Vec<(String, f64)>,
}

/// The file as TOML gives it: each test a table, read into its spec once its own keys are out.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFitFile {
    estimate: Vec<String>,
    #[serde(default)]
    positioning: Vec<toml::Table>,
    #[serde(default)]
    diagonal: Vec<toml::Table>,
    #[serde(default)]
    circular: Vec<toml::Table>,
    #[serde(default)]
    rtest: Vec<toml::Table>,
    #[serde(default)]
    ballbar: Vec<toml::Table>,
}

fn key_error(file: &str, key: String, message: String) -> CalibrateError {
    CalibrateError::Key {
        file: file.to_string(),
        key,
        message,
    }
}

/// `{ hall = 26.0, spindle = 31 }`: the temperatures of an entry.
fn temperatures(
    file: &str,
    at: &str,
    value: toml::Value,
) -> Result<Vec<(String, f64)>, CalibrateError> {
    let toml::Value::Table(table) = value else {
        return Err(key_error(
            file,
            format!("{at}, temperatures"),
            format!(
                "expected a table of inputs and °C, `{{ hall = 26.0 }}`, found {}",
                value.type_str()
            ),
        ));
    };
    table
        .into_iter()
        .map(|(input, value)| match value {
            toml::Value::Float(c) if c.is_finite() => Ok((input, c)),
            toml::Value::Integer(c) => Ok((input, c as f64)),
            other => Err(key_error(
                file,
                format!("{at}, temperatures.{input}"),
                format!("`{other}` is not a temperature in °C"),
            )),
        })
        .collect()
}

/// A test's parameters, with the path of its measured results.
trait Spec: serde::de::DeserializeOwned {
    fn csv(&mut self) -> Option<&mut PathBuf>;
}

macro_rules! spec {
    ($($t:ty),*) => {$(
        impl Spec for $t {
            fn csv(&mut self) -> Option<&mut PathBuf> {
                self.csv.as_mut()
            }
        }
    )*};
}

spec!(PositioningSpec, DiagonalSpec, CircularSpec, RTestSpec);

impl Spec for BallbarFigures {
    fn csv(&mut self) -> Option<&mut PathBuf> {
        None
    }
}

/// The tests of one kind, each read into its spec with its CSV path resolved against `folder`
/// (and confined to it as `reach` says).
fn entries<S: Spec>(
    file: &str,
    (folder, reach): (&Path, Reach),
    kind: &str,
    tables: Vec<toml::Table>,
) -> Result<Vec<Entry<S>>, CalibrateError> {
    tables
        .into_iter()
        .enumerate()
        .map(|(n, mut table)| {
            let key = format!("[[{kind}]] number {}", n + 1);
            let temperatures_c = match table.remove("temperatures") {
                None => Vec::new(),
                Some(value) => temperatures(file, &key, value)?,
            };
            let mut spec: S =
                toml::Value::Table(table)
                    .try_into()
                    .map_err(|e: toml::de::Error| {
                        // The parser quotes a string of the input whole (a megabyte, or lines).
                        key_error(
                            file,
                            key.clone(),
                            crate::error::double_quotes_cut(e.message()),
                        )
                    })?;
            if let Some(p) = spec.csv() {
                *p = confined(folder, p, reach).map_err(|source| CalibrateError::NamedFile {
                    file: file.to_string(),
                    key: format!("{key}, csv"),
                    source,
                })?;
            }
            Ok(Entry {
                spec,
                key,
                temperatures_c,
            })
        })
        .collect()
}

impl FitFile {
    /// Reads the file; CSV paths are relative to its folder, and must lie in it or below it.
    pub fn read(path: &Path) -> Result<FitFile, CalibrateError> {
        FitFile::read_reaching(path, Reach::Folder)
    }

    /// [`FitFile::read`] with CSV files allowed where `reach` says.
    pub fn read_reaching(path: &Path, reach: Reach) -> Result<FitFile, CalibrateError> {
        let name = path.display().to_string();
        let text = read_text(path)?;
        if let Some(message) = crate::error::toml_beyond_limits(&text) {
            return Err(CalibrateError::Parameter(format!("{name}: {message}")));
        }
        let raw: RawFitFile = toml::from_str(&text).map_err(|e| {
            CalibrateError::Parameter(format!("{name}: {}", toml_message(&e, &text)))
        })?;
        let at = (path.parent().unwrap_or(Path::new("")), reach);
        Ok(FitFile {
            estimate: raw.estimate,
            positioning: entries(&name, at, "positioning", raw.positioning)?,
            diagonal: entries(&name, at, "diagonal", raw.diagonal)?,
            circular: entries(&name, at, "circular", raw.circular)?,
            rtest: entries(&name, at, "rtest", raw.rtest)?,
            ballbar: entries(&name, at, "ballbar", raw.ballbar)?,
            file: name,
        })
    }

    pub(crate) fn key_error(
        &self,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> CalibrateError {
        key_error(&self.file, key.into(), message.into())
    }

    /// The unknowns `estimate` names, on `machine`.
    pub fn unknowns(&self, machine: &Machine) -> Result<Vec<Unknown>, CalibrateError> {
        let mut unknowns: Vec<Unknown> = Vec::new();
        for name in &self.estimate {
            let u = Unknown::parse(name, machine).map_err(|m| self.key_error("estimate", m))?;
            if unknowns.contains(&u) {
                return Err(self.key_error("estimate", format!("`{name}` is named twice")));
            }
            unknowns.push(u);
        }
        if unknowns.is_empty() {
            return Err(self.key_error("estimate", "names no location or spindle error"));
        }
        Ok(unknowns)
    }

    /// The evaluation inputs of an entry on `machine`: its temperatures, every axis `+` (the
    /// tests' paths decide the directions of the axes they move). An input the machine does not
    /// declare is an error naming the entry and the input.
    pub fn inputs_of<S>(
        &self,
        entry: &Entry<S>,
        machine: &Machine,
    ) -> Result<Inputs, CalibrateError> {
        let declared: &[String] = machine.thermal.as_ref().map_or(&[], |t| &t.inputs);
        for (input, _) in &entry.temperatures_c {
            if !declared.contains(input) {
                return Err(self.key_error(
                    format!("{}, temperatures.{input}", entry.key),
                    format!(
                        "`{input}` is not a thermal input of the machine ({})",
                        declared_inputs(machine)
                    ),
                ));
            }
        }
        Ok(Inputs {
            temperatures_c: entry.temperatures_c.clone(),
            ..Inputs::default()
        })
    }
}
