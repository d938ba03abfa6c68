//! `volmap features`: part files whose values imply endless cuts or are not numbers, refused
//! naming the file and key (`refusals` holds more), meshes far larger than the sampling refused
//! with the machine, and a part read from a multi-part field at its own pose.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use predicates::prelude::*;

use super::sweep::{map, swept};
use super::{s, volmap};

/// `volmap args` must exit 2 within a few seconds, its error naming each of `named`.
fn refused(args: &[&str], named: &[&str]) {
    let start = Instant::now();
    let output = volmap()
        .args(args)
        .timeout(Duration::from_secs(60))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for n in named {
        assert!(stderr.contains(n), "{args:?}: `{n}` not named in {stderr}");
    }
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{args:?} took {:?}",
        start.elapsed()
    );
}

/// The text of a part file with `placement` and `sampling` lines and one feature.
pub fn part_text(placement: &str, sampling: &str, feature: &str) -> String {
    format!(
        "name = \"p\"\n[placement]\n{placement}\n[cutter]\nradius_mm = 8.0\nlength_mm = 60.0\n\
         [sampling]\n{sampling}\n[[features]]\n{feature}\n"
    )
}

/// A part file with `placement` and `sampling` lines and one feature.
fn part(dir: &Path, name: &str, placement: &str, sampling: &str, feature: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, part_text(placement, sampling, feature)).unwrap();
    path
}

/// The part's zero and its sampling, where a row does not change them.
pub const ZERO: &str = "zero_mm = [200.0, 150.0, 300.0]";
pub const SPACING: &str = "spacing_mm = 5.0";

/// A hole `h` of `diameter` and `depth` (mm).
pub fn hole(diameter: &str, depth: &str) -> String {
    format!(
        "kind = \"hole\"\nname = \"h\"\ncentre_mm = [50.0, 100.0, -20.0]\n\
         diameter_mm = {diameter}\ndepth_mm = {depth}\ntolerance_mm = 0.04"
    )
}

#[test]
fn a_placement_that_is_not_a_number_names_the_part_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    for (placement, key) in [
        ("zero_mm = [nan, 150.0, 300.0]", "zero_mm[0]"),
        ("zero_mm = [200.0, 150.0, inf]", "zero_mm[2]"),
        (
            "zero_mm = [200.0, 150.0, 300.0]\nrotation_deg = nan",
            "rotation_deg",
        ),
    ] {
        let path = part(
            dir.path(),
            "p.toml",
            placement,
            SPACING,
            &hole("20.0", "30.0"),
        );
        refused(
            &["features", "--machine", "vmc-li2015", "--part", s(&path)],
            &["p.toml", key],
        );
        let output = volmap()
            .args(["features", "--machine", "vmc-li2015", "--part", s(&path)])
            .output()
            .unwrap();
        assert!(!String::from_utf8_lossy(&output.stderr).contains("cylindricity"));
    }
    // A hole's centre that is not a number, likewise.
    let path = part(
        dir.path(),
        "c.toml",
        ZERO,
        SPACING,
        &hole("20.0", "30.0").replace("[50.0, 100.0, -20.0]", "[50.0, nan, -20.0]"),
    );
    refused(
        &["features", "--machine", "vmc-li2015", "--part", s(&path)],
        &["c.toml", "`h`", "centre_mm[1]"],
    );
}

/// An ASCII STL of one triangle with corners `a`, `b`, `c`.
fn triangle_stl(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> String {
    let v = |p: [f64; 3]| format!("vertex {} {} {}\n", p[0], p[1], p[2]);
    format!(
        "solid t\nfacet normal 0 0 1\nouter loop\n{}{}{}endloop\nendfacet\nendsolid t\n",
        v(a),
        v(b),
        v(c)
    )
}

#[test]
fn meshes_far_larger_than_the_sampling_are_refused_at_once_with_the_machine() {
    let dir = tempfile::tempdir().unwrap();
    for (name, stl) in [
        // One vertex at 65,536 mm.
        (
            "far.stl",
            triangle_stl([0.0, 0.0, 0.0], [65536.0, 0.0, 0.0], [0.0, 10.0, 0.0]),
        ),
        // A 100 mm part written in micrometres.
        (
            "um.stl",
            triangle_stl([0.0, 0.0, 0.0], [100000.0, 0.0, 0.0], [0.0, 100000.0, 0.0]),
        ),
    ] {
        std::fs::write(dir.path().join(name), stl).unwrap();
        let feature =
            format!("kind = \"profile\"\nname = \"skin\"\nmesh = \"{name}\"\ntolerance_mm = 0.1");
        let path = part(dir.path(), "skin.toml", ZERO, SPACING, &feature);
        refused(
            &["features", "--machine", "vmc-li2015", "--part", s(&path)],
            &["skin.toml", "`skin`", "spacing_mm", "in mm"],
        );
    }
    // The same part in mm passes.
    std::fs::write(
        dir.path().join("mm.stl"),
        triangle_stl([0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]),
    )
    .unwrap();
    let feature = "kind = \"profile\"\nname = \"skin\"\nmesh = \"mm.stl\"\ntolerance_mm = 0.1";
    let path = part(dir.path(), "mm.toml", ZERO, SPACING, feature);
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part", s(&path)])
        .assert()
        .code(predicate::in_iter([0, 3]));
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
        super::json_result(&json)
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
