//! Points CSV: the commanded positions `volmap sample` is asked about, and the answers written
//! back. One header row naming the columns `X Y Z` (mm) and, optionally, `A B C` (degrees); one
//! position per row.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use super::csv::{Csv, CsvError};
use super::{read_text, FileError};
use crate::error::input_errors;
use crate::model::channels::{Sample, SAMPLE_COLUMNS};
use crate::model::{AxisLetter, Command};

/// What is wrong with a points file.
#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Csv(#[from] CsvError),
}

input_errors!(PointsError);

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
    let mut csv = Csv::new(text, path);
    let header = csv.header("naming X, Y, Z (and A, B, C)")?;
    let mut columns = Vec::new();
    let mut given = [false; 6];
    for name in &header.names {
        let letter = match name.chars().collect::<Vec<_>>()[..] {
            [c] => AxisLetter::from_char(c),
            _ => None,
        }
        .ok_or_else(|| {
            csv.error(
                header.line,
                format!("unknown column `{name}` (the columns are X, Y, Z, A, B, C)"),
            )
        })?;
        if std::mem::replace(&mut given[letter.index()], true) {
            return Err(csv
                .error(header.line, format!("column {letter} appears twice"))
                .into());
        }
        columns.push(letter);
    }
    for letter in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
        if !given[letter.index()] {
            return Err(csv
                .error(
                    header.line,
                    format!("no column {letter}: X, Y and Z are required"),
                )
                .into());
        }
    }
    let mut points = Vec::new();
    for row in csv.rows() {
        row.require_fields(columns.len())?;
        let mut command = [0.0; 6];
        for (n, letter) in columns.iter().enumerate() {
            command[letter.index()] = row.number(n, &letter.to_string())?;
        }
        points.push(QueryPoint {
            line: row.line,
            command,
            given,
        });
    }
    Ok(points)
}

pub fn read_points(path: &Path) -> Result<Vec<QueryPoint>, PointsError> {
    parse_points(&read_text(path)?, &path.display().to_string())
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
