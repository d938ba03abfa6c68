//! Machine models from measurements: location errors fitted to standard-test results
//! ([`fit`]), machine files built from component errors measured at sparse positions ([`build`]).

pub mod build;
pub mod fit;

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
}

input_errors!(CalibrateError);
