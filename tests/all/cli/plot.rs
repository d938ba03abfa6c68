//! `volmap plot`.

use predicates::prelude::*;

use super::volmap;

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
