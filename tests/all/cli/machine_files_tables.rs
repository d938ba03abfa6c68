//! Machine files with CSV tables, written by `build --out` and `fit --out` into another folder
//! than their base: the written file stands alone (the tables outside its folder copied into
//! `NAME.tables/` beside it, the base untouched), reads with no flag, and maps exactly like the
//! base with the measured or fitted values in.

use std::path::Path;

use predicates::prelude::*;
use volmap::model::Machine;
use volmap::reference::deviation;

use super::volmap;

const BASE: &str = include_str!("../../../machines/vmc-li2015.toml");
const EXY_INLINE: &str =
    "EXY = { table = [[0, 0.0], [300, 0.03], [600, 0.0]], interp = \"quadratic\" }";
const EC0Y_BASE: &str = "EC0Y = 1.5e-5";

/// `vmc-li2015` with its Y straightness `EXY` read from `tables/y.csv` beside the file, the
/// file written as `base/machine.toml` under `dir` with its `EC0Y` set by `ec0y`.
fn base_with_csv(dir: &Path, ec0y: &str) -> std::path::PathBuf {
    assert!(BASE.contains(EXY_INLINE) && BASE.contains(EC0Y_BASE));
    let folder = dir.join("base");
    std::fs::create_dir_all(folder.join("tables")).unwrap();
    std::fs::write(
        folder.join("tables/y.csv"),
        "position_mm,EXY\n0,0.0\n300,0.03\n600,0.0\n",
    )
    .unwrap();
    let text = BASE
        .replace(
            EXY_INLINE,
            "EXY = { csv = \"tables/y.csv\", interp = \"quadratic\" }",
        )
        .replace(EC0Y_BASE, ec0y);
    let path = folder.join("machine.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The largest difference of VE and OE between two machines over a grid of their travel.
fn largest_difference(a: &Machine, b: &Machine) -> f64 {
    let mut largest: f64 = 0.0;
    for i in 0..=6 {
        for j in 0..=6 {
            for k in 0..=4 {
                let command = [
                    1000.0 * i as f64 / 6.0,
                    600.0 * j as f64 / 6.0,
                    500.0 * k as f64 / 4.0,
                    0.0,
                    0.0,
                    0.0,
                ];
                let (da, db) = (deviation(a, &command), deviation(b, &command));
                largest = largest
                    .max((da.volumetric_mm - db.volumetric_mm).abs().max())
                    .max((da.orientation_rad - db.orientation_rad).abs().max());
            }
        }
    }
    largest
}

#[test]
fn build_into_another_folder_keeps_the_bases_csv_tables() {
    let dir = tempfile::tempdir().unwrap();
    let base = base_with_csv(dir.path(), EC0Y_BASE);
    std::fs::write(
        dir.path().join("x.csv"),
        "position_mm,EXX_um\n0,0\n250,2.1\n500,5\n750,6\n1000,6.5\n",
    )
    .unwrap();
    std::fs::create_dir_all(dir.path().join("out/deeper")).unwrap();
    let build = |out: &str| {
        let output = volmap()
            .current_dir(dir.path())
            .args(["build", "--base", "base/machine.toml", "--axis", "X=x.csv"])
            .args(["--out", out])
            .output()
            .unwrap();
        assert!(output.status.success());
        String::from_utf8(output.stderr).unwrap()
    };
    // Beside the base no path changes; two folders away the table is copied beside the new
    // file, which reads with no flag; the base's table is untouched.
    let base_table = std::fs::read(dir.path().join("base/tables/y.csv")).unwrap();
    assert_eq!(build("base/beside.toml"), "");
    assert_eq!(build("out/deeper/built.toml"), "");
    let moved = std::fs::read_to_string(dir.path().join("out/deeper/built.toml")).unwrap();
    assert!(moved.contains("csv = \"built.tables/y.csv\""), "{moved}");
    assert_eq!(
        std::fs::read(dir.path().join("out/deeper/built.tables/y.csv")).unwrap(),
        base_table
    );
    assert_eq!(
        std::fs::read(dir.path().join("base/tables/y.csv")).unwrap(),
        base_table
    );
    assert!(!dir.path().join("base/beside.tables").exists());
    let beside = std::fs::read_to_string(dir.path().join("base/beside.toml")).unwrap();
    assert!(beside.contains("csv = \"tables/y.csv\""), "{beside}");
    let beside = Machine::from_path(&dir.path().join("base/beside.toml")).unwrap();
    let moved_path = dir.path().join("out/deeper/built.toml");
    let moved = Machine::from_path(&moved_path).unwrap();
    assert_eq!(largest_difference(&beside, &moved), 0.0);
    // Mapped with no flag, as a user maps it first.
    volmap()
        .current_dir(dir.path())
        .args([
            "map",
            "--machine",
            "out/deeper/built.toml",
            "--grid",
            "4x4x4",
            "--device",
            "cpu",
        ])
        .args(["--out", "out/built.exr"])
        .assert()
        .success()
        .stderr(predicate::str::contains("error").not());
    // The built X positioning is in: the file differs from the base by it (6.5 µm at X = 1000).
    let base = Machine::from_path(&base).unwrap();
    assert!(largest_difference(&base, &moved) > 1e-3);
}

#[test]
fn fit_into_another_folder_maps_like_the_base_with_the_estimate() {
    let dir = tempfile::tempdir().unwrap();
    // The measured machine: the base's squareness 15 µrad is really 40 µrad.
    let truth = base_with_csv(dir.path(), "EC0Y = 4.0e-5");
    volmap()
        .args([
            "test", "circular", "--plane", "XY", "--points", "36", "--json",
        ])
        .arg(dir.path().join("xy.json"))
        .arg("--machine")
        .arg(&truth)
        .assert()
        .success();
    let report: serde_json::Value = super::json_result(dir.path().join("xy.json"));
    let mut text = String::from("angle_deg,deviation_mm\n");
    assert_eq!(
        report["positions"].as_array().unwrap().len(),
        report["predicted"][0].as_array().unwrap().len()
    );
    for (a, r) in report["positions"]
        .as_array()
        .unwrap()
        .iter()
        .zip(report["predicted"][0].as_array().unwrap())
    {
        text += &format!("{a},{r}\n");
    }
    std::fs::write(dir.path().join("xy.csv"), text).unwrap();
    std::fs::write(
        dir.path().join("fit.toml"),
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 36\ncsv = \"xy.csv\"\n",
    )
    .unwrap();
    let base = base_with_csv(dir.path(), EC0Y_BASE);
    std::fs::create_dir_all(dir.path().join("out")).unwrap();
    volmap()
        .current_dir(dir.path())
        .args([
            "fit",
            "--machine",
            "base/machine.toml",
            "--measurements",
            "fit.toml",
            "--out",
            "out/fitted.toml",
            "--json",
            "out/fit.json",
        ])
        .assert()
        .success()
        .stdout(
            predicates::str::contains("valuation")
                .and(predicates::str::contains("condition number")),
        )
        .stderr(predicates::str::contains("--allow-outside-paths").not());
    let json: serde_json::Value = super::json_result(dir.path().join("out/fit.json"));
    let figures = &json["identifiability"];
    assert!(figures["valuation"][0].as_f64().unwrap() > 2.0, "{figures}");
    assert_eq!(figures["correlation"][0][0].as_f64(), Some(1.0));
    assert!(figures["sensitivity"][0].as_f64().unwrap() > 0.0);
    let written = std::fs::read_to_string(dir.path().join("out/fitted.toml")).unwrap();
    assert!(
        written.contains("csv = \"fitted.tables/y.csv\""),
        "{written}"
    );
    let value: toml::Table = toml::from_str(&written).unwrap();
    let estimate = value["axes"]["Y"]["EC0Y"]["value"].as_float().unwrap();
    assert!((estimate - 4.0e-5).abs() < 1e-9, "{estimate}");
    // The base with the estimate in, beside the base.
    let expected_path = dir.path().join("base/expected.toml");
    std::fs::write(
        &expected_path,
        std::fs::read_to_string(&base)
            .unwrap()
            .replace(EC0Y_BASE, &format!("EC0Y = {estimate:?}")),
    )
    .unwrap();
    let fitted = Machine::from_path(&dir.path().join("out/fitted.toml")).unwrap();
    let expected = Machine::from_path(&expected_path).unwrap();
    assert_eq!(largest_difference(&fitted, &expected), 0.0);
}
