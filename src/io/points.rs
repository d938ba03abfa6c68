//! Points CSV: the commanded positions `volmap sample` is asked about, and the answers written
//! back. One header row naming the columns `X Y Z` (mm) and, optionally, `A B C` (degrees); one
//! position per row.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use crate::model::channels::{Sample, SAMPLE_COLUMNS};
use crate::model::{AxisLetter, Command};

#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Csv {
        path: String,
        line: usize,
        message: String,
    },
}

/// One queried position and the CSV line it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct QueryPoint {
    pub line: usize,
    pub command: Command,
    /// Which of the six axis columns the CSV gave (the others are 0).
    pub given: [bool; 6],
}

/// Reads positions from CSV text; `path` names it in errors.
pub fn parse_points(text: &str, path: &str) -> Result<Vec<QueryPoint>, PointsError> {
    let csv_error = |line: usize, message: String| PointsError::Csv {
        path: path.to_string(),
        line,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (header_index, header) = lines.next().ok_or_else(|| {
        csv_error(
            1,
            "empty: expected a header row naming X, Y, Z (and A, B, C)".into(),
        )
    })?;
    let mut columns = Vec::new();
    let mut given = [false; 6];
    for name in header.split(',').map(str::trim) {
        let letter = match name.chars().collect::<Vec<_>>()[..] {
            [c] => AxisLetter::from_char(c),
            _ => None,
        }
        .ok_or_else(|| {
            csv_error(
                header_index + 1,
                format!("unknown column `{name}` (the columns are X, Y, Z, A, B, C)"),
            )
        })?;
        if std::mem::replace(&mut given[letter.index()], true) {
            return Err(csv_error(
                header_index + 1,
                format!("column {letter} appears twice"),
            ));
        }
        columns.push(letter);
    }
    for letter in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
        if !given[letter.index()] {
            return Err(csv_error(
                header_index + 1,
                format!("no column {letter}: X, Y and Z are required"),
            ));
        }
    }
    let mut points = Vec::new();
    for (n, row) in lines {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(csv_error(
                n + 1,
                format!(
                    "{} fields, the header names {}",
                    fields.len(),
                    columns.len()
                ),
            ));
        }
        let mut command = [0.0; 6];
        for (letter, field) in columns.iter().zip(&fields) {
            let value: f64 = field
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    csv_error(
                        n + 1,
                        format!("`{field}` in column {letter} is not a finite number"),
                    )
                })?;
            command[letter.index()] = value;
        }
        points.push(QueryPoint {
            line: n + 1,
            command,
            given,
        });
    }
    Ok(points)
}

pub fn read_points(path: &Path) -> Result<Vec<QueryPoint>, PointsError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| PointsError::Io {
        path: name.clone(),
        source,
    })?;
    parse_points(&text, &name)
}

/// Writes the positions with their samples as CSV: the position columns the input named, then
/// [`SAMPLE_COLUMNS`]. Rows are formatted in parallel, written in order.
pub fn write_samples(
    out: &mut (impl Write + ?Sized),
    points: &[QueryPoint],
    samples: &[Sample],
) -> std::io::Result<()> {
    let given = points
        .first()
        .map_or([true, true, true, false, false, false], |p| p.given);
    let letters: Vec<usize> = (0..6).filter(|&n| given[n]).collect();
    let mut header: Vec<String> = letters
        .iter()
        .map(|&n| AxisLetter::ALL[n].to_string())
        .collect();
    header.extend(SAMPLE_COLUMNS.iter().map(|c| c.to_string()));
    writeln!(out, "{}", header.join(","))?;
    let blocks: Vec<Vec<u8>> = points
        .par_chunks(16_384)
        .zip(samples.par_chunks(16_384))
        .map(|(points, samples)| {
            let mut block = Vec::with_capacity(points.len() * 160);
            let mut number = ryu::Buffer::new();
            for (p, s) in points.iter().zip(samples) {
                for (n, &letter) in letters.iter().enumerate() {
                    if n > 0 {
                        block.push(b',');
                    }
                    let value = p.command[letter];
                    // Whole millimetres and degrees as integers, the way positions are written.
                    if value.fract() == 0.0 && value.abs() < 1e15 {
                        let _ = write!(block, "{}", value as i64);
                    } else {
                        block.extend_from_slice(number.format(value).as_bytes());
                    }
                }
                for v in s {
                    block.push(b',');
                    block.extend_from_slice(number.format(*v).as_bytes());
                }
                block.push(b'\n');
            }
            block
        })
        .collect();
    for block in blocks {
        out.write_all(&block)?;
    }
    Ok(())
}
