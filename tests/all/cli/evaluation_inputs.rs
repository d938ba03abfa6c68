//! Evaluation inputs on the command line (`--temperatures`, `--approach`): `map`, `sample`,
//! `features`, `budget`; fields that record them and readers that refuse other ones.

use std::path::{Path, PathBuf};

use predicates::prelude::*;
use volmap::io::field::FieldReader;
use volmap::model::channels::CHANNELS;
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::reference::Twin;

use super::volmap;
use crate::field_inputs::THERMAL_MACHINE;

fn manifest(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Maps the machine file `machine` on the CPU with `extra` flags into `out`.
fn map(machine: &Path, out: &Path, extra: &[&str]) {
    volmap()
        .args(["map", "--device", "cpu", "--grid", "5x4x3", "--machine"])
        .arg(machine)
        .args(extra)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
}

/// The values of a single-part field at grid point `(i, j, k)`, channels in field order.
fn field_values(path: &Path, ijk: [usize; 3]) -> ([f64; 3], [f32; 6]) {
    let mut reader = FieldReader::open(path).unwrap();
    let info = reader.info().clone();
    let [nx, ny, _] = info.dims;
    let mut line = vec![0.0f32; CHANNELS.len() * nx];
    reader
        .read_line((ijk[1] + ijk[2] * ny) as u64, &mut line)
        .unwrap();
    let command = info.grid().command(ijk);
    (
        [command[0], command[1], command[2]],
        std::array::from_fn(|c| line[c * nx + ijk[0]]),
    )
}

/// VE from a field's channels (`OE.X OE.Y OE.Z VE.X VE.Y VE.Z`).
fn ve(values: [f32; 6]) -> [f64; 3] {
    let index = |name: &str| CHANNELS.iter().position(|c| *c == name).unwrap();
    ["VE.X", "VE.Y", "VE.Z"].map(|n| values[index(n)] as f64)
}

#[test]
fn a_map_at_inputs_holds_the_machine_at_them_and_info_prints_them() {
    let dir = tempfile::tempdir().unwrap();
    let machine_path = write(dir.path(), "thermal.toml", THERMAL_MACHINE);
    let machine = Machine::from_path(&machine_path).unwrap();
    let cold = dir.path().join("cold.exr");
    let warm = dir.path().join("warm.exr");
    map(&machine_path, &cold, &[]);
    map(
        &machine_path,
        &warm,
        &[
            "--temperatures",
            "x_scale=25,spindle=30",
            "--approach",
            "Y=-",
        ],
    );
    let inputs = Inputs::parse("x_scale=25,spindle=30", "Y=-", &machine).unwrap();
    let twin = Twin::of(&machine.at(&inputs));
    for ijk in [[0, 0, 0], [4, 3, 2], [2, 1, 1], [3, 2, 0]] {
        let (at, warm_values) = field_values(&warm, ijk);
        let (_, cold_values) = field_values(&cold, ijk);
        let want = twin
            .deviation(&[at[0], at[1], at[2], 0.0, 0.0, 0.0])
            .volumetric_mm;
        let (warm_ve, cold_ve) = (ve(warm_values), ve(cold_values));
        // The field is the reference of the machine at the inputs ...
        for d in 0..3 {
            assert!(
                (warm_ve[d] - want[d]).abs() < 1e-7,
                "{ijk:?}: {warm_ve:?} vs {want:?}"
            );
        }
        // ... and differs from the map at the default inputs by the scale's expansion
        // α·x·ΔT along X, Y's 4 µm backlash and the spindle's growth c·ΔT along Z (the machine's
        // 1e-5 rad angles turn these by less than 1e-6 mm).
        let delta = [11.5e-6 * at[0] * 5.0, 0.004, -0.0015 * 10.0];
        for d in 0..3 {
            assert!(
                (warm_ve[d] - cold_ve[d] - delta[d]).abs() < 1e-6,
                "{ijk:?} axis {d}: {warm_ve:?} - {cold_ve:?} vs {delta:?}"
            );
        }
    }
    volmap().arg("info").arg(&warm).assert().success().stdout(
        predicate::str::contains(
            "inputs      approach X+ Y- Z+; temperatures x_scale=25 °C, spindle=30 °C (reference 20 °C)",
        ),
    );
    volmap()
        .arg("info")
        .arg(&cold)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "approach X+ Y+ Z+; temperatures x_scale=20 °C, spindle=20 °C",
        ));
    // Wherever there is an adapter, the GPU maps the same inputs within the tolerance.
    volmap()
        .args(["map", "--grid", "9x5x3", "--check", "45", "--machine"])
        .arg(&machine_path)
        .args([
            "--temperatures",
            "x_scale=25,spindle=30",
            "--approach",
            "Y=-,X=-",
        ])
        .arg("--out")
        .arg(dir.path().join("auto.exr"))
        .assert()
        .success()
        .stdout(predicate::str::contains(": ok").and(predicate::str::contains("X- Y- Z+")));
}

#[test]
fn sample_exact_takes_the_inputs_and_a_field_must_hold_them() {
    let dir = tempfile::tempdir().unwrap();
    let machine_path = write(dir.path(), "thermal.toml", THERMAL_MACHINE);
    let machine = Machine::from_path(&machine_path).unwrap();
    let points = write(dir.path(), "p.csv", "X,Y,Z\n1500,250,125\n500,1000,0\n");
    let warm = dir.path().join("warm.exr");
    map(
        &machine_path,
        &warm,
        &["--temperatures", "x_scale=25", "--approach", "Y=-"],
    );
    let sample = |args: &[&str]| {
        let output = volmap()
            .arg("sample")
            .args(args)
            .arg("--points")
            .arg(&points)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
            .collect::<Vec<Vec<f64>>>()
    };
    let machine_arg = machine_path.to_str().unwrap();
    let exact = sample(&[
        "--exact",
        "--machine",
        machine_arg,
        "--temperatures",
        "x_scale=25",
        "--approach",
        "Y=-",
    ]);
    let twin = Twin::of(&machine.at(&Inputs::parse("x_scale=25", "Y=-", &machine).unwrap()));
    assert!(!exact.is_empty());
    for row in &exact {
        let d = twin.deviation(&[row[0], row[1], row[2], 0.0, 0.0, 0.0]);
        let want: Vec<f64> = d
            .volumetric_mm
            .iter()
            .chain(d.orientation_rad.iter())
            .copied()
            .collect();
        assert_eq!(&row[3..], &want[..]);
    }
    assert_ne!(
        exact,
        sample(&["--exact", "--machine", machine_arg]),
        "the inputs change the answer"
    );
    // The field holds them at its grid points (these are): the same values in f32.
    let warm_arg = warm.to_str().unwrap();
    let from_field = sample(&[
        "--field",
        warm_arg,
        "--temperatures",
        "x_scale=25",
        "--approach",
        "Y=-",
    ]);
    assert_eq!(exact.len(), from_field.len());
    assert!(!exact.is_empty());
    for (a, b) in exact.iter().zip(&from_field) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-7 * x.abs().max(1.0), "{a:?} vs {b:?}");
        }
    }
    // Asking it for other inputs (the default ones among them) is refused, saying what it holds.
    for args in [
        vec![],
        vec!["--temperatures", "x_scale=25"],
        vec!["--approach", "Y=-", "--temperatures", "x_scale=26"],
    ] {
        volmap()
            .args(["sample", "--field", warm_arg])
            .args(&args)
            .arg("--points")
            .arg(&points)
            .assert()
            .code(2)
            .stderr(
                predicate::str::contains("--field")
                    .and(predicate::str::contains(
                        "holds the field computed at approach X+ Y- Z+; temperatures x_scale=25 °C, spindle=20 °C",
                    ))
                    .and(predicate::str::contains(
                        "hint: --approach X=+,Y=-,Z=+ --temperatures x_scale=25,spindle=20",
                    )),
            );
    }
    // Beside a file written with --out, standard output says what the answer was computed for.
    let out = dir.path().join("answer.csv");
    for (source, said) in [
        (vec!["--exact", "--machine", machine_arg], "exactly for"),
        (vec!["--field", warm_arg], "from "),
    ] {
        volmap()
            .arg("sample")
            .args(&source)
            .args(["--temperatures", "x_scale=25", "--approach", "Y=-"])
            .arg("--points")
            .arg(&points)
            .arg("--out")
            .arg(&out)
            .assert()
            .success()
            .stdout(
                predicate::str::contains("2 position(s) sampled")
                    .and(predicate::str::contains(said))
                    .and(predicate::str::contains(
                        "at approach X+ Y- Z+; temperatures x_scale=25 °C, spindle=20 °C",
                    )),
            );
        assert!(std::fs::read_to_string(&out)
            .unwrap()
            .starts_with("X,Y,Z,VE.X"));
    }
}

#[test]
fn a_multi_part_field_records_its_inputs_in_every_part() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "5axis-hwang2014",
            "--device",
            "cpu",
            "--grid",
            "3x3x2",
            "--poses",
            "B=0:30:30",
            "--approach",
            "X=-,C=-",
            "--out",
        ])
        .arg(&sweep)
        .assert()
        .success();
    volmap()
        .arg("info")
        .arg(&sweep)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "inputs      approach Y+ X- C- Z+ B+",
        ));
    let points = write(dir.path(), "p.csv", "X,Y,Z,B,C\n400,300,250,30,0\n");
    volmap()
        .args(["sample", "--field"])
        .arg(&sweep)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "(part B=0,C=0) holds the field computed at approach Y+ X- C- Z+ B+",
        ));
    volmap()
        .args(["sample", "--approach", "C=-,X=-", "--field"])
        .arg(&sweep)
        .arg("--points")
        .arg(&points)
        .assert()
        .success();
}

/// A part with a floor and a rib, on a machine whose spindle grows with its temperature and
/// whose X guideway bows with the hall's.
const FEATURE_MACHINE: &str = r#"
name = "warm gantry"
chain = "FFXYZ"
[thermal]
inputs = ["spindle", "hall"]
[axes.X]
range = [0.0, 400.0]
EZX = { value = 0.0, per_kelvin = { hall = { table = [[0, 0.0], [200, 0.001], [400, 0.0]], interp = "quadratic" } } }
[axes.Y]
range = [0.0, 300.0]
[axes.Z]
range = [-100.0, 100.0]
[spindle]
EZS = { value = 0.0, per_kelvin = { spindle = -0.0015 } }
"#;

const FEATURE_PART: &str = r#"
name = "floor and rib"
[placement]
zero_mm = [0.0, 0.0, 0.0]
[cutter]
radius_mm = 5.0
length_mm = 40.0
[sampling]
spacing_mm = 5.0
[[features]]
kind = "end_milled_plane"
name = "floor"
corner_mm = [0.0, 0.0, -10.0]
size_mm = [400.0, 100.0]
tolerance_mm = 0.05
[[features]]
kind = "rib_height"
name = "rib"
corner_mm = [100.0, 150.0, 0.0]
size_mm = [50.0, 4.0]
tolerance_mm = 0.05
"#;

/// The error of each feature, from `volmap features ... --json`.
fn feature_errors(dir: &Path, args: &[&str]) -> Vec<f64> {
    let json = dir.join("rows.json");
    let part = write(dir, "part.toml", FEATURE_PART);
    let output = volmap()
        .arg("features")
        .args(args)
        .arg("--part")
        .arg(&part)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let rows: serde_json::Value = super::json_result(&json);
    rows.as_array()
        .unwrap()
        .iter()
        .map(|r| r["error_mm"].as_f64().unwrap())
        .collect()
}

#[test]
fn features_take_the_inputs_of_the_machine_and_of_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let machine = write(dir.path(), "warm.toml", FEATURE_MACHINE);
    let m = machine.to_str().unwrap();
    let close = |got: f64, want: f64, what: &str| {
        assert!((got - want).abs() < 1e-9, "{what}: {got} vs {want}");
    };
    let cold = feature_errors(dir.path(), &["--machine", m]);
    close(cold[0], 0.0, "floor at 20 °C");
    close(cold[1], 0.0, "rib at 20 °C");
    // The spindle 10 K warm grows 15 µm towards the work: the rib comes out 15 µm low, the floor
    // is lowered alike and stays flat.
    let spindle = feature_errors(
        dir.path(),
        &["--machine", m, "--temperatures", "spindle=30"],
    );
    close(spindle[0], 0.0, "floor, warm spindle");
    close(spindle[1], 0.015, "rib, warm spindle");
    // The hall 10 K warm bows X by 10 µm mid-travel: the floor's flatness is the bow's height.
    let hall = feature_errors(dir.path(), &["--machine", m, "--temperatures", "hall=30"]);
    close(hall[0], 0.010, "floor, warm hall");

    // A field mapped at the warm spindle answers for it, and for nothing else.
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--device",
            "cpu",
            "--grid",
            "41x31x21",
            "--temperatures",
            "spindle=30",
            "--machine",
            m,
            "--out",
        ])
        .arg(&field)
        .assert()
        .success();
    let f = field.to_str().unwrap();
    let from_field = feature_errors(dir.path(), &["--field", f, "--temperatures", "spindle=30"]);
    assert!((from_field[1] - 0.015).abs() < 1e-6, "{from_field:?}");
    assert!(from_field[0] < 1e-6, "{from_field:?}");
    volmap()
        .args(["features", "--field", f, "--part"])
        .arg(dir.path().join("part.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--field").and(predicate::str::contains(
            "holds the field computed at approach X+ Y+ Z+; temperatures spindle=30 °C, hall=20 °C",
        )));
}

#[test]
fn budget_draws_machines_around_the_machine_at_the_inputs() {
    let tolerances = manifest("examples/tolerances/gantry-2m.toml");
    let run = |extra: &[&str]| {
        let output = volmap()
            .args([
                "budget",
                "--machine",
                "gantry-2m",
                "--device",
                "cpu",
                "--grid",
                "5x4x3",
                "--samples",
                "16",
                "--tolerances",
            ])
            .arg(&tolerances)
            .args(extra)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout).unwrap()
    };
    let cold = run(&[]);
    let warm = run(&["--temperatures", "x_scale=25,hall=22", "--approach", "Y=-"]);
    assert!(
        warm.contains("around the machine at approach X+ Y- Z+; temperatures x_scale=25 °C"),
        "{warm}"
    );
    // The budget's ideal machine has no errors for the inputs to change; the machines drawn
    // around the warm one are further out (α·3000 mm·5 K = 0.17 mm along X alone).
    let budget = |text: &str| {
        text.lines()
            .take_while(|l| !l.starts_with("Monte Carlo"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(budget(&cold), budget(&warm));
    let mean_max_ve = |text: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with("max |VE| µm"))
            .unwrap();
        line.split_whitespace().nth(3).unwrap().parse().unwrap()
    };
    assert!(
        mean_max_ve(&warm) > mean_max_ve(&cold) + 100.0,
        "{cold}\n{warm}"
    );
}

#[test]
fn bad_inputs_exit_2_naming_the_flag_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let points = write(dir.path(), "p.csv", "X,Y,Z\n100,100,100\n");
    let part = write(dir.path(), "part.toml", FEATURE_PART);
    let field = dir.path().join("f.exr");
    map(&manifest("machines/gantry-2m.toml"), &field, &[]);
    let tolerances = manifest("examples/tolerances/gantry-2m.toml");
    let commands: Vec<Vec<String>> = vec![
        vec![
            "map".into(),
            "--device".into(),
            "cpu".into(),
            "--out".into(),
            dir.path().join("x.exr").display().to_string(),
        ],
        vec![
            "sample".into(),
            "--exact".into(),
            "--points".into(),
            points.display().to_string(),
        ],
        vec![
            "sample".into(),
            "--points".into(),
            points.display().to_string(),
            "--field".into(),
            field.display().to_string(),
        ],
        vec![
            "features".into(),
            "--part".into(),
            part.display().to_string(),
        ],
        vec![
            "features".into(),
            "--part".into(),
            part.display().to_string(),
            "--field".into(),
            field.display().to_string(),
        ],
        vec![
            "budget".into(),
            "--device".into(),
            "cpu".into(),
            "--tolerances".into(),
            tolerances.display().to_string(),
        ],
    ];
    for command in &commands {
        let machine: &[&str] = if command.contains(&"--field".to_string()) {
            &[]
        } else {
            &["--machine", "gantry-2m"]
        };
        for (flag, value, message) in [
            (
                "--temperatures",
                "bench=25",
                "`bench` is not a thermal input",
            ),
            (
                "--temperatures",
                "hall=warm",
                "`hall=warm`: the temperature",
            ),
            ("--temperatures", "hall=20,hall=21", "`hall` is given twice"),
            ("--approach", "W=-", "`W` is not an axis"),
            ("--approach", "X=up", "the approach direction is + or -"),
            ("--approach", "X", "expected NAME=VALUE"),
        ] {
            volmap()
                .args(command)
                .args(machine)
                .args([flag, value])
                .assert()
                .code(2)
                .stderr(
                    predicate::str::contains(format!("error: {flag}: "))
                        .and(predicate::str::contains(message)),
                );
        }
    }
}
