//! The machine file (TOML; what the values mean: docs/model.md): parsing and validation.
//!
//! The top level, `[tool]` and `[spindle]` are serde structs with `deny_unknown_fields`. The keys
//! of an `[axes.K]` section depend on its letter (`EXX` belongs to X, `EXY` to Y), so axis
//! sections are read key by key; every key is either known or an error that names it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::csv::CsvError;
use super::source::Reach;
use super::{read_text, FileError};
use crate::error::{excerpt, input_errors, toml_message};

use crate::model::chain::{AxisLetter, Chain, ChainError};
use crate::model::errorfn::TableError;
use crate::model::inputs::{Dependent, Inputs, Thermal};
use crate::model::perturbation::{ErrorTarget, SPINDLE_NAMES};
use crate::model::{Axis, Machine, MachineSource, COMPONENT_NAMES};

mod plausible;
mod uncertainty;
mod values;

pub use plausible::{
    check_at_inputs, ImplausibleAtInputs, MAX_PLAUSIBLE_ANGLE_RAD, MAX_PLAUSIBLE_LENGTH_MM,
    PLAUSIBLE_TEMPERATURE_CHANGE_K,
};

use plausible::ErrorValue;
use values::{ValueKind, ValueSpec};

/// What is wrong with a machine file. Each message names the file and the key.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{file}: {message}")]
    Toml { file: String, message: String },
    #[error("{file}: {source}")]
    Chain {
        file: String,
        #[source]
        source: ChainError,
    },
    #[error("{file}: axis {axis} is in the chain `{chain}` but has no [axes.{axis}] section")]
    MissingAxisSection {
        file: String,
        axis: AxisLetter,
        chain: String,
    },
    #[error("{file}: [axes.{section}] names no axis of the chain `{chain}`")]
    AxisNotInChain {
        file: String,
        section: String,
        chain: String,
    },
    #[error("{file}: {key}: {message}")]
    Key {
        file: String,
        key: String,
        message: String,
    },
    #[error("{file}: {key}: {source}")]
    Table {
        file: String,
        key: String,
        #[source]
        source: TableError,
    },
    #[error("{file}: {key}: {source}")]
    CsvFile {
        file: String,
        key: String,
        #[source]
        source: FileError,
    },
    #[error("{file}: {key}: {source}")]
    Csv {
        file: String,
        key: String,
        #[source]
        source: CsvError,
    },
    #[error("{file}: {key}: {value} is negative: a standard uncertainty is zero or positive")]
    NegativeUncertainty {
        file: String,
        key: String,
        value: String,
    },
    #[error("{file}: {key}: {given} standard uncertainties for a table of {nodes} nodes: give one per node")]
    UncertaintyCount {
        file: String,
        key: String,
        given: usize,
        nodes: usize,
    },
    #[error("{file}: [covariance]: {pairs} make a covariance matrix that is not positive semi-definite: no quantities have these variances and covariances together (each pair needs |cov| <= u1·u2, and three or more must agree as well)")]
    NotPositiveSemidefinite { file: String, pairs: String },
    #[error("no embedded machine is called `{name}` and no file `{name}` exists{}(`volmap machines` lists the embedded ones)", .suggestion.as_ref().map_or(" ".to_string(), |s| format!("; did you mean `{s}`? ")))]
    UnknownMachine {
        name: String,
        /// The embedded machine whose name is nearest, where one is near.
        suggestion: Option<String>,
    },
}

input_errors!(MachineError);

impl MachineError {
    /// Whether this is a CSV table named outside the machine file's folder.
    pub fn is_outside_folder(&self) -> bool {
        matches!(self, MachineError::CsvFile { source, .. } if source.is_outside_folder())
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMachine {
    name: String,
    chain: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    tool: Option<RawTool>,
    #[serde(default)]
    spindle: Option<toml::Table>,
    #[serde(default)]
    thermal: Option<RawThermal>,
    #[serde(default)]
    axes: BTreeMap<String, toml::Table>,
    /// `[covariance]`: `"NAME NAME" = covariance` in the values' units squared.
    #[serde(default)]
    covariance: Option<toml::Table>,
}

/// `[tool]`: the tool tip in the spindle frame, mm.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    offset: [f64; 3],
}

/// `[thermal]`: the declared temperature inputs.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawThermal {
    #[serde(rename = "reference_C", default = "default_reference_c")]
    reference_c: f64,
    inputs: Vec<String>,
}

/// The longest machine name, in characters.
pub const MAX_NAME_CHARS: usize = 200;

/// The shortest travel an axis may have, mm (degrees for a rotary axis): a micrometre.
pub const MIN_TRAVEL: f64 = 1e-3;

/// The temperature of the geometric model where `[thermal]` does not say, °C (ISO 1).
fn default_reference_c() -> f64 {
    20.0
}

impl Machine {
    /// Reads a machine file; CSV tables are found relative to the file's folder, and must lie
    /// in it or below it.
    pub fn from_path(path: &Path) -> Result<Machine, MachineError> {
        Machine::from_path_reaching(path, Reach::Folder)
    }

    /// [`Machine::from_path`] with CSV tables allowed where `reach` says.
    pub fn from_path_reaching(path: &Path, reach: Reach) -> Result<Machine, MachineError> {
        let file = path.display().to_string();
        let text = read_text(path)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Machine::from_toml_reaching(&text, &file, Some(&base), reach)
    }

    /// Parses machine-file text. `file` names it in errors; `csv_base` is the folder CSV paths are
    /// relative to (`None`: CSV tables are not allowed, as in embedded machines), and which they
    /// must lie in or below.
    pub fn from_toml(
        text: &str,
        file: &str,
        csv_base: Option<&Path>,
    ) -> Result<Machine, MachineError> {
        Machine::from_toml_reaching(text, file, csv_base, Reach::Folder)
    }

    /// [`Machine::from_toml`] with CSV tables allowed where `reach` says.
    pub fn from_toml_reaching(
        text: &str,
        file: &str,
        csv_base: Option<&Path>,
        reach: Reach,
    ) -> Result<Machine, MachineError> {
        if let Some(message) = crate::error::toml_beyond_limits(text) {
            return Err(MachineError::Toml {
                file: file.to_string(),
                message,
            });
        }
        let raw: RawMachine = toml::from_str(text).map_err(|e| MachineError::Toml {
            file: file.to_string(),
            message: toml_message(&e, text),
        })?;
        let chain = Chain::parse(&raw.chain).map_err(|source| MachineError::Chain {
            file: file.to_string(),
            source,
        })?;
        let thermal = match raw.thermal {
            Some(t) => Some(thermal(file, t)?),
            None => None,
        };
        let mut reader = Reader {
            file: file.to_string(),
            csv_base: csv_base.map(Path::to_path_buf),
            reach,
            csv_files: Vec::new(),
            chain: chain.clone(),
            thermal_inputs: thermal
                .as_ref()
                .map_or(Vec::new(), |t: &Thermal| t.inputs.clone()),
            dependent: Vec::new(),
            values: Vec::new(),
            found: Vec::new(),
            uncertain: Vec::new(),
        };

        for section in raw.axes.keys() {
            let known = section.len() == 1
                && section
                    .chars()
                    .next()
                    .and_then(AxisLetter::from_char)
                    .is_some_and(|l| chain.contains(l));
            if !known {
                return Err(MachineError::AxisNotInChain {
                    file: file.to_string(),
                    section: excerpt(section).into_owned(),
                    chain: raw.chain.clone(),
                });
            }
        }
        let mut axes = Vec::new();
        for letter in chain.axes() {
            let table = raw.axes.get(&letter.to_string()).ok_or_else(|| {
                MachineError::MissingAxisSection {
                    file: file.to_string(),
                    axis: letter,
                    chain: raw.chain.clone(),
                }
            })?;
            axes.push(reader.axis(letter, table)?);
        }

        let tool_offset_mm = raw.tool.map_or([0.0; 3], |t| t.offset);
        reader.check_finite_all("tool.offset", &tool_offset_mm)?;
        let mut spindle = [0.0; 5];
        for (key, value) in raw.spindle.iter().flatten() {
            let path = format!("spindle.{key}");
            let index = SPINDLE_NAMES.iter().position(|n| n == key).ok_or_else(|| {
                reader.key_error(
                    &path,
                    format!(
                        "unknown key `{key}` (the spindle's errors are {})",
                        SPINDLE_NAMES.join(", ")
                    ),
                )
            })?;
            let target = ErrorTarget::Spindle { index };
            let spec = reader.error_value(target, key, &path, value, ValueKind::Constant)?;
            spindle[index] = spec.value.eval(0.0);
            reader.values.push(ErrorValue {
                key: path.clone(),
                axis: None,
                angular: index >= 3,
                spec: spec.clone(),
            });
            reader.keep(target, spec);
        }
        let uncertainty = reader.uncertainty(raw.covariance.as_ref())?;

        plausible::check_lengths(file, &axes, &tool_offset_mm)?;
        plausible::check_values(file, &reader.values, &axes)?;
        // The name is printed in every summary and written into every output's header.
        if raw.name.chars().any(char::is_control) || raw.name.chars().count() > MAX_NAME_CHARS {
            return Err(reader.key_error(
                "name",
                format!(
                    "a machine's name is one line of at most {MAX_NAME_CHARS} characters, without control characters"
                ),
            ));
        }

        Ok(Machine {
            name: raw.name,
            description: raw.description,
            chain,
            axes,
            tool_offset_mm,
            spindle,
            thermal,
            dependent: reader.dependent,
            inputs: Inputs::default(),
            uncertainty,
            source: MachineSource {
                toml: text.to_string(),
                csv_files: reader.csv_files,
                folder: csv_base.map(Path::to_path_buf),
            },
        })
    }
}

struct Reader {
    file: String,
    csv_base: Option<PathBuf>,
    /// Where CSV tables may lie.
    reach: Reach,
    csv_files: Vec<(String, String)>,
    chain: Chain,
    /// `[thermal].inputs`, the names `per_kelvin` may use.
    thermal_inputs: Vec<String>,
    /// The error values read so far that depend on the evaluation inputs.
    dependent: Vec<Dependent>,
    /// The error values read so far, checked once every travel is known.
    values: Vec<ErrorValue>,
    /// The standard uncertainties the forms of the error value being read carry, not yet
    /// assigned to the value and its part (see `uncertainty.rs`).
    found: Vec<uncertainty::Found>,
    /// The error values (and parts) read so far that carry standard uncertainties.
    uncertain: Vec<crate::model::uncertainty::UncertainValue>,
}

/// `[thermal]` checked: inputs named once each.
fn thermal(file: &str, raw: RawThermal) -> Result<Thermal, MachineError> {
    let error = |message: String| MachineError::Key {
        file: file.to_string(),
        key: "thermal.inputs".into(),
        message,
    };
    use crate::model::inputs::{ABSOLUTE_ZERO_C, MAX_REFERENCE_C};
    if !(ABSOLUTE_ZERO_C..=MAX_REFERENCE_C).contains(&raw.reference_c) {
        return Err(MachineError::Key {
            file: file.to_string(),
            key: "thermal.reference_C".into(),
            message: format!(
                "{} °C: a reference temperature lies between absolute zero ({ABSOLUTE_ZERO_C} °C) and {MAX_REFERENCE_C} °C",
                crate::error::shown(raw.reference_c)
            ),
        });
    }
    for (n, input) in raw.inputs.iter().enumerate() {
        if input.trim().is_empty() || input.contains([',', '=']) {
            return Err(error(format!(
                "`{input}` is not a name (no commas, no `=`)"
            )));
        }
        if raw.inputs[..n].contains(input) {
            return Err(error(format!("`{input}` is declared twice")));
        }
    }
    Ok(Thermal {
        reference_c: raw.reference_c,
        inputs: raw.inputs,
    })
}

impl Reader {
    /// Keeps an error value that depends on the evaluation inputs.
    fn keep(&mut self, target: ErrorTarget, spec: ValueSpec) {
        if spec.reverse.is_some() || !spec.per_kelvin.is_empty() {
            self.dependent.push(Dependent {
                target,
                value: spec.value,
                reverse: spec.reverse,
                per_kelvin: spec.per_kelvin,
            });
        }
    }

    /// An error at `key` (cut to an excerpt: a key the file misspells may be any length).
    fn key_error(&self, key: &str, message: impl Into<String>) -> MachineError {
        MachineError::Key {
            file: self.file.clone(),
            key: excerpt(key).into_owned(),
            message: message.into(),
        }
    }

    fn check_finite(&self, key: &str, value: f64) -> Result<f64, MachineError> {
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.key_error(key, format!("value {value} is not a finite number")))
        }
    }

    fn check_finite_all(&self, key: &str, values: &[f64]) -> Result<(), MachineError> {
        values
            .iter()
            .try_for_each(|&v| self.check_finite(key, v).map(|_| ()))
    }

    fn number(&self, key: &str, value: &toml::Value) -> Result<f64, MachineError> {
        let v = match value {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(i) => *i as f64,
            other => {
                return Err(self.key_error(
                    key,
                    format!("expected a number, found {}", other.type_str()),
                ))
            }
        };
        self.check_finite(key, v)
    }

    fn numbers<const N: usize>(
        &self,
        key: &str,
        value: &toml::Value,
    ) -> Result<[f64; N], MachineError> {
        let array = value
            .as_array()
            .filter(|a| a.len() == N)
            .ok_or_else(|| self.key_error(key, format!("expected an array of {N} numbers")))?;
        let mut out = [0.0; N];
        for (n, v) in array.iter().enumerate() {
            out[n] = self.number(key, v)?;
        }
        Ok(out)
    }

    fn axis(&mut self, letter: AxisLetter, table: &toml::Table) -> Result<Axis, MachineError> {
        let section = format!("axes.{letter}");
        let mut axis = Axis::nominal(letter, [0.0, 0.0]);
        let mut range = None;
        for (key, value) in table {
            let path = format!("{section}.{key}");
            match key.as_str() {
                "range" => {
                    let [lo, hi] = self.numbers::<2>(&path, value)?;
                    if lo >= hi {
                        return Err(self.key_error(
                            &path,
                            format!("range [{lo}, {hi}] is inverted or empty: the first value must be below the second"),
                        ));
                    }
                    if hi - lo < MIN_TRAVEL {
                        return Err(self.key_error(
                            &path,
                            format!(
                                "range [{}, {}] is a travel of less than {MIN_TRAVEL} mm (or degrees): no axis moves so little",
                                crate::error::shown(lo),
                                crate::error::shown(hi)
                            ),
                        ));
                    }
                    range = Some([lo, hi]);
                }
                "offset" => axis.offset_mm = self.numbers::<3>(&path, value)?,
                "direction" => {
                    let d = self.number(&path, value)?;
                    if d != 1.0 && d != -1.0 {
                        return Err(
                            self.key_error(&path, format!("direction must be 1 or -1, found {d}"))
                        );
                    }
                    axis.direction = d;
                }
                _ => self.error_key(&mut axis, key, &path, value)?,
            }
        }
        axis.range = range.ok_or_else(|| {
            self.key_error(
                &format!("{section}.range"),
                "missing: every axis needs its travel",
            )
        })?;
        Ok(axis)
    }

    /// `E<c><k>` (component error of axis k) or `E<c>0<k>` (location error of axis k).
    fn error_key(
        &mut self,
        axis: &mut Axis,
        key: &str,
        path: &str,
        value: &toml::Value,
    ) -> Result<(), MachineError> {
        let chars: Vec<char> = key.chars().collect();
        let component = (chars.len() == 3 || chars.len() == 4)
            && chars[0] == 'E'
            && COMPONENT_NAMES.contains(&chars[1])
            && (chars.len() == 3 || chars[2] == '0');
        let owner = chars.last().copied().and_then(AxisLetter::from_char);
        let (true, Some(owner)) = (component, owner) else {
            return Err(self.key_error(
                path,
                format!(
                    "unknown key `{key}` (an axis section takes range, offset, direction, component errors such as E{c}{l} and location errors such as E{c}0{l})",
                    c = 'X',
                    l = axis.letter
                ),
            ));
        };
        if owner != axis.letter {
            return Err(self.key_error(
                path,
                format!("`{key}` is an error of axis {owner}; it belongs in [axes.{owner}]"),
            ));
        }
        let n = COMPONENT_NAMES
            .iter()
            .position(|&c| c == chars[1])
            .unwrap_or(0);
        let letter = axis.letter;
        let target = if chars.len() == 4 {
            ErrorTarget::Location {
                axis: letter,
                index: n,
            }
        } else {
            ErrorTarget::Component {
                axis: letter,
                index: n,
            }
        };
        let spec = self.error_value(
            target,
            key,
            path,
            value,
            if chars.len() == 4 {
                ValueKind::Constant
            } else {
                ValueKind::Component
            },
        )?;
        self.values.push(ErrorValue {
            key: path.to_string(),
            axis: Some(letter),
            angular: n >= 3,
            spec: spec.clone(),
        });
        if chars.len() == 4 {
            axis.location[n] = spec.value.eval(0.0);
        } else {
            axis.components[n] = Some(spec.value.clone());
        }
        self.keep(target, spec);
        Ok(())
    }
}
