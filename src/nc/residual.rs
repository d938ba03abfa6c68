//! The model run along a compensated program before it is kept (as `trace --compensate` does):
//! a program whose real tool tip misses the intended path by more than the chord tolerance is
//! not a success.

use super::error::{NcError, NcOption};
use super::options::Options;
use super::report::Compensated;
use super::trace::trace_compensated;
use crate::model::Machine;

/// The model run along the written program (as `trace --compensate` does): the largest distance
/// of the real tool tip from the intended path along its feed moves (take-ups aside), and the
/// program's lines where it exceeds the chord tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    pub largest_mm: f64,
    pub lines: Vec<usize>,
}

/// [`Residual`] of `compensated`, made from `program` with `options`: sampled every 0.5 mm, or
/// at a longer step where a long program would exceed the trace's limit on samples.
pub fn residual(
    machine: &Machine,
    program: &[u8],
    compensated: &Compensated,
    path: &str,
    options: &Options,
) -> Result<Residual, NcError> {
    let mut step_mm = 0.5;
    let samples = loop {
        match trace_compensated(machine, (program, compensated), path, options, step_mm) {
            Ok(samples) => break samples,
            Err(NcError::Option {
                option: NcOption::TraceStep,
                ..
            }) if step_mm < 1e3 => step_mm *= 4.0,
            Err(e) => return Err(e),
        }
    };
    let feeds = samples.iter().filter(|s| s.motion != 0);
    let largest_mm = feeds.clone().map(|s| s.deviation_mm).fold(0.0, f64::max);
    let mut lines: Vec<usize> = feeds
        .filter(|s| s.deviation_mm > options.chord_tolerance_mm)
        .map(|s| s.line)
        .collect();
    lines.sort_unstable();
    lines.dedup();
    Ok(Residual { largest_mm, lines })
}
