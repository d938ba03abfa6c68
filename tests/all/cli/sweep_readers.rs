//! Five-axis maps read back: `sample`, `plot slice` and `features` pick the part of a multi-part
//! field by its pose, and name the line or the flag where no part is at the pose asked for.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use super::sweep::{map, swept};
use super::volmap;

/// The samples (CSV rows without the position columns) `volmap sample` writes.
fn sample(field: &Path, points: &Path) -> Vec<String> {
    let output = volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(field)
        .arg("--points")
        .arg(points)
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
        .map(|l| l.split(',').skip(5).collect::<Vec<_>>().join(","))
        .collect()
}

#[test]
fn sample_picks_the_part_of_each_points_pose() {
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    map(&["--pose", "B=90,C=180"], "cpu", &a);
    map(&["--pose", "B=-90,C=0"], "cpu", &b);
    let points = dir.path().join("p.csv");
    std::fs::write(
        &points,
        "X,Y,Z,B,C\n100,200,300,90,180\n# a comment\n412.5,37,480,-90,0\n700,550,20,90,180\n",
    )
    .unwrap();
    let from_sweep = sample(&field, &points);
    let only = |keep: &[usize]| {
        let text = std::fs::read_to_string(&points).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        let path = dir.path().join("only.csv");
        let mut out = rows[0].to_string();
        for &n in keep {
            out.push('\n');
            out.push_str(rows[n + 1]);
        }
        std::fs::write(&path, out).unwrap();
        path
    };
    let at_a = sample(&a, &only(&[0, 2]));
    let at_b = sample(&b, &only(&[1]));
    assert_eq!(
        from_sweep,
        [at_a[0].clone(), at_b[0].clone(), at_a[1].clone()]
    );

    // A pose the file does not hold: exit 2, naming the line and listing the poses.
    std::fs::write(&points, "X,Y,Z,B,C\n100,200,300,90,180\n100,200,300,45,0\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("line 3")
                .and(predicate::str::contains("B=45,C=0"))
                .and(predicate::str::contains("B=-90,C=0 B=-90,C=90"))
                .and(predicate::str::contains("B=90,C=270")),
        );
    // Columns that leave several parts: exit 2, saying which column to add.
    std::fs::write(&points, "X,Y,Z,B\n100,200,300,90\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2").and(predicate::str::contains("column C")));
}

#[test]
fn plot_slice_picks_the_part_of_its_pose() {
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let svg = dir.path().join("s.svg");
    volmap()
        .args(["plot", "slice", "--pose", "B=0,C=270", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("at B=0,C=270: |VE| at Z="));
    // The values are those of the single-pose field of that pose.
    let single = dir.path().join("single.exr");
    map(&["--pose", "B=0,C=270"], "cpu", &single);
    let from_part = volmap::query::field_slice_at_pose(
        &field,
        Some(([0.0, 0.0, 270.0], "B=0,C=270")),
        "y",
        None,
        "VE.Z",
    )
    .unwrap();
    let alone = volmap::query::field_slice(&single, "y", None, "VE.Z").unwrap();
    assert_eq!(from_part.values, alone.values);
    assert_eq!(from_part.extent, alone.extent);

    volmap()
        .args(["plot", "slice", "--pose", "B=30,C=45", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--pose")
                .and(predicate::str::contains("B=30,C=45"))
                .and(predicate::str::contains("B=-90,C=0 B=-90,C=90")),
        );
    volmap()
        .args(["plot", "slice", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("holds 12 poses")
                .and(predicate::str::contains("hint: --pose picks one")),
        );
    volmap()
        .args(["plot", "slice", "--pose", "Q=1", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--pose"));
    // A single-pose field: without --pose as before; with its own pose too, another refused.
    for (pose, code) in [(None, 0), (Some("B=0,C=270"), 0), (Some("B=0"), 2)] {
        let mut command = volmap();
        command.args(["plot", "slice", "--field"]).arg(&single);
        if let Some(pose) = pose {
            command.args(["--pose", pose]);
        }
        command.arg("--out").arg(&svg).assert().code(code);
    }
}

/// A small part machined at `pose_deg` on the test machine.
fn part_file(dir: &Path, pose: &str) -> PathBuf {
    let path = dir.join(format!("part-{}.toml", pose.len()));
    std::fs::write(
        &path,
        format!(
            r#"name = "plate"
[placement]
zero_mm = [200.0, 150.0, 300.0]
pose_deg = {{ {pose} }}
[cutter]
radius_mm = 8.0
length_mm = 60.0
[sampling]
spacing_mm = 20.0
[[features]]
kind = "end_milled_plane"
name = "floor"
corner_mm = [0.0, 0.0, -20.0]
size_mm = [300.0, 200.0]
tolerance_mm = 0.05
[[features]]
kind = "hole"
name = "hole"
centre_mm = [50.0, 100.0, -20.0]
diameter_mm = 20.0
depth_mm = 30.0
tolerance_mm = 0.04
"#
        ),
    )
    .unwrap();
    path
}

#[test]
fn features_read_the_part_at_the_parts_pose() {
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let single = dir.path().join("single.exr");
    map(&["--pose", "B=90,C=90"], "cpu", &single);
    let part = part_file(dir.path(), "B = 90.0, C = 90.0");
    let rows = |field: &Path| -> serde_json::Value {
        let json = dir.path().join("rows.json");
        let output = volmap()
            .args(["features", "--field"])
            .arg(field)
            .arg("--part")
            .arg(&part)
            .arg("--json")
            .arg(&json)
            .output()
            .unwrap();
        assert!(
            matches!(output.status.code(), Some(0 | 3)),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
    };
    let from_sweep = rows(&field);
    assert_eq!(from_sweep.as_array().unwrap().len(), 2);
    assert_eq!(from_sweep, rows(&single));

    // A part at a pose the file does not hold: exit 2, listing the poses.
    let elsewhere = part_file(dir.path(), "B = 45.0");
    volmap()
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&elsewhere)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--field")
                .and(predicate::str::contains("B=45,C=0"))
                .and(predicate::str::contains("B=-90,C=0 B=-90,C=90")),
        );
}
