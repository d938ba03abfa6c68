//! The paths `volmap bench` measures, each `runs` times: the GPU kernels against their
//! write-only ceiling, the f64 reference and the CPU engine, the disk ceiling (the field's bytes
//! written by the field writer without computing them) and whole maps into a field file with
//! every compression.

use std::path::Path;

use super::timing::{timed, Spread};
use super::{BenchError, Row};
use crate::engine::map::{self, MapOptions, MapTimes};
use crate::engine::{cpu, reference, Engine};
use crate::gpu::{GpuError, GpuMapper, KernelChoice, Tiling, TimedKernel};
use crate::io::field::{Compression, FieldError, FieldWriter, Storage};
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;
use crate::reference::Twin;

/// Seconds every GPU kernel passes over the grid before its clock starts: the driver's lazy
/// work done and the device's clocks up, whatever ran before.
pub const WARM_UP_SECONDS: f64 = 0.5;

/// What the GPU kernels measured.
pub(super) struct GpuKernels {
    /// Points per second of the write-only ceiling (its median run).
    pub ceiling: f64,
    pub timing: String,
    pub kernel_tiling: String,
    pub ceiling_tiling: String,
    /// Median seconds of the kernel alone and with its readback, over the grid.
    pub kernel_s: f64,
    pub readback_s: f64,
    pub rows: Vec<Row>,
}

/// The write-only ceiling (the fastest over several tilings, by median), the chain kernel
/// taking turns with it, and the kernel with its readback through the engine's own run.
pub(super) fn bench_gpu_kernels(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    runs: usize,
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
    let (mut seconds, timestamps) =
        gpu.time_kernels(machine, grid, &kernels, runs, WARM_UP_SECONDS)?;
    let kernel_seconds = seconds.pop().expect("the chain kernel's runs");
    let fastest = (0..ceilings.len())
        .min_by(|&a, &b| {
            Spread::of(&seconds[a])
                .median
                .total_cmp(&Spread::of(&seconds[b]).median)
        })
        .expect("a ceiling tiling");
    let ceiling_s = Spread::of(&seconds[fastest]).median;
    let kernel_s = Spread::of(&kernel_seconds).median;
    let mut rows = vec![
        Row::new(
            "GPU write-only kernel (ceiling)",
            points,
            seconds.swap_remove(fastest),
        ),
        Row::new("GPU kernel", points, kernel_seconds),
    ];
    on_step("GPU kernel + readback");
    let readback = time_maps(gpu, machine, grid, runs)?;
    let readback_s = Spread::of(&readback).median;
    rows.push(Row::new("GPU kernel + readback", points, readback));
    Ok(GpuKernels {
        ceiling: points as f64 / ceiling_s,
        timing: timing_name(timestamps),
        kernel_tiling: describe_tiling(gpu.tiling()),
        ceiling_tiling: describe_tiling(ceilings[fastest]),
        kernel_s,
        readback_s,
        rows,
    })
}

/// How the GPU kernels were timed.
fn timing_name(timestamps: bool) -> String {
    if timestamps {
        "timestamp queries"
    } else {
        "wall clock"
    }
    .to_string()
}

/// The kernel of a machine with errors of other axes' positions (`folded_main`) taking turns
/// with the write-only kernel of the same dispatch (its ceiling), and its map passes with their
/// readback through the engine's own run.
pub(super) fn bench_gpu_folded(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<GpuKernels, BenchError> {
    let points = grid.points();
    on_step("GPU kernel and its write-only ceiling");
    let ([kernel_seconds, ceiling_seconds], timestamps) =
        gpu.time_folded(machine, grid, runs, WARM_UP_SECONDS)?;
    let ceiling_s = Spread::of(&ceiling_seconds).median;
    let kernel_s = Spread::of(&kernel_seconds).median;
    let readback = bench_gpu_per_point(gpu, machine, grid, runs, on_step)?;
    let readback_s = Spread::of(&readback.seconds).median;
    let tiling = describe_tiling(gpu.folded_tiling(machine, grid));
    Ok(GpuKernels {
        ceiling: points as f64 / ceiling_s,
        timing: timing_name(timestamps),
        kernel_tiling: tiling.clone(),
        ceiling_tiling: tiling,
        kernel_s,
        readback_s,
        rows: vec![
            Row::new("GPU write-only kernel (ceiling)", points, ceiling_seconds),
            Row::new("GPU kernel", points, kernel_seconds),
            readback,
        ],
    })
}

/// The GPU map passes with their readback, as a map runs them (tables filled, chunks read
/// back): the kernel of a machine with errors of other axes' positions, or of its plain
/// counterpart.
pub(super) fn bench_gpu_per_point(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Row, BenchError> {
    on_step("GPU map passes + readback");
    // Compile the kernel on one line first: the clock is for the map, not the driver.
    let line = Grid {
        dims: [grid.dims[0], 1, 1],
        ..grid.clone()
    };
    time_maps(gpu, machine, &line, 1)?;
    let seconds = time_maps(gpu, machine, grid, runs)?;
    Ok(Row::new(
        "GPU map passes + readback",
        grid.points(),
        seconds,
    ))
}

/// The seconds of `runs` GPU maps of `grid` with their readback, each chunk read back and
/// dropped.
fn time_maps(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    runs: usize,
) -> Result<Vec<f64>, BenchError> {
    let mut seconds = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (done, s) = timed(|| {
            gpu.run(machine, grid, None, |_, _, data| -> Result<(), GpuError> {
                std::hint::black_box(data);
                Ok(())
            })
        });
        done?;
        seconds.push(s);
    }
    Ok(seconds)
}

/// The f64 reference on one thread (the baseline) and the CPU engine on all cores.
pub(super) fn bench_cpu_engines(
    machine: &Machine,
    grid: &Grid,
    reference_points: u64,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    on_step("f64 reference, 1 thread");
    let twin = Twin::of(machine);
    let sample = reference_points.min(grid.points());
    let seconds = (0..runs)
        .map(|_| {
            timed(|| {
                for p in 0..sample {
                    std::hint::black_box(reference::point_values(&twin, grid, grid.indices(p)));
                }
            })
            .1
        })
        .collect();
    let mut rows = vec![Row::new("f64 reference, 1 thread", sample, seconds)];
    on_step("CPU engine");
    let mut seconds = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (done, s) = timed(|| {
            Engine::Cpu.run(
                machine,
                grid,
                None,
                |_, _, data| -> Result<(), BenchError> {
                    std::hint::black_box(data);
                    Ok(())
                },
            )
        });
        done?;
        seconds.push(s);
    }
    rows.push(Row::new(
        format!("CPU engine, f64, {} threads", rayon::current_num_threads()),
        grid.points(),
        seconds,
    ));
    Ok(rows)
}

/// The disk ceiling: the bytes of an uncompressed field of `grid` written the way a map writes
/// them (the field writer, chunks of `chunk_points`, synced to disk and renamed) from one chunk
/// of values computed once, so nothing is computed while the clock runs.
pub(super) fn bench_disk_ceiling(
    machine: &Machine,
    grid: &Grid,
    chunk_points: u64,
    scratch: &Path,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Row, BenchError> {
    on_step("disk ceiling");
    let nx = grid.dims[0] as u64;
    let lines_per_chunk = (chunk_points / nx).clamp(1, grid.lines());
    let mut values = vec![0.0f32; (lines_per_chunk * nx) as usize * CHANNELS.len()];
    cpu::CpuPlan::new(machine, grid).compute_lines(0, lines_per_chunk, &mut values);
    let info = map::field_info(machine, grid, "bench");
    let path = scratch.join("bench-disk.exr");
    let mut seconds = Vec::with_capacity(runs);
    let mut bytes = 0;
    for _ in 0..runs {
        let (written, s) = timed(|| -> Result<u64, BenchError> {
            let mut writer = FieldWriter::create(&path, &info)?;
            for (first, lines) in grid.chunks(lines_per_chunk * nx).iter() {
                writer.write_lines(first, lines, &values)?;
            }
            Ok(writer.finish()?.bytes)
        });
        bytes = written?;
        let _ = std::fs::remove_file(&path);
        seconds.push(s);
    }
    let mut row = Row::new("disk ceiling (field writer, none)", grid.points(), seconds);
    row.file_bytes = Some(bytes);
    row.disk = true;
    Ok(row)
}

/// What a map is benchmarked on: the machine, its grid, the folder for the fields and the runs.
pub(super) struct MapBench<'a> {
    pub machine: &'a Machine,
    pub grid: &'a Grid,
    pub scratch: &'a Path,
    pub runs: usize,
}

/// Whole maps into a field file on `engine` (named `engine_name`), with each of
/// `compressions`.
pub(super) fn bench_maps(
    bench: &MapBench,
    engine: &Engine,
    engine_name: &str,
    compressions: &[Compression],
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let MapBench {
        machine,
        grid,
        scratch,
        runs,
    } = *bench;
    let mut rows = Vec::new();
    for &compression in compressions {
        let name = format!("map to EXR, {engine_name}, {}", compression.name());
        on_step(&name);
        let options = MapOptions {
            storage: Storage {
                compression,
                half: false,
            },
            ..MapOptions::default()
        };
        let path = scratch.join("bench-map.exr");
        let mut seconds = Vec::with_capacity(runs);
        let mut times: Vec<MapTimes> = Vec::with_capacity(runs);
        for _ in 0..runs {
            let summary = map::map_to_file(machine, grid, engine, &path, &options, |_| {});
            let _ = std::fs::remove_file(&path);
            let summary = summary?;
            seconds.push(summary.seconds);
            times.push(summary.times);
        }
        let median = Spread::median_run(&seconds);
        let median = (times[median], seconds[median]);
        let mut row = Row::new(name, grid.points(), seconds);
        row.file_bytes = Some(median.0.write.bytes);
        row.times = Some(median);
        row.disk = true;
        rows.push(row);
    }
    Ok(rows)
}

/// Points the encoders compress in `volmap bench`'s comparison (at most).
const ENCODER_POINTS: u64 = 1 << 20;

/// The block encoders on one core, volmap's (ZIP and PXR24 deflated at level 1) against the
/// `exr` crate's (level 4), over the first lines of the map: points compressed per second and
/// the bytes they take.
pub(super) fn bench_encoders(
    machine: &Machine,
    grid: &Grid,
    runs: usize,
    on_step: &mut impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    on_step("block encoders on one core");
    let nx = grid.dims[0] as u64;
    let lines = (ENCODER_POINTS / nx).clamp(1, grid.lines());
    let mut values = vec![0.0f32; (lines * nx) as usize * CHANNELS.len()];
    cpu::CpuPlan::new(machine, grid).compute_lines(0, lines, &mut values);
    let mut rows = Vec::new();
    for compression in [Compression::Zip, Compression::Pxr24] {
        let storage = Storage {
            compression,
            half: false,
        };
        for (exr_crate, whose) in [(false, "volmap, level 1"), (true, "exr crate, level 4")] {
            let mut seconds = Vec::with_capacity(runs);
            let mut bytes = 0;
            for _ in 0..runs {
                let (compressed, s) = timed(|| {
                    crate::io::field::compress_on_one_thread(
                        storage,
                        nx as usize,
                        &values,
                        exr_crate,
                    )
                });
                bytes = compressed.map_err(|what| FieldError::Compress {
                    path: "(volmap bench)".into(),
                    what,
                })?;
                seconds.push(s);
            }
            let mut row = Row::new(
                format!("compress, 1 core, {} ({whose})", compression.name()),
                lines * nx,
                seconds,
            );
            row.file_bytes = Some(bytes);
            rows.push(row);
        }
    }
    Ok(rows)
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
