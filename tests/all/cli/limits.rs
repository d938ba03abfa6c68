//! The counts an input implies, checked against the documented limits before anything is
//! allocated or looped: each item of "Panics, aborts and hangs" as a regression, every one exit
//! code 2 with the key or flag named, quickly (a hang would time the test suite out).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use predicates::prelude::*;

use super::volmap;

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

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A part file with `placement` and `sampling` lines and one feature.
fn part(dir: &Path, name: &str, placement: &str, sampling: &str, feature: &str) -> PathBuf {
    let path = dir.join(name);
    let text = format!(
        "name = \"p\"\n[placement]\n{placement}\n[cutter]\nradius_mm = 8.0\nlength_mm = 60.0\n\
         [sampling]\n{sampling}\n[[features]]\n{feature}\n"
    );
    std::fs::write(&path, text).unwrap();
    path
}

const ZERO: &str = "zero_mm = [200.0, 150.0, 300.0]";
const SPACING: &str = "spacing_mm = 5.0";

fn hole(diameter: &str, depth: &str) -> String {
    format!(
        "kind = \"hole\"\nname = \"h\"\ncentre_mm = [50.0, 100.0, -20.0]\n\
         diameter_mm = {diameter}\ndepth_mm = {depth}\ntolerance_mm = 0.04"
    )
}

#[test]
fn part_files_that_imply_endless_cuts_are_refused_naming_the_file_and_keys() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        // Capacity overflow, a 50 GB allocation, the `expect` at the cuts.
        (
            part(d, "d.toml", ZERO, SPACING, &hole("1e300", "30.0")),
            vec!["`h`", "diameter_mm"],
        ),
        (
            part(d, "d9.toml", ZERO, SPACING, &hole("1e9", "30.0")),
            vec!["`h`", "diameter_mm"],
        ),
        (
            part(d, "h.toml", ZERO, SPACING, &hole("20.0", "1e300")),
            vec!["`h`", "depth_mm"],
        ),
        (
            part(
                d,
                "rib.toml",
                ZERO,
                SPACING,
                "kind = \"rib_height\"\nname = \"r\"\ncorner_mm = [0.0, 220.0, 0.0]\n\
                 size_mm = [1e300, 5.0]\ntolerance_mm = 0.1",
            ),
            vec!["`r`", "size_mm"],
        ),
        // An endless loop.
        (
            part(
                d,
                "sp.toml",
                ZERO,
                "spacing_mm = 1e-300",
                &hole("20.0", "30.0"),
            ),
            vec!["spacing_mm", "1e-300"],
        ),
        // Sizes of 2^16 to 2^32 mm: hours, and over 6 GiB.
        (
            part(
                d,
                "big.toml",
                ZERO,
                SPACING,
                "kind = \"end_milled_plane\"\nname = \"f\"\ncorner_mm = [0.0, 0.0, -20.0]\n\
                 size_mm = [65536.0, 4294967296.0]\ntolerance_mm = 0.05",
            ),
            vec!["`f`", "size_mm", "limit of 1000000"],
        ),
    ];
    for (path, named) in &cases {
        let mut all = vec![s(path)];
        all.extend(named);
        refused(
            &["features", "--machine", "vmc-li2015", "--part", s(path)],
            &all,
        );
    }
    // A cutter long enough for a hole 1e300 deep: the count, not the reach, refuses it; the
    // datum features of positions too.
    let text = std::fs::read_to_string(&cases[2].0)
        .unwrap()
        .replace("length_mm = 60.0", "length_mm = 1e300");
    std::fs::write(d.join("cut.toml"), text).unwrap();
    refused(
        &[
            "features",
            "--machine",
            "vmc-li2015",
            "--part",
            s(&d.join("cut.toml")),
        ],
        &["`h`", "depth_mm"],
    );
    let positions = part(
        d,
        "pos.toml",
        ZERO,
        SPACING,
        "kind = \"end_milled_plane\"\nname = \"floor\"\ncorner_mm = [0.0, 0.0, -20.0]\n\
         size_mm = [300.0, 200.0]\ntolerance_mm = 0.05\n[[features]]\nkind = \"rib_position\"\n\
         name = \"side\"\nstart_mm = [0.0, 0.0, -20.0]\ndirection_deg = 0.0\nlength_mm = 1e300\n\
         depth_mm = 20.0\ndatums = [\"floor\"]\ntolerance_mm = 0.06\n[[features]]\n\
         kind = \"hole_position\"\nname = \"hp\"\ncentre_mm = [50.0, 100.0, -20.0]\n\
         diameter_mm = 20.0\ndepth_mm = 1e300\ndatums = [\"floor\"]\ntolerance_mm = 0.04",
    );
    refused(
        &[
            "features",
            "--machine",
            "vmc-li2015",
            "--part",
            s(&positions),
        ],
        &["`side`", "length_mm"],
    );
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

#[test]
fn counts_of_tests_compensations_samples_and_drawings_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X500 Y300 Z200 F1000\n").unwrap();
    let out = dir.path().join("o.nc");
    let five = ["--machine", "5axis-hwang2014"];
    let li = ["--machine", "vmc-li2015"];
    let tolerances = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/tolerances/vmc-li2015.toml"
    );
    let part = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/li2015-part.toml");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["test", "rtest", "--axis", "C", "--step", "1e-300"],
            vec!["--step", "100000"],
        ),
        (
            vec!["test", "rtest", "--axis", "C", "--step", "1e-9"],
            vec!["--step", "100000"],
        ),
        (
            vec![
                "test", "rtest", "--axis", "C", "--from", "-1e308", "--to", "1e308",
            ],
            vec!["--from", "--to"],
        ),
        (
            vec![
                "test",
                "positioning",
                "--axis",
                "X",
                "--targets",
                "1000000000000",
            ],
            vec!["--targets", "100000"],
        ),
        (
            vec![
                "test",
                "positioning",
                "--axis",
                "X",
                "--runs",
                "1000000000000",
            ],
            vec!["--runs", "100"],
        ),
        (
            vec![
                "test",
                "diagonal",
                "--diagonal",
                "PPP",
                "--points",
                "1000000000000",
            ],
            vec!["--points"],
        ),
        (
            vec![
                "test",
                "circular",
                "--plane",
                "XY",
                "--points",
                "1000000000000",
            ],
            vec!["--points"],
        ),
        (
            vec![
                "compensate",
                "--program",
                s(&program),
                "--out",
                s(&out),
                "--decimals",
                "65536",
            ],
            vec!["--decimals", "at most 15"],
        ),
        (
            vec![
                "trace",
                "--program",
                s(&program),
                "--compensate",
                "--decimals",
                "65536",
            ],
            vec!["--decimals"],
        ),
        (
            vec!["trace", "--program", s(&program), "--step", "1e-300"],
            vec!["--step"],
        ),
        (
            vec![
                "budget",
                "--tolerances",
                tolerances,
                "--grid",
                "3x3x3",
                "--samples",
                "1000000000000",
            ],
            vec!["--samples", "1000000"],
        ),
        (
            vec![
                "features",
                "--part",
                part,
                "--tolerances",
                tolerances,
                "--samples",
                "1000000000000",
            ],
            vec!["--samples"],
        ),
    ];
    for (args, named) in cases {
        let machine = if args[0] == "test" && args[1] == "rtest" {
            five
        } else {
            li
        };
        let mut all = args.clone();
        all.extend(machine);
        refused(&all, &named);
    }
    assert!(!out.exists());
    let svg = dir.path().join("g.svg");
    refused(
        &["plot", "grid", "--grid", "300x300x300", "--out", s(&svg)],
        &["--grid", "300x300x300"],
    );
    assert!(!svg.exists());
    // The limits themselves pass.
    volmap()
        .args([
            "test",
            "positioning",
            "--axis",
            "X",
            "--targets",
            "100000",
            "--runs",
            "100",
        ])
        .args(li)
        .assert()
        .success();
    volmap()
        .args([
            "compensate",
            "--program",
            s(&program),
            "--out",
            s(&out),
            "--decimals",
            "15",
        ])
        .args(li)
        .assert()
        .success();
    // The coordinates of the compensated G0 are written with more than 9 decimals.
    let text = std::fs::read_to_string(&out).unwrap();
    let decimals = |word: &str| word.split('.').nth(1).map_or(0, str::len);
    assert!(
        text.split_whitespace()
            .any(|w| w.starts_with('X') && decimals(w) > 9),
        "{text}"
    );
}

#[test]
fn a_chunk_below_a_grid_line_maps_one_line_per_chunk_on_every_device() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = super::super::common::gpu().is_some();
    let devices: &[&str] = if gpu { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        let whole = dir.path().join(format!("{device}-whole.exr"));
        let one = dir.path().join(format!("{device}-one.exr"));
        for (path, chunk) in [(&whole, None), (&one, Some("1"))] {
            let mut cmd = volmap();
            cmd.args([
                "map", "--grid", "8x6x5", "--check", "30", "--device", device,
            ])
            .arg("--out")
            .arg(path);
            if let Some(c) = chunk {
                cmd.args(["--chunk-points", c]);
            }
            cmd.assert()
                .success()
                .stdout(predicate::str::contains(": ok"));
        }
        let sample = |field: &Path| {
            let points = dir.path().join("p.csv");
            std::fs::write(&points, "X,Y,Z\n0,0,0\n571.4,240,375\n1000,600,500\n").unwrap();
            let output = volmap()
                .args([
                    "sample",
                    "--device",
                    "cpu",
                    "--points",
                    s(&points),
                    "--field",
                    s(field),
                ])
                .output()
                .unwrap();
            assert!(output.status.success());
            String::from_utf8(output.stdout).unwrap()
        };
        assert_eq!(sample(&whole), sample(&one), "{device}");
    }
}
