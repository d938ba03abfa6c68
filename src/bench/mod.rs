//! `volmap bench`: the throughput of every path on this machine, in grid points per second, as
//! a ratio to the f64 reference, for the GPU kernels as a fraction of a write-only kernel with the
//! same dispatch and output on the same adapter, and for maps into a field file as a fraction
//! of the disk ceiling (the same bytes written the same way, nothing computed), with the share of
//! each stage of the map. Every figure is the median of repeated runs, with its spread.
//!
//! Each machine is measured from the same state whatever ran before: the caller opens a fresh
//! engine (on a GPU a new device, so no buffer or pipeline of the machine before is held or
//! reused), and the GPU kernels warm up over the grid before they are timed.

mod monte_carlo;
mod paths;
mod plain;
mod table;
mod timing;
mod uncertainty;

use std::path::Path;

use serde::Serialize;

pub use paths::{describe_tiling, WARM_UP_SECONDS};
pub use plain::{plain_counterpart, PLAIN_SUFFIX};
pub use table::table;
pub use timing::Spread;
pub use uncertainty::{with_calibration_uncertainty, BENCH_DRAWS};

use crate::design::DesignError;
use crate::engine::map::MapTimes;
use crate::engine::{Engine, EngineError};
use crate::error::{Classify, ErrorKind};
use crate::gpu::GpuError;
use crate::io::field::{Compression, FieldError};
use crate::model::grid::Grid;
use crate::model::Machine;

/// One measured path: the median of its runs and their spread.
#[derive(Debug, Clone, Serialize)]
pub struct PathResult {
    pub path: String,
    pub points: u64,
    /// Seconds of the median run, and the spread of every run.
    pub seconds: f64,
    pub spread: Spread,
    /// Points per second of the median run, the slowest and the fastest, millions.
    pub mpts_per_s: f64,
    pub mpts_per_s_min: f64,
    pub mpts_per_s_max: f64,
    /// Throughput over that of the f64 reference on one thread.
    pub ratio_to_reference: f64,
    /// Throughput over that of the write-only kernel (GPU paths).
    pub fraction_of_ceiling: Option<f64>,
    /// Throughput over that of the disk ceiling (maps into a field file, and the ceiling).
    pub fraction_of_disk: Option<f64>,
    /// Bytes of the field file (maps, the disk ceiling).
    pub file_bytes: Option<u64>,
    /// Where the time of a map went (its median run).
    pub stages: Option<StageShares>,
}

/// The share of a map's time (its median run) each stage was busy. The stages overlap (the
/// engine computes while the writer compresses and writes), so the shares may add up to more
/// than 1; the largest is the stage that bounds the map.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StageShares {
    /// The map's thread in the engine: computing and, on a GPU, reading back.
    pub engine: f64,
    /// On a GPU: the kernel alone over the grid (its median timing), and the readback (the
    /// kernel with its readback, less the kernel).
    pub device: Option<f64>,
    pub readback: Option<f64>,
    /// Handing chunks over to the writer (statistics, copies), waits for room included.
    pub handoff: f64,
    /// Of which waiting for room in the writer's queues.
    pub waiting: f64,
    /// Compressing blocks (on every core).
    pub compress: f64,
    /// Writing blocks into the file.
    pub write: f64,
    /// Syncing the file to disk and renaming it at the end.
    pub sync: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct MachineResult {
    pub machine: String,
    pub chain: String,
    pub grid: [usize; 3],
    /// How the GPU kernels were timed: "timestamp queries" or "wall clock".
    pub kernel_timing: Option<String>,
    /// How the chain kernel divides a chunk among invocations, e.g. "64 points × 4 lines".
    pub kernel_tiling: Option<String>,
    /// The tiling of the fastest write-only kernel, the ceiling.
    pub ceiling_tiling: Option<String>,
    /// The disk ceiling in megabytes (10⁶) per second, its median run.
    pub disk_mb_per_s: f64,
    pub paths: Vec<PathResult>,
    /// For a machine with errors of other axes' positions: on each path measured with its
    /// plain counterpart too (rows named with [`PLAIN_SUFFIX`]), the machine's rate over the
    /// counterpart's.
    pub against_plain: Vec<PlainRatio>,
    /// The GPU's first-order uncertainty of the map: its time per uncertain quantity over the
    /// time of one kernel pass over the grid (central differences: two passes and their sums).
    pub uncertainty_passes_per_quantity: Option<f64>,
}

/// A path's rate over that of the same machine with plain tables.
#[derive(Debug, Clone, Serialize)]
pub struct PlainRatio {
    pub path: String,
    pub ratio: f64,
}

/// A whole `volmap bench` run: where it ran and what each machine measured.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// UTC date, YYYY-MM-DD.
    pub date: String,
    pub adapter: Option<String>,
    pub cpu: String,
    pub threads: usize,
    /// Runs of every path; figures are their medians.
    pub runs: usize,
    /// Seconds the GPU kernels warm up before they are timed.
    pub warm_up_s: f64,
    pub machines: Vec<MachineResult>,
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Engine(#[from] EngineError),
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error(transparent)]
    Design(#[from] DesignError),
}

impl Classify for BenchError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Work
    }
}

/// A measured path before it becomes a [`PathResult`].
pub(crate) struct Row {
    path: String,
    points: u64,
    seconds: Vec<f64>,
    file_bytes: Option<u64>,
    /// Where the time of a map's median run went, with that run's seconds.
    times: Option<(MapTimes, f64)>,
    /// Whether it is held against the disk ceiling.
    disk: bool,
}

impl Row {
    fn new(path: impl Into<String>, points: u64, seconds: Vec<f64>) -> Row {
        Row {
            path: path.into(),
            points,
            seconds,
            file_bytes: None,
            times: None,
            disk: false,
        }
    }
}

/// Measures every path for `machine` over `grid` (the GPU paths when `engine` is the GPU), each
/// `runs` times, writing scratch fields into `scratch`. `reference_points` bounds the points the
/// single-thread reference computes (its throughput does not depend on how many); `on_step`
/// names each path as it starts. `engine` should be opened for this machine alone (see the
/// module's documentation).
pub fn bench_machine(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    scratch: &Path,
    reference_points: u64,
    runs: usize,
    mut on_step: impl FnMut(&str),
) -> Result<MachineResult, BenchError> {
    let runs = runs.max(1);
    // The GPU kernels first, before any file is written: the kernel's flushing of written files
    // would compete with them for the cores lavapipe runs on.
    // A machine with errors of other axes' positions maps with its own kernel (folded.wgsl),
    // held against the write-only kernel of its dispatch, and the paths where it differs are
    // measured on its plain counterpart beside them (plain.rs).
    let cross_axis = machine.has_cross_axis_errors();
    let gpu = match engine {
        Engine::Gpu(gpu) if !cross_axis => Some(paths::bench_gpu_kernels(
            gpu,
            machine,
            grid,
            runs,
            &mut on_step,
        )?),
        Engine::Gpu(gpu) => Some(paths::bench_gpu_folded(
            gpu,
            machine,
            grid,
            runs,
            &mut on_step,
        )?),
        _ => None,
    };
    let mut rows = paths::bench_cpu_engines(machine, grid, reference_points, runs, &mut on_step)?;
    if let Some(gpu) = &gpu {
        rows.extend(
            gpu.rows
                .iter()
                .map(|r| Row::new(&r.path, r.points, r.seconds.clone())),
        );
    }
    let disk = paths::bench_disk_ceiling(
        machine,
        grid,
        engine.chunk_points(),
        scratch,
        runs,
        &mut on_step,
    )?;
    let disk_rate = grid.points() as f64 / Spread::of(&disk.seconds).median;
    let disk_mb_per_s =
        disk.file_bytes.unwrap_or(0) as f64 / Spread::of(&disk.seconds).median / 1e6;
    rows.push(disk);
    rows.extend(paths::bench_encoders(machine, grid, runs, &mut on_step)?);
    let compressions = Compression::ALL;
    let maps = paths::MapBench {
        machine,
        grid,
        scratch,
        runs,
    };
    if let Engine::Gpu(_) = engine {
        rows.extend(paths::bench_maps(
            &maps,
            engine,
            "GPU",
            &compressions,
            &mut on_step,
        )?);
    }
    rows.extend(paths::bench_maps(
        &maps,
        &Engine::Cpu,
        "CPU engine",
        &compressions,
        &mut on_step,
    )?);
    rows.extend(paths::bench_maps(
        &maps,
        &Engine::Reference,
        "f64 reference",
        &[Compression::None],
        &mut on_step,
    )?);
    rows.extend(monte_carlo::bench_monte_carlo(
        machine,
        grid,
        engine,
        runs,
        &mut on_step,
    )?);
    let uncertainty_rows =
        uncertainty::bench_uncertainty(machine, grid, engine, runs, &mut on_step)?;
    let quantities = with_calibration_uncertainty(machine).uncertainty.count();
    let uncertainty_passes_per_quantity = gpu.as_ref().and_then(|g| {
        uncertainty_rows
            .iter()
            .find(|r| r.path.starts_with("GPU map uncertainty, first order"))
            .map(|r| {
                Spread::of(&r.seconds).median / quantities.max(1) as f64 / g.kernel_s.max(1e-12)
            })
    });
    rows.extend(uncertainty_rows);
    let against_plain = if cross_axis {
        plain::bench_plain(
            machine,
            grid,
            engine,
            (&maps, reference_points),
            &mut rows,
            &mut on_step,
        )?
    } else {
        Vec::new()
    };
    let ceiling = gpu.as_ref().map(|g| g.ceiling);
    let reference_rate = rows[0].points as f64 / Spread::of(&rows[0].seconds).median;
    let gpu_kernel = gpu.as_ref().map(|g| (g.kernel_s, g.readback_s));
    let paths = rows
        .into_iter()
        .map(|row| result(row, reference_rate, ceiling, disk_rate, gpu_kernel))
        .collect();
    Ok(MachineResult {
        machine: machine.name.clone(),
        chain: machine.chain.hwang_notation(),
        grid: grid.dims,
        kernel_timing: gpu.as_ref().map(|g| g.timing.clone()),
        kernel_tiling: gpu.as_ref().map(|g| g.kernel_tiling.clone()),
        ceiling_tiling: gpu.as_ref().map(|g| g.ceiling_tiling.clone()),
        disk_mb_per_s,
        paths,
        against_plain,
        uncertainty_passes_per_quantity,
    })
}

/// A row's figures: rates from its median run, ratios to the reference, the ceilings, and the
/// stage shares of a map (the GPU's kernel and readback from their own timings, over the same
/// grid, `gpu_kernel` = seconds of the kernel and of the kernel with its readback).
fn result(
    row: Row,
    reference_rate: f64,
    ceiling: Option<f64>,
    disk_rate: f64,
    gpu_kernel: Option<(f64, f64)>,
) -> PathResult {
    let spread = Spread::of(&row.seconds);
    let rate = |s: f64| row.points as f64 / s.max(1e-12);
    let median_rate = rate(spread.median);
    // A map's uncertainty counts grid points of many passes: no kernel's ceiling to hold it to.
    let gpu_path = row.path.starts_with("GPU") && !row.path.contains("map uncertainty");
    // The kernel's own timings say nothing of the plain counterpart's map.
    let on_gpu = row.path.contains(", GPU,") && !row.path.ends_with(PLAIN_SUFFIX);
    let stages = row.times.map(|(t, wall)| {
        let wall = wall.max(1e-12);
        let (device, readback) = match gpu_kernel.filter(|_| on_gpu) {
            Some((kernel_s, readback_s)) => (
                Some(kernel_s / wall),
                Some((readback_s - kernel_s).max(0.0) / wall),
            ),
            None => (None, None),
        };
        StageShares {
            engine: t.engine_s / wall,
            device,
            readback,
            handoff: t.handoff_s / wall,
            waiting: t.write.waiting_s / wall,
            compress: t.write.compress_s / wall,
            write: t.write.write_s / wall,
            sync: t.write.sync_s / wall,
        }
    });
    PathResult {
        fraction_of_ceiling: ceiling.filter(|_| gpu_path).map(|c| median_rate / c),
        fraction_of_disk: row.disk.then_some(median_rate / disk_rate),
        file_bytes: row.file_bytes,
        stages,
        path: row.path,
        points: row.points,
        seconds: spread.median,
        spread,
        mpts_per_s: median_rate / 1e6,
        mpts_per_s_min: rate(spread.max) / 1e6,
        mpts_per_s_max: rate(spread.min) / 1e6,
        ratio_to_reference: median_rate / reference_rate,
    }
}
