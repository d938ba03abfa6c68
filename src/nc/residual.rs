//! The model run along a compensated program before it is kept (as `trace --compensate` does):
//! a program whose real tool tip misses the intended path by more than the chord tolerance is
//! not a success.

use super::error::{NcError, NcOption};
use super::options::Options;
use super::report::Compensated;
use super::trace::trace_compensated_each;
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
    loop {
        let mut largest_mm: f64 = 0.0;
        let mut lines: Vec<usize> = Vec::new();
        // Only feed moves count; nothing per sample is held.
        let traced = trace_compensated_each(
            machine,
            (program, compensated),
            path,
            options,
            step_mm,
            |s| {
                if s.motion == 0 {
                    return;
                }
                largest_mm = largest_mm.max(s.deviation_mm);
                if s.deviation_mm > options.chord_tolerance_mm && lines.last() != Some(&s.line) {
                    lines.push(s.line);
                }
            },
        );
        match traced {
            Ok(()) => {
                lines.sort_unstable();
                lines.dedup();
                return Ok(Residual { largest_mm, lines });
            }
            Err(NcError::Option {
                option: NcOption::TraceStep,
                ..
            }) if step_mm < 1e3 => step_mm *= 4.0,
            Err(e) => return Err(e),
        }
    }
}
