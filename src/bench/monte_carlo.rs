//! Monte Carlo over sampled machines in `volmap bench`, on the GPU (statistics reduced on the
//! device) and on the CPU engine, in machine-points per second.

use super::timing::timed;
use super::{BenchError, Row};
use crate::design::monte_carlo::Study;
use crate::engine::Engine;
use crate::model::grid::Grid;
use crate::model::perturbation::{Distribution, ErrorTarget, Perturbation, Shape, Tolerance};
use crate::model::Machine;

/// Monte Carlo takes at least this long on each engine, so that its rate is not its overhead.
const MONTE_CARLO_SECONDS: f64 = 0.5;

/// Monte Carlo on the GPU and on the CPU engine: every error value of the machine toleranced
/// (20 µm, 20 µrad uniform, the shapes in turn), the number of machines grown until a run takes
/// [`MONTE_CARLO_SECONDS`], then `runs` runs of that many.
pub(super) fn bench_monte_carlo(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let tolerances = every_error_toleranced(machine);
    let grids = [grid.clone()];
    let study = Study {
        machine,
        tolerances: &tolerances,
        grids: &grids,
        seed: 0,
    };
    let ones = vec![1.0; tolerances.len()];
    let cpu = Engine::Cpu;
    let mut engines = vec![(&cpu, "CPU engine Monte Carlo")];
    if let Engine::Gpu(_) = engine {
        // A machine with errors of other axes' positions: its errors tabulated per sample in parts
        // (src/gpu/chain/folded.rs).
        let name = if machine.has_cross_axis_errors() {
            "GPU Monte Carlo, other axes"
        } else {
            "GPU Monte Carlo"
        };
        engines.insert(0, (engine, name));
    }
    let mut rows = Vec::new();
    for (engine, name) in engines {
        on_step(name);
        // Once untimed: the first run compiles the kernels for this shape of machine.
        study.sample_stats(engine, 1, &ones, |_| {})?;
        let mut samples = 2usize;
        let mut seconds = loop {
            let (stats, seconds) = timed(|| study.sample_stats(engine, samples, &ones, |_| {}));
            std::hint::black_box(stats?);
            if seconds >= MONTE_CARLO_SECONDS || samples >= 1 << 20 {
                break vec![seconds];
            }
            let grow = (MONTE_CARLO_SECONDS / seconds.max(1e-6) * 1.2).clamp(2.0, 16.0);
            samples = (samples as f64 * grow) as usize;
        };
        while seconds.len() < runs {
            let (stats, s) = timed(|| study.sample_stats(engine, samples, &ones, |_| {}));
            std::hint::black_box(stats?);
            seconds.push(s);
        }
        rows.push(Row::new(
            format!("{name}, {samples} machines"),
            samples as u64 * grid.points(),
            seconds,
        ));
    }
    Ok(rows)
}

/// Every component and location error of every axis, and the spindle's, toleranced uniformly.
fn every_error_toleranced(machine: &Machine) -> Vec<Tolerance> {
    let width = |index: usize| if index < 3 { 0.02 } else { 2e-5 };
    let mut out = Vec::new();
    for (k, axis) in machine.axes.iter().enumerate() {
        for index in 0..6 {
            out.push(Tolerance {
                perturbation: Perturbation {
                    target: ErrorTarget::Component {
                        axis: axis.letter,
                        index,
                    },
                    shape: [Shape::Constant, Shape::Line, Shape::Bow][(index + k) % 3],
                },
                distribution: Distribution::Uniform {
                    half_width: width(index),
                },
            });
            out.push(Tolerance {
                perturbation: Perturbation {
                    target: ErrorTarget::Location {
                        axis: axis.letter,
                        index,
                    },
                    shape: Shape::Constant,
                },
                distribution: Distribution::Uniform {
                    half_width: width(index),
                },
            });
        }
    }
    for index in 0..5 {
        out.push(Tolerance {
            perturbation: Perturbation {
                target: ErrorTarget::Spindle { index },
                shape: Shape::Constant,
            },
            distribution: Distribution::Uniform {
                half_width: width(index),
            },
        });
    }
    out
}
