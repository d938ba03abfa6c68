//! What goes wrong in an export: one error type for the core and every format, and the error
//! of a written file that does not read back. It imports nothing else of the export, so every
//! other file of it may import it.

use crate::error::{Classify, ErrorKind};
use crate::io::FileError;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("`{name}` is not a format volmap exports (formats: {known})")]
    UnknownFormat { name: String, known: String },
    #[error("the machine (chain {chain}) has no {missing} axis: a compensation table corrects X, Y and Z")]
    MissingAxes { chain: String, missing: String },
    #[error("the linear axes do not span X, Y and Z at the pose")]
    Singular,
    #[error("{format}: its files with the report written into them do not read back as the files without it")]
    ReportChangesTables { format: &'static str },
    #[error("a tool length of {0} mm: a length is a finite number of mm, 0 or more")]
    BadToolLength(f64),
    #[error("{format} corrects a probe's readings: it needs the probe's offset from the nozzle (Klipper's [probe] x_offset, y_offset)")]
    NoProbeOffset { format: &'static str },
    #[error("{format} corrects no probe: there is no probe offset to give")]
    NoProbe { format: &'static str },
    #[error("probe offset {x_mm}, {y_mm} mm: both must be finite")]
    BadProbeOffset { x_mm: f64, y_mm: f64 },
    #[error(
        "{format} does not number its compensation points: there are no point numbers to give"
    )]
    NoPointNumbers { format: &'static str },
    #[error("point numbers {first}-{last}: {why}")]
    BadPointNumbers { first: i64, last: i64, why: String },
    #[error("{format} is written one way for every control: there is no control to choose")]
    NoControlChoice { format: &'static str },
    #[error("`{control}` is not a control {format} is written for (controls: {known})")]
    UnknownControl {
        format: &'static str,
        control: String,
        known: String,
    },
    #[error("no command puts the real tool tip on the target X={:.3} Y={:.3} Z={:.3} mm (the Newton steps do not converge): the machine's errors are too large", at_mm[0], at_mm[1], at_mm[2])]
    NoSolution { at_mm: [f64; 3] },
    #[error("{format} holds fixed factors, not tables: there is no table size to choose")]
    NoTableSize { format: &'static str },
    #[error(
        "{points} points{axis} is more than a {format} table holds: at most {max} ({limits_from})"
    )]
    TooManyPoints {
        format: &'static str,
        axis: String,
        /// The count in words (`count_words`: it may be beyond any integer).
        points: String,
        max: usize,
        limits_from: &'static str,
    },
    #[error("{points} points is fewer than a {format} table needs: at least {min}")]
    TooFewPoints {
        format: &'static str,
        points: usize,
        min: usize,
    },
    #[error("a spacing of {spacing_mm} mm{axis} is below the smallest a {format} table takes: {min_mm} mm ({limits_from})")]
    SpacingTooSmall {
        format: &'static str,
        axis: String,
        spacing_mm: f64,
        min_mm: f64,
        limits_from: &'static str,
    },
    #[error("{what} would be {value}: {format} holds {holds}")]
    BeyondFormat {
        format: &'static str,
        what: String,
        value: f64,
        holds: &'static str,
    },
    #[error("a spacing of {0} mm: it must be a positive number of mm")]
    BadSpacing(f64),
    #[error("a spacing of {} mm is wider than every travel of the machine (the longest is {} mm): its tables would hold two nodes an axis, the last up to a spacing beyond the travel", crate::limits::number_words(*spacing_mm), crate::limits::number_words(*longest_mm))]
    SpacingTooLarge { spacing_mm: f64, longest_mm: f64 },
    #[error("{points} points per axis for the residual: at least 2 and at most {max}")]
    BadEvaluationGrid { points: usize, max: usize },
    #[error("{format} can hold none of this machine's errors: {holds}; the table as written corrects nothing")]
    NothingHeld {
        format: &'static str,
        holds: &'static str,
    },
    #[error("the residual of the {format} table, {residual_um:.3} µm largest ({rms_um:.3} µm RMS; {before_um:.3} µm largest before), is above the {limit_um:.3} µm asked for: nothing written")]
    ResidualAbove {
        format: &'static str,
        residual_um: f64,
        rms_um: f64,
        before_um: f64,
        limit_um: f64,
    },
    #[error("the {format} export cannot hold this machine's errors: {message}")]
    Unrepresentable {
        format: &'static str,
        message: String,
    },
    #[error("{0} is not a folder: a {1} export writes several files into a folder")]
    NotAFolder(String, &'static str),
    #[error("reading back {file}: line {line}: {message}")]
    Read {
        file: String,
        line: usize,
        message: String,
    },
    #[error(transparent)]
    File(#[from] FileError),
}

impl Classify for ExportError {
    fn kind(&self) -> ErrorKind {
        match self {
            ExportError::File(e) => e.kind(),
            // What volmap wrote and cannot read back is its own failure, not the user's.
            ExportError::Read { .. } => ErrorKind::Work,
            _ => ErrorKind::Input,
        }
    }
}

/// Reading a written file back: a line that does not read, as the control would refuse it.
pub fn read_error(file: &str, line: usize, message: impl Into<String>) -> ExportError {
    ExportError::Read {
        file: file.to_string(),
        line,
        message: message.into(),
    }
}
