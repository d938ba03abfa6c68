//! The uncertainty of a map in `volmap bench` (`map --uncertainty`, `--uncertainty-samples`):
//! first order and Monte Carlo, on the GPU and on the CPU engine, beside the plain map's rows.
//! Nothing is written: the rows time the engine's sums, the map's own rows time its file.

use super::timing::timed;
use super::{BenchError, Row};
use crate::engine::uncertainty::UncertaintyMethod;
use crate::engine::{Engine, EngineError};
use crate::model::grid::Grid;
use crate::model::perturbation::ErrorTarget;
use crate::model::uncertainty::{UncertainKind, UncertainValue, Uncertainty};
use crate::model::Machine;

/// Draws of the Monte Carlo rows: a map's uncertainty by Monte Carlo is usually asked for with
/// hundreds to thousands; the rate per draw does not depend on how many.
pub const BENCH_DRAWS: usize = 64;

/// The machine with a standard uncertainty on each of its axes' six component errors, as a
/// laser calibration of every axis gives them: 1 µm on a length, 1 µrad on an angle.
pub fn with_calibration_uncertainty(machine: &Machine) -> Machine {
    let mut values = Vec::new();
    for axis in &machine.axes {
        for index in 0..6 {
            let target = ErrorTarget::Component {
                axis: axis.letter,
                index,
            };
            values.push(UncertainValue {
                name: target.key(),
                target,
                approach: None,
                per_kelvin: None,
                kind: UncertainKind::Scalar {
                    u: if index < 3 { 1e-3 } else { 1e-6 },
                },
            });
        }
    }
    let mut out = machine.clone();
    out.uncertainty = Uncertainty {
        values,
        covariance: Vec::new(),
    };
    out
}

/// The rows of the map's uncertainty: first order (one pair of maps per uncertain quantity)
/// and Monte Carlo ([`BENCH_DRAWS`] draws) on `engine` when it is the GPU and on the CPU
/// engine, each `runs` times, in grid points per second of the whole uncertainty. The GPU
/// rows are left out for a machine with errors of other axes' positions (the GPU refuses its
/// uncertainty).
pub(super) fn bench_uncertainty(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let machine = with_calibration_uncertainty(machine);
    let quantities = machine.uncertainty.count();
    let cpu = Engine::Cpu;
    let mut engines = vec![(&cpu, "CPU engine")];
    if matches!(engine, Engine::Gpu(_)) && !machine.has_cross_axis_errors() {
        engines.insert(0, (engine, "GPU"));
    }
    let methods = [
        (
            UncertaintyMethod::FirstOrder,
            format!("first order, {quantities} quantities"),
        ),
        (
            UncertaintyMethod::MonteCarlo {
                draws: BENCH_DRAWS,
                seed: 1,
            },
            format!("Monte Carlo, {BENCH_DRAWS} draws"),
        ),
    ];
    let mut rows = Vec::new();
    for (engine, engine_name) in engines {
        for (method, method_name) in &methods {
            let name = format!("{engine_name} map uncertainty, {method_name}");
            on_step(&name);
            let run = || {
                engine.run_uncertainty::<EngineError>(&machine, grid, *method, None, |_, _, u| {
                    std::hint::black_box(u);
                    Ok(())
                })
            };
            // Once untimed: the first run compiles the kernels for this shape of machine.
            run()?;
            let mut seconds = Vec::with_capacity(runs);
            for _ in 0..runs {
                let (result, s) = timed(run);
                std::hint::black_box(result?);
                seconds.push(s);
            }
            rows.push(Row::new(name, grid.points(), seconds));
        }
    }
    Ok(rows)
}
