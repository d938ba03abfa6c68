//! `volmap test` at a pose of a work-side rotary axis, and measured positions rounded past the
//! ends.

use predicates::prelude::*;

use super::volmap;

/// FYXCFZB with one error: the positioning error of X, EXX = 2e-5·X.
const SCALE_OF_X_TOML: &str = r#"
name = "five-axis, scale of X"
chain = "FYXCFZB"
[tool]
offset = [0.0, 0.0, -250.0]
[axes.X]
range = [0.0, 800.0]
EXX = { poly = [0.0, 2.0e-5] }
[axes.Y]
range = [0.0, 600.0]
[axes.Z]
range = [0.0, 500.0]
[axes.B]
range = [-110.0, 110.0]
[axes.C]
range = [0.0, 360.0]
offset = [0.0, 0.0, 150.0]
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
fn positioning_at_c_90_reads_the_positioning_error_of_x() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("m.toml");
    std::fs::write(&machine, SCALE_OF_X_TOML).unwrap();
    let json = dir.path().join("x.json");
    // The laser along the tool's motion reads 2e-5·X: E = 2e-5·800 at every pose of C.
    for pose in ["C=0", "C=90", "C=135"] {
        volmap()
            .args(["test", "positioning", "--axis", "X", "--at", "0,0,200"])
            .args(["--targets", "5", "--pose", pose, "--machine"])
            .arg(&machine)
            .arg("--json")
            .arg(&json)
            .assert()
            .success();
        assert!(
            (figure(&json, "E") - 2.0e-5 * 800.0).abs() < 1e-12,
            "{pose}"
        );
    }
}

#[test]
fn a_diagonal_rounded_past_its_end_is_read_to_its_end() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("m.toml");
    std::fs::write(&machine, SCALE_OF_X_TOML).unwrap();
    // PPP over 800 × 600 × 500 mm: √1 250 000 = 1118.033989 mm, written as 1118.034.
    let csv = dir.path().join("d.csv");
    let run = |text: &str| {
        std::fs::write(&csv, text).unwrap();
        let mut command = volmap();
        command
            .args(["test", "diagonal", "--diagonal", "PPP", "--machine"])
            .arg(&machine)
            .arg("--measured")
            .arg(&csv);
        command.assert()
    };
    run("position_mm,deviation_um\n0,0\n500,4\n1118.034,9\n").success();
    run("position_mm,deviation_um\n0,0\n500,4\n1118.036,9\n")
        .code(2)
        .stderr(
            predicate::str::contains("d.csv")
                .and(predicate::str::contains("line 4"))
                .and(predicate::str::contains("off the diagonal"))
                .and(predicate::str::contains("0.001 mm")),
        );
}
