//! The model run along a compensated program before it is kept (as `trace --compensate` does):
//! a program whose real tool tip misses the intended path by more than the chord tolerance is
//! not a success.

use super::error::{NcError, NcOption};
use super::kinematics::Compensator;
use super::options::Options;
use super::report::Compensated;
use super::trace::{trace_compensated_each, TraceSample};
use crate::model::inputs::Inputs;
use crate::model::Machine;
use crate::reference::Propagation;

/// The model run along the written program (as `trace --compensate` does): the largest distance
/// of the real tool tip from the intended path along its feed moves (take-ups aside), and the
/// program's lines where it exceeds the chord tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    pub largest_mm: f64,
    pub lines: Vec<usize>,
    /// The sample where the largest distance was met (its line that of the program it was made
    /// from); `None` where the program has no feed move.
    pub worst: Option<TraceSample>,
    /// The step the path was sampled at, mm.
    pub step_mm: f64,
}

/// The expanded uncertainty (`k = 2`, mm) of the tool tip's error at `sample`, from the
/// standard uncertainties of the machine's error values: `2·|u(VE)|`, the norm of the
/// first-order standard uncertainties of VE's components (at the sample's command, approach and
/// tool). It bounds the standard uncertainty of VE along any direction, the error's too
/// (`nᵀΣn ≤ trace Σ`), without the covariances between the components. 0 where the machine
/// has no uncertainties.
pub fn expanded_uncertainty_at(
    machine: &Machine,
    sample: &TraceSample,
    path: &str,
    options: &Options,
) -> Result<f64, NcError> {
    if machine.uncertainty.is_empty() {
        return Ok(0.0);
    }
    let mut compensator = Compensator::new(path, options, machine);
    let kinematics = compensator.kinematics(sample.tool, sample.line)?;
    let inputs = Inputs {
        approach: sample.approach,
        ..options.inputs.clone()
    };
    let u = Propagation::new(&kinematics.machine().at(&inputs)).first_order(&sample.command);
    Ok(2.0 * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
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
        let mut worst: Option<TraceSample> = None;
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
                if worst.is_none() || s.deviation_mm > largest_mm {
                    largest_mm = largest_mm.max(s.deviation_mm);
                    worst = Some(s.clone());
                }
                if s.deviation_mm > options.chord_tolerance_mm && lines.last() != Some(&s.line) {
                    lines.push(s.line);
                }
            },
        );
        match traced {
            Ok(()) => {
                lines.sort_unstable();
                lines.dedup();
                return Ok(Residual {
                    largest_mm,
                    lines,
                    worst,
                    step_mm,
                });
            }
            Err(NcError::Option {
                option: NcOption::TraceStep,
                ..
            }) if step_mm < 1e3 => step_mm *= 4.0,
            Err(e) => return Err(e),
        }
    }
}
