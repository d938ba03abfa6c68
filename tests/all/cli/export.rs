//! `volmap export` as a user runs it: the report, the files, `--json`, and the requests it
//! refuses (exit 2, naming the flag and the problem, nothing written).

use predicates::prelude::*;

use super::volmap;

/// No file of `dir` is a temporary one left behind.
fn no_temporaries(dir: &std::path::Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".part"), "{name} left behind");
    }
}

#[test]
fn export_writes_the_grid_and_reports_the_residual() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("vmc.csv");
    let json = dir.path().join("vmc.json");
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "grid-csv"])
        .args(["--points", "5", "--out"])
        .arg(&out)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stderr(predicate::str::contains("error:").not())
        .stdout(
            predicate::str::contains("grid-csv: generic 3-D correction grid (CSV) for 3-axis VMC")
                .and(predicate::str::contains(
                    "table grid             5 x 5 x 5 points (125), spacing 250 x 150 x 125 mm",
                ))
                .and(predicate::str::contains(
                    "residual measured on   41 x 41 x 41 points",
                ))
                .and(predicate::str::contains(
                    "error before           largest 130.130 µm",
                ))
                .and(predicate::str::contains(
                    "inputs                 approach X+ Y+ Z+",
                )),
        );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("# Written by volmap"));
    assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 126);
    let report: serde_json::Value = super::json_result(&json);
    assert_eq!(report["report"]["format"], "grid-csv");
    assert_eq!(report["written"][0], out.display().to_string());
    let residual = report["report"]["residual"]["max_mm"].as_f64().unwrap();
    let before = report["report"]["before"]["max_mm"].as_f64().unwrap();
    assert!(residual > 0.0 && residual < 0.1 * before);
    no_temporaries(dir.path());
}

#[test]
fn an_unmet_max_residual_writes_nothing_and_gives_the_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("vmc.csv");
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "grid-csv"])
        .args(["--points", "3", "--max-residual", "0.0001", "--out"])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("error: --max-residual: the residual of the grid-csv table")
                .and(predicate::str::contains(
                    "is above the 0.100 µm asked for: nothing written",
                )),
        );
    assert!(!out.exists());
    no_temporaries(dir.path());
    // The same table meets a looser limit.
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "grid-csv"])
        .args(["--points", "3", "--max-residual", "0.05", "--out"])
        .arg(&out)
        .assert()
        .success();
    assert!(out.exists());
}

#[test]
fn bad_table_sizes_exit_2_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.csv");
    let cases: [(&[&str], &str); 5] = [
        (
            &["--spacing", "0.025"],
            "error: --spacing: a spacing of 0.025 mm is below the smallest a grid-csv table takes: 0.1 mm",
        ),
        (
            &["--points", "500"],
            "error: --points: 500 points is more than a grid-csv table holds: at most 101",
        ),
        (
            &["--points", "1"],
            "error: --points: 1 points is fewer than a grid-csv table needs: at least 2",
        ),
        (
            &["--residual-grid", "1"],
            "error: --residual-grid: 1 points per axis for the residual: at least 2",
        ),
        (
            &["--max-residual=-1"],
            "error: --max-residual -1: it must be a number of mm, zero or more",
        ),
    ];
    for (flags, message) in cases {
        volmap()
            .args(["export", "--machine", "vmc-li2015", "--format", "grid-csv"])
            .args(flags)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(predicate::str::starts_with(message));
        assert!(!out.exists());
    }
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "fanuc-x",
            "--out",
        ])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error: --format: `fanuc-x` is not a format volmap exports (formats: grid-csv",
        ));
    volmap()
        .args(["export", "--format", "grid-csv", "--out"])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("no machine named"));
}

#[test]
fn a_sweep_of_table_sizes_prints_and_plots_the_residual() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("sweep.svg");
    let assert = volmap()
        .args([
            "export",
            "--machine",
            "vmc-dobariya2015",
            "--format",
            "grid-csv",
        ])
        .args(["--sweep-points", "2,3,5", "--plot"])
        .arg(&plot)
        .assert()
        .success();
    let stdout = String::from_utf8(assert.get_output().stdout.clone()).unwrap();
    let residuals: Vec<f64> = stdout
        .lines()
        .filter_map(|l| {
            let words: Vec<&str> = l.split_whitespace().collect();
            match words[..] {
                [n, max, "µm", _, "µm"] if n.parse::<usize>().is_ok() => max.parse().ok(),
                _ => None,
            }
        })
        .collect();
    assert_eq!(residuals.len(), 3, "{stdout}");
    // Dobariya's Z error is quadratic: more points leave less.
    assert!(
        residuals[2] < residuals[1] && residuals[1] < residuals[0],
        "{stdout}"
    );
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.contains("points per table") && svg.contains("residual (µm)"));
}

#[test]
fn linuxcnc_writes_a_folder_of_joint_files_and_ini_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lc");
    volmap()
        .args(["export", "--machine", "gantry-2m", "--format", "linuxcnc"])
        .args([
            "--control",
            "2.10",
            "--points",
            "9",
            "--approach",
            "Y=-",
            "--residual-grid",
            "11",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("table joint 1 (Y)")
                .and(predicate::str::contains("table matrixkins"))
                .and(predicate::str::contains("approach X+ Y- Z+"))
                .and(predicate::str::contains(
                    "the control picks each axis's table by the direction it moves",
                ))
                .and(predicate::str::contains("EZY")),
        );
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "linuxcnc.ini",
            "volmap-report.txt",
            "volmap_joint0_X.comp",
            "volmap_joint1_Y.comp",
            "volmap_joint2_Z.comp",
            "volmap_matrixkins.hal"
        ]
    );
    let report = std::fs::read_to_string(out.join("volmap-report.txt")).unwrap();
    assert!(report.starts_with("Written by volmap "), "{report}");
    assert!(
        report.contains("\nresidual with these tables: largest "),
        "{report}"
    );
    // The rows come first: LinuxCNC stops reading at the first line that is not three numbers.
    let x = std::fs::read_to_string(out.join("volmap_joint0_X.comp")).unwrap();
    let first = x.lines().next().unwrap();
    assert_eq!(first.split_whitespace().count(), 3, "{first}");
    assert!(first.split_whitespace().all(|w| w.parse::<f64>().is_ok()));
    // A folder export refused by --max-residual creates nothing.
    let refused = dir.path().join("refused");
    volmap()
        .args(["export", "--machine", "gantry-2m", "--format", "linuxcnc"])
        .args([
            "--points",
            "5",
            "--residual-grid",
            "11",
            "--max-residual",
            "0.001",
            "--out",
        ])
        .arg(&refused)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("nothing written"));
    assert!(!refused.exists());
    // --out naming a file for a folder format.
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    volmap()
        .args(["export", "--machine", "gantry-2m", "--format", "linuxcnc"])
        .args(["--points", "5", "--residual-grid", "11", "--out"])
        .arg(&file)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "is not a folder: a linuxcnc export writes several files into a folder",
        ));
}

#[test]
fn skew_formats_refuse_what_they_cannot_hold_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("skew.cfg");
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-dobariya2015",
            "--format",
            "klipper",
            "--out",
        ])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --format: klipper can hold none of this machine's errors: three skew factors",
        ));
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "marlin", "--points", "3", "--out"])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --points: marlin holds fixed factors, not tables: there is no table size to choose",
        ));
    assert!(!out.exists());
    // A skew that leaves more than the machine had says so, and still writes what was asked.
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "klipper", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::starts_with(
            "warning: the klipper table leaves a larger largest error than the machine has without it",
        ));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("[skew_correction volmap]\nxy_skew = "));
    // printer.cfg includes it by the name it was written as.
    let name = out.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        text.contains(&format!("# Load: [include {name}] in printer.cfg")),
        "{text}"
    );
    assert!(name != "volmap_skew.cfg");
}

/// `--help` names every format volmap writes, and which of them write a folder.
#[test]
fn rrf_writes_m556_and_a_height_map_folder() {
    let dir = tempfile::tempdir().unwrap();
    let skew = dir.path().join("skew.g");
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "rrf",
            "--out",
        ])
        .arg(&skew)
        .assert()
        .success()
        .stderr(predicate::str::contains("error:").not())
        .stdout(predicate::str::contains("table M556             tanXY "));
    let text = std::fs::read_to_string(&skew).unwrap();
    let code: Vec<&str> = text.lines().filter(|l| !l.starts_with(';')).collect();
    assert_eq!(code.len(), 1, "{text}");
    assert!(
        code[0].starts_with("M556 S100 X") && code[0].ends_with(" P0"),
        "{text}"
    );
    let folder = dir.path().join("rrf");
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "rrf-heightmap",
        ])
        .args(["--spacing", "100", "--out"])
        .arg(&folder)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "table height map       11 x 7 points from X 0.00 Y 0.00, spacing 100.00 x 100.00 mm",
        ));
    let map = std::fs::read_to_string(folder.join("heightmap.csv")).unwrap();
    assert!(map.starts_with("RepRapFirmware height map file v2 generated by volmap"));
    assert_eq!(map.lines().count(), 3 + 7);
    assert!(std::fs::read_to_string(folder.join("volmap-report.txt"))
        .unwrap()
        .contains("machine: 3-axis VMC"));
    no_temporaries(&folder);
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "rrf-heightmap"])
        .args(["--points", "30", "--out"])
        .arg(dir.path().join("too-many"))
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --points: 900 points over X and Y together (30 x 30) is more than a rrf-heightmap table holds: at most 441",
        ));
    assert!(!dir.path().join("too-many").exists());
}

#[test]
fn klipper_twist_takes_the_probe_offset() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("twist.cfg");
    volmap()
        .args([
            "export",
            "--machine",
            "gantry-2m",
            "--format",
            "klipper-twist",
        ])
        .args(["--probe-offset", "-25,40", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "table twist along X    11 values from 25.000 to 3000.000 mm",
        ));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("\n[axis_twist_compensation]\nz_compensations: "),
        "{text}"
    );
    assert!(text.contains("x_offset -25.000, y_offset 40.000 mm"));
    for (flags, message) in [
        (vec!["--format", "klipper-twist"], "error: --probe-offset: klipper-twist corrects a probe's readings: it needs the probe's offset"),
        (vec!["--format", "klipper-twist", "--probe-offset", "25"], "error: invalid value '25' for '--probe-offset <PROBE_OFFSET>': `25`: expected X,Y in mm"),
        (vec!["--format", "marlin", "--probe-offset", "1,2"], "error: --probe-offset: marlin corrects no probe"),
    ] {
        volmap()
            .args(["export", "--machine", "gantry-2m"])
            .args(&flags)
            .arg("--out")
            .arg(dir.path().join("bad.cfg"))
            .assert()
            .code(2)
            .stderr(predicate::str::starts_with(message));
        assert!(!dir.path().join("bad.cfg").exists());
    }
}

#[test]
fn help_names_every_format_and_its_layout() {
    let out = volmap().args(["export", "--help"]).assert().success();
    let help = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    let format_help = &help[help.find("--format").unwrap()..help.find("--out").unwrap()];
    let out_help = &help[help.find("--out").unwrap()..help.find("--spacing").unwrap()];
    for format in volmap::export::formats::FORMATS {
        let spec = format.spec();
        let name = spec.name;
        let named = |text: &str| {
            text.split(|c: char| !(c.is_alphanumeric() || c == '-'))
                .any(|w| w == name)
        };
        assert!(named(format_help), "{name} missing from: {format_help}");
        let (file_part, folder_part) = out_help.split_at(out_help.find("folder").unwrap());
        match spec.layout {
            volmap::export::Layout::File => assert!(named(file_part), "{name}: {out_help}"),
            volmap::export::Layout::Folder => assert!(named(folder_part), "{name}: {out_help}"),
        }
    }
}
