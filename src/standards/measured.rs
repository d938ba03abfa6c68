//! Measured results in: CSV with one header row naming the columns, one measurement per row.
//!
//! A column is named by what it holds and its unit, `deviation_mm` or `deviation_um`, `angle_deg`:
//! lengths may come in mm or µm (`_um`, as interferometers export them), and are read in mm.

use std::path::Path;

use super::StandardsError;
use crate::io::csv::{Csv, CsvError};
use crate::io::read_text;
use crate::limits::{number_words, MAX_MEASURED_MAGNITUDE};

/// The unit a column is read in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// mm, or µm (`_um`) converted to mm.
    Length,
    /// degrees (`_deg`).
    Angle,
    /// A small angle: arc-seconds (`_arcsec`), or µrad (`_urad`) converted to arc-seconds.
    SmallAngle,
    /// A plain count or label (no suffix).
    None,
}

/// A parsed CSV: the columns asked for, in the order asked, and each row's line number.
#[derive(Debug, Clone)]
pub struct Measured {
    pub path: String,
    pub lines: Vec<usize>,
    /// `[column][row]`, lengths in mm, angles in degrees, small angles in arc-seconds.
    pub columns: Vec<Vec<f64>>,
    /// The raw text of text columns (`None` unit), `[column][row]`; empty for numeric columns.
    pub text: Vec<Vec<String>>,
}

impl Measured {
    /// Reads `path` and picks the columns `wanted` (`(name, unit)`), each required. Columns not
    /// asked for are an error, so a misspelt name does not pass silently.
    pub fn read(path: &Path, wanted: &[(&str, Unit)]) -> Result<Measured, StandardsError> {
        let text = read_text(path)?;
        Self::parse(&text, &path.display().to_string(), wanted)
    }

    pub fn parse(
        text: &str,
        path: &str,
        wanted: &[(&str, Unit)],
    ) -> Result<Measured, StandardsError> {
        let expected = wanted
            .iter()
            .map(|(c, u)| match u {
                Unit::Length => format!("{c}_mm (or {c}_um)"),
                Unit::Angle => format!("{c}_deg"),
                Unit::SmallAngle => format!("{c}_arcsec (or {c}_urad)"),
                Unit::None => c.to_string(),
            })
            .collect::<Vec<_>>()
            .join(", ");
        let mut csv = Csv::new(text, path);
        let header = csv.header(&format!("naming {expected}"))?;
        // For each header column: which wanted column it is and the factor to mm.
        let mut source: Vec<(usize, f64)> = Vec::new();
        let mut found = vec![false; wanted.len()];
        for column in &header.names {
            let matched = wanted.iter().enumerate().find_map(|(n, (c, unit))| {
                let factor = match unit {
                    Unit::Length if *column == format!("{c}_mm") => Some(1.0),
                    Unit::Length if *column == format!("{c}_um") => Some(1e-3),
                    Unit::Angle if *column == format!("{c}_deg") => Some(1.0),
                    Unit::SmallAngle if *column == format!("{c}_arcsec") => Some(1.0),
                    Unit::SmallAngle if *column == format!("{c}_urad") => {
                        Some(1e-6 * super::ARCSEC_PER_RAD)
                    }
                    Unit::None if column == c => Some(1.0),
                    _ => None,
                };
                factor.map(|f| (n, f))
            });
            let Some((n, factor)) = matched else {
                return Err(csv
                    .error(
                        header.line,
                        format!(
                            "unknown column `{}`; the columns are: {expected}",
                            crate::error::excerpt(column)
                        ),
                    )
                    .into());
            };
            if found[n] {
                return Err(csv
                    .error(
                        header.line,
                        format!("column `{}` appears twice", crate::error::excerpt(column)),
                    )
                    .into());
            }
            found[n] = true;
            source.push((n, factor));
        }
        if let Some(n) = found.iter().position(|f| !f) {
            return Err(csv
                .error(
                    header.line,
                    format!(
                        "missing column `{}`; the columns are: {expected}",
                        wanted[n].0
                    ),
                )
                .into());
        }
        let mut measured = Measured {
            path: path.to_string(),
            lines: Vec::new(),
            columns: vec![Vec::new(); wanted.len()],
            text: vec![Vec::new(); wanted.len()],
        };
        for row in csv.rows() {
            row.require_fields(source.len())?;
            for (field, &(n, factor)) in source.iter().enumerate() {
                if wanted[n].1 == Unit::None {
                    measured.text[n].push(row.fields[field].to_string());
                    measured.columns[n].push(f64::NAN);
                    continue;
                }
                let value = row.number(field, &format!("`{}`", wanted[n].0))?;
                if value.abs() * factor > MAX_MEASURED_MAGNITUDE {
                    return Err(row
                        .error(
                            format!(
                                "`{}` in column `{}` is beyond any measurement of a machine tool (at most {MAX_MEASURED_MAGNITUDE:e} mm, degrees or arc-seconds in magnitude): check the unit",
                                number_words(value),
                                header.names[field]
                            ),
                        )
                        .into());
                }
                measured.columns[n].push(value * factor);
            }
            measured.lines.push(row.line);
        }
        if measured.lines.is_empty() {
            return Err(csv
                .error(header.line, "no measurements after the header")
                .into());
        }
        Ok(measured)
    }

    pub fn len(&self) -> usize {
        self.lines.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// An error at row `row` of this file.
    pub fn error(&self, row: usize, message: String) -> StandardsError {
        StandardsError::Csv(CsvError {
            path: self.path.clone(),
            line: self.lines[row],
            message,
        })
    }

    /// Checks that column `n` rises strictly from row to row (positions and angles must come in
    /// the order they were measured along the path).
    pub fn require_increasing(&self, n: usize, what: &str) -> Result<(), StandardsError> {
        self.require_monotonic(n, what, true)
    }

    /// Checks that column `n` rises (or falls) strictly from row to row.
    pub fn require_monotonic(
        &self,
        n: usize,
        what: &str,
        rising: bool,
    ) -> Result<(), StandardsError> {
        for row in 1..self.len() {
            let (before, value) = (self.columns[n][row - 1], self.columns[n][row]);
            if (rising && value <= before) || (!rising && value >= before) {
                let order = if rising { "rising" } else { "falling" };
                return Err(self.error(
                    row,
                    format!(
                        "{what} {value} after {before}: rows must be sorted by {what}, {order}"
                    ),
                ));
            }
        }
        Ok(())
    }
}
