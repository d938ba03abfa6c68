//! `volmap bench`: the throughput of every path on this machine, in grid points per second, as
//! a ratio to the f64 reference and, for the GPU kernels, as a fraction of a write-only kernel
//! with the same dispatch and output on the same adapter, so a figure means the same on lavapipe
//! and on a real GPU.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::design::monte_carlo::Study;
use crate::design::DesignError;
use crate::engine::map::{self, MapOptions};
use crate::engine::{reference, Engine, EngineError};
use crate::error::{Classify, ErrorKind};
use crate::gpu::{GpuError, GpuMapper, KernelChoice, Tiling, TimedKernel};
use crate::io::field::{FieldError, FieldWriter};
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::perturbation::{Distribution, ErrorTarget, Perturbation, Shape, Tolerance};
use crate::model::Machine;
use crate::reference::Twin;

/// One measured path.
#[derive(Debug, Clone, Serialize)]
pub struct PathResult {
    pub path: String,
    pub points: u64,
    pub seconds: f64,
    pub mpts_per_s: f64,
    /// Throughput over that of the f64 reference on one thread.
    pub ratio_to_reference: f64,
    /// Throughput over that of the write-only kernel (GPU paths).
    pub fraction_of_ceiling: Option<f64>,
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
    pub paths: Vec<PathResult>,
}

/// A whole `volmap bench` run: where it ran and what each machine measured.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// UTC date, YYYY-MM-DD.
    pub date: String,
    pub adapter: Option<String>,
    pub cpu: String,
    pub threads: usize,
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

/// Kernel timings are the best of this many runs over the grid.
pub const KERNEL_RUNS: usize = 10;

fn timed<R>(f: impl FnOnce() -> R) -> (R, f64) {
    let start = Instant::now();
    let r = f();
    (r, start.elapsed().as_secs_f64())
}

/// A measured path: its name, the points it computed and the seconds it took.
type Row = (String, u64, f64);

/// Measures every path for `machine` over `grid` (the GPU paths when `engine` is the GPU),
/// writing scratch fields into `scratch`.
/// `reference_points` bounds the points the single-thread reference computes (its throughput
/// does not depend on how many); `on_step` names each path as it starts.
pub fn bench_machine(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    scratch: &Path,
    reference_points: u64,
    mut on_step: impl FnMut(&str),
) -> Result<MachineResult, BenchError> {
    // The GPU kernels first, before any file is written: the kernel's flushing of written files
    // would compete with them for the cores lavapipe runs on.
    // A machine with errors of other axes' positions maps point by point (no folded kernel, no
    // ceiling to hold it against): its GPU rows are the map's own.
    let cross_axis = machine.has_cross_axis_errors();
    let gpu = match engine {
        Engine::Gpu(gpu) if !cross_axis => {
            Some(bench_gpu_kernels(gpu, machine, grid, &mut on_step)?)
        }
        _ => None,
    };
    let mut rows = bench_cpu_paths(machine, grid, scratch, reference_points, &mut on_step)?;
    if let Some(gpu) = &gpu {
        rows.extend(gpu.rows.iter().cloned());
        on_step("map to EXR, GPU");
        let path = scratch.join("bench-map.exr");
        let summary =
            map::map_to_file(machine, grid, engine, &path, &MapOptions::default(), |_| {});
        let _ = std::fs::remove_file(&path);
        rows.push(("map to EXR, GPU".into(), grid.points(), summary?.seconds));
    }
    if let (Engine::Gpu(gpu), true) = (engine, cross_axis) {
        on_step("GPU per-point kernel + readback");
        let map = |grid: &Grid| {
            gpu.run(machine, grid, None, |_, _, data| -> Result<(), GpuError> {
                std::hint::black_box(data);
                Ok(())
            })
        };
        // Compile the kernel on one line first: the clock is for the map, not the driver.
        map(&Grid {
            dims: [grid.dims[0], 1, 1],
            ..grid.clone()
        })?;
        let (done, seconds) = timed(|| map(grid));
        done?;
        rows.push((
            "GPU per-point kernel + readback".into(),
            grid.points(),
            seconds,
        ));
    }
    rows.extend(bench_monte_carlo(machine, grid, engine, &mut on_step)?);
    let ceiling = gpu.as_ref().map(|g| g.ceiling);
    let reference_rate = rows[0].1 as f64 / rows[0].2;
    let paths = rows
        .into_iter()
        .map(|(path, points, seconds)| {
            let rate = points as f64 / seconds.max(1e-12);
            let gpu_path = path.starts_with("GPU");
            PathResult {
                fraction_of_ceiling: ceiling.filter(|_| gpu_path).map(|c| rate / c),
                path,
                points,
                seconds,
                mpts_per_s: rate / 1e6,
                ratio_to_reference: rate / reference_rate,
            }
        })
        .collect();
    Ok(MachineResult {
        machine: machine.name.clone(),
        chain: machine.chain.hwang_notation(),
        grid: grid.dims,
        kernel_timing: gpu.as_ref().map(|g| g.timing.clone()),
        kernel_tiling: gpu.as_ref().map(|g| g.kernel_tiling.clone()),
        ceiling_tiling: gpu.as_ref().map(|g| g.ceiling_tiling.clone()),
        paths,
    })
}

/// What the GPU kernels measured.
struct GpuKernels {
    /// Points per second of the write-only ceiling.
    ceiling: f64,
    timing: String,
    kernel_tiling: String,
    ceiling_tiling: String,
    rows: Vec<Row>,
}

/// The write-only ceiling (the fastest over several tilings), the chain kernel taking turns with
/// it, and the kernel with its readback through the engine's own run.
fn bench_gpu_kernels(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    on_step: &mut impl FnMut(&str),
) -> Result<GpuKernels, BenchError> {
    let points = grid.points();
    on_step("GPU kernel and its write-only ceiling");
    let ceilings = gpu.ceiling_tilings();
    let mut kernels: Vec<TimedKernel> = ceilings
        .iter()
        .map(|&tiling| TimedKernel {
            choice: KernelChoice::WriteOnly,
            tiling,
        })
        .collect();
    kernels.push(TimedKernel {
        choice: KernelChoice::Chain,
        tiling: gpu.tiling(),
    });
    let (seconds, timestamps) = gpu.time_kernels(machine, grid, &kernels, KERNEL_RUNS)?;
    let (fastest, ceiling_seconds) = seconds[..ceilings.len()].iter().copied().enumerate().fold(
        (0, f64::INFINITY),
        |best, (n, s)| {
            if s < best.1 {
                (n, s)
            } else {
                best
            }
        },
    );
    let mut rows: Vec<Row> = vec![
        (
            "GPU write-only kernel (ceiling)".into(),
            points,
            ceiling_seconds,
        ),
        ("GPU kernel".into(), points, seconds[ceilings.len()]),
    ];
    on_step("GPU kernel + readback");
    let (done, seconds) = timed(|| {
        gpu.run(machine, grid, None, |_, _, data| -> Result<(), GpuError> {
            std::hint::black_box(data);
            Ok(())
        })
    });
    done?;
    rows.push(("GPU kernel + readback".into(), points, seconds));
    Ok(GpuKernels {
        ceiling: points as f64 / ceiling_seconds,
        timing: if timestamps {
            "timestamp queries"
        } else {
            "wall clock"
        }
        .to_string(),
        kernel_tiling: describe_tiling(gpu.tiling()),
        ceiling_tiling: describe_tiling(ceilings[fastest]),
        rows,
    })
}

/// The f64 reference on one thread (the baseline), the CPU engine, writing the EXR file, and a
/// whole map with the reference.
fn bench_cpu_paths(
    machine: &Machine,
    grid: &Grid,
    scratch: &Path,
    reference_points: u64,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let points = grid.points();
    let mut rows: Vec<Row> = Vec::new();
    on_step("f64 reference, 1 thread");
    let twin = Twin::of(machine);
    let sample = reference_points.min(points);
    let (_, seconds) = timed(|| {
        for p in 0..sample {
            std::hint::black_box(reference::point_values(&twin, grid, grid.indices(p)));
        }
    });
    rows.push(("f64 reference, 1 thread".into(), sample, seconds));

    on_step("CPU engine");
    // The engine's own run, its chunks kept for the EXR write that follows.
    let mut field = vec![0.0f32; points as usize * CHANNELS.len()];
    let values_per_line = grid.dims[0] * CHANNELS.len();
    let (done, seconds) = timed(|| {
        Engine::Cpu.run(
            machine,
            grid,
            None,
            |first, lines, data| -> Result<(), BenchError> {
                let start = first as usize * values_per_line;
                let values = lines as usize * values_per_line;
                field[start..start + values].copy_from_slice(&data[..values]);
                Ok(())
            },
        )
    });
    done?;
    rows.push((
        format!("CPU engine, f64, {} threads", rayon::current_num_threads()),
        points,
        seconds,
    ));

    on_step("EXR write");
    let info = map::field_info(machine, grid, "bench");
    let path = scratch.join("bench-write.exr");
    let (written, seconds) = timed(|| -> Result<(), BenchError> {
        let mut writer = FieldWriter::create(&path, &info)?;
        writer.write_lines(0, grid.lines(), &field)?;
        writer.finish()?;
        Ok(())
    });
    written?;
    rows.push(("EXR write".into(), points, seconds));
    drop(field);

    on_step("reference + EXR write");
    let summary = map::map_to_file(
        machine,
        grid,
        &Engine::Reference,
        &path,
        &MapOptions::default(),
        |_| {},
    )?;
    let _ = std::fs::remove_file(&path);
    rows.push((
        "map to EXR, f64 reference, all threads".into(),
        points,
        summary.seconds,
    ));
    Ok(rows)
}

/// Monte Carlo takes at least this long on each engine, so that its rate is not its overhead.
const MONTE_CARLO_SECONDS: f64 = 0.5;

/// Monte Carlo over sampled machines on the GPU (statistics reduced on the device) and on the CPU
/// engine, in machine-points per second: every error value of the machine toleranced (20 µm,
/// 20 µrad uniform, the shapes in turn), the number of machines grown until a run takes
/// [`MONTE_CARLO_SECONDS`].
fn bench_monte_carlo(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
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
        // A machine with errors of other axes' positions: each sample mapped point by point.
        let name = if machine.has_cross_axis_errors() {
            "GPU Monte Carlo, per point"
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
        loop {
            let (stats, seconds) = timed(|| study.sample_stats(engine, samples, &ones, |_| {}));
            std::hint::black_box(stats?);
            if seconds >= MONTE_CARLO_SECONDS || samples >= 1 << 20 {
                rows.push((
                    format!("{name}, {samples} machines"),
                    samples as u64 * grid.points(),
                    seconds,
                ));
                break;
            }
            let grow = (MONTE_CARLO_SECONDS / seconds.max(1e-6) * 1.2).clamp(2.0, 16.0);
            samples = (samples as f64 * grow) as usize;
        }
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

/// A tiling in words: "64 points × 4 lines per invocation".
pub fn describe_tiling(tiling: Tiling) -> String {
    format!(
        "{} points × {} line{} per invocation",
        tiling.points_per_lane,
        tiling.lines_per_lane,
        if tiling.lines_per_lane == 1 { "" } else { "s" }
    )
}

/// The report as the table `volmap bench` prints.
pub fn table(report: &BenchReport) -> String {
    let mut out = format!(
        "volmap bench, {}\n  adapter  {}\n  CPU      {} ({} threads)\n",
        report.date,
        report
            .adapter
            .as_deref()
            .unwrap_or("none (GPU paths left out)"),
        report.cpu,
        report.threads
    );
    for m in &report.machines {
        out.push_str(&format!(
            "\n{} ({}), grid {}x{}x{}{}\n  {:<40} {:>10} {:>11} {:>12}\n",
            m.machine,
            m.chain,
            m.grid[0],
            m.grid[1],
            m.grid[2],
            m.kernel_timing
                .as_ref()
                .map_or(String::new(), |t| format!(", GPU kernels timed by {t}")),
            "path",
            "Mpts/s",
            "× reference",
            "of ceiling"
        ));
        for p in &m.paths {
            let fraction = p
                .fraction_of_ceiling
                .map_or(String::new(), |f| format!("{:.0}%", f * 100.0));
            out.push_str(&format!(
                "  {:<40} {:>10.2} {:>11.1} {:>12}\n",
                p.path, p.mpts_per_s, p.ratio_to_reference, fraction
            ));
        }
        if m.paths.iter().any(|p| p.path.contains("Monte Carlo")) {
            out.push_str(
                "  Monte Carlo rows count machine-points (machines × grid points), each machine's statistics reduced where it is computed\n",
            );
        }
        if let (Some(kernel), Some(ceiling)) = (&m.kernel_tiling, &m.ceiling_tiling) {
            out.push_str(&format!(
                "  tilings: GPU kernel {kernel}; ceiling (the fastest write-only) {ceiling}\n"
            ));
        }
    }
    out
}
