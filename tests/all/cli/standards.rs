//! `volmap test`, `fit` and `build`.

use predicates::prelude::*;

use super::volmap;

#[test]
fn standard_tests_print_figures_compare_measurements_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    volmap()
        .args(["test", "positioning", "--axis", "X", "--targets", "6"])
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
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["positions"].as_array().unwrap().len(), 36);
    assert_eq!(report["figures"][0]["name"], "G");
    // Bad input: exit code 2 with the reason; nothing written.
    volmap()
        .args(["test", "diagonal", "--from", "0,0,0", "--to", "2000,0,0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("outside the travel of X"));
    volmap()
        .args(["test", "circular", "--plane", "XY", "--plot"])
        .arg(dir.path().join("c.gif"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains(".svg or .png"));
    volmap()
        .args(["test", "rtest", "--axis", "C"])
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
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("xy.json")).unwrap())
            .unwrap();
    let mut text = String::from("angle_deg,deviation_mm\n");
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
