//! Points CSV: the commanded positions `volmap sample` is asked about, and the answers written
//! back. One header row naming the columns `X Y Z` (mm) and, optionally, `A B C` (degrees), in
//! either case; any other column (an `id`, a note) is carried through to the answer. One position
//! per row.
//!
//! The file is read in batches ([`PointReader`]) and the answers written batch by batch
//! ([`SampleWriter`]), so memory holds one batch whatever the number of points.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use rayon::prelude::*;

use super::csv::{is_skipped, CsvError, Header, Row};
use super::source::{describe_bytes, LINE_LIMIT_BYTES};
use super::FileError;
use crate::error::{excerpt, input_errors};
use crate::model::channels::{Sample, SAMPLE_COLUMNS, UNCERTAINTY_COLUMNS};
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

/// The columns of a points file: the names as written, and the axis each one holds (`None`
/// for a column carried through).
#[derive(Debug, Clone, PartialEq)]
pub struct PointColumns {
    /// The line of the header row.
    pub line: usize,
    pub names: Vec<String>,
    pub axes: Vec<Option<AxisLetter>>,
    /// Which of the six axis columns are present.
    pub given: [bool; 6],
}

impl PointColumns {
    fn of(header: &Header, path: &str) -> Result<PointColumns, CsvError> {
        let error = |message: String| CsvError {
            path: path.to_string(),
            line: header.line,
            message,
        };
        let mut axes = Vec::new();
        let mut given = [false; 6];
        for (n, name) in header.names.iter().enumerate() {
            if name.is_empty() {
                return Err(error(format!("column {} has no name", n + 1)));
            }
            if SAMPLE_COLUMNS
                .iter()
                .chain(&UNCERTAINTY_COLUMNS)
                .any(|c| c.eq_ignore_ascii_case(name))
            {
                return Err(error(format!(
                    "column `{}` is one the answer adds ({}, {}): rename it",
                    excerpt(name),
                    SAMPLE_COLUMNS.join(", "),
                    UNCERTAINTY_COLUMNS.join(", ")
                )));
            }
            let letter = match name.chars().collect::<Vec<_>>()[..] {
                [c] => AxisLetter::from_char(c.to_ascii_uppercase()),
                _ => None,
            };
            if let Some(letter) = letter {
                if std::mem::replace(&mut given[letter.index()], true) {
                    return Err(error(format!("column {letter} appears twice")));
                }
            }
            axes.push(letter);
        }
        for letter in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
            if !given[letter.index()] {
                return Err(error(format!(
                    "no column {letter}: X, Y and Z are required"
                )));
            }
        }
        Ok(PointColumns {
            line: header.line,
            names: header.names.clone(),
            axes,
            given,
        })
    }
}

/// A batch of positions and, for each, its row's fields as written (trimmed, joined by commas),
/// which the answer repeats.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointBatch {
    pub points: Vec<QueryPoint>,
    pub rows: Vec<String>,
}

/// Reads a points file in batches: the header when opened, then [`PointReader::next_batch`].
pub struct PointReader<R> {
    input: R,
    path: String,
    line: usize,
    columns: PointColumns,
    text: String,
}

impl PointReader<BufReader<File>> {
    /// Opens the file and reads its header.
    pub fn open(path: &Path) -> Result<Self, PointsError> {
        let file = super::source::open_stream(path)?;
        PointReader::new(
            BufReader::with_capacity(1 << 16, file),
            &path.display().to_string(),
        )
    }
}

impl<R: BufRead> PointReader<R> {
    /// Reads the header from `input`; `path` names the file in errors.
    pub fn new(input: R, path: &str) -> Result<Self, PointsError> {
        let mut reader = PointReader {
            input,
            path: path.to_string(),
            line: 0,
            columns: PointColumns {
                line: 0,
                names: Vec::new(),
                axes: Vec::new(),
                given: [false; 6],
            },
            text: String::new(),
        };
        let Some(line) = reader.next_record()? else {
            return Err(CsvError {
                path: reader.path,
                line: 1,
                message: "empty file: expected a header row naming X, Y, Z (and A, B, C)".into(),
            }
            .into());
        };
        let header = Header::parse(line, reader.text.trim());
        header.require_distinct(&reader.path)?;
        reader.columns = PointColumns::of(&header, &reader.path)?;
        Ok(reader)
    }

    pub fn columns(&self) -> &PointColumns {
        &self.columns
    }

    /// Moves to the next line the grammar does not skip, into `self.text`; its line number, or
    /// `None` at the end of the file.
    fn next_record(&mut self) -> Result<Option<usize>, PointsError> {
        loop {
            self.text.clear();
            let read = (&mut self.input)
                .take(LINE_LIMIT_BYTES as u64 + 1)
                .read_line(&mut self.text)
                .map_err(|e| {
                    if e.kind() == std::io::ErrorKind::InvalidData {
                        // The line that is not UTF-8 (read_line says none).
                        return PointsError::from(CsvError {
                            path: self.path.clone(),
                            line: self.line + 1,
                            message: "not UTF-8 text".to_string(),
                        });
                    }
                    FileError::read(Path::new(&self.path), e).into()
                })?;
            if read == 0 {
                return Ok(None);
            }
            self.line += 1;
            if read > LINE_LIMIT_BYTES {
                return Err(CsvError {
                    path: self.path.clone(),
                    line: self.line,
                    message: format!(
                        "longer than {}, the most a line may hold",
                        describe_bytes(LINE_LIMIT_BYTES as u64)
                    ),
                }
                .into());
            }
            if self.line == 1 {
                if let Some(rest) = self.text.strip_prefix('\u{feff}') {
                    self.text = rest.to_string();
                }
            }
            if !is_skipped(self.text.trim()) {
                return Ok(Some(self.line));
            }
        }
    }

    /// Up to `max` more positions; an empty batch at the end of the file.
    pub fn next_batch(&mut self, max: usize) -> Result<PointBatch, PointsError> {
        let mut batch = PointBatch::default();
        while batch.points.len() < max {
            let Some(line) = self.next_record()? else {
                break;
            };
            let row = Row::parse(line, self.text.trim(), &self.path);
            row.require_fields(self.columns.axes.len())?;
            let mut command = [0.0; 6];
            for (n, axis) in self.columns.axes.iter().enumerate() {
                if let Some(letter) = axis {
                    command[letter.index()] = row.number(n, &letter.to_string())?;
                }
            }
            batch.points.push(QueryPoint {
                line,
                command,
                given: self.columns.given,
            });
            batch.rows.push(row.fields.join(","));
        }
        Ok(batch)
    }
}

/// Reads every position of CSV text; `path` names it in errors.
pub fn parse_points(text: &str, path: &str) -> Result<Vec<QueryPoint>, PointsError> {
    Ok(PointReader::new(text.as_bytes(), path)?
        .next_batch(usize::MAX)?
        .points)
}

/// Reads every position of a file (for few points: [`PointReader`] reads in batches).
pub fn read_points(path: &Path) -> Result<Vec<QueryPoint>, PointsError> {
    Ok(PointReader::open(path)?.next_batch(usize::MAX)?.points)
}

/// The precision of the values written: a field holds f32, so values interpolated in it are
/// written as the shortest decimal that reads back to the same f32; exact values as the shortest
/// that reads back to the same f64.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

/// Writes the answers: the input's columns as written, then [`SAMPLE_COLUMNS`].
pub struct SampleWriter {
    precision: Precision,
}

/// The standard uncertainties of VE written beside a sample ([`UNCERTAINTY_COLUMNS`]).
pub type VeUncertainty = [f64; 3];

impl SampleWriter {
    /// Writes the header row.
    pub fn start(
        out: &mut (impl Write + ?Sized),
        columns: &PointColumns,
        precision: Precision,
    ) -> std::io::Result<SampleWriter> {
        SampleWriter::start_with(out, columns, precision, false)
    }

    /// [`SampleWriter::start`], with the [`UNCERTAINTY_COLUMNS`] after the samples' where
    /// `uncertainty` says.
    pub fn start_with(
        out: &mut (impl Write + ?Sized),
        columns: &PointColumns,
        precision: Precision,
        uncertainty: bool,
    ) -> std::io::Result<SampleWriter> {
        let mut header = columns.names.clone();
        header.extend(SAMPLE_COLUMNS.iter().map(|c| c.to_string()));
        if uncertainty {
            header.extend(UNCERTAINTY_COLUMNS.iter().map(|c| c.to_string()));
        }
        writeln!(out, "{}", header.join(","))?;
        Ok(SampleWriter { precision })
    }

    /// Writes one row per sample; a row without one (a position skipped) is left out. Rows are
    /// formatted in parallel, written in order.
    pub fn write(
        &self,
        out: &mut (impl Write + ?Sized),
        batch: &PointBatch,
        samples: &[Option<Sample>],
    ) -> std::io::Result<()> {
        self.write_with(out, batch, samples, &[])
    }

    /// [`SampleWriter::write`] with the standard uncertainties of VE after each sample: one per
    /// sample, or none (`&[]`) for a writer started without them.
    pub fn write_with(
        &self,
        out: &mut (impl Write + ?Sized),
        batch: &PointBatch,
        samples: &[Option<Sample>],
        uncertainties: &[VeUncertainty],
    ) -> std::io::Result<()> {
        let blocks: Vec<Vec<u8>> = batch
            .rows
            .par_chunks(8_192)
            .zip(samples.par_chunks(8_192))
            .enumerate()
            .map(|(n, (rows, samples))| {
                let u: &[VeUncertainty] = uncertainties.get(n * 8_192..).unwrap_or(&[]);
                let mut block = Vec::with_capacity(rows.len() * 160);
                let mut number = ryu::Buffer::new();
                for (i, (row, s)) in rows.iter().zip(samples).enumerate() {
                    let Some(s) = s else { continue };
                    block.extend_from_slice(row.as_bytes());
                    let extra = u.get(i).map_or(&[][..], |u| &u[..]);
                    for &v in s.iter().chain(extra) {
                        block.push(b',');
                        let text = match self.precision {
                            Precision::F32 => number.format(v as f32),
                            Precision::F64 => number.format(v),
                        };
                        block.extend_from_slice(text.as_bytes());
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
}
