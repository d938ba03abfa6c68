//! `volmap test`, `fit` and `build`.

use std::time::Duration;

use predicates::prelude::*;

use super::{assert_finite_svg, s, volmap};

#[test]
fn standard_tests_print_figures_compare_measurements_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    volmap()
        .args([
            "test",
            "positioning",
            "--machine",
            "vmc-li2015",
            "--axis",
            "X",
            "--targets",
            "6",
        ])
        .assert()
        .success()
        .stdout(
            predicate::str::contains("ISO 230-2 positioning of X (6 targets, 5 runs each way)")
                .and(predicate::str::contains("A↑"))
                .and(predicate::str::contains(
                    "mean bidirectional positioning error",
                )),
        );
    // A measured circle: predicted and measured side by side, both plots and the JSON.
    let measured = dir.path().join("xy.csv");
    let mut text = String::from("angle_deg,deviation_um\n");
    for i in 0..36 {
        text += &format!("{},{}\n", 10 * i, (i as f64 / 3.0).sin());
    }
    std::fs::write(&measured, text).unwrap();
    let (svg, png, json) = (
        dir.path().join("c.svg"),
        dir.path().join("c.png"),
        dir.path().join("c.json"),
    );
    volmap()
        .args([
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--radius",
            "100",
            "--measured",
        ])
        .arg(&measured)
        .arg("--plot")
        .arg(&svg)
        .arg("--plot")
        .arg(&png)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("measured µm")
                .and(predicate::str::contains("largest |measured − predicted|"))
                .and(predicate::str::contains("circular deviation")),
        );
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("radial deviation, measured"));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let report: serde_json::Value = super::json_result(&json);
    assert_eq!(report["positions"].as_array().unwrap().len(), 36);
    assert_eq!(report["figures"][0]["name"], "G");
    // Bad input: exit code 2 with the reason; nothing written.
    volmap()
        .args([
            "test",
            "diagonal",
            "--machine",
            "vmc-li2015",
            "--from",
            "0,0,0",
            "--to",
            "2000,0,0",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("outside the travel of X"));
    volmap()
        .args([
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--plot",
        ])
        .arg(dir.path().join("c.gif"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains(".svg or .png"));
    volmap()
        .args(["test", "rtest", "--machine", "vmc-li2015", "--axis", "C"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("has no C axis"));
}

#[test]
fn build_and_fit_write_machine_files_that_map() {
    let dir = tempfile::tempdir().unwrap();
    let x = dir.path().join("x.csv");
    std::fs::write(
        &x,
        "position_mm,EXX_um,EBX_urad\n0,0,0\n250,3,1\n500,5,1.5\n750,6,1\n1000,6.5,0\n",
    )
    .unwrap();
    let built = dir.path().join("built.toml");
    volmap()
        .args(["build", "--base", "vmc-li2015", "--axis"])
        .arg(format!("X={}", x.display()))
        .arg("--out")
        .arg(&built)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("EXX").and(predicate::str::contains("best at leave-one-out")),
        );
    volmap()
        .args(["map", "--grid", "4x3x3", "--device", "cpu", "--machine"])
        .arg(&built)
        .arg("--out")
        .arg(dir.path().join("built.exr"))
        .assert()
        .success();
    // A circle measured on the built machine, fitted for the XY squareness.
    let circle = dir.path().join("xy.csv");
    let output = volmap()
        .args([
            "test", "circular", "--plane", "XY", "--points", "24", "--json",
        ])
        .arg(dir.path().join("xy.json"))
        .arg("--machine")
        .arg(&built)
        .output()
        .unwrap();
    assert!(output.status.success());
    let report: serde_json::Value = super::json_result(dir.path().join("xy.json"));
    let mut text = String::from("angle_deg,deviation_mm\n");
    assert_eq!(
        report["positions"].as_array().unwrap().len(),
        report["predicted"][0].as_array().unwrap().len()
    );
    for (a, r) in report["positions"]
        .as_array()
        .unwrap()
        .iter()
        .zip(report["predicted"][0].as_array().unwrap())
    {
        text += &format!("{},{}\n", a, r);
    }
    std::fs::write(&circle, text).unwrap();
    let measurements = dir.path().join("fit.toml");
    std::fs::write(
        &measurements,
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 24\ncsv = \"xy.csv\"\n",
    )
    .unwrap();
    let fitted = dir.path().join("fitted.toml");
    volmap()
        .args(["fit", "--machine", "vmc-li2015", "--measurements"])
        .arg(&measurements)
        .arg("--out")
        .arg(&fitted)
        .assert()
        .success()
        .stdout(predicate::str::contains("EC0Y").and(predicate::str::contains("uncertainty")));
    volmap()
        .args(["info"])
        .arg(dir.path().join("built.exr"))
        .assert()
        .success();
    assert!(volmap::model::Machine::from_path(&fitted).is_ok());
    volmap()
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "Q=x.csv",
            "--out",
        ])
        .arg(dir.path().join("never.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("AXIS=FILE.csv"));
    assert!(!dir.path().join("never.toml").exists());
}

/// A three-axis machine with a backlash of 4 µm on X and a thermal X scale.
const BACKLASH_TOML: &str = r#"
name = "backlash"
chain = "FYXFZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale", "hall"]
[axes.X]
range = [-400.0, 400.0]
EXX = { value = 0.0, reverse = 0.004, per_kelvin = { x_scale = { poly = [0.0, 1.0e-5] } } }
[axes.Y]
range = [-300.0, 300.0]
[axes.Z]
range = [-250.0, 250.0]
"#;

fn figure(json: &std::path::Path, name: &str) -> f64 {
    let report = super::json_result(json);
    report["figures"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == name)
        .unwrap()["predicted_mm"]
        .as_f64()
        .unwrap()
}

#[test]
fn test_takes_temperatures_and_the_approach_of_axes_it_does_not_move() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("backlash.toml");
    std::fs::write(&machine, BACKLASH_TOML).unwrap();
    let json = dir.path().join("x.json");
    // B is the backlash; at x_scale = 30 °C the scale adds 1e-5·10 per mm over 800 mm to E.
    volmap()
        .args(["test", "positioning", "--axis", "X", "--machine"])
        .arg(&machine)
        .args(["--temperatures", "x_scale=30", "--approach", "Z=-", "--json"])
        .arg(&json)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "inputs: approach X from the run (+ for ↑, − for ↓), Y+ Z-; temperatures x_scale=30 °C, hall=20 °C (reference 20 °C)",
        ));
    assert!((figure(&json, "B") - 0.004).abs() < 1e-12);
    assert!((figure(&json, "E") - (0.004 + 1e-4 * 800.0)).abs() < 1e-12);
    // The path decides the direction of the axes the test moves.
    volmap()
        .args([
            "test",
            "positioning",
            "--axis",
            "X",
            "--approach",
            "X=-",
            "--machine",
        ])
        .arg(&machine)
        .assert()
        .success()
        .stderr(predicate::str::contains("--approach X: the test moves X"));
    // Bad inputs: exit code 2 naming the flag.
    volmap()
        .args([
            "test",
            "circular",
            "--plane",
            "XY",
            "--temperatures",
            "lobby=22",
            "--machine",
        ])
        .arg(&machine)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--temperatures").and(predicate::str::contains("lobby")));
    volmap()
        .args([
            "test",
            "diagonal",
            "--diagonal",
            "PPP",
            "--approach",
            "C=-",
            "--machine",
        ])
        .arg(&machine)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--approach").and(predicate::str::contains("`C`")));
}

#[test]
fn fit_estimates_a_thermal_coefficient_and_writes_it() {
    let dir = tempfile::tempdir().unwrap();
    let given = dir.path().join("given.toml");
    std::fs::write(&given, BACKLASH_TOML).unwrap();
    // The truth: EC0Y = 10 µrad + 2 µrad/K·(hall − 20).
    let truth = dir.path().join("truth.toml");
    std::fs::write(
        &truth,
        BACKLASH_TOML.replace(
            "range = [-300.0, 300.0]",
            "range = [-300.0, 300.0]\nEC0Y = { value = 1.0e-5, per_kelvin = { hall = 2.0e-6 } }",
        ),
    )
    .unwrap();
    let mut fit = String::from("estimate = [\"EC0Y\", \"EC0Y.per_kelvin.hall\"]\n");
    for hall in [18, 24] {
        let json = dir.path().join(format!("xy{hall}.json"));
        volmap()
            .args([
                "test",
                "circular",
                "--plane",
                "XY",
                "--points",
                "36",
                "--machine",
            ])
            .arg(&truth)
            .arg("--temperatures")
            .arg(format!("hall={hall}"))
            .arg("--json")
            .arg(&json)
            .assert()
            .success();
        let report: serde_json::Value = super::json_result(&json);
        let mut text = String::from("angle_deg,deviation_mm\n");
        assert_eq!(
            report["positions"].as_array().unwrap().len(),
            report["predicted"][0].as_array().unwrap().len()
        );
        for (a, r) in report["positions"]
            .as_array()
            .unwrap()
            .iter()
            .zip(report["predicted"][0].as_array().unwrap())
        {
            text += &format!("{a},{r}\n");
        }
        std::fs::write(dir.path().join(format!("xy{hall}.csv")), text).unwrap();
        fit += &format!(
            "[[circular]]\nplane = \"XY\"\npoints = 36\ncsv = \"xy{hall}.csv\"\ntemperatures = {{ hall = {hall} }}\n"
        );
    }
    let measurements = dir.path().join("fit.toml");
    std::fs::write(&measurements, &fit).unwrap();
    let fitted = dir.path().join("fitted.toml");
    volmap()
        .args(["fit", "--measurements"])
        .arg(&measurements)
        .arg("--machine")
        .arg(&given)
        .arg("--out")
        .arg(&fitted)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("EC0Y.per_kelvin.hall").and(predicate::str::contains("rad/K")),
        );
    let machine = volmap::model::Machine::from_path(&fitted).unwrap();
    let inputs = volmap::model::inputs::Inputs::parse("hall=30", "", &machine).unwrap();
    // Exact measurements: the fit lands on the truth, 10 + 2·10 µrad at 30 °C.
    let ec0y = machine
        .at(&inputs)
        .axis(volmap::model::AxisLetter::Y)
        .unwrap()
        .location[5];
    assert!((ec0y - 3.0e-5).abs() < 1e-9, "{ec0y}");
    // The reversal and thermal terms of X are kept.
    assert_eq!(machine.dependent.len(), 2);
    // A test measured at an input the machine does not declare.
    std::fs::write(&measurements, fit.replace("hall = 24", "lobby = 24")).unwrap();
    volmap()
        .args(["fit", "--measurements"])
        .arg(&measurements)
        .arg("--machine")
        .arg(&given)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("fit.toml").and(predicate::str::contains(
                "[[circular]] number 2, temperatures.lobby",
            )),
        );
}

/// Leave-one-out over every node in constant time per node: 200,000 measured positions build
/// (in the time the quadratic scheme took for about a thousand).
#[test]
fn build_reads_hundreds_of_thousands_of_rows() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("position_mm,EXX_um,EBX_urad\n");
    let n = 200_000;
    for k in 0..n {
        let q = 1000.0 * k as f64 / (n - 1) as f64;
        text += &format!("{q:.6},{:.6},{:.6}\n", (q / 80.0).sin(), (q / 130.0).cos());
    }
    std::fs::write(dir.path().join("x.csv"), text).unwrap();
    volmap()
        .current_dir(dir.path())
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--out",
            "b.toml",
        ])
        .timeout(Duration::from_secs(300))
        .assert()
        .success()
        .stdout(predicate::str::contains("EXX   200000").and(predicate::str::contains("cubic")));
}

#[test]
fn test_plots_of_extreme_finite_measurements_are_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let measured = dir.path().join("d.csv");
    std::fs::write(
        &measured,
        "position_mm,deviation_mm\n0,0\n5e-324,5e-324\n1e-323,1e-323\n",
    )
    .unwrap();
    let (svg, png) = (dir.path().join("d.svg"), dir.path().join("d.png"));
    volmap()
        .args([
            "test",
            "diagonal",
            "--machine",
            "vmc-li2015",
            "--diagonal",
            "PPP",
        ])
        .args([
            "--measured",
            s(&measured),
            "--plot",
            s(&svg),
            "--plot",
            s(&png),
        ])
        .assert()
        .success();
    assert_finite_svg(&svg);
    assert!(png.exists());
    // An R-test measured file with a sweep of 20° and values from subnormal to 1e9 mm.
    let rtest = dir.path().join("r.csv");
    std::fs::write(
        &rtest,
        "angle_deg,dX_mm,dY_mm,dZ_mm\n270,0,0,0\n280,1e9,-1e9,5e-324\n290,0,0,1e-320\n",
    )
    .unwrap();
    let args = [
        "test",
        "rtest",
        "--machine",
        "5axis-hwang2014",
        "--axis",
        "C",
    ];
    volmap()
        .args(args)
        .args([
            "--sphere",
            "200,0,100",
            "--measured",
            s(&rtest),
            "--plot",
            s(&svg),
        ])
        .assert()
        .success();
    assert_finite_svg(&svg);
    // Beyond any measurement: the file and line named, not a plot of infinities.
    std::fs::write(
        &rtest,
        "angle_deg,dX_mm,dY_mm,dZ_mm\n270,0,0,0\n280,1e308,-1e308,0\n290,0,0,0\n",
    )
    .unwrap();
    let output = volmap()
        .args(args)
        .args([
            "--sphere",
            "200,0,100",
            "--measured",
            s(&rtest),
            "--plot",
            s(&svg),
        ])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("r.csv") && stderr.contains("line 3"),
        "{stderr}"
    );
}

#[test]
fn a_long_test_prints_its_figures_and_the_rows_on_request() {
    let run = |table: bool| -> String {
        let mut cmd = volmap();
        cmd.args([
            "test",
            "circular",
            "--plane",
            "xy",
            "--machine",
            "vmc-li2015",
        ]);
        if table {
            cmd.arg("--table");
        }
        let out = cmd.assert().success();
        String::from_utf8(out.get_output().stdout.clone()).unwrap()
    };
    // A circle every degree: 360 points, the figures and the diagnostics without the rows.
    let short = run(false);
    assert!(
        short.contains("  360 points: --table prints them, --json writes them\n"),
        "{short}"
    );
    assert!(short.contains("G ") && short.contains("ballbar diagnostics"));
    let row =
        |l: &&str| l.trim_start().starts_with(|c: char| c.is_ascii_digit()) && l.contains(" | ");
    assert_eq!(short.lines().filter(row).count(), 0, "{short}");
    let long = run(true);
    assert_eq!(long.lines().filter(row).count(), 360);
    assert!(!long.contains("--table prints them"));
    // A short test keeps its rows: positioning of X at 5 per metre.
    let out = volmap()
        .args([
            "test",
            "positioning",
            "--axis",
            "X",
            "--machine",
            "vmc-li2015",
        ])
        .assert()
        .success();
    let text = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    assert!(text.lines().filter(row).count() >= 5, "{text}");
}
