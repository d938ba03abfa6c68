//! The machine file (TOML, MODEL.md "The machine file"): parsing and validation.
//!
//! The top level, `[tool]` and `[spindle]` are serde structs with `deny_unknown_fields`. The keys
//! of an `[axes.K]` section depend on its letter (`EXX` belongs to X, `EXY` to Y), so axis
//! sections are read key by key; every key is either known or an error that names it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::csv::{Csv, CsvError};
use super::{read_text, FileError};
use crate::error::input_errors;

use crate::model::chain::{AxisLetter, Chain, ChainError};
use crate::model::errorfn::{ErrorFunction, Interp, Table, TableError};
use crate::model::{Axis, Machine, MachineSource, COMPONENT_NAMES};

/// What is wrong with a machine file. Each message names the file and the key.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{file}: {message}")]
    Toml { file: String, message: String },
    #[error("{file}: chain: {source}")]
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
    #[error("no embedded machine is called `{name}` and no file `{name}` exists (`volmap machines` lists the embedded ones)")]
    UnknownMachine { name: String },
}

input_errors!(MachineError);

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
    spindle: Option<RawSpindle>,
    #[serde(default)]
    axes: BTreeMap<String, toml::Table>,
}

/// `[tool]`: the tool tip in the spindle frame, mm.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    offset: [f64; 3],
}

/// `[spindle]`: the constant spindle error `S = E(EXS, EYS, EZS, EAS, EBS, 0)`.
#[allow(non_snake_case)]
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpindle {
    EXS: Option<f64>,
    EYS: Option<f64>,
    EZS: Option<f64>,
    EAS: Option<f64>,
    EBS: Option<f64>,
}

impl Machine {
    /// Reads a machine file; CSV tables are found relative to the file's folder.
    pub fn from_path(path: &Path) -> Result<Machine, MachineError> {
        let file = path.display().to_string();
        let text = read_text(path)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Machine::from_toml(&text, &file, Some(&base))
    }

    /// Parses machine-file text. `file` names it in errors; `csv_base` is the folder CSV paths are
    /// relative to (`None`: CSV tables are not allowed, as in embedded machines).
    pub fn from_toml(
        text: &str,
        file: &str,
        csv_base: Option<&Path>,
    ) -> Result<Machine, MachineError> {
        let raw: RawMachine = toml::from_str(text).map_err(|e| MachineError::Toml {
            file: file.to_string(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })?;
        let chain = Chain::parse(&raw.chain).map_err(|source| MachineError::Chain {
            file: file.to_string(),
            source,
        })?;
        let mut reader = Reader {
            file: file.to_string(),
            csv_base: csv_base.map(Path::to_path_buf),
            csv_files: Vec::new(),
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
                    section: section.clone(),
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
        let s = raw.spindle.unwrap_or_default();
        let spindle = [s.EXS, s.EYS, s.EZS, s.EAS, s.EBS].map(|v| v.unwrap_or(0.0));
        for (n, name) in ["EXS", "EYS", "EZS", "EAS", "EBS"].iter().enumerate() {
            reader.check_finite(&format!("spindle.{name}"), spindle[n])?;
        }

        Ok(Machine {
            name: raw.name,
            description: raw.description,
            chain,
            axes,
            tool_offset_mm,
            spindle,
            source: MachineSource {
                toml: text.to_string(),
                csv_files: reader.csv_files,
            },
        })
    }
}

/// The keys of an error value given as a table, before they are checked against each other.
struct ErrorSpec {
    poly: Option<Vec<f64>>,
    nodes: Option<Vec<(f64, f64)>>,
    csv: Option<String>,
    column: Option<String>,
    interp: Interp,
    periodic: bool,
}

struct Reader {
    file: String,
    csv_base: Option<PathBuf>,
    csv_files: Vec<(String, String)>,
}

impl Reader {
    fn key_error(&self, key: &str, message: impl Into<String>) -> MachineError {
        MachineError::Key {
            file: self.file.clone(),
            key: key.to_string(),
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
        if chars.len() == 4 {
            axis.location[n] = self.number(path, value).map_err(|_| {
                self.key_error(path, "a location error is a constant: give a finite number")
            })?;
        } else {
            axis.components[n] = Some(self.error_function(axis.letter, key, path, value)?);
        }
        Ok(())
    }

    fn error_function(
        &mut self,
        letter: AxisLetter,
        column_default: &str,
        path: &str,
        value: &toml::Value,
    ) -> Result<ErrorFunction, MachineError> {
        let table = match value {
            toml::Value::Table(t) => t,
            _ => return Ok(ErrorFunction::Constant(self.number(path, value)?)),
        };
        let spec = self.error_spec(letter, path, table)?;
        let sources = [
            spec.poly.is_some(),
            spec.nodes.is_some(),
            spec.csv.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if sources != 1 {
            return Err(self.key_error(path, "give exactly one of `poly`, `table` or `csv`"));
        }
        if spec.column.is_some() && spec.csv.is_none() {
            return Err(self.key_error(&format!("{path}.column"), "`column` goes with `csv`"));
        }
        if let Some(coefficients) = spec.poly {
            if table.contains_key("interp") || table.contains_key("periodic") {
                return Err(self.key_error(
                    path,
                    "`interp` and `periodic` apply to tables, not to `poly`",
                ));
            }
            return Ok(ErrorFunction::Poly(coefficients));
        }
        let nodes = match (spec.nodes, spec.csv) {
            (Some(nodes), _) => nodes,
            (None, Some(csv)) => {
                let column = spec.column.unwrap_or_else(|| column_default.to_string());
                self.csv_column(path, &csv, &column)?
            }
            (None, None) => unreachable!("one source is present"),
        };
        Table::new(nodes, spec.interp, spec.periodic)
            .map(ErrorFunction::Table)
            .map_err(|source| MachineError::Table {
                file: self.file.clone(),
                key: path.to_string(),
                source,
            })
    }

    /// The keys of an error value's table, each checked on its own.
    fn error_spec(
        &self,
        letter: AxisLetter,
        path: &str,
        table: &toml::Table,
    ) -> Result<ErrorSpec, MachineError> {
        let mut spec = ErrorSpec {
            poly: None,
            nodes: None,
            csv: None,
            column: None,
            interp: Interp::Linear,
            periodic: false,
        };
        for (key, v) in table {
            let sub = format!("{path}.{key}");
            let text = |what: &str| {
                v.as_str()
                    .map(str::to_string)
                    .ok_or_else(|| self.key_error(&sub, format!("expected a {what}")))
            };
            match key.as_str() {
                "poly" => {
                    let array = v
                        .as_array()
                        .filter(|a| !a.is_empty())
                        .ok_or_else(|| self.key_error(&sub, "expected a non-empty array of coefficients [c0, c1, …]"))?;
                    spec.poly = Some(array.iter().map(|c| self.number(&sub, c)).collect::<Result<Vec<_>, _>>()?);
                }
                "table" => {
                    let rows = v
                        .as_array()
                        .ok_or_else(|| self.key_error(&sub, "expected an array of [position, value] rows"))?;
                    let mut parsed = Vec::with_capacity(rows.len());
                    for (r, row) in rows.iter().enumerate() {
                        let [q, e] = self.numbers::<2>(&format!("{sub}[{r}]"), row)?;
                        parsed.push((q, e));
                    }
                    spec.nodes = Some(parsed);
                }
                "csv" => spec.csv = Some(text("file name")?),
                "column" => spec.column = Some(text("column name")?),
                "interp" => {
                    let name = v.as_str().unwrap_or("");
                    spec.interp = Interp::parse(name).ok_or_else(|| {
                        self.key_error(&sub, format!("unknown interpolation `{v}`: use \"linear\", \"quadratic\" or \"cubic\""))
                    })?;
                }
                "periodic" => {
                    spec.periodic = v.as_bool().ok_or_else(|| self.key_error(&sub, "expected true or false"))?;
                    if spec.periodic && letter.is_linear() {
                        return Err(self.key_error(&sub, "only rotary axes (A, B, C) have periodic tables"));
                    }
                }
                other => {
                    return Err(self.key_error(
                        &sub,
                        format!("unknown key `{other}` (an error value takes poly, table, csv, column, interp, periodic)"),
                    ))
                }
            }
        }
        Ok(spec)
    }

    /// Reads `(position, value)` rows from a CSV file: one header row, first column the position.
    fn csv_column(
        &mut self,
        key: &str,
        csv: &str,
        column: &str,
    ) -> Result<Vec<(f64, f64)>, MachineError> {
        let Some(base) = &self.csv_base else {
            return Err(self.key_error(key, "CSV tables need a machine file on disk (embedded machines carry their tables inline)"));
        };
        let path = base.join(csv);
        let text = read_text(&path).map_err(|source| MachineError::CsvFile {
            file: self.file.clone(),
            key: key.to_string(),
            source,
        })?;
        let csv_name = path.display().to_string();
        let rows = read_column(&text, &csv_name, column).map_err(|source| MachineError::Csv {
            file: self.file.clone(),
            key: key.to_string(),
            source,
        })?;
        if !self.csv_files.iter().any(|(name, _)| name == csv) {
            self.csv_files.push((csv.to_string(), text));
        }
        Ok(rows)
    }
}

/// The `(position, value)` rows of `column` in a CSV table whose first column is the position.
fn read_column(text: &str, path: &str, column: &str) -> Result<Vec<(f64, f64)>, CsvError> {
    let mut csv = Csv::new(text, path);
    let header = csv.header("naming the position, then the error columns")?;
    let index = header
        .names
        .iter()
        .position(|n| n == column)
        .ok_or_else(|| {
            csv.error(
                header.line,
                format!(
                    "has no column `{column}` (its columns: {})",
                    header.names.join(", ")
                ),
            )
        })?;
    if index == 0 {
        return Err(csv.error(
            header.line,
            format!("column `{column}` is the position column; name a value column"),
        ));
    }
    let position = format!("`{}`", header.names[0]);
    let value = format!("`{column}`");
    csv.rows()
        .map(|row| Ok((row.number(0, &position)?, row.number(index, &value)?)))
        .collect()
}
