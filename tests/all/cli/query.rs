//! `volmap sample` and `volmap features`: answers from a field or from the model.

use predicates::prelude::*;

use super::volmap;

#[test]
fn sample_from_a_field_and_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "5x5x5",
            "--device",
            "cpu",
            "--out",
        ])
        .arg(&field)
        .assert()
        .success();
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n500,300,250\n0,0,0\n").unwrap();
    let out = dir.path().join("s.csv");
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("X,Y,Z,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z"));
    assert_eq!(lines.count(), 2);
    volmap()
        .args(["sample", "--exact", "--machine", "vmc-li2015", "--points"])
        .arg(&points)
        .assert()
        .success()
        .stdout(
            predicate::str::starts_with("X,Y,Z,VE.X").and(predicate::str::contains("500,300,250,")),
        );
    std::fs::write(&points, "X,Y,Z\n5000,0,0\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2: X=5000 lies outside"));
    volmap()
        .args(["sample", "--points"])
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--field"));
}

#[test]
fn exact_samples_take_the_pose_from_the_columns_or_from_pose() {
    let dir = tempfile::tempdir().unwrap();
    let with_columns = dir.path().join("a.csv");
    let without = dir.path().join("b.csv");
    std::fs::write(&with_columns, "X,Y,Z,B,C\n100,200,300,30,60\n").unwrap();
    std::fs::write(&without, "X,Y,Z\n100,200,300\n").unwrap();
    let run = |points: &std::path::Path, pose: &str| {
        let output = volmap()
            .args([
                "sample",
                "--exact",
                "--machine",
                "5axis-hwang2014",
                "--pose",
                pose,
                "--points",
            ])
            .arg(points)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let text = String::from_utf8(output.stdout).unwrap();
        let row: Vec<String> = text
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .map(str::to_string)
            .collect();
        row[row.len() - 6..].to_vec()
    };
    assert_eq!(run(&with_columns, ""), run(&without, "B=30,C=60"));
    assert_ne!(run(&without, ""), run(&without, "B=30,C=60"));
}

#[test]
fn features_rate_the_machine_from_the_model_or_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let example =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let json = dir.path().join("rows.json");
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&example)
        .arg("--json")
        .arg(&json)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("pocket floor").and(predicate::str::contains("inspect")));
    let rows: serde_json::Value = super::json_result(&json);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for row in rows {
        for key in [
            "name",
            "kind",
            "error_mm",
            "tolerance_mm",
            "safety",
            "verdict",
            "worst_point",
        ] {
            assert!(row.get(key).is_some(), "{key} missing in {row}");
        }
        let error = row["error_mm"].as_f64().unwrap();
        assert!(error > 0.0 && error < 0.1, "{row}");
    }

    // The same from a field over the part's region: close to the exact figures.
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "101x61x51",
            "--device",
            "cpu",
            "--out",
        ])
        .arg(&field)
        .assert()
        .success();
    let from_field = dir.path().join("field.json");
    volmap()
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&example)
        .arg("--json")
        .arg(&from_field)
        .assert()
        .code(0);
    let field_rows: serde_json::Value = super::json_result(&from_field);
    assert_eq!(field_rows.as_array().unwrap().len(), rows.len());
    for (exact, sampled) in rows.iter().zip(field_rows.as_array().unwrap()) {
        let (e, s) = (
            exact["error_mm"].as_f64().unwrap(),
            sampled["error_mm"].as_f64().unwrap(),
        );
        assert!(
            (e - s).abs() < 0.05 * e + 1e-5,
            "{}: {e} exact, {s} from the field",
            exact["name"]
        );
    }

    // A tighter tolerance makes the machine unfit: exit code 3.
    let tight = dir.path().join("tight.toml");
    std::fs::write(
        &tight,
        std::fs::read_to_string(&example)
            .unwrap()
            .replace("tolerance_mm = 0.05", "tolerance_mm = 0.001"),
    )
    .unwrap();
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&tight)
        .assert()
        .code(3)
        .stdout(predicate::str::contains("unfit"));
    // A part beyond the mapped grid is an error naming the feature.
    let far = dir.path().join("far.toml");
    std::fs::write(
        &far,
        std::fs::read_to_string(&example).unwrap().replace(
            "zero_mm = [200.0, 150.0, 300.0]",
            "zero_mm = [900.0, 150.0, 300.0]",
        ),
    )
    .unwrap();
    volmap()
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&far)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("feature `pocket floor`")
                .and(predicate::str::contains("outside the mapped grid")),
        );
}

#[test]
fn sample_on_the_gpu_agrees_with_the_cpu_and_needs_an_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("field.exr");
    volmap()
        .args(["map", "--grid", "9x8x7", "--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    let points = dir.path().join("points.csv");
    std::fs::write(&points, "X,Y,Z\n10,20,30\n312.5,4.25,17\n0,0,0\n").unwrap();
    let sample = |device: &str| {
        let output = volmap()
            .args(["sample", "--device", device, "--field"])
            .arg(&field)
            .arg("--points")
            .arg(&points)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout).unwrap()
    };
    let on_cpu = sample("cpu");
    if super::super::common::sampler().is_some() {
        let on_gpu = sample("gpu");
        let rows = |text: &str| -> Vec<Vec<f64>> {
            text.lines()
                .skip(1)
                .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
                .collect()
        };
        let (a, b) = (rows(&on_cpu), rows(&on_gpu));
        assert_eq!(a.len(), 3);
        assert_eq!(on_cpu.lines().next(), on_gpu.lines().next());
        assert_eq!(b.len(), a.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.len(), y.len());
            for (u, v) in x.iter().zip(y) {
                assert!(
                    (u - v).abs() <= 1e-6 * u.abs().max(1e-6),
                    "{on_cpu}\n{on_gpu}"
                );
            }
        }
    }
    volmap()
        .env("WGPU_BACKEND", "gl")
        .args(["sample", "--device", "gpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("no GPU adapter found"));
}
