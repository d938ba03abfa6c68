//! `volmap bench`: the throughput of every path on this machine, in grid points per second, as
//! a ratio to the f64 reference and, for the GPU kernels, as a fraction of a write-only kernel
//! with the same dispatch and output on the same adapter, so a figure means the same on lavapipe
//! and on a real GPU.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::engine::cpu::{self, CpuPlan};
use crate::engine::map::{self, MapError, MapOptions};
use crate::engine::Engine;
use crate::gpu::{GpuError, KernelChoice, Tiling, TimedKernel};
use crate::io::field::FieldWriter;
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;

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

#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// UTC date, YYYY-MM-DD.
    pub date: String,
    pub adapter: Option<String>,
    pub cpu: String,
    pub threads: usize,
    pub machines: Vec<MachineResult>,
}

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Map(#[from] MapError),
    #[error(transparent)]
    Field(#[from] crate::io::field::FieldError),
    #[error("benchmark scratch folder: {0}")]
    Scratch(std::io::Error),
}

/// The CPU's model name (Linux), or the architecture.
pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, name)| name.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// Today's UTC date from the system clock (civil-from-days, proleptic Gregorian).
pub fn today() -> String {
    let days = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// Kernel timings are the best of this many runs over the grid.
pub const KERNEL_RUNS: usize = 10;

fn timed<R>(f: impl FnOnce() -> R) -> (R, f64) {
    let start = Instant::now();
    let r = f();
    (r, start.elapsed().as_secs_f64())
}

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
    let points = grid.points();
    let mut rows: Vec<(String, u64, f64)> = Vec::new();
    // The GPU kernels first, before any file is written: the kernel's flushing of written files
    // would compete with them for the cores lavapipe runs on.
    let mut gpu_rows: Vec<(String, u64, f64)> = Vec::new();
    let mut ceiling = None;
    let mut kernel_timing = None;
    let mut kernel_tiling = None;
    let mut ceiling_tiling = None;
    if let Engine::Gpu(gpu) = engine {
        on_step("GPU kernel and its write-only ceiling");
        // The ceiling is the fastest of the write-only kernel over several tilings; all take
        // turns with the chain kernel.
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
        kernel_timing = Some(
            if timestamps {
                "timestamp queries"
            } else {
                "wall clock"
            }
            .to_string(),
        );
        let (fastest, ceiling_seconds) =
            seconds[..ceilings.len()].iter().copied().enumerate().fold(
                (0, f64::INFINITY),
                |best, (n, s)| if s < best.1 { (n, s) } else { best },
            );
        ceiling = Some(points as f64 / ceiling_seconds);
        ceiling_tiling = Some(describe_tiling(ceilings[fastest]));
        kernel_tiling = Some(describe_tiling(gpu.tiling()));
        gpu_rows.push((
            "GPU write-only kernel (ceiling)".into(),
            points,
            ceiling_seconds,
        ));
        gpu_rows.push(("GPU kernel".into(), points, seconds[ceilings.len()]));
        on_step("GPU kernel + readback");
        let (done, seconds) = timed(|| {
            gpu.run(machine, grid, None, |_, _, data| -> Result<(), GpuError> {
                std::hint::black_box(data);
                Ok(())
            })
        });
        done?;
        gpu_rows.push(("GPU kernel + readback".into(), points, seconds));
    }

    on_step("f64 reference, 1 thread");
    let ideal = machine.without_errors();
    let sample = reference_points.min(points);
    let (_, seconds) = timed(|| {
        for p in 0..sample {
            std::hint::black_box(cpu::point_values(machine, &ideal, grid, grid.indices(p)));
        }
    });
    rows.push(("f64 reference, 1 thread".into(), sample, seconds));

    on_step("CPU engine");
    let mut field = vec![0.0f32; points as usize * CHANNELS.len()];
    let (_, seconds) =
        timed(|| CpuPlan::new(machine, grid).compute_lines(0, grid.lines(), &mut field));
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
    let (written, seconds) = timed(|| -> Result<(), BenchError> {
        let mut writer = FieldWriter::create(&path, &info)?;
        let mut buffer = Vec::new();
        for (first, lines) in grid.chunks(cpu::CPU_CHUNK_POINTS) {
            buffer.resize(lines as usize * grid.dims[0] * CHANNELS.len(), 0.0);
            cpu::reference_lines(machine, &ideal, grid, first, lines, &mut buffer);
            writer.write_lines(first, lines, &buffer)?;
        }
        writer.finish()?;
        Ok(())
    });
    written?;
    rows.push((
        "map to EXR, f64 reference, all threads".into(),
        points,
        seconds,
    ));

    rows.append(&mut gpu_rows);
    if let Engine::Gpu(_) = engine {
        on_step("map to EXR, GPU");
        let (summary, _) = timed(|| {
            map::map_to_file(machine, grid, engine, &path, &MapOptions::default(), |_| {})
        });
        rows.push(("map to EXR, GPU".into(), points, summary?.seconds));
    }
    let _ = std::fs::remove_file(&path);

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
        kernel_timing,
        kernel_tiling,
        ceiling_tiling,
        paths,
    })
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
        if let (Some(kernel), Some(ceiling)) = (&m.kernel_tiling, &m.ceiling_tiling) {
            out.push_str(&format!(
                "  tilings: GPU kernel {kernel}; ceiling (the fastest write-only) {ceiling}\n"
            ));
        }
    }
    out
}
