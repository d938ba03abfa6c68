//! Measured results in: CSV with one header row naming the columns, one measurement per row.
//!
//! A column is named by what it holds and its unit, `deviation_mm` or `deviation_um`, `angle_deg`:
//! lengths may come in mm or µm (`_um`, as interferometers export them), and are read in mm.

use std::path::Path;

use super::StandardsError;

/// The unit a column is read in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// mm, or µm (`_um`) converted to mm.
    Length,
    /// degrees (`_deg`).
    Angle,
    /// A plain count or label (no suffix).
    None,
}

/// A parsed CSV: the columns asked for, in the order asked, and each row's line number.
#[derive(Debug, Clone)]
pub struct Measured {
    pub path: String,
    pub lines: Vec<usize>,
    /// `[column][row]`, lengths in mm, angles in degrees.
    pub columns: Vec<Vec<f64>>,
    /// The raw text of text columns (`None` unit), `[column][row]`; empty for numeric columns.
    pub text: Vec<Vec<String>>,
}

/// A measurement file's name (for errors) and text.
pub(crate) fn read_text(path: &Path) -> Result<(String, String), StandardsError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| StandardsError::Io {
        path: name.clone(),
        source,
    })?;
    Ok((name, text))
}

/// The lines of a measurement CSV that hold its header and rows: 1-based line numbers, trimmed;
/// blank lines and `#` comments skipped.
pub(crate) fn csv_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// A row's fields, as many as the header has columns (else the message why not).
pub(crate) fn csv_fields(row: &str, columns: usize) -> Result<Vec<&str>, String> {
    let fields: Vec<&str> = row.split(',').map(str::trim).collect();
    if fields.len() != columns {
        return Err(format!("{} fields, the header has {columns}", fields.len()));
    }
    Ok(fields)
}

/// A finite number from a field of `column` (else the message why not).
pub(crate) fn csv_number(field: &str, column: &str) -> Result<f64, String> {
    field
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("`{field}` in column `{column}` is not a number"))
}

impl Measured {
    /// Reads `path` and picks the columns `wanted` (`(name, unit)`), each required. Columns not
    /// asked for are an error, so a misspelt name does not pass silently.
    pub fn read(path: &Path, wanted: &[(&str, Unit)]) -> Result<Measured, StandardsError> {
        let (name, text) = read_text(path)?;
        Self::parse(&text, &name, wanted)
    }

    pub fn parse(
        text: &str,
        path: &str,
        wanted: &[(&str, Unit)],
    ) -> Result<Measured, StandardsError> {
        let csv_error = |line: usize, message: String| StandardsError::Csv {
            path: path.to_string(),
            line,
            message,
        };
        let mut rows = csv_lines(text);
        let expected = || {
            wanted
                .iter()
                .map(|(c, u)| match u {
                    Unit::Length => format!("{c}_mm (or {c}_um)"),
                    Unit::Angle => format!("{c}_deg"),
                    Unit::None => c.to_string(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (header_line, header) = rows.next().ok_or_else(|| {
            csv_error(
                1,
                format!("empty file; expected a header row: {}", expected()),
            )
        })?;
        // For each header column: which wanted column it is and the factor to mm.
        let mut source: Vec<(usize, f64)> = Vec::new();
        let mut found = vec![false; wanted.len()];
        for column in header.split(',').map(str::trim) {
            let matched = wanted.iter().enumerate().find_map(|(n, (c, unit))| {
                let factor = match unit {
                    Unit::Length if column == format!("{c}_mm") => Some(1.0),
                    Unit::Length if column == format!("{c}_um") => Some(1e-3),
                    Unit::Angle if column == format!("{c}_deg") => Some(1.0),
                    Unit::None if column == *c => Some(1.0),
                    _ => None,
                };
                factor.map(|f| (n, f))
            });
            let Some((n, factor)) = matched else {
                return Err(csv_error(
                    header_line,
                    format!("unknown column `{column}`; the columns are: {}", expected()),
                ));
            };
            if found[n] {
                return Err(csv_error(
                    header_line,
                    format!("column `{column}` appears twice"),
                ));
            }
            found[n] = true;
            source.push((n, factor));
        }
        if let Some(n) = found.iter().position(|f| !f) {
            return Err(csv_error(
                header_line,
                format!(
                    "missing column `{}`; the columns are: {}",
                    wanted[n].0,
                    expected()
                ),
            ));
        }
        let mut measured = Measured {
            path: path.to_string(),
            lines: Vec::new(),
            columns: vec![Vec::new(); wanted.len()],
            text: vec![Vec::new(); wanted.len()],
        };
        for (line, row) in rows {
            let fields = csv_fields(row, source.len()).map_err(|m| csv_error(line, m))?;
            for (field, &(n, factor)) in fields.iter().zip(&source) {
                if wanted[n].1 == Unit::None {
                    measured.text[n].push(field.to_string());
                    measured.columns[n].push(f64::NAN);
                    continue;
                }
                let value = csv_number(field, wanted[n].0).map_err(|m| csv_error(line, m))?;
                measured.columns[n].push(value * factor);
            }
            measured.lines.push(line);
        }
        if measured.lines.is_empty() {
            return Err(csv_error(
                header_line,
                "no measurements after the header".into(),
            ));
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
        StandardsError::Csv {
            path: self.path.clone(),
            line: self.lines[row],
            message,
        }
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
