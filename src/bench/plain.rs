//! What errors of other axes' positions cost: a machine with `of` or `table2d` terms measured
//! beside its plain counterpart, the same machine with every such term made a term of the
//! axis's own position, on the paths where the two differ (the CPU engine, the GPU kernel with
//! its readback, the map, Monte Carlo).

use super::paths::{self, MapBench};
use super::{monte_carlo, BenchError, PlainRatio, Row, Spread};
use crate::engine::Engine;
use crate::io::field::Compression;
use crate::model::errorfn::ErrorFunction;
use crate::model::grid::Grid;
use crate::model::Machine;

/// What a bench row's path is called with the plain counterpart's figures.
pub const PLAIN_SUFFIX: &str = " (plain tables)";

/// `machine` with every term that reads another axis's position made a term of the axis's own:
/// `of`'s polynomial or table read at the axis's own position, a `table2d` left out. The same
/// number of terms of the same kinds, so the same work per evaluation, less the cross-axis
/// lookups.
pub fn plain_counterpart(machine: &Machine) -> Machine {
    let mut plain = machine.clone();
    for axis in &mut plain.axes {
        for f in axis.components.iter_mut().flatten() {
            *f = own_axis_only(f);
        }
    }
    plain
}

fn own_axis_only(f: &ErrorFunction) -> ErrorFunction {
    match f {
        ErrorFunction::Sum(terms) => ErrorFunction::Sum(terms.iter().map(own_axis_only).collect()),
        ErrorFunction::Of { form, .. } => own_axis_only(form),
        ErrorFunction::Table2d(_) => ErrorFunction::Constant(0.0),
        other => other.clone(),
    }
}

/// Which of a machine's rows a plain row stands beside: the same path, the machine count of a
/// Monte Carlo row aside.
fn same_path(a: &str, b: &str) -> bool {
    let stem = |p: &str| match p.find(" Monte Carlo") {
        Some(n) => p[..n].to_string(),
        None => p.to_string(),
    };
    stem(a) == stem(b)
}

/// Measures the plain counterpart of `machine` on the paths where they differ and adds its rows
/// to `rows` (the machine's own), each named with [`PLAIN_SUFFIX`]; returns for each the
/// machine's rate over the counterpart's.
pub(super) fn bench_plain(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    bench: (&MapBench, u64),
    rows: &mut Vec<Row>,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<PlainRatio>, BenchError> {
    let plain = plain_counterpart(machine);
    let (maps, reference_points) = bench;
    let runs = maps.runs;
    let mut step = |s: &str| on_step(&format!("{s}{PLAIN_SUFFIX}"));
    let mut plain_rows = paths::bench_cpu_engines(&plain, grid, reference_points, runs, &mut step)?;
    plain_rows.remove(0);
    if let Engine::Gpu(gpu) = engine {
        plain_rows.push(paths::bench_gpu_per_point(
            gpu, &plain, grid, runs, &mut step,
        )?);
        let plain_maps = MapBench {
            machine: &plain,
            ..*maps
        };
        plain_rows.extend(paths::bench_maps(
            &plain_maps,
            engine,
            "GPU",
            &[Compression::None],
            &mut step,
        )?);
    }
    plain_rows.extend(monte_carlo::bench_monte_carlo(
        &plain, grid, engine, runs, &mut step,
    )?);
    let rate = |r: &Row| r.points as f64 / Spread::of(&r.seconds).median.max(1e-12);
    let mut ratios = Vec::new();
    for plain_row in &mut plain_rows {
        if let Some(own) = rows.iter().find(|r| same_path(&r.path, &plain_row.path)) {
            ratios.push(PlainRatio {
                path: own.path.clone(),
                ratio: rate(own) / rate(plain_row),
            });
        }
        plain_row.path.push_str(PLAIN_SUFFIX);
    }
    rows.extend(plain_rows);
    Ok(ratios)
}
