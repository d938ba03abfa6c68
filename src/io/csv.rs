//! The one CSV reader behind every CSV input: the tables a machine file names, points to
//! sample, measured test results, interferometer exports.
//!
//! The grammar is the same for all: one header row naming the columns, then one record per row;
//! fields separated by commas and trimmed; blank lines and lines starting with `#` skipped.
//! Line numbers count every line of the file from 1, so an error names the line a user sees in
//! an editor. What the columns mean, and which are required, is the caller's.

use crate::error::{excerpt, input_errors};

/// What is wrong at a line of a CSV file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}: line {line}: {message}")]
pub struct CsvError {
    pub path: String,
    pub line: usize,
    pub message: String,
}

input_errors!(CsvError);

/// A CSV text being read: [`Csv::header`] first, then [`Csv::rows`].
pub struct Csv<'a> {
    path: &'a str,
    lines: Box<dyn Iterator<Item = (usize, &'a str)> + 'a>,
}

/// The header row: its line and the column names in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    pub line: usize,
    pub names: Vec<String>,
}

/// One record: its line and its fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Row<'a> {
    pub line: usize,
    pub fields: Vec<&'a str>,
    path: &'a str,
}

impl<'a> Csv<'a> {
    /// Reads `text`; `path` names the file in errors. A leading byte-order mark is dropped.
    pub fn new(text: &'a str, path: &'a str) -> Csv<'a> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let lines: Box<dyn Iterator<Item = (usize, &'a str)> + 'a> = Box::new(
            text.lines()
                .enumerate()
                .map(|(n, l)| (n + 1, l.trim()))
                .filter(|(_, l)| !is_skipped(l)),
        );
        Csv { path, lines }
    }

    /// An error at `line` of this file.
    pub fn error(&self, line: usize, message: impl Into<String>) -> CsvError {
        CsvError {
            path: self.path.to_string(),
            line,
            message: message.into(),
        }
    }

    /// The header row; an empty file is an error that says what the header should name
    /// (`expected`, e.g. "naming X, Y, Z"), and so is a column named twice.
    pub fn header(&mut self, expected: &str) -> Result<Header, CsvError> {
        let (line, text) = self.lines.next().ok_or_else(|| {
            self.error(1, format!("empty file: expected a header row {expected}"))
        })?;
        let header = Header::parse(line, text);
        header.require_distinct(self.path)?;
        Ok(header)
    }

    /// The records after the header, in order.
    pub fn rows(&mut self) -> impl Iterator<Item = Row<'a>> + '_ {
        let path = self.path;
        (&mut self.lines).map(move |(line, text)| Row::parse(line, text, path))
    }
}

/// Whether a (trimmed) line is one the grammar skips: blank, or a comment starting with `#`.
/// For readers that take a file line by line rather than whole.
pub fn is_skipped(line: &str) -> bool {
    line.is_empty() || line.starts_with('#')
}

impl Header {
    /// The header row `text` at `line`.
    pub fn parse(line: usize, text: &str) -> Header {
        Header {
            line,
            names: text.split(',').map(|n| n.trim().to_string()).collect(),
        }
    }

    /// Requires every column named once (letter case aside: `x` and `X` are one column to the
    /// readers that take either); `path` names the file in the error.
    pub fn require_distinct(&self, path: &str) -> Result<(), CsvError> {
        for (n, name) in self.names.iter().enumerate() {
            if name.is_empty() {
                continue;
            }
            if let Some(m) = self.names[..n]
                .iter()
                .position(|earlier| earlier.eq_ignore_ascii_case(name))
            {
                return Err(CsvError {
                    path: path.to_string(),
                    line: self.line,
                    message: format!(
                        "column `{}` appears twice (columns {} and {})",
                        excerpt(name),
                        m + 1,
                        n + 1
                    ),
                });
            }
        }
        Ok(())
    }
}

impl<'a> Row<'a> {
    /// The record `text` at `line` of the file `path`.
    pub fn parse(line: usize, text: &'a str, path: &'a str) -> Row<'a> {
        Row {
            line,
            fields: text.split(',').map(str::trim).collect(),
            path,
        }
    }

    /// An error at this row's line.
    pub fn error(&self, message: impl Into<String>) -> CsvError {
        CsvError {
            path: self.path.to_string(),
            line: self.line,
            message: message.into(),
        }
    }

    /// Requires exactly `columns` fields, as many as the header names.
    pub fn require_fields(&self, columns: usize) -> Result<(), CsvError> {
        if self.fields.len() == columns {
            Ok(())
        } else {
            Err(self.error(format!(
                "{} fields, the header has {columns}",
                self.fields.len()
            )))
        }
    }

    /// Field `index` as text; `column` names it in the error when the row is too short.
    pub fn text(&self, index: usize, column: &str) -> Result<&'a str, CsvError> {
        self.fields.get(index).copied().ok_or_else(|| {
            self.error(format!(
                "has {} fields, column {} is field {}",
                self.fields.len(),
                excerpt(column),
                index + 1
            ))
        })
    }

    /// Field `index` as a finite number; `column` names it in errors (as it should read there,
    /// e.g. "`deviation`" or "Z").
    pub fn number(&self, index: usize, column: &str) -> Result<f64, CsvError> {
        let field = self.text(index, column)?;
        let value: f64 = field.parse().map_err(|_| {
            self.error(format!(
                "`{}` in column {} is not a number",
                excerpt(field),
                excerpt(column)
            ))
        })?;
        if !value.is_finite() {
            return Err(self.error(format!(
                "`{}` in column {} is not a finite number",
                excerpt(field),
                excerpt(column)
            )));
        }
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_counted_as_an_editor_shows_them() {
        let text = "# exported\nX, Y\n\n1, 2\n# note\n3,4\n";
        let mut csv = Csv::new(text, "p.csv");
        let header = csv.header("naming X").unwrap();
        assert_eq!(
            (header.line, header.names.clone()),
            (2, vec!["X".into(), "Y".into()])
        );
        let rows: Vec<(usize, Vec<&str>)> = csv.rows().map(|r| (r.line, r.fields)).collect();
        assert_eq!(rows, [(4, vec!["1", "2"]), (6, vec!["3", "4"])]);
    }

    #[test]
    fn bad_fields_name_the_file_line_and_column() {
        let mut csv = Csv::new("a,b\n1,x\n1,inf\n1\n", "m.csv");
        csv.header("").unwrap();
        let rows: Vec<Row> = csv.rows().collect();
        let message = |e: CsvError| e.to_string();
        assert_eq!(
            message(rows[0].number(1, "`b`").unwrap_err()),
            "m.csv: line 2: `x` in column `b` is not a number"
        );
        assert_eq!(
            message(rows[1].number(1, "`b`").unwrap_err()),
            "m.csv: line 3: `inf` in column `b` is not a finite number"
        );
        assert_eq!(
            message(rows[2].require_fields(2).unwrap_err()),
            "m.csv: line 4: 1 fields, the header has 2"
        );
        assert_eq!(
            message(rows[2].number(1, "`b`").unwrap_err()),
            "m.csv: line 4: has 1 fields, column `b` is field 2"
        );
        let mut empty = Csv::new("\n# nothing\n", "e.csv");
        assert_eq!(
            message(empty.header("naming X").unwrap_err()),
            "e.csv: line 1: empty file: expected a header row naming X"
        );
    }
}
