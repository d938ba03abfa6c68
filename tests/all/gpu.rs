//! The GPU engine against the f64 reference, at every grid point, within the one rule volmap
//! states: max(1e-6 mm, 16 f32 units in the last place of |VE|) for VE and max(1e-9 rad, 8 units
//! of |OE|) for OE (`engine::map::ve_tolerance_mm`, `oe_tolerance_rad`).

use volmap::engine::map::{oe_tolerance_rad, ve_tolerance_mm};
use volmap::gpu::{GpuMapper, Tiling};
use volmap::io::embedded;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::{AxisLetter, Machine};

use super::common::{all_five_axis_chains, gpu, ranges, with_random_errors, Rng};
use AxisLetter::*;

/// Maps `grid` on the GPU with at most `chunk_points` per chunk; returns the field (line order)
/// and the number of chunks.
fn gpu_field(
    machine: &Machine,
    grid: &Grid,
    chunk_points: Option<u64>,
) -> Option<(Vec<f32>, usize)> {
    Some(field_with(gpu()?, machine, grid, chunk_points))
}

fn field_with(
    gpu: &GpuMapper,
    machine: &Machine,
    grid: &Grid,
    chunk_points: Option<u64>,
) -> (Vec<f32>, usize) {
    let mut field = Vec::new();
    let mut chunks = 0;
    let mut next_line = 0;
    gpu.run(
        machine,
        grid,
        chunk_points,
        |first, lines, data| -> Result<(), volmap::gpu::GpuError> {
            assert_eq!(first, next_line, "chunks arrive in line order");
            next_line += lines;
            field.extend_from_slice(&data[..(lines as usize * CHANNELS.len() * grid.dims[0])]);
            chunks += 1;
            Ok(())
        },
    )
    .expect("GPU map");
    assert_eq!(next_line, grid.lines());
    (field, chunks)
}

/// The largest VE and OE differences between a GPU field and the reference at every point, each
/// over its tolerance at that point (at most 1 where the field holds the rule).
fn max_differences(machine: &Machine, grid: &Grid, field: &[f32]) -> (f64, f64) {
    let twin = volmap::reference::Twin::of(machine);
    let nx = grid.dims[0];
    let (mut ve, mut oe) = (0.0f64, 0.0f64);
    for line in 0..grid.lines() as usize {
        let base = line * CHANNELS.len() * nx;
        for i in 0..nx {
            let want = volmap::engine::reference::point_values(
                &twin,
                grid,
                grid.indices((line * nx + i) as u64),
            );
            let d = |c: std::ops::Range<usize>| -> f64 {
                c.map(|c| (field[base + c * nx + i] as f64 - want[c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let norm = |c: std::ops::Range<usize>| c.map(|c| want[c] * want[c]).sum::<f64>().sqrt();
            oe = oe.max(d(0..3) / oe_tolerance_rad(norm(0..3)));
            ve = ve.max(d(3..6) / ve_tolerance_mm(norm(3..6)));
        }
    }
    (ve, oe)
}

fn assert_matches_reference(machine: &Machine, grid: &Grid) {
    let Some((field, _)) = gpu_field(machine, grid, None) else {
        return;
    };
    assert_field_matches_reference(machine, grid, &field);
}

fn assert_field_matches_reference(machine: &Machine, grid: &Grid, field: &[f32]) {
    let (ve, oe) = max_differences(machine, grid, field);
    eprintln!(
        "{}: max |ΔVE| {ve:.2} and max |ΔOE| {oe:.2} of their tolerances",
        machine.name
    );
    assert!(
        ve <= 1.0,
        "{}: max |ΔVE| {ve} of its tolerance",
        machine.name
    );
    assert!(
        oe <= 1.0,
        "{}: max |ΔOE| {oe} of its tolerance",
        machine.name
    );
}

#[test]
fn embedded_machines_match_the_reference() {
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::embedded(name).unwrap().unwrap();
        let poses: Vec<[f64; 6]> = match name {
            "5axis-hwang2014" => vec![
                [0.0; 6],
                [0.0, 0.0, 0.0, 0.0, 45.0, 30.0],
                [0.0, 0.0, 0.0, 0.0, -110.0, 359.0],
            ],
            "4axis-hwang2014" => vec![[0.0; 6], [0.0, 0.0, 0.0, 0.0, 0.0, 137.5]],
            _ => vec![[0.0; 6]],
        };
        for pose in poses {
            let grid = Grid::full_travel(&machine, [17, 13, 11], pose).unwrap();
            assert_matches_reference(&machine, &grid);
        }
    }
}

#[test]
fn two_metre_workspace_with_every_error_kind() {
    // Travels of 2 m, nominal offsets of up to 200 mm, every component and location error, all
    // interpolation kinds, periodic rotary tables: the case the deviation form exists for.
    let mut rng = Rng::new(2026);
    for chain in ["FYXCFZB", "FXYZFAC", "FFXYZBC", "FBCZYXF"] {
        let letters: Vec<AxisLetter> = volmap::model::Chain::parse(chain).unwrap().axes().collect();
        let machine = with_random_errors(
            Machine::nominal(chain, chain, &ranges(&letters)).unwrap(),
            &mut rng,
        );
        let mut pose = [0.0; 6];
        for &l in &letters {
            if !l.is_linear() {
                pose[l.index()] = rng.uniform(-180.0, 180.0);
            }
        }
        let grid = Grid::full_travel(&machine, [9, 8, 7], pose).unwrap();
        assert_matches_reference(&machine, &grid);
    }
}

#[test]
fn random_chain_orders_match_the_reference() {
    let chains = all_five_axis_chains([X, Y, Z, A, B]);
    let mut rng = Rng::new(99);
    for _ in 0..12 {
        let chain = &chains[(rng.next_u64() % chains.len() as u64) as usize];
        let machine = with_random_errors(
            Machine::nominal(chain, chain, &ranges(&[X, Y, Z, A, B])).unwrap(),
            &mut rng,
        );
        let pose = [
            0.0,
            0.0,
            0.0,
            rng.uniform(-180.0, 180.0),
            rng.uniform(-180.0, 180.0),
            0.0,
        ];
        let grid = Grid::full_travel(&machine, [5, 4, 3], pose).unwrap();
        assert_matches_reference(&machine, &grid);
    }
}

#[test]
fn a_grid_in_many_chunks_equals_one_chunk() {
    let machine = embedded::embedded("5axis-hwang2014").unwrap().unwrap();
    let grid = Grid::full_travel(&machine, [37, 23, 19], [0.0, 0.0, 0.0, 0.0, 20.0, 75.0]).unwrap();
    let Some((whole, one)) = gpu_field(&machine, &grid, None) else {
        return;
    };
    assert_eq!(one, 1);
    // 37 · 5 points per chunk: 88 full chunks and a short last one.
    let (chunked, many) = gpu_field(&machine, &grid, Some(37 * 5)).unwrap();
    assert_eq!(many, (23 * 19usize).div_ceil(5));
    assert_eq!(whole, chunked, "chunking must not change a single value");
    let (ve, oe) = max_differences(&machine, &grid, &chunked);
    assert!(ve <= 1.0 && oe <= 1.0, "{ve} and {oe} of their tolerances");
}

#[test]
fn a_chunk_cap_below_a_line_takes_one_whole_line_per_chunk() {
    // Asked for chunks of 50 points on lines of 100 (or of 1 point), the GPU maps one whole line
    // per chunk, as the CPU does: never a partial line, never a wrong map.
    let machine = embedded::embedded("vmc-li2015").unwrap().unwrap();
    let grid = Grid::full_travel(&machine, [100, 2, 2], [0.0; 6]).unwrap();
    let Some((whole, _)) = gpu_field(&machine, &grid, None) else {
        return;
    };
    for cap in [50, 1] {
        let (field, chunks) = gpu_field(&machine, &grid, Some(cap)).unwrap();
        assert_eq!(chunks, 4, "cap {cap}");
        assert_eq!(field, whole, "cap {cap}");
    }
    assert_field_matches_reference(&machine, &grid, &whole);
}

#[test]
fn more_lines_than_a_dispatch_dimension_holds_run_in_several_chunks() {
    // One workgroup row per line: 70,000 lines exceed the 65,535 workgroups of a dispatch
    // dimension, so the 210,000 points (far below the point budget) need two chunks.
    let machine = embedded::embedded("vmc-li2015").unwrap().unwrap();
    let grid = Grid::full_travel(&machine, [3, 70_000, 1], [0.0; 6]).unwrap();
    let Some(gpu) = gpu() else { return };
    // Random points, and the last lines, which only the second chunk computes.
    let mut checked = volmap::engine::map::sample_points(grid.points() - 300, 3000);
    checked.extend(grid.points() - 300..grid.points());
    let mut captured = Vec::new();
    let mut chunks = 0;
    let nx = grid.dims[0];
    gpu.run(
        &machine,
        &grid,
        None,
        |first, lines, data| -> Result<(), volmap::gpu::GpuError> {
            chunks += 1;
            for &p in checked
                .iter()
                .filter(|&&p| (first..first + lines).contains(&(p / nx as u64)))
            {
                let (line, i) = ((p / nx as u64 - first) as usize, (p % nx as u64) as usize);
                let base = line * CHANNELS.len() * nx + i;
                captured.push(std::array::from_fn::<f32, 6, _>(|c| data[base + c * nx]));
            }
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(chunks, 2);
    assert_eq!(captured.len(), checked.len());
    let result = volmap::engine::map::check_against_reference(&machine, &grid, &checked, &captured);
    assert!(result.passed(), "{result:?}");
}

#[test]
fn error_angles_beyond_the_kernels_range_are_refused() {
    let Some(gpu) = gpu() else { return };
    let mut machine = embedded::embedded("vmc-li2015").unwrap().unwrap();
    // 5° written where radians belong.
    machine.axis_mut(AxisLetter::Y).unwrap().location[5] = 5.0;
    let grid = Grid::full_travel(&machine, [4, 4, 4], [0.0; 6]).unwrap();
    let error = gpu
        .run(
            &machine,
            &grid,
            None,
            |_, _, _| -> Result<(), volmap::gpu::GpuError> { Ok(()) },
        )
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("below 0.1 rad") && error.contains("the CPU engine has no such limit"),
        "{error}"
    );
}

#[test]
fn every_shape_of_the_point_pass_matches_the_reference() {
    // The point pass is compiled per shape of machine: X's translations and rotations evaluated
    // in the pass (one polynomial piece each) or read from the axis pass's table (several
    // pieces); Pre and Post folded into one or two group tables by j, by k or constant (a rotary
    // axis or Y before X or not); and no X axis at all.
    use volmap::model::{ErrorFunction, Interp, Table};
    let one_piece =
        |scale: f64| ErrorFunction::Poly(vec![scale, scale / 700.0, -scale / 4.9e5, scale / 3.4e8]);
    let three_node = |scale: f64| {
        ErrorFunction::Table(
            Table::new(
                vec![(0.0, 0.0), (350.0, scale), (700.0, -scale / 2.0)],
                Interp::Quadratic,
                false,
            )
            .unwrap(),
        )
    };
    let pieces = |scale: f64| {
        ErrorFunction::Table(
            Table::new(
                (0..6)
                    .map(|k| (140.0 * k as f64, scale * ((k * 7 % 5) as f64 - 2.0)))
                    .collect(),
                Interp::Cubic,
                false,
            )
            .unwrap(),
        )
    };
    for chain in ["FYXFZ", "FCYXFZ", "FYXCFZ", "FYFZ"] {
        for (translations_inline, rotations_inline) in
            [(true, true), (true, false), (false, true), (false, false)]
        {
            let letters: Vec<AxisLetter> =
                volmap::model::Chain::parse(chain).unwrap().axes().collect();
            let travels: Vec<(AxisLetter, [f64; 2])> = letters
                .iter()
                .map(|&l| {
                    (
                        l,
                        if l.is_linear() {
                            [0.0, 700.0]
                        } else {
                            [0.0, 360.0]
                        },
                    )
                })
                .collect();
            let mut machine = Machine::nominal("shape", chain, &travels).unwrap();
            machine.tool_offset_mm = [0.0, 0.0, -120.0];
            if let Some(x) = machine.axis_mut(X) {
                for n in 0..3 {
                    x.components[n] = Some(if translations_inline {
                        if n == 0 {
                            one_piece(0.01)
                        } else {
                            three_node(0.008)
                        }
                    } else {
                        pieces(0.006)
                    });
                    x.components[3 + n] = Some(if rotations_inline {
                        one_piece(3e-5)
                    } else {
                        pieces(2e-5)
                    });
                }
            }
            if let Some(y) = machine.axis_mut(Y) {
                y.components[1] = Some(pieces(0.004));
                y.location[5] = 1.5e-5;
            }
            let pose = [0.0, 0.0, 0.0, 0.0, 0.0, 30.0];
            // Without X the grid is one point deep along it.
            let nx = if machine.axis(X).is_some() { 23 } else { 1 };
            let grid = Grid::full_travel(&machine, [nx, 7, 5], pose).unwrap();
            assert_matches_reference(&machine, &grid);
        }
    }
}

#[test]
fn every_tiling_of_the_point_pass_matches_the_reference() {
    // Each invocation takes 1, 2 or 4 lines and a run of points along them. 37 points and 35
    // lines leave short runs and incomplete groups of lines at the ends of every chunk, and a
    // chunk of 37·9 points starts mid-group.
    if gpu().is_none() {
        return;
    }
    let mut gpu = GpuMapper::open().unwrap().expect("an adapter");
    let machine = embedded::embedded("5axis-hwang2014").unwrap().unwrap();
    let grid = Grid::full_travel(&machine, [37, 7, 5], [0.0, 0.0, 0.0, 0.0, -35.0, 210.0]).unwrap();
    for (points_per_lane, lines_per_lane) in
        [(64, 4), (64, 2), (64, 1), (32, 1), (8, 2), (3, 4), (1, 1)]
    {
        gpu.set_tiling(Tiling {
            points_per_lane,
            lines_per_lane,
        })
        .unwrap();
        for chunk_points in [None, Some(37 * 9)] {
            let (field, _) = field_with(&gpu, &machine, &grid, chunk_points);
            eprint!(
                "{points_per_lane} points × {lines_per_lane} lines, chunks of {chunk_points:?}: "
            );
            assert_field_matches_reference(&machine, &grid, &field);
        }
    }
    // The folded kernel of a machine whose X reads Y (X alone varies along a line: lines per
    // invocation as the tiling says) and of one whose Y reads X (one line an invocation), with
    // the tiling of a hardware GPU too (a line split among invocations).
    let gantry = embedded::embedded("gantry-2m").unwrap().unwrap();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/machines/gantry-2m.toml"
    ))
    .unwrap()
    .replace("of = [\"Y\", \"Z\"]", "of = [\"X\", \"Y\"]");
    let sagging = Machine::from_toml(&text, "gantry.toml", None).unwrap();
    for (points_per_lane, lines_per_lane) in [(64, 4), (8, 2), (3, 4), (1, 1)] {
        gpu.set_tiling(Tiling {
            points_per_lane,
            lines_per_lane,
        })
        .unwrap();
        for machine in [&gantry, &sagging] {
            let grid = Grid::full_travel(machine, [37, 7, 5], [0.0; 6]).unwrap();
            for chunk_points in [None, Some(37 * 9)] {
                let (field, _) = field_with(&gpu, machine, &grid, chunk_points);
                eprint!("{} {points_per_lane} × {lines_per_lane}: ", machine.name);
                assert_field_matches_reference(machine, &grid, &field);
            }
        }
    }
    for lines_per_lane in [0, 3, 8] {
        let error = gpu
            .set_tiling(Tiling {
                points_per_lane: 64,
                lines_per_lane,
            })
            .unwrap_err()
            .to_string();
        assert!(error.contains("no point pass takes"), "{error}");
    }
}

#[test]
fn an_x_table_shorter_than_the_grid_holds_its_end_values() {
    // One polynomial piece over [100, 500] mm while the grid runs from 0 to 700 mm: beyond the
    // table the end values hold, which the point pass's polynomials in the grid index cannot
    // express, so X's errors come from the axis pass's table there.
    use volmap::model::{ErrorFunction, Interp, Table};
    let short = |scale: f64| {
        ErrorFunction::Table(
            Table::new(
                vec![(100.0, scale), (300.0, -scale), (500.0, scale / 2.0)],
                Interp::Quadratic,
                false,
            )
            .unwrap(),
        )
    };
    let travels = [(X, [0.0, 700.0]), (Y, [0.0, 400.0]), (Z, [0.0, 300.0])];
    let mut machine = Machine::nominal("short X tables", "FYXFZ", &travels).unwrap();
    machine.tool_offset_mm = [0.0, 0.0, -90.0];
    let x = machine.axis_mut(X).unwrap();
    x.components[1] = Some(short(0.01));
    x.components[5] = Some(short(4e-5));
    let grid = Grid::full_travel(&machine, [29, 5, 4], [0.0; 6]).unwrap();
    assert_matches_reference(&machine, &grid);
}
