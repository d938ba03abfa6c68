//! Point queries: trilinear sampling of fields and exact values from the model.

use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::io::field::LoadedField;
use volmap::io::points::{parse_points, PointReader};
use volmap::model::grid::Grid;
use volmap::model::{AxisLetter, ErrorFunction, Machine};
use volmap::query::{self, Outside, QueryError};

use super::common::{sampler, Rng};
use AxisLetter::*;

/// A machine whose VE is linear in the commanded position: trilinear interpolation is exact.
fn linear_machine() -> Machine {
    let mut m = Machine::nominal(
        "linear",
        "FFXYZ",
        &[(X, [0.0, 600.0]), (Y, [-200.0, 200.0]), (Z, [0.0, 300.0])],
    )
    .unwrap();
    m.axis_mut(X).unwrap().components[0] = Some(ErrorFunction::Poly(vec![0.001, 2e-5]));
    m.axis_mut(Y).unwrap().components[1] = Some(ErrorFunction::Poly(vec![-0.002, 3e-5]));
    m.axis_mut(Z).unwrap().components[2] = Some(ErrorFunction::Poly(vec![0.0, -1e-5]));
    m
}

fn mapped(
    dir: &std::path::Path,
    machine: &Machine,
    dims: [usize; 3],
    pose: [f64; 6],
) -> std::path::PathBuf {
    let grid = Grid::full_travel(machine, dims, pose).unwrap();
    let path = dir.join("field.exr");
    map::map_to_file(
        machine,
        &grid,
        &Engine::Cpu,
        &path,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    path
}

fn points_csv(points: &[[f64; 3]]) -> String {
    let mut text = String::from("X,Y,Z\n");
    for p in points {
        text.push_str(&format!("{},{},{}\n", p[0], p[1], p[2]));
    }
    text
}

#[test]
fn trilinear_sampling_is_exact_where_the_field_is_trilinear() {
    let dir = tempfile::tempdir().unwrap();
    let machine = linear_machine();
    let field = LoadedField::open(&mapped(dir.path(), &machine, [7, 5, 4], [0.0; 6])).unwrap();
    let mut rng = Rng::new(17);
    let positions: Vec<[f64; 3]> = (0..500)
        .map(|_| {
            [
                rng.uniform(0.0, 600.0),
                rng.uniform(-200.0, 200.0),
                rng.uniform(0.0, 300.0),
            ]
        })
        .chain([[0.0, -200.0, 0.0], [600.0, 200.0, 300.0]])
        .collect();
    let points = parse_points(&points_csv(&positions), "p.csv").unwrap();
    let sampled = query::sample_field(&field, &points, "p.csv").unwrap();
    let exact = query::sample_exact(&machine, &points);
    assert_eq!((sampled.len(), exact.len()), (points.len(), points.len()));
    for ((p, s), e) in points.iter().zip(&sampled).zip(&exact) {
        for c in 0..6 {
            // The field stores f32: equal up to its rounding.
            assert!(
                (s[c] - e[c]).abs() <= 1e-7 * e[c].abs() + 1e-12,
                "{:?} column {c}: {} vs {}",
                p.command,
                s[c],
                e[c]
            );
        }
    }
    assert!((exact[0][0] - (0.001 + 2e-5 * positions[0][0])).abs() < 1e-12);
}

#[test]
fn grid_nodes_give_the_stored_values_and_midpoints_their_means() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let pose = [0.0, 0.0, 0.0, 0.0, 15.0, 100.0];
    let path = mapped(dir.path(), &machine, [5, 4, 3], pose);
    let field = LoadedField::open(&path).unwrap();
    let grid = field.info.grid();
    let node = |ijk: [usize; 3]| field.sample(&grid.command(ijk)).unwrap();
    let a = node([1, 2, 1]);
    let b = node([2, 2, 1]);
    let mut mid = grid.command([1, 2, 1]);
    mid[0] += grid.spacing_mm[0] / 2.0;
    let m = field.sample(&mid).unwrap();
    for c in 0..6 {
        assert!(
            (m[c] - (a[c] + b[c]) / 2.0).abs() <= 1e-12 + 1e-9 * m[c].abs(),
            "column {c}"
        );
    }
    // Nodes hold what the map wrote: the f32 of the model's value.
    let exact = query::sample_exact(
        &machine,
        &parse_points("X,Y,Z,B,C\n200,400,250,15,100\n", "p.csv").unwrap(),
    );
    let stored = node([1, 2, 1]);
    assert_eq!(grid.command([1, 2, 1])[..3], [200.0, 400.0, 250.0]);
    for c in 0..6 {
        assert_eq!(stored[c], exact[0][c] as f32 as f64, "column {c}");
    }
}

#[test]
fn positions_outside_the_grid_or_the_pose_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let field = LoadedField::open(&mapped(
        dir.path(),
        &machine,
        [4, 4, 4],
        [0.0, 0.0, 0.0, 0.0, 15.0, 100.0],
    ))
    .unwrap();
    let outside = parse_points("X,Y,Z\n10,10,10\n\n800.5,0,0\n", "p.csv").unwrap();
    let error = query::sample_field(&field, &outside, "p.csv").unwrap_err();
    assert!(
        matches!(
            error,
            QueryError::Outside {
                line: 4,
                axis: 'X',
                ..
            }
        ),
        "{error}"
    );
    assert!(
        error.to_string().contains("p.csv: line 4: X=800.5"),
        "{error}"
    );
    let wrong_pose = parse_points("X,Y,Z,B\n10,10,10,15\n10,10,10,20\n", "p.csv").unwrap();
    let error = query::sample_field(&field, &wrong_pose, "p.csv")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("line 3") && error.contains("B=20") && error.contains("B=15"),
        "{error}"
    );
}

#[test]
fn bad_point_files_name_the_line() {
    let cases = [
        ("", "line 1: empty"),
        ("X,Y\n1,2\n", "no column Z"),
        (
            "X,Y,Z,ve.x\n1,2,3,4\n",
            "column `ve.x` is one the answer adds",
        ),
        (
            "X,Y,Z,x\n1,2,3,4\n",
            "column `x` appears twice (columns 1 and 4)",
        ),
        (
            "X,Y,Z,id,id\n1,2,3,a,b\n",
            "column `id` appears twice (columns 4 and 5)",
        ),
        ("id,,X,Y,Z\n1,2,3,4,5\n", "column 2 has no name"),
        ("X,Y,Z\n1,2,3\n4,5\n", "line 3: 2 fields"),
        ("X,Y,Z\n1,2,abc\n", "line 2: `abc` in column Z"),
        ("X,Y,Z\n1,2,nan\n", "not a finite number"),
    ];
    for (text, message) in cases {
        let error = parse_points(text, "pts.csv").unwrap_err().to_string();
        assert!(
            error.contains("pts.csv") && error.contains(message),
            "`{text}`: {error}"
        );
    }
}

/// Random positions within the field's grid, its corners and the middle of its faces included.
fn positions_within(field: &LoadedField, count: usize, rng: &mut Rng) -> Vec<[f64; 3]> {
    let grid = field.info.grid();
    let end = |d: usize| grid.origin_mm[d] + (grid.dims[d] - 1) as f64 * grid.spacing_mm[d];
    let mut positions: Vec<[f64; 3]> = (0..8)
        .map(|c| {
            std::array::from_fn(|d| {
                if c >> d & 1 == 1 {
                    end(d)
                } else {
                    grid.origin_mm[d]
                }
            })
        })
        .collect();
    positions.push(std::array::from_fn(|d| 0.5 * (grid.origin_mm[d] + end(d))));
    positions.extend(
        (0..count).map(|_| std::array::from_fn(|d| rng.uniform(grid.origin_mm[d], end(d)))),
    );
    positions
}

/// The largest difference per column and the largest magnitude of each column.
fn column_differences(
    a: &[volmap::model::channels::Sample],
    b: &[volmap::model::channels::Sample],
) -> ([f64; 6], [f64; 6]) {
    let mut difference = [0.0f64; 6];
    let mut largest = [0.0f64; 6];
    assert_eq!(a.len(), b.len());
    assert!(!a.is_empty());
    for (x, y) in a.iter().zip(b) {
        for c in 0..6 {
            difference[c] = difference[c].max((x[c] - y[c]).abs());
            largest[c] = largest[c].max(x[c].abs());
        }
    }
    (difference, largest)
}

#[test]
fn gpu_sampling_matches_the_cpu() {
    let Some(sampler) = sampler() else { return };
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    for dims in [[9, 7, 6], [5, 4, 1], [1, 6, 3]] {
        let field = LoadedField::open(&mapped(
            dir.path(),
            &machine,
            dims,
            [0.0, 0.0, 0.0, 0.0, 30.0, 60.0],
        ))
        .unwrap();
        let positions = positions_within(&field, 2000, &mut Rng::new(5));
        let points = parse_points(&points_csv(&positions), "p.csv").unwrap();
        let on_cpu = query::sample_field(&field, &points, "p.csv").unwrap();
        let on_gpu = query::sample_field_gpu(&field, &points, "p.csv", sampler).unwrap();
        let (difference, largest) = column_differences(&on_cpu, &on_gpu);
        // An f32 blend of f32 values: a few units of f32 rounding of the largest value.
        for c in 0..6 {
            assert!(
                difference[c] <= 1e-6 * largest[c] + 1e-15,
                "{dims:?}, column {c}: GPU and CPU differ by {} (largest value {})",
                difference[c],
                largest[c]
            );
        }
    }
}

#[test]
fn gpu_sampling_in_slabs_equals_one_slab() {
    let Some(sampler) = sampler() else { return };
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("vmc-li2015").unwrap();
    let field = LoadedField::open(&mapped(dir.path(), &machine, [6, 5, 11], [0.0; 6])).unwrap();
    let positions = positions_within(&field, 3000, &mut Rng::new(9));
    let points = parse_points(&points_csv(&positions), "p.csv").unwrap();
    let located: Vec<_> = points
        .iter()
        .map(|p| field.cell(&p.command).unwrap())
        .collect();
    let dims = field.info.dims;
    let whole = sampler
        .sample(dims, field.values(), &located, None)
        .unwrap();
    let plane_bytes = (dims[0] * dims[1] * 24) as u64;
    // 2 planes (1 cell deep per slab), 3 and 4 planes: slab ends fall at different places.
    for planes in [2, 3, 4] {
        let slabbed = sampler
            .sample(dims, field.values(), &located, Some(planes * plane_bytes))
            .unwrap();
        assert_eq!(whole, slabbed, "slabs of {planes} planes");
    }
    let error = sampler
        .sample(dims, field.values(), &located, Some(plane_bytes))
        .unwrap_err()
        .to_string();
    assert!(error.contains("two z planes"), "{error}");
}

#[test]
fn the_reader_streams_batches_keeping_other_columns_and_either_case() {
    let text =
        "# export\nid, x,y ,Z,b,note\np1,1,2,3,15,first\n\np2, 4.5,5,6,15,\n# c\np3,7,8,9,15,x y\n";
    let mut reader = PointReader::new(text.as_bytes(), "p.csv").unwrap();
    let columns = reader.columns().clone();
    assert_eq!(columns.names, ["id", "x", "y", "Z", "b", "note"]);
    assert_eq!(
        columns.axes,
        [None, Some(X), Some(Y), Some(Z), Some(B), None]
    );
    assert_eq!(columns.given, [true, true, true, false, true, false]);
    let first = reader.next_batch(2).unwrap();
    assert_eq!(first.rows, ["p1,1,2,3,15,first", "p2,4.5,5,6,15,"]);
    assert_eq!(
        first.points.iter().map(|p| p.line).collect::<Vec<_>>(),
        [3, 5]
    );
    assert_eq!(first.points[1].command, [4.5, 5.0, 6.0, 0.0, 15.0, 0.0]);
    let second = reader.next_batch(2).unwrap();
    assert_eq!(second.rows, ["p3,7,8,9,15,x y"]);
    assert_eq!(second.points[0].line, 7);
    assert!(reader.next_batch(2).unwrap().points.is_empty());
    // The batches together are the file read whole.
    let whole = parse_points(text, "p.csv").unwrap();
    assert_eq!(whole, [first.points, second.points].concat());
    // An error in a later batch names its line.
    let mut reader = PointReader::new("X,Y,Z\n1,2,3\n4,5,6\n7,8,q\n".as_bytes(), "p.csv").unwrap();
    assert_eq!(reader.next_batch(2).unwrap().points.len(), 2);
    let error = reader.next_batch(2).unwrap_err().to_string();
    assert!(error.contains("p.csv: line 4: `q` in column Z"), "{error}");
}

#[test]
fn positions_outside_the_grid_are_skipped_or_nan_or_the_first_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let machine = linear_machine();
    let field = LoadedField::open(&mapped(dir.path(), &machine, [3, 3, 3], [0.0; 6])).unwrap();
    let grid = field.info.grid();
    let inside = grid.origin_mm.map(|o| o + 1.0);
    let text = format!(
        "X,Y,Z\n{},{},{}\n-5000,0,0\n0,0,-7000\n",
        inside[0], inside[1], inside[2]
    );
    let points = parse_points(&text, "p.csv").unwrap();
    let within = |outside| query::sample_field_within(&field, &points, "p.csv", outside);
    let error = within(Outside::Error).unwrap_err();
    assert!(
        matches!(
            error,
            QueryError::Outside {
                line: 3,
                axis: 'X',
                ..
            }
        ),
        "{error}"
    );
    let expected = query::sample_field(&field, &points[..1], "p.csv").unwrap()[0];
    assert_eq!(within(Outside::Skip).unwrap(), [Some(expected), None, None]);
    let nan = within(Outside::Nan).unwrap();
    assert_eq!(nan[0], Some(expected));
    assert!(nan[1..]
        .iter()
        .all(|s| s.unwrap().iter().all(|v| v.is_nan())));
    if let Some(sampler) = sampler() {
        let on_gpu =
            query::sample_field_gpu_within(&field, &points, "p.csv", sampler, Outside::Skip)
                .unwrap();
        assert!(on_gpu[0].is_some() && on_gpu[1..] == [None, None]);
        let error =
            query::sample_field_gpu_within(&field, &points, "p.csv", sampler, Outside::Error)
                .unwrap_err();
        assert!(
            matches!(error, QueryError::Outside { line: 3, .. }),
            "{error}"
        );
    }
}
