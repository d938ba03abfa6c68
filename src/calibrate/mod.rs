//! Machine models from measurements: location and spindle errors and their thermal
//! coefficients fitted to standard-test results
//! ([`fit`]), machine files built from component errors measured at sparse positions ([`build`]).

mod axis_csv;
pub mod ballbar_figures;
pub mod build;
pub mod fit;
mod fit_file;
pub mod identifiability;
mod tables;
mod unknowns;

use crate::error::input_errors;
use crate::io::csv::CsvError;
use crate::io::FileError;
use crate::standards::StandardsError;

pub use tables::rebase_tables;

/// What is wrong with the measurements, the fit file or the estimates asked for.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Csv(#[from] CsvError),
    /// A test of the fit file could not run.
    #[error(transparent)]
    Test(#[from] StandardsError),
    #[error("{0}")]
    Parameter(String),
    /// An interpolation asked of `build` for what is not a component of a measured axis.
    #[error("{0}")]
    InterpChoice(String),
    /// A test of the fit file (`[[circular]] number 2`) that could not be read or run.
    #[error("{file}: {key}: {source}")]
    Entry {
        file: String,
        key: String,
        #[source]
        source: Box<CalibrateError>,
    },
    /// A file a fit file names that cannot be read (or lies outside its folder).
    #[error("{file}: {key}: {source}")]
    NamedFile {
        file: String,
        key: String,
        #[source]
        source: FileError,
    },
    /// A key of the fit file that does not fit the machine or is not understood.
    #[error("{file}: {key}: {message}")]
    Key {
        file: String,
        key: String,
        message: String,
    },
}

input_errors!(CalibrateError);

impl CalibrateError {
    /// Whether this is a file named outside the folder of the fit file that names it.
    pub fn is_outside_folder(&self) -> bool {
        match self {
            CalibrateError::NamedFile { source, .. } => source.is_outside_folder(),
            CalibrateError::Entry { source, .. } => source.is_outside_folder(),
            _ => false,
        }
    }
}

/// The significant digits of the numbers `fit` and `build` write into machine files at most: far
/// more than any measurement resolves (a laser interferometer resolves about 1e-9 of its range),
/// and few enough that the last bits of unit conversions and sums do not show (2.1 µm read in mm
/// is `0.0021000000000000003`, written `0.0021`).
pub const SIGNIFICANT_DIGITS: i32 = 12;

/// `value` rounded to [`SIGNIFICANT_DIGITS`] significant digits and, where `resolution` is
/// positive, to the decimal place of `resolution` (one significant digit kept at least).
pub fn rounded(value: f64, resolution: f64) -> f64 {
    if value == 0.0 || !value.is_finite() {
        return value;
    }
    let leading = value.abs().log10().floor() as i32;
    let mut digits = SIGNIFICANT_DIGITS;
    if resolution > 0.0 && resolution.is_finite() {
        let place = resolution.log10().floor() as i32;
        digits = digits.min((leading - place + 1).max(1));
    }
    format!("{:.*e}", (digits - 1) as usize, value)
        .parse()
        .unwrap_or(value)
}

/// A number as a person would write it, rounded by [`rounded`] and then exact (the shortest
/// decimal that reads back as the rounded value): `0.0`, `1.5e-5`, `0.0021`.
pub(crate) fn toml_number(value: f64) -> toml_edit::Value {
    let value = rounded(value, 0.0);
    let text = if value != 0.0 && (value.abs() < 1e-3 || value.abs() >= 1e6) {
        format!("{value:e}")
    } else {
        format!("{value:?}")
    };
    text.parse()
        .unwrap_or_else(|_| toml_edit::Value::from(value))
}

/// The text of a machine file headed by `lines` as comments (where it came from), a blank line
/// between them and the file as it was.
pub fn with_header(text: &str, lines: &[String]) -> String {
    let mut out: String = lines
        .iter()
        .flat_map(|line| line.lines())
        .map(|line| format!("# {line}\n"))
        .collect();
    out.push('\n');
    out.push_str(text);
    out
}
