//! `map --uncertainty`: the standard uncertainty of every channel at every grid point, on the GPU
//! (sums on the device) and the CPU engine, against values derived by hand from the chain, the
//! f64 reference's propagation at every point, and Monte Carlo against first order; the part of
//! uncertainties in the field file and its readers.

use volmap::engine::map::{ve_tolerance_mm, MapOptions};
use volmap::engine::uncertainty::{numerical_tolerance, UncertaintyMethod};
use volmap::engine::{map, Engine};
use volmap::io::field::FieldFile;
use volmap::model::grid::Grid;
use volmap::model::Machine;
use volmap::reference::Propagation;

/// A 3-axis FYXFZ machine (X-Y table under a Z head, tool 100 mm below the spindle) with `x`
/// and `y` in its axes' sections and `rest` at the end of the file.
fn vmc(x: &str, y: &str, rest: &str) -> Machine {
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n{x}\n[axes.Y]\nrange = [0.0, 400.0]\n{y}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n{rest}\n"
    );
    Machine::from_toml(&text, "u.toml", None).unwrap()
}

fn grid(dims: [usize; 3]) -> Grid {
    Grid {
        dims,
        origin_mm: [0.0; 3],
        spacing_mm: [500.0, 400.0, 300.0].map(|s| s / 8.0),
        pose: [0.0; 6],
    }
}

/// The engines at hand: the CPU engine always, the GPU where an adapter exists.
fn engines() -> Vec<Engine> {
    let mut engines = vec![Engine::Cpu];
    if crate::common::gpu().is_some() {
        let (gpu, _) = Engine::select(volmap::engine::DeviceChoice::Gpu).unwrap();
        engines.push(gpu);
    }
    engines
}

/// Maps `machine` with its uncertainty by `method` into a temporary file and reads back both
/// parts: per point (in point order) the values and the uncertainties, channel order.
fn mapped(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    method: UncertaintyMethod,
) -> (Vec<[f32; 6]>, Vec<[f32; 6]>) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("u.exr");
    let options = MapOptions {
        uncertainty: Some(method),
        ..MapOptions::default()
    };
    map::map_to_file(machine, grid, engine, &out, &options, |_| {}).unwrap();
    let file = FieldFile::open(&out).unwrap();
    assert!(!file.is_multipart(), "a map of one pose is no sweep");
    assert_eq!(file.parts(), 1, "one part of errors");
    assert_eq!(
        file.uncertainty(0).map(String::from),
        Some(method.describe())
    );
    let read = |mut reader: volmap::io::field::FieldReader| {
        let nx = grid.dims[0];
        let mut points = Vec::new();
        reader
            .for_each_chunk(1 << 16, |_, _, data| {
                for line in data.chunks_exact(6 * nx) {
                    points.extend((0..nx).map(|i| std::array::from_fn(|c| line[c * nx + i])));
                }
            })
            .unwrap();
        points
    };
    let values = read(file.reader(0).unwrap());
    let u = read(file.uncertainty_reader(0).unwrap().unwrap());
    assert_eq!(values.len() as u64, grid.points());
    assert_eq!(u.len() as u64, grid.points());
    (values, u)
}

/// On FYXFZ the tip is `x·x̂ + Rz(EC0Y)·(y·ŷ + (z + tool)·ẑ)`: `VE.x = −y·sin EC0Y`, so to first
/// order `u(VE.x) = |y|·cos(EC0Y)·u`, `u(VE.y) = |y|·sin(EC0Y)·u`, `u(VE.z) = 0`, and the tool
/// turns by EC0Y about z: `u(OE.z) = u`. At every grid point, on every engine.
#[test]
fn a_squareness_maps_to_y_times_u_at_every_point() {
    let (c, u): (f64, f64) = (1.8e-5, 2.0e-6);
    let machine = vmc("", &format!("EC0Y = {{ value = {c:e}, u = {u:e} }}"), "");
    let grid = grid([5, 9, 3]);
    for engine in engines() {
        let (values, got) = mapped(&machine, &grid, &engine, UncertaintyMethod::FirstOrder);
        assert_eq!(got.len(), 5 * 9 * 3);
        for (p, (v, g)) in values.iter().zip(&got).enumerate() {
            let y = grid.command(grid.indices(p as u64))[1];
            let ve = (v[3] as f64).hypot(v[4] as f64).hypot(v[5] as f64);
            // The field's values round to f32: the tolerance of the map's check.
            let tol = ve_tolerance_mm(ve);
            let want = [y * c.cos() * u, y * c.sin() * u, 0.0];
            for k in 0..3 {
                let d = (g[3 + k] as f64 - want[k]).abs();
                assert!(
                    d <= tol,
                    "{} point {p} y {y}: u(VE) {g:?} vs {want:?}",
                    engine.name()
                );
            }
            assert!(
                (g[2] as f64 - u).abs() <= 1e-9,
                "{}: u(OE.z) {}",
                engine.name(),
                g[2]
            );
            assert!(g[0].abs() < 1e-12 && g[1].abs() < 1e-12, "{g:?}");
        }
    }
}

/// `VE.x = EXX(x)` on FYXFZ: a linear table with per-node u gives `sqrt((1−t)²u_i² +
/// t²u_{i+1}²)` between nodes, and with `u_scale` the correlated part `u_scale·(x − q0)` adds in
/// quadrature. Grid points at x = 0, 62.5, …, 500 fall between the nodes 0, 200, 400.
#[test]
fn a_tables_node_and_scale_uncertainties_map_as_derived() {
    let (u0, u1, u2, s) = (1e-3, 3e-3, 2e-3, 4e-6);
    let machine = vmc(
        &format!(
            "EXX = {{ table = [[0, 0.0], [200, 0.01], [400, 0.02]], u = [{u0:e}, {u1:e}, {u2:e}], u_scale = {s:e} }}"
        ),
        "",
        "",
    );
    let grid = grid([9, 2, 2]);
    for engine in engines() {
        let (values, got) = mapped(&machine, &grid, &engine, UncertaintyMethod::FirstOrder);
        assert_eq!(got.len(), 9 * 2 * 2);
        for (p, (v, g)) in values.iter().zip(&got).enumerate() {
            let x = grid.command(grid.indices(p as u64))[0];
            let (nodes, t) = if x <= 200.0 {
                ((u0, u1), x / 200.0)
            } else if x <= 400.0 {
                ((u1, u2), (x - 200.0) / 200.0)
            } else {
                ((u2, u2), 1.0)
            };
            let nodes2 = ((1.0 - t) * nodes.0).powi(2) + (t * nodes.1).powi(2);
            let scale = s * x.min(400.0);
            let want = (nodes2 + scale * scale).sqrt();
            let tol = ve_tolerance_mm((v[3] as f64).abs());
            assert!(
                (g[3] as f64 - want).abs() <= tol,
                "{} x {x}: {} vs {want}",
                engine.name(),
                g[3]
            );
        }
    }
}

/// A machine with uncertain values of every kind (angles and lengths, a table with its scale,
/// a correlated pair): at every grid point the map's first-order uncertainty equals the f64
/// reference's own propagation (central differences with h = u, the covariance written out)
/// within the map's tolerance, on every engine; and Monte Carlo on the engine agrees with
/// first order within four of its standard errors, `u/√(2(N − 1))`.
#[test]
fn every_engine_propagates_as_the_reference_and_monte_carlo_agrees() {
    let machine = vmc(
        "EXX = { table = [[0, 0.0], [200, 0.01], [400, 0.02]], u = [1e-3, 3e-3, 2e-3], u_scale = 2e-6 }\n\
         EBX = { value = 1e-5, u = 3e-6 }",
        "EC0Y = { value = 1.8e-5, u = 2e-6 }\nEA0Y = { value = 1e-5, u = 1e-6 }",
        "[spindle]\nEXS = { value = 0.0, u = 1e-3 }\n[covariance]\n\"axes.Y.EC0Y spindle.EXS\" = -1e-9\n",
    );
    let grid = grid([4, 3, 3]);
    let propagation = Propagation::new(&machine);
    let draws = 4000;
    for engine in engines() {
        let (values, got) = mapped(&machine, &grid, &engine, UncertaintyMethod::FirstOrder);
        let (_, mc) = mapped(
            &machine,
            &grid,
            &engine,
            UncertaintyMethod::MonteCarlo { draws, seed: 7 },
        );
        assert_eq!(got.len(), 36);
        assert_eq!(mc.len(), 36);
        for p in 0..got.len() {
            let command = grid.command(grid.indices(p as u64));
            let want = propagation.first_order(&command);
            let ve = (values[p][3] as f64)
                .hypot(values[p][4] as f64)
                .hypot(values[p][5] as f64);
            for k in 0..3 {
                // Channel order (OE, VE) against the reference's (VE, OE).
                let d = (got[p][3 + k] as f64 - want[k]).abs();
                assert!(
                    d <= ve_tolerance_mm(ve),
                    "{} p {p}: {:?} vs {want:?}",
                    engine.name(),
                    got[p]
                );
                let d = (got[p][k] as f64 - want[3 + k]).abs();
                assert!(
                    d <= 1e-9,
                    "{} p {p}: {:?} vs {want:?}",
                    engine.name(),
                    got[p]
                );
                let se = want[k] / (2.0 * (draws as f64 - 1.0)).sqrt();
                let d = (mc[p][3 + k] as f64 - want[k]).abs();
                assert!(
                    d <= 4.0 * se + 1e-9,
                    "{} p {p} VE {k}: MC {} vs {}",
                    engine.name(),
                    mc[p][3 + k],
                    want[k]
                );
            }
        }
    }
}

/// The GPU's and the CPU engine's Monte Carlo draw the same machines (a draw is a function of
/// the seed, the draw and the quantity): the two maps agree to the f32 rounding of the fields,
/// far closer than Monte Carlo's own spread.
#[test]
fn monte_carlo_draws_the_same_machines_on_every_engine() {
    let Some(_) = crate::common::gpu() else {
        return;
    };
    let machine = vmc(
        "EBX = { value = 1e-5, u = 3e-6 }",
        "EC0Y = { value = 1.8e-5, u = 2e-6 }",
        "",
    );
    let grid = grid([3, 3, 3]);
    let method = UncertaintyMethod::MonteCarlo {
        draws: 300,
        seed: 3,
    };
    let engines = engines();
    assert_eq!(engines.len(), 2, "the CPU engine and the GPU");
    let (values, cpu) = mapped(&machine, &grid, &engines[0], method);
    let (_, gpu) = mapped(&machine, &grid, &engines[1], method);
    assert_eq!(cpu.len(), gpu.len());
    for p in 0..cpu.len() {
        let ve = (values[p][3] as f64)
            .hypot(values[p][4] as f64)
            .hypot(values[p][5] as f64);
        for c in 3..6 {
            let d = (cpu[p][c] as f64 - gpu[p][c] as f64).abs();
            assert!(d <= ve_tolerance_mm(ve), "p {p} c {c}: {cpu:?} vs {gpu:?}");
        }
    }
}

/// JCGM 101 §7.9.4: the numerical tolerance of a value to two significant digits is half a
/// unit of its second digit (u = 3.2e-3 → 0.05e-3).
#[test]
fn the_numerical_tolerance_is_half_a_unit_of_the_second_digit() {
    assert!((numerical_tolerance(3.2e-3) - 0.5e-4).abs() < 1e-18);
    assert!((numerical_tolerance(12.0) - 0.5).abs() < 1e-12);
    assert!((numerical_tolerance(0.99e-6) - 0.5e-8).abs() < 1e-20);
    assert!(numerical_tolerance(0.0).is_infinite());
}
