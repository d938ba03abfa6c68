//! Machine models from measurements: location errors fitted to standard-test results
//! ([`fit`]), machine files built from component errors measured at sparse positions ([`build`]).

pub mod build;
pub mod fit;
