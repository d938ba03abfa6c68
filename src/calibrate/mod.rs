//! Machine models from measurements: location and spindle errors and their thermal
//! coefficients fitted to standard-test results
//! ([`fit`]), machine files built from component errors measured at sparse positions ([`build`]).

pub mod build;
pub mod fit;
mod fit_file;
mod unknowns;

use crate::error::input_errors;
use crate::io::csv::CsvError;
use crate::io::FileError;
use crate::standards::StandardsError;

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
    /// A key of the fit file that does not fit the machine or is not understood.
    #[error("{file}: {key}: {message}")]
    Key {
        file: String,
        key: String,
        message: String,
    },
}

input_errors!(CalibrateError);
