//! `volmap trace`: the deviation along a program before it cuts, and after compensation.

use predicates::prelude::*;

use super::volmap;

/// A machine whose only error is a scale error of X: the real tip is 1e-4·x ahead in X (every
/// move gets a correction).
pub(super) const SCALE: &str = r#"
name = "scale"
chain = "FFXYZ"
[axes.X]
range = [0.0, 200.0]
EXX = { poly = [0.0, 1.0e-4] }
[axes.Y]
range = [0.0, 200.0]
[axes.Z]
range = [0.0, 200.0]
"#;

#[test]
fn trace_samples_every_move_and_names_the_largest_line() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("scale.toml");
    std::fs::write(&machine, SCALE).unwrap();
    let program = dir.path().join("p.nc");
    // X runs to 50 on line 3: 1e-4 · 50 mm = 5 µm there, the most; back to 20 (2 µm) on line 4.
    std::fs::write(
        &program,
        "G90 G0 X0 Y10. Z10.\nG1 X10. F500\nX50.\nX20.\nG2 X30. Y20. I10. J0\n",
    )
    .unwrap();
    let (csv, plot, json) = (
        dir.path().join("trace.csv"),
        dir.path().join("trace.png"),
        dir.path().join("trace.json"),
    );
    volmap()
        .args(["trace", "--machine"])
        .arg(&machine)
        .arg("--program")
        .arg(&program)
        .args(["--compensate", "--step", "1", "--out"])
        .arg(&csv)
        .arg("--plot")
        .arg(&plot)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "as-programmed  largest 5.000 µm along the feed moves at line 3",
        ));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut rows = text.lines();
    assert_eq!(
        rows.next().unwrap(),
        "program,line,motion,distance_mm,x_mm,y_mm,z_mm,deviation_mm"
    );
    let rows: Vec<Vec<&str>> = rows.map(|r| r.split(',').collect()).collect();
    let before: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == "as-programmed").collect();
    // Every sample's deviation is 1e-4 · x (to the CSV's 9 decimals), and line 3 is sampled every
    // mm from X10 to X50.
    let line3 = before.iter().filter(|r| r[1] == "3").count();
    assert_eq!(line3, 40);
    assert!(before.iter().any(|r| r[1] == "5" && r[2] == "G2"));
    for r in &before {
        let (x, deviation): (f64, f64) = (r[4].parse().unwrap(), r[7].parse().unwrap());
        assert!((deviation - 1e-4 * x).abs() < 1e-9, "{r:?}");
    }
    // Compensated, a straight move is exact but for the rounding of its written X (4 decimals:
    // 5e-5 mm, which the scale error stretches by 1 + 1e-4) and the CSV's 9 decimals; the arc,
    // an ellipse under a scale error of X, is held within the chord tolerance (1 µm) plus the
    // rounding of X and Y. (Measured: 5e-7 mm on the straight moves, 0.41 µm on the arc.)
    let rounding_mm = 5e-5 * (1.0 + 1e-4) + 5e-10;
    let after: Vec<(&str, f64)> = rows
        .iter()
        .filter(|r| r[0] == "compensated")
        .map(|r| (r[1], r[7].parse().unwrap()))
        .collect();
    let (arc, straight): (Vec<_>, Vec<_>) = after.iter().partition(|(line, _)| *line == "5");
    assert!(!arc.is_empty() && !straight.is_empty(), "{after:?}");
    assert!(
        straight.iter().all(|&&(_, d)| d <= rounding_mm),
        "{straight:?}"
    );
    let arc_bound_mm = 1e-3 + 2f64.sqrt() * rounding_mm;
    assert!(arc.iter().all(|&&(_, d)| d <= arc_bound_mm), "{arc:?}");
    let summary: serde_json::Value = super::json_result(&json);
    assert_eq!(summary[0]["largest_line"], 3);
    // The figure covers the feed moves; the rapid to the start (no deviation at X0) apart.
    assert_eq!(summary[0]["covers"], "feed moves (G1 G2 G3)");
    assert_eq!(summary[0]["largest_rapid_mm"], 0.0);
    assert_eq!(summary[0]["per_block"].as_array().unwrap().len(), 5);
    let png = std::fs::read(&plot).unwrap();
    assert_eq!(&png[..4], b"\x89PNG");
    // A bad program: exit 2, naming the line.
    std::fs::write(&program, "G0 X10 Y10 Z10\nG2 X20 Y20\n").unwrap();
    volmap()
        .args(["trace", "--machine"])
        .arg(&machine)
        .arg("--program")
        .arg(&program)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2"));
}

/// `trace --compensate` and `compensate` report the same "after" for the same program: the feed
/// moves of the program as written, measured from the intended point at the same fraction of the
/// move. On the Dobariya, Patel and Jani test piece each feed move is one written piece, sampled
/// at the same fractions by both (every 0.5 mm), so the figures agree to the last bits (1e-12);
/// the rapids, which the control does not hold, are apart in both.
#[test]
fn trace_and_compensate_report_the_same_after_over_the_feed_moves() {
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine = root.join("examples/dobariya2015/machine.toml");
    let program = root.join("examples/dobariya2015/test-piece.nc");
    let (traced, report) = (
        dir.path().join("trace.json"),
        dir.path().join("report.json"),
    );
    volmap()
        .args(["trace", "--machine"])
        .arg(&machine)
        .arg("--program")
        .arg(&program)
        .args(["--work-offset", "G54=0,0,10", "--compensate", "--json"])
        .arg(&traced)
        .assert()
        .success()
        .stdout(predicate::str::contains("µm along the feed moves at line"));
    volmap()
        .args(["compensate", "--machine"])
        .arg(&machine)
        .arg("--program")
        .arg(&program)
        .args(["--work-offset", "G54=0,0,10", "--out"])
        .arg(dir.path().join("out.nc"))
        .arg("--json")
        .arg(&report)
        .assert()
        .success()
        .stdout(predicate::str::contains("along the feed moves"));
    let read = |p: &std::path::Path| -> serde_json::Value { super::json_result(p) };
    let (traced, report) = (read(&traced), read(&report));
    assert_eq!(report["errors_cover"], "feed moves (G1 G2 G3)");
    assert_eq!(traced[1]["covers"], "feed moves (G1 G2 G3)");
    let after = report["largest_error_after_mm"].as_f64().unwrap();
    let compensated = traced[1]["largest_mm"].as_f64().unwrap();
    assert!((after - compensated).abs() < 1e-12, "{after} {compensated}");
    let before = report["largest_error_before_mm"].as_f64().unwrap();
    let programmed = traced[0]["largest_mm"].as_f64().unwrap();
    assert!((before - programmed).abs() < 1e-12, "{before} {programmed}");
    // Both within the 1 µm chord tolerance, from 0.49 mm (the paper's Table 3 over the piece).
    assert!(after <= 1e-3 && before > 0.4, "{after} {before}");
}
