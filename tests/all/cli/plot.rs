//! `volmap plot`.

use predicates::prelude::*;

use super::sweep::{map, swept};
use super::{assert_finite_svg, assert_refused, s, volmap};

#[test]
fn plot_commands_write_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("f.exr");
    volmap()
        .args(["map", "--grid", "9x8x7", "--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    let (svg, png) = (dir.path().join("s.svg"), dir.path().join("s.png"));
    volmap()
        .args([
            "plot",
            "slice",
            "--normal",
            "y",
            "--quantity",
            "VE.Z",
            "--field",
        ])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .arg("--out")
        .arg(&png)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("VE.Z at Y="));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let grid = dir.path().join("g.svg");
    volmap()
        .args([
            "plot",
            "grid",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "3x3x3",
            "--out",
        ])
        .arg(&grid)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&grid)
        .unwrap()
        .contains("error magnified"));
    volmap()
        .args(["plot", "slice", "--quantity", "speed", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--quantity: `speed` is not a quantity",
        ));
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

#[test]
fn plot_values_that_are_not_numbers_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    for scale in ["nan", "inf", "-5", "0"] {
        let svg = dir.path().join("g.svg");
        let scale_flag = format!("--scale={scale}");
        assert_refused(
            volmap().args([
                "plot",
                "grid",
                "--grid",
                "3x3x3",
                &scale_flag,
                "--out",
                s(&svg),
            ]),
            &["--scale"],
        );
        assert!(!svg.exists(), "{scale}");
    }
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--grid",
            "5x5x5",
            "--device",
            "cpu",
            "--out",
            s(&field),
        ])
        .assert()
        .success();
    for at in ["nan", "inf", "-inf"] {
        let svg = dir.path().join("s.svg");
        assert_refused(
            volmap().args([
                "plot",
                "slice",
                "--field",
                s(&field),
                "--at",
                at,
                "--out",
                s(&svg),
            ]),
            &["--at"],
        );
        assert!(!svg.exists());
    }
}

#[test]
fn a_field_slice_of_subnormal_spacing_is_drawn_or_refused_never_a_panic() {
    use volmap::engine::map::{map_to_file, MapOptions};
    use volmap::engine::Engine;
    use volmap::model::grid::Grid;
    let dir = tempfile::tempdir().unwrap();
    let machine = volmap::io::embedded::load("vmc-li2015").unwrap();
    let grid = Grid {
        dims: [4, 3, 3],
        origin_mm: [0.0, 0.0, 0.0],
        spacing_mm: [5e-324, 1e-323, 100.0],
        pose: [0.0; 6],
    };
    let field = dir.path().join("f.exr");
    map_to_file(
        &machine,
        &grid,
        &Engine::Cpu,
        &field,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    for normal in ["x", "y", "z"] {
        let svg = dir.path().join(format!("{normal}.svg"));
        let output = volmap()
            .args(["plot", "slice", "--field", s(&field), "--normal", normal])
            .args(["--out", s(&svg)])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        match output.status.code() {
            Some(0) => assert_finite_svg(&svg),
            // A reader that refuses such a spacing says so.
            Some(2) => assert!(stderr.contains("spacing"), "{stderr}"),
            code => panic!("{normal}: exit {code:?}: {stderr}"),
        }
    }
}
