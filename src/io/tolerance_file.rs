//! The tolerance file (TOML, docs/model.md, "Tolerances and sampled machines"): how far each error
//! value of the machines built may lie from the machine file's, and the scaled copy a tolerance
//! allocation writes.
//!
//! ```toml
//! [axes.Y]
//! EC0Y = { uniform = 20e-6 }                   # EC0Y = nominal + s, s ~ U(-20e-6, +20e-6)
//! EXY  = { normal = 0.004, shape = "line" }    # positioning error growing along the travel
//! [spindle]
//! EZS = { normal = 0.002 }
//! ```
//!
//! The file is read with `toml_edit` so that an allocation can write it back with its comments
//! and layout kept, only the widths changed. Each error names the file and the key.

use std::path::{Path, PathBuf};

use toml_edit::{DocumentMut, Item, TableLike};

use super::machine_file::{MAX_PLAUSIBLE_ANGLE_RAD, MAX_PLAUSIBLE_LENGTH_MM};
use super::{read_text, FileError};
use crate::error::{Classify, ErrorKind};
use crate::limits::number_words;
use crate::model::perturbation::{
    Distribution, ErrorTarget, Perturbation, Shape, Tolerance, SPINDLE_NAMES,
};
use crate::model::{AxisLetter, Machine, COMPONENT_NAMES};

/// What is wrong with a tolerance file. Each message names the file and the key.
#[derive(Debug, thiserror::Error)]
pub enum ToleranceError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{file}: {message}")]
    Toml { file: String, message: String },
    #[error("{file}: {key}: {message}")]
    Key {
        file: String,
        key: String,
        message: String,
    },
    #[error(
        "{file}: names no tolerance: give at least one, e.g. [axes.Y] EC0Y = {{ uniform = 20e-6 }}"
    )]
    Empty { file: String },
}

impl Classify for ToleranceError {
    fn kind(&self) -> ErrorKind {
        match self {
            ToleranceError::File(e) => e.kind(),
            _ => ErrorKind::Input,
        }
    }
}

/// A tolerance file read against a machine.
#[derive(Debug, Clone)]
pub struct ToleranceFile {
    pub path: PathBuf,
    /// In the order of the file.
    pub tolerances: Vec<Tolerance>,
    document: DocumentMut,
}

impl ToleranceFile {
    /// Reads the tolerance file at `path` for `machine`.
    pub fn load(path: &Path, machine: &Machine) -> Result<ToleranceFile, ToleranceError> {
        let text = read_text(path)?;
        ToleranceFile::parse(&text, path, machine)
    }

    /// Parses `text`, read from `path`, for `machine`.
    pub fn parse(
        text: &str,
        path: &Path,
        machine: &Machine,
    ) -> Result<ToleranceFile, ToleranceError> {
        let file = path.display().to_string();
        if let Some(message) = crate::error::toml_beyond_limits(text) {
            return Err(ToleranceError::Toml { file, message });
        }
        let document: DocumentMut =
            text.parse()
                .map_err(|e: toml_edit::TomlError| ToleranceError::Toml {
                    file: file.clone(),
                    message: crate::error::toml_edit_message(&e, text),
                })?;
        let reader = Reader {
            file: &file,
            machine,
        };
        let mut tolerances = Vec::new();
        for (section, item) in document.iter() {
            match section {
                "axes" => {
                    let axes = reader.table(section, item)?;
                    for (letter, item) in axes.iter() {
                        let path = format!("axes.{letter}");
                        let axis = reader.axis(&path, letter)?;
                        for (key, item) in reader.table(&path, item)?.iter() {
                            let target = reader.axis_target(&path, axis, key)?;
                            tolerances.push(reader.tolerance(&path, key, item, target)?);
                        }
                    }
                }
                "spindle" => {
                    for (key, item) in reader.table(section, item)?.iter() {
                        let index =
                            SPINDLE_NAMES
                                .iter()
                                .position(|n| *n == key)
                                .ok_or_else(|| {
                                    reader.key_error(
                                        &format!("spindle.{key}"),
                                        format!(
                                            "not an error of the spindle (its errors are {})",
                                            SPINDLE_NAMES.join(", ")
                                        ),
                                    )
                                })?;
                        let target = ErrorTarget::Spindle { index };
                        tolerances.push(reader.tolerance(section, key, item, target)?);
                    }
                }
                other => {
                    return Err(reader.key_error(
                        other,
                        "unknown section (a tolerance file has [axes.K] sections and [spindle])",
                    ))
                }
            }
        }
        if tolerances.is_empty() {
            return Err(ToleranceError::Empty { file });
        }
        Ok(ToleranceFile {
            path: path.to_path_buf(),
            tolerances,
            document,
        })
    }

    /// The file's text with the width of every tolerance `scale(t)` says to scale multiplied by
    /// its factor; comments, order and layout kept.
    pub fn scaled_text(&self, scale: impl Fn(usize) -> Option<f64>) -> String {
        let mut document = self.document.clone();
        for (t, tolerance) in self.tolerances.iter().enumerate() {
            let Some(factor) = scale(t) else { continue };
            let key = tolerance.perturbation.target.key();
            let distribution = tolerance.distribution;
            // Never wider than the reader accepts, however the factor rounds.
            let width = distribution
                .scaled(factor)
                .width()
                .min(most_width(tolerance.perturbation.target).0);
            let mut item: Option<&mut Item> = None;
            for part in key.split('.') {
                item = match item {
                    None => document.get_mut(part),
                    Some(i) => i.get_mut(part),
                };
            }
            if let Some(value) = item
                .and_then(|i| i.get_mut(distribution.name()))
                .and_then(Item::as_value_mut)
            {
                let decor = value.decor().clone();
                *value = width_value(width);
                *value.decor_mut() = decor;
            }
        }
        document.to_string()
    }
}

/// The widest tolerance of `target` the file may give, and its unit: an angular error's
/// (rad) or a translational error's (mm) most plausible value on any machine tool.
pub fn most_width(target: ErrorTarget) -> (f64, &'static str) {
    if target.is_angular() {
        (MAX_PLAUSIBLE_ANGLE_RAD, "rad")
    } else {
        (MAX_PLAUSIBLE_LENGTH_MM, "mm")
    }
}

/// A width rounded to 6 significant digits and written as a person would: `0.0025`, `1.5e-5`.
fn width_value(width: f64) -> toml_edit::Value {
    let rounded: f64 = format!("{width:.5e}").parse().unwrap_or(width);
    let text = if rounded != 0.0 && rounded.abs() < 1e-3 {
        format!("{rounded:e}")
    } else {
        format!("{rounded:?}")
    };
    text.parse()
        .unwrap_or_else(|_| toml_edit::Value::from(rounded))
}

struct Reader<'a> {
    file: &'a str,
    machine: &'a Machine,
}

impl Reader<'_> {
    /// An error at `key` (cut to an excerpt: a key the file misspells may be any length).
    fn key_error(&self, key: &str, message: impl Into<String>) -> ToleranceError {
        ToleranceError::Key {
            file: self.file.to_string(),
            key: crate::error::excerpt(key).into_owned(),
            message: message.into(),
        }
    }

    fn table<'i>(&self, key: &str, item: &'i Item) -> Result<&'i dyn TableLike, ToleranceError> {
        item.as_table_like()
            .ok_or_else(|| self.key_error(key, "expected a table"))
    }

    /// The axis of section `[axes.<letter>]`.
    fn axis(&self, path: &str, letter: &str) -> Result<AxisLetter, ToleranceError> {
        let chain = self.machine.chain.hwang_notation();
        match letter.chars().collect::<Vec<_>>()[..] {
            [c] => AxisLetter::from_char(c),
            _ => None,
        }
        .filter(|&l| self.machine.axis(l).is_some())
        .ok_or_else(|| {
            self.key_error(
                path,
                format!("names no axis of the machine's chain `{chain}`"),
            )
        })
    }

    /// `E<c><k>` (component error) or `E<c>0<k>` (location error) of axis `axis`.
    fn axis_target(
        &self,
        path: &str,
        axis: AxisLetter,
        key: &str,
    ) -> Result<ErrorTarget, ToleranceError> {
        let chars: Vec<char> = key.chars().collect();
        let index = match chars[..] {
            ['E', c, ..] if chars.len() == 3 || (chars.len() == 4 && chars[2] == '0') => {
                COMPONENT_NAMES.iter().position(|&n| n == c)
            }
            _ => None,
        };
        let owner = chars.last().copied().and_then(AxisLetter::from_char);
        let full = format!("{path}.{key}");
        match (index, owner) {
            (Some(index), Some(owner)) if owner == axis => Ok(if chars.len() == 4 {
                ErrorTarget::Location { axis, index }
            } else {
                ErrorTarget::Component { axis, index }
            }),
            (Some(_), Some(owner)) => Err(self.key_error(
                &full,
                format!("`{key}` is an error of axis {owner}, not of {axis}"),
            )),
            _ => Err(self.key_error(
                &full,
                format!(
                    "not an error of this machine (axis {axis} has component errors \
                     EX{axis} … EC{axis} and location errors EX0{axis} … EC0{axis})"
                ),
            )),
        }
    }

    /// `{ uniform = h }` or `{ normal = σ }`, with an optional `shape`.
    fn tolerance(
        &self,
        path: &str,
        key: &str,
        item: &Item,
        target: ErrorTarget,
    ) -> Result<Tolerance, ToleranceError> {
        let full = format!("{path}.{key}");
        let table = item.as_table_like().ok_or_else(|| {
            self.key_error(
                &full,
                "expected { uniform = h } or { normal = σ }, with an optional shape",
            )
        })?;
        let mut distribution = None;
        let mut shape = Shape::Constant;
        for (name, value) in table.iter() {
            let at = format!("{full}.{name}");
            match name {
                "uniform" | "normal" => {
                    if distribution.is_some() {
                        return Err(self.key_error(
                            &full,
                            "gives two distributions: give one of uniform and normal",
                        ));
                    }
                    let width = self.width(&at, value)?;
                    let (most, unit) = most_width(target);
                    if width > most {
                        return Err(self.key_error(
                            &at,
                            format!(
                                "{} {unit} is wider than any machine tool's error (at most {most:e} {unit}): check the unit",
                                number_words(width)
                            ),
                        ));
                    }
                    distribution = Some(if name == "uniform" {
                        Distribution::Uniform { half_width: width }
                    } else {
                        Distribution::Normal { sigma: width }
                    });
                }
                "shape" => {
                    let text = value.as_str().ok_or_else(|| {
                        self.key_error(&at, "expected \"constant\", \"line\" or \"bow\"")
                    })?;
                    shape = Shape::parse(text).ok_or_else(|| {
                        self.key_error(
                            &at,
                            format!("unknown shape `{text}` (constant, line or bow)"),
                        )
                    })?;
                }
                other => {
                    return Err(self.key_error(
                        &at,
                        format!(
                            "unknown distribution or key `{other}` (a tolerance takes \
                             uniform = h or normal = σ, and shape)"
                        ),
                    ))
                }
            }
        }
        let distribution = distribution.ok_or_else(|| {
            self.key_error(&full, "no distribution: give uniform = h or normal = σ")
        })?;
        if shape != Shape::Constant && !matches!(target, ErrorTarget::Component { .. }) {
            return Err(self.key_error(
                &format!("{full}.shape"),
                format!(
                    "`{}` on a {} error: location and spindle errors are constants and take \
                     the shape \"constant\" only",
                    shape.name(),
                    if matches!(target, ErrorTarget::Spindle { .. }) {
                        "spindle"
                    } else {
                        "location"
                    }
                ),
            ));
        }
        Ok(Tolerance {
            perturbation: Perturbation { target, shape },
            distribution,
        })
    }

    /// A width: a finite number at or above zero.
    fn width(&self, key: &str, item: &Item) -> Result<f64, ToleranceError> {
        let value = item.as_value();
        let width = value
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .ok_or_else(|| self.key_error(key, "expected a number"))?;
        if !width.is_finite() {
            return Err(self.key_error(key, format!("{width} is not a finite width")));
        }
        if width < 0.0 {
            return Err(self.key_error(
                key,
                format!("{width} is negative: a width is at or above zero"),
            ));
        }
        Ok(width)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Machine;

    fn machine() -> Machine {
        Machine::nominal(
            "t",
            "FYXFZ",
            &[
                (AxisLetter::X, [0.0, 600.0]),
                (AxisLetter::Y, [0.0, 400.0]),
                (AxisLetter::Z, [0.0, 300.0]),
            ],
        )
        .unwrap()
    }

    #[test]
    fn reads_the_file_in_order_and_scales_only_what_it_is_asked_to() {
        let text = "# a design\n[axes.Y]\nEC0Y = { uniform = 20e-6 } # squareness\nEXY = { normal = 0.004, shape = \"line\" }\n[spindle]\nEZS = { normal = 2 }\n";
        let file = ToleranceFile::parse(text, Path::new("t.toml"), &machine()).unwrap();
        let keys: Vec<String> = file
            .tolerances
            .iter()
            .map(|t| t.perturbation.target.key())
            .collect();
        assert_eq!(keys, ["axes.Y.EC0Y", "axes.Y.EXY", "spindle.EZS"]);
        assert_eq!(file.tolerances[1].perturbation.shape, Shape::Line);
        assert_eq!(
            file.tolerances[2].distribution,
            Distribution::Normal { sigma: 2.0 }
        );
        let scaled = file.scaled_text(|t| (t != 1).then_some(0.5));
        assert!(scaled.contains("# a design"), "{scaled}");
        assert!(scaled.contains("# squareness"), "{scaled}");
        let again = ToleranceFile::parse(&scaled, Path::new("t.toml"), &machine()).unwrap();
        assert_eq!(again.tolerances[0].distribution.width(), 10e-6);
        assert_eq!(again.tolerances[1].distribution.width(), 0.004);
        assert_eq!(again.tolerances[2].distribution.width(), 1.0);
    }
}
