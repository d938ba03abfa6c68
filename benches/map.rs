//! Criterion benchmarks of every map path, in grid points per second, for the 3-axis and the
//! 5-axis embedded machines: the f64 reference (one thread), the CPU engine (all threads), the
//! GPU kernel alone and with readback, the write-only ceiling at each tiling it is measured with,
//! and writing the EXR field. `cargo bench`; the fixed seed is the grid itself. Without an
//! adapter the GPU benchmarks are left out, with a line saying so. `volmap bench` prints the same
//! figures as one table.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use volmap::engine::cpu::CpuPlan;
use volmap::engine::map;
use volmap::engine::reference;
use volmap::gpu::{GpuError, GpuMapper, KernelChoice, TimedKernel};
use volmap::io::embedded;
use volmap::io::field::FieldWriter;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;

fn bench_maps(c: &mut Criterion) {
    let gpu = GpuMapper::open().ok().flatten();
    if gpu.is_none() {
        eprintln!("no GPU adapter: GPU benchmarks left out");
    }
    let scratch = tempfile::tempdir().expect("scratch folder");
    for (name, pose) in [
        ("vmc-li2015", [0.0; 6]),
        ("5axis-hwang2014", [0.0, 0.0, 0.0, 0.0, 30.0, 60.0]),
    ] {
        let machine = embedded::load(name).unwrap();
        let twin = volmap::reference::Twin::of(&machine);
        let mut group = c.benchmark_group(name);
        group
            .sample_size(10)
            .measurement_time(Duration::from_secs(5));

        let small = Grid::full_travel(&machine, [32, 32, 8], pose).unwrap();
        group.throughput(Throughput::Elements(small.points()));
        group.bench_function("f64 reference, 1 thread", |b| {
            b.iter(|| {
                for p in 0..small.points() {
                    black_box(reference::point_values(&twin, &small, small.indices(p)));
                }
            })
        });

        let grid = Grid::full_travel(&machine, [128, 128, 64], pose).unwrap();
        group.throughput(Throughput::Elements(grid.points()));
        let mut field = vec![0.0f32; grid.points() as usize * CHANNELS.len()];
        group.bench_function("CPU engine, all threads", |b| {
            b.iter(|| {
                CpuPlan::new(&machine, &grid).compute_lines(0, grid.lines(), black_box(&mut field))
            })
        });
        let info = map::field_info(&machine, &grid, "bench");
        let path = scratch.path().join("bench.exr");
        group.bench_function("EXR write", |b| {
            b.iter(|| {
                let mut writer = FieldWriter::create(&path, &info).unwrap();
                writer.write_lines(0, grid.lines(), &field).unwrap();
                writer.finish().unwrap();
            })
        });

        if let Some(gpu) = &gpu {
            let (machine, grid) = (&machine, &grid);
            let timed = |choice, tiling| {
                let kernel = TimedKernel { choice, tiling };
                move |b: &mut criterion::Bencher| {
                    b.iter_custom(|iterations| {
                        (0..iterations)
                            .map(|_| {
                                Duration::from_secs_f64(
                                    gpu.time_kernels(machine, grid, &[kernel], 1, 0.0)
                                        .unwrap()
                                        .0[0][0],
                                )
                            })
                            .sum()
                    })
                }
            };
            group.bench_function("GPU kernel", timed(KernelChoice::Chain, gpu.tiling()));
            // The ceiling is the fastest of these (see `volmap bench`).
            for tiling in gpu.ceiling_tilings() {
                group.bench_function(
                    format!(
                        "GPU write-only ceiling, {}",
                        volmap::bench::describe_tiling(tiling)
                    ),
                    timed(KernelChoice::WriteOnly, tiling),
                );
            }
            group.bench_function("GPU kernel + readback", |b| {
                b.iter(|| {
                    gpu.run(machine, grid, None, |_, _, data| -> Result<(), GpuError> {
                        black_box(data);
                        Ok(())
                    })
                    .unwrap()
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_maps);
criterion_main!(benches);
