//! The model real machines need (docs/model.md): errors of other axes' positions (`of`, `table2d`),
//! sums, reversal and thermal terms, against cases derived by hand; every bad machine file for
//! them named by file and key.

use volmap::engine::{DeviceChoice, Engine};
use volmap::io::machine_file::MachineError;
use volmap::model::grid::Grid;
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::reference::Twin;

use super::common::gpu;

/// A gantry with X, Y and Z on the tool side (FFXYZ), no offsets and no tool length: every
/// error of the tool-side chain at the base orientation moves the tip by itself.
fn gantry(errors: &str) -> Machine {
    let text = format!(
        r#"
name = "gantry"
chain = "FFXYZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale", "spindle", "hall"]
[axes.X]
range = [0.0, 2000.0]
{x}
[axes.Y]
range = [0.0, 1500.0]
{y}
[axes.Z]
range = [0.0, 800.0]
{z}
[spindle]
{s}
"#,
        x = section(errors, "X"),
        y = section(errors, "Y"),
        z = section(errors, "Z"),
        s = section(errors, "S"),
    );
    Machine::from_toml(&text, "gantry.toml", None).unwrap()
}

/// The lines of `errors` that start with `K:`, without the prefix.
fn section(errors: &str, key: &str) -> String {
    errors
        .lines()
        .filter_map(|l| l.trim().strip_prefix(&format!("{key}:")))
        .map(|l| format!("{}\n", l.trim()))
        .collect()
}

fn inputs(machine: &Machine, temperatures: &str, approach: &str) -> Inputs {
    Inputs::parse(temperatures, approach, machine).unwrap()
}

/// VE at a command of the machine at the inputs.
fn ve(machine: &Machine, inputs: &Inputs, command: [f64; 6]) -> [f64; 3] {
    let d = Twin::of(&machine.at(inputs)).deviation(&command);
    d.volumetric_mm.into()
}

fn close(a: [f64; 3], b: [f64; 3], what: &str) {
    for d in 0..3 {
        assert!((a[d] - b[d]).abs() < 1e-12, "{what}: {a:?} vs {b:?}");
    }
}

#[test]
fn a_scales_expansion_is_alpha_q_delta_t_along_x() {
    let m =
        gantry("X: EXX = { value = 0.0, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }");
    let at = [1500.0, 300.0, 100.0, 0.0, 0.0, 0.0];
    close(
        ve(&m, &inputs(&m, "", ""), at),
        [0.0; 3],
        "at the reference temperature",
    );
    let warm = inputs(&m, "x_scale=24.5", "");
    close(
        ve(&m, &warm, at),
        [11.5e-6 * 1500.0 * 4.5, 0.0, 0.0],
        "4.5 K warmer",
    );
    // Another input leaves it alone.
    close(
        ve(&m, &inputs(&m, "hall=30", ""), at),
        [0.0; 3],
        "another input",
    );
}

#[test]
fn spindle_growth_moves_the_tip_along_z_by_c_delta_t() {
    let m = gantry("S: EZS = { value = 0.0, per_kelvin = { spindle = -0.0015 } }");
    let t = inputs(&m, "spindle=31", "");
    close(
        ve(&m, &t, [100.0, 200.0, 300.0, 0.0, 0.0, 0.0]),
        [0.0, 0.0, -0.0015 * 11.0],
        "spindle",
    );
    assert_eq!(m.at(&t).spindle[2], -0.0015 * 11.0);
}

#[test]
fn a_sag_of_another_axis_follows_that_axis() {
    // The cross-rail (X) sags as the ram (Z) extends: EZX = k·Z².
    let m = gantry("X: EZX = { poly = [0.0, 0.0, -2.0e-8], of = \"Z\" }");
    let none = Inputs::default();
    for (x, z) in [(0.0, 0.0), (700.0, 400.0), (2000.0, 800.0)] {
        close(
            ve(&m, &none, [x, 100.0, z, 0.0, 0.0, 0.0]),
            [0.0, 0.0, -2.0e-8 * z * z],
            "sag",
        );
    }
    assert!(m.has_cross_axis_errors());
}

#[test]
fn a_two_axis_table_at_its_nodes_and_between_them() {
    let m = gantry(
        "Y: EZY = { table2d = { of = [\"X\", \"Y\"], x = [0.0, 1000.0, 2000.0], y = [0.0, 1500.0], values = [[0.0, 0.002], [0.004, 0.010], [0.0, 0.006]] } }",
    );
    let none = Inputs::default();
    let z = |x: f64, y: f64| ve(&m, &none, [x, y, 0.0, 0.0, 0.0, 0.0])[2];
    assert!((z(1000.0, 1500.0) - 0.010).abs() < 1e-15);
    assert!((z(2000.0, 0.0) - 0.0).abs() < 1e-15);
    assert!((z(500.0, 750.0) - (0.0 + 0.002 + 0.004 + 0.010) / 4.0).abs() < 1e-15);
    assert!((z(1500.0, 1500.0) - 0.008).abs() < 1e-15);
}

#[test]
fn backlash_is_the_reverse_value_while_the_axis_approaches_negative() {
    let m = gantry("X: EXX = { poly = [0.0, 1.0e-5], reverse = { poly = [0.004, 1.0e-5] } }");
    let at = [500.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    close(
        ve(&m, &inputs(&m, "", "X=+"), at),
        [0.005, 0.0, 0.0],
        "approaching +",
    );
    close(
        ve(&m, &inputs(&m, "", "X=-"), at),
        [0.009, 0.0, 0.0],
        "approaching −",
    );
    // Another axis's direction does not matter.
    close(
        ve(&m, &inputs(&m, "", "Y=-"), at),
        [0.005, 0.0, 0.0],
        "Y approaching −",
    );
}

#[test]
fn a_sum_is_the_sum_of_its_forms() {
    let m = gantry(
        "Y: EXY = { sum = [0.001, { poly = [0.0, 2.0e-6] }, { table = [[0, 0.0], [800, 0.004]], of = \"Z\" }] }",
    );
    let none = Inputs::default();
    close(
        ve(&m, &none, [0.0, 1000.0, 400.0, 0.0, 0.0, 0.0]),
        [0.001 + 0.002 + 0.002, 0.0, 0.0],
        "sum",
    );
}

#[test]
fn the_general_form_combines_reverse_and_thermal_terms_of_other_axes() {
    let m = gantry(
        "Z: EZZ = { value = { poly = [0.0, 1.0e-5] }, reverse = { poly = [0.002, 1.0e-5] }, per_kelvin = { hall = { poly = [0.0, 1.0e-6], of = \"X\" } } }",
    );
    let t = inputs(&m, "hall=25", "Z=-");
    let v = ve(&m, &t, [1000.0, 0.0, 200.0, 0.0, 0.0, 0.0]);
    close(
        v,
        [0.0, 0.0, 0.002 + 0.002 + 1.0e-6 * 1000.0 * 5.0],
        "general form",
    );
    assert!(m.at(&t).has_cross_axis_errors());
    assert!(
        !m.has_cross_axis_errors(),
        "at the reference temperature the thermal term is 0"
    );
}

/// The largest |ΔVE| and |ΔOE| between an engine's map and the reference at every point.
fn worst_against_reference(engine: &Engine, machine: &Machine, grid: &Grid) -> [f64; 2] {
    let twin = Twin::of(machine);
    let mut worst = [0.0f64; 2];
    engine
        .run(
            machine,
            grid,
            Some(97),
            |first, lines, data| -> Result<(), volmap::gpu::GpuError> {
                let nx = grid.dims[0];
                for l in 0..lines as usize {
                    for i in 0..nx {
                        let line = first as usize + l;
                        let ijk = [i, line % grid.dims[1], line / grid.dims[1]];
                        let d = twin.deviation(&grid.command(ijk));
                        let at = |c: usize| data[l * 6 * nx + c * nx + i] as f64;
                        for c in 0..3 {
                            worst[0] = worst[0].max((at(3 + c) - d.volumetric_mm[c]).abs());
                            worst[1] = worst[1].max((at(c) - d.orientation_rad[c]).abs());
                        }
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    worst
}

/// Every new form at once on a 2 m gantry: a sag of X with Z, a two-axis table, a sum, thermal
/// terms (some of other axes' positions), a backlash.
const EVERY_FORM: &str = "X: EXX = { value = { table = [[0, 0.0], [1000, 0.006], [2000, 0.004]], interp = \"cubic\" }, reverse = { poly = [0.003, 2.0e-6] }, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }
X: EZX = { sum = [{ poly = [0.0, 0.0, -2.0e-8], of = \"Z\" }, { table = [[0, 0.0], [1000, -0.01], [2000, 0.0]], interp = \"quadratic\" }] }
X: EBX = { poly = [1.0e-6, 1.0e-8], of = \"Y\" }
Y: EZY = { table2d = { of = [\"X\", \"Y\"], x = [0.0, 1000.0, 2000.0], y = [0.0, 700.0, 1500.0], values = [[0.0, 0.002, 0.001], [0.004, 0.010, 0.003], [0.0, 0.006, -0.002]] } }
Y: EC0Y = { value = 1.0e-5, per_kelvin = { hall = 2.0e-6 } }
Y: EAY = { value = { poly = [2.0e-6, 1.0e-9] }, per_kelvin = { hall = { poly = [0.0, 1.0e-9], of = \"Z\" } } }
Z: EXZ = { table = [[0, 0.0], [400, 0.003], [800, 0.001]], of = \"X\", interp = \"linear\" }
S: EZS = { value = 0.001, per_kelvin = { spindle = -0.0015 } }";

#[test]
fn the_engines_evaluate_every_form_within_the_tolerances_of_the_reference() {
    let m = gantry(EVERY_FORM);
    let mut engines = vec![Engine::Cpu];
    if gpu().is_some() {
        engines.push(Engine::select(DeviceChoice::Gpu).unwrap().0);
    }
    for engine in &engines {
        for (temperatures, approach) in [
            ("", ""),
            ("x_scale=27,hall=15", "X=-"),
            ("spindle=35,hall=28", "Y=-,X=+,Z=-"),
        ] {
            let machine = m.at(&inputs(&m, temperatures, approach));
            assert!(machine.has_cross_axis_errors());
            let grid = Grid::full_travel(&machine, [13, 9, 7], [0.0; 6]).unwrap();
            let worst = worst_against_reference(engine, &machine, &grid);
            assert!(
                worst[0] < 1e-6 && worst[1] < 1e-9,
                "{} at {temperatures} {approach}: {worst:?}",
                engine.name()
            );
        }
    }
    // Where some axes do not vary along X, the GPU composes them once per line (runs of 64
    // points on a hardware GPU: 70 points make a full run and a partial one): X alone, an error
    // of Y on X (X's part of j added per line to its part of i); X alone with an error of Z too
    // (parts of i, j and k); X alone with a table of X and Y on X (a part of i and j, read per
    // point and line); and X then Y (a table of X and Y) with Z after them.
    let without = |keys: &[&str]| -> String {
        EVERY_FORM
            .lines()
            .filter(|l| !keys.iter().any(|k| l.contains(k)))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let x_and_y_on_x = format!(
        "{}\nX: EYX = {{ table2d = {{ of = [\"X\", \"Y\"], x = [0.0, 2000.0], y = [0.0, 1500.0], values = [[0.0, 0.004], [-0.003, 0.006]] }} }}",
        without(&["EZY", "EXZ"])
    );
    for errors in [
        without(&["EZY", "EXZ", "EZX"]),
        without(&["EZY", "EXZ"]),
        x_and_y_on_x,
        without(&["EXZ"]),
    ] {
        let m = gantry(&errors);
        for engine in &engines {
            let machine = m.at(&inputs(&m, "hall=24,spindle=30", "Y=-"));
            assert!(machine.has_cross_axis_errors());
            let grid = Grid::full_travel(&machine, [70, 5, 4], [0.0; 6]).unwrap();
            let worst = worst_against_reference(engine, &machine, &grid);
            assert!(
                worst[0] < 1e-6 && worst[1] < 1e-9,
                "{} on {errors}: {worst:?}",
                engine.name()
            );
        }
    }
    // Without the cross-axis forms the folded kernel maps the thermal and reversal terms.
    let plain = gantry(
        "X: EXX = { value = { table = [[0, 0.0], [1000, 0.006], [2000, 0.004]], interp = \"cubic\" }, reverse = { poly = [0.003, 2.0e-6] }, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }\nY: EC0Y = { value = 1.0e-5, per_kelvin = { hall = 2.0e-6 } }\nS: EZS = { value = 0.001, per_kelvin = { spindle = -0.0015 } }",
    );
    for engine in &engines {
        let machine = plain.at(&inputs(&plain, "x_scale=27,hall=15", "X=-"));
        assert!(!machine.has_cross_axis_errors());
        let grid = Grid::full_travel(&machine, [9, 7, 5], [0.0; 6]).unwrap();
        let worst = worst_against_reference(engine, &machine, &grid);
        assert!(
            worst[0] < 1e-6 && worst[1] < 1e-9,
            "{}: {worst:?}",
            engine.name()
        );
    }
}

#[test]
fn sampled_machines_with_every_form_at_positions_match_the_reference() {
    let Some(gpu) = gpu() else { return };
    let m = gantry(EVERY_FORM);
    let machine = m.at(&inputs(&m, "hall=26", "Z=-"));
    let commands: Vec<[f64; 6]> = (0..25)
        .map(|n| {
            let f = n as f64 / 24.0;
            [
                2000.0 * f,
                1500.0 * (1.0 - f),
                800.0 * (f * 7.0).fract(),
                0.0,
                0.0,
                0.0,
            ]
        })
        .collect();
    let values = gpu
        .variant_values(&machine, &[], &[vec![]], &commands, |_| {})
        .unwrap();
    let twin = Twin::of(&machine);
    assert_eq!(values.len(), 1);
    assert_eq!(values[0].len(), commands.len());
    for (c, v) in commands.iter().zip(&values[0]) {
        let d = twin.deviation(c);
        for k in 0..3 {
            assert!((v[k] - d.volumetric_mm[k]).abs() < 1e-6, "{c:?}: {v:?}");
            assert!(
                (v[3 + k] - d.orientation_rad[k]).abs() < 1e-9,
                "{c:?}: {v:?}"
            );
        }
    }
}

fn error_of(errors: &str) -> String {
    let text = format!(
        "name = \"g\"\nchain = \"FFXYZ\"\n[thermal]\ninputs = [\"hall\"]\n[axes.X]\nrange = [0.0, 100.0]\n{errors}\n[axes.Y]\nrange = [0.0, 100.0]\n[axes.Z]\nrange = [0.0, 100.0]\n"
    );
    match Machine::from_toml(&text, "bad.toml", None) {
        Ok(_) => panic!("accepted: {errors}"),
        Err(e) => {
            let _: &MachineError = &e;
            e.to_string()
        }
    }
}

#[test]
fn bad_forms_name_the_file_and_the_key() {
    for (errors, key, message) in [
        ("EZX = { poly = [0.0, 1.0], of = \"B\" }", "axes.X.EZX.of", "not an axis of the chain"),
        ("EZX = { value = 0.0, per_kelvin = { spindle = 1e-6 } }", "axes.X.EZX.per_kelvin.spindle", "not a declared thermal input"),
        ("EX0X = { value = 0.001, reverse = 0.002 }", "axes.X.EX0X.reverse", "`reverse` is for component errors"),
        ("EZX = { table2d = { of = [\"X\", \"Z\"], x = [0.0, 1.0], y = [0.0, 1.0], values = [[0.0, 1.0]] } }", "axes.X.EZX.table2d", "rows"),
        ("EZX = { table2d = { of = [\"X\", \"Z\"], x = [1.0, 0.0], y = [0.0, 1.0], values = [[0.0, 1.0], [0.0, 1.0]] } }", "axes.X.EZX.table2d", "increase strictly"),
        ("EZX = { table = [[0, 0.0], [50, 1.0], [20, 0.0]], of = \"Z\" }", "axes.X.EZX", "increase strictly"),
        ("EZX = { value = { value = 0.0 } }", "axes.X.EZX.value.value", "no value, reverse or per_kelvin"),
        ("EZX = { sum = [0.0, { poly = [1.0], per_kelvin = { hall = 1.0 } }] }", "axes.X.EZX.sum[1].per_kelvin", "of its own"),
        ("EZX = { sum = [] }", "axes.X.EZX.sum", "non-empty"),
        ("EZX = { value = 0.0, size = 1 }", "axes.X.EZX.size", "general form"),
        ("EX0X = { poly = [0.0, 1.0] }", "axes.X.EX0X", "location or spindle error is a number"),
    ] {
        let message_got = error_of(errors);
        assert!(
            message_got.contains("bad.toml") && message_got.contains(key) && message_got.contains(message),
            "{errors}: {message_got}"
        );
    }
    let undeclared = Machine::from_toml(
        "name = \"g\"\nchain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 1.0]\nEXX = { value = 0.0, per_kelvin = { hall = 1.0 } }\n[axes.Y]\nrange = [0.0, 1.0]\n[axes.Z]\nrange = [0.0, 1.0]\n",
        "bad.toml",
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(undeclared.contains("no [thermal] section"), "{undeclared}");
}

#[test]
fn bad_evaluation_inputs_are_errors() {
    let m = gantry("");
    for (temperatures, approach, message) in [
        ("oven=30", "", "not a thermal input"),
        ("hall=warm", "", "not a finite number"),
        ("hall", "", "NAME=VALUE"),
        ("", "B=-", "not an axis of this machine"),
        ("", "X=up", "+ or -"),
        ("hall=20,hall=21", "", "twice"),
    ] {
        let e = Inputs::parse(temperatures, approach, &m)
            .unwrap_err()
            .to_string();
        assert!(e.contains(message), "{temperatures} {approach}: {e}");
    }
}
