//! ISO 230-2 positioning of rotary axes against an angle reference, in arc-seconds: the figures
//! of hand-derived angular positioning errors and reversals, on a table and on a head.

use volmap::model::Machine;
use volmap::standards::{self, ErrorUnit, PositioningSpec, Setup};

use super::cli::volmap;

const ARCSEC: f64 = 180.0 * 3600.0 / std::f64::consts::PI;

const TABLE: &str = r#"
name = "table"
chain = "FYXCFZ"
[axes.X]
range = [-200.0, 200.0]
[axes.Y]
range = [-200.0, 200.0]
[axes.C]
range = [0.0, 360.0]
ECC = { poly = [0.0, 2.0e-7], reverse = { poly = [-1.0e-5, 2.0e-7] } }
EXC = 0.004
EAC = { poly = [0.0, 1.0e-7] }
[axes.Z]
range = [-100.0, 100.0]
"#;

fn spec(axis: &str, targets: Option<usize>) -> PositioningSpec {
    PositioningSpec {
        axis: axis.into(),
        targets,
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: None,
    }
}

fn figure(result: &standards::TestResult, name: &str) -> f64 {
    result
        .figures
        .iter()
        .find(|f| f.name == name)
        .unwrap()
        .predicted
}

#[test]
fn a_table_reads_its_angular_positioning_error_and_reversal_in_arcseconds() {
    let machine = Machine::from_toml(TABLE, "table.toml", None).unwrap();
    let setup = Setup::new(&machine, "").unwrap();
    let result = standards::positioning(&setup, &spec("C", None)).unwrap();
    assert_eq!(result.unit, ErrorUnit::Arcsec);
    // Every 30° over 0–360°: 13 targets.
    assert_eq!(result.positions.len(), 13);
    // ↑: ECC = 2e-7·θ rad; ↓: −1e-5 + 2e-7·θ (the tilt EAC and the offset EXC are not about C).
    for (n, &theta) in result.positions.iter().enumerate() {
        let up = 2.0e-7 * theta * ARCSEC;
        let down = (-1.0e-5 + 2.0e-7 * theta) * ARCSEC;
        assert!(
            (result.predicted[0][n] - up).abs() < 1e-6,
            "{theta}: {result:?}"
        );
        assert!((result.predicted[1][n] - down).abs() < 1e-6, "{theta}");
    }
    let close = |name: &str, rad: f64| {
        let value = figure(&result, name);
        assert!((value - rad * ARCSEC).abs() < 1e-6, "{name}: {value}");
    };
    close("E↑", 7.2e-5);
    close("B", 1.0e-5);
    close("E", 8.2e-5);
    close("M", 7.2e-5);
    close("A", 8.2e-5);
    close("R", 1.0e-5);
    let json = serde_json::to_value(&result).unwrap();
    assert_eq!(json["unit"], "arcsec");
    assert!(json["figures"][0]["predicted_arcsec"].is_number(), "{json}");
}

#[test]
fn a_head_reads_its_own_axis_the_same_way_at_any_pose_of_the_table() {
    let text = r#"
name = "head-table"
chain = "FYXCFZB"
[axes.X]
range = [-200.0, 200.0]
[axes.Y]
range = [-200.0, 200.0]
[axes.C]
range = [0.0, 360.0]
[axes.Z]
range = [-100.0, 100.0]
[axes.B]
range = [-90.0, 90.0]
EBB = { poly = [0.0, 1.5e-7] }
ECB = 2.0e-5
"#;
    let machine = Machine::from_toml(text, "head.toml", None).unwrap();
    for pose in ["", "C=90", "C=217"] {
        let setup = Setup::new(&machine, pose).unwrap();
        let result = standards::positioning(&setup, &spec("B", Some(7))).unwrap();
        let first = result.positions[0];
        assert_eq!(result.positions.len(), 7);
        for (n, &theta) in result.positions.iter().enumerate() {
            // Zeroed at the first target, −90°.
            let expected = 1.5e-7 * (theta - first) * ARCSEC;
            assert!(
                (result.predicted[0][n] - expected).abs() < 1e-6,
                "{pose} {theta}: {} against {expected}",
                result.predicted[0][n]
            );
        }
    }
}

#[test]
fn measured_rotary_runs_are_read_in_arcseconds_or_microradians() {
    let dir = tempfile::tempdir().unwrap();
    let machine = Machine::from_toml(TABLE, "table.toml", None).unwrap();
    // Measured as the model predicts, in µrad, plus 1 µrad on every ↓ reading: B grows by it.
    let mut text = String::from("target_deg,direction,run,deviation_urad\n");
    for run in 1..=2 {
        for t in [0.0, 90.0, 180.0, 270.0, 360.0] {
            text += &format!("{t},+,{run},{}\n", 0.2 * t);
        }
        for t in [360.0, 270.0, 180.0, 90.0, 0.0] {
            text += &format!("{t},-,{run},{}\n", -10.0 + 0.2 * t + 1.0);
        }
    }
    let path = dir.path().join("c.csv");
    std::fs::write(&path, &text).unwrap();
    let setup = Setup::new(&machine, "").unwrap();
    let result = standards::positioning(
        &setup,
        &PositioningSpec {
            csv: Some(path.clone()),
            ..spec("C", None)
        },
    )
    .unwrap();
    let b = result.figures.iter().find(|f| f.name == "B").unwrap();
    assert!((b.predicted - 1.0e-5 * ARCSEC).abs() < 1e-6);
    assert!((b.measured.unwrap() - 9.0e-6 * ARCSEC).abs() < 1e-6);
    // The CLI prints arc-seconds; a length column for a rotary axis names what it wants.
    let machine_path = dir.path().join("table.toml");
    std::fs::write(&machine_path, TABLE).unwrap();
    let out = volmap()
        .args(["test", "positioning", "--axis", "C", "--machine"])
        .arg(&machine_path)
        .arg("--measured")
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("predicted µrad") && stdout.contains("target C (deg)"),
        "{stdout}"
    );
    std::fs::write(&path, text.replace("deviation_urad", "deviation_mm")).unwrap();
    volmap()
        .args(["test", "positioning", "--axis", "C", "--machine"])
        .arg(&machine_path)
        .arg("--measured")
        .arg(&path)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("deviation_arcsec"));
}

#[test]
fn the_default_r_test_runs_on_every_rotary_axis_of_every_embedded_machine() {
    // The default sphere: the tip at mid-travel where the linear axes can follow it over the
    // whole sweep, else one nearer the axis (on 5axis-hwang2014's C, whose axis stands at the
    // corner of X and Y's travels, the axis itself).
    for (name, _) in volmap::io::embedded::EMBEDDED {
        let machine = volmap::io::embedded::load(name).unwrap();
        for letter in machine.rotary_axes() {
            let axis = letter.as_char().to_string();
            let out = volmap()
                .args(["test", "rtest", "--machine", name, "--axis", &axis])
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success(),
                "{name} {axis}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            assert!(
                text.contains(&format!("R-test of {axis}: sphere at (")),
                "{text}"
            );
            assert!(!text.contains("-0.0,"), "{text}");
        }
    }
    // A sphere the axes cannot follow: the position to 4 decimals, not 17 digits.
    volmap()
        .args([
            "test",
            "rtest",
            "--machine",
            "5axis-hwang2014",
            "--axis",
            "C",
        ])
        .args(["--sphere", "300,200,150", "--from", "0", "--to", "90"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "R-test of C at C=40°: Y=-39.6274 lies outside the travel of Y (0 to 600)",
        ));
}
