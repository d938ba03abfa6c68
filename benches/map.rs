//! Throughput of the map paths, in grid points per second: the f64 reference on one core and on
//! all cores, and the GPU kernel with readback, for the 3-axis and the 5-axis embedded machines.
//! `cargo bench`. Without an adapter the GPU benchmarks are left out, with a line saying so.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use volmap::cpu;
use volmap::gpu::{GpuError, GpuMapper};
use volmap::grid::Grid;
use volmap::machine::embedded;
use volmap::reference;

fn bench_maps(c: &mut Criterion) {
    let gpu = GpuMapper::open().ok().flatten();
    if gpu.is_none() {
        eprintln!("no GPU adapter: GPU benchmarks left out");
    }
    for (name, pose) in [
        ("vmc-li2015", [0.0; 6]),
        ("5axis-hwang2014", [0.0, 0.0, 0.0, 0.0, 30.0, 60.0]),
    ] {
        let machine = embedded::load(name).unwrap();
        let ideal = machine.without_errors();
        let mut group = c.benchmark_group(name);

        let grid = Grid::full_travel(&machine, [16, 16, 16], pose).unwrap();
        group.throughput(Throughput::Elements(grid.points()));
        group.bench_function("reference, one core", |b| {
            b.iter(|| {
                for p in 0..grid.points() {
                    black_box(reference::deviation_against(
                        &machine,
                        &ideal,
                        &grid.command(grid.indices(p)),
                    ));
                }
            })
        });
        let mut out = vec![0.0f32; grid.points() as usize * 6];
        group.bench_function("reference, all cores", |b| {
            b.iter(|| {
                cpu::reference_lines(
                    &machine,
                    &ideal,
                    &grid,
                    0,
                    grid.lines(),
                    black_box(&mut out),
                )
            })
        });

        if let Some(gpu) = &gpu {
            let grid = Grid::full_travel(&machine, [128, 128, 64], pose).unwrap();
            group.throughput(Throughput::Elements(grid.points()));
            group.sample_size(10);
            group.bench_function("GPU kernel with readback", |b| {
                b.iter(|| {
                    gpu.run(
                        &machine,
                        &grid,
                        None,
                        |_, _, data| -> Result<(), GpuError> {
                            black_box(data);
                            Ok(())
                        },
                    )
                    .unwrap()
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_maps);
criterion_main!(benches);
