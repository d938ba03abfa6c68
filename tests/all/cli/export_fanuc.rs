//! `volmap export --format fanuc | fanuc-3d | isg` as a user runs it: the files in the folder
//! (or the file), the report, and the requests refused (exit 2, naming the flag and the
//! problem, nothing written).

use predicates::prelude::*;

use super::volmap;

fn no_temporaries(dir: &std::path::Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".part"), "{name} left behind");
    }
}

#[test]
fn fanuc_writes_parameters_pitch_data_and_notes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fanuc");
    volmap()
        .args(["export", "--machine", "gantry-2m", "--format", "fanuc"])
        .args(["--points", "21", "--approach", "Y=-", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("error:").not())
        .stdout(
            predicate::str::contains("fanuc: FANUC pitch error compensation")
                .and(predicate::str::contains(
                    // 21 points span the 2000 mm travel: 20 intervals of 100 mm.
                    "table Y pitch          points 170-190 (reference 170) at 0.000 to 2000.000 mm, interval 100.000 mm, magnification 1; bidirectional, negative-direction points 680-700",
                ))
                .and(predicate::str::contains("residual measured on   41 x 41 x 41 points"))
                .and(predicate::str::contains("cannot hold"))
                .and(predicate::str::contains("EC0Y")),
        );
    let names: Vec<String> = ["PITCHPRM.TXT", "PITCH.TXT", "NOTES.TXT"]
        .iter()
        .map(|n| std::fs::read_to_string(out.join(n)).unwrap())
        .collect();
    assert!(names[0].starts_with("%\nN03620Q1A1P0A2P170A3P340\n"));
    assert!(names[0].contains("N03626Q1A2P680\n"));
    assert!(names[1].starts_with("%\nN10000P0\n") && names[1].ends_with("%\n"));
    assert!(names[2].contains("set 3605#0 = 1"));
    no_temporaries(&out);
}

#[test]
fn fanuc_3d_writes_the_lattice() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lattice.csv");
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "fanuc-3d"])
        .args(["--spacing", "100", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "table 3-D lattice      11 x 7 x 6 points (462), interval 100.000 x 100.000 x 100.000 mm",
        ));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 463);
}

#[test]
fn isg_writes_the_configuration_list_the_parameters_and_the_start_up_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("isg");
    volmap()
        .args(["export", "--machine", "5axis-hwang2014", "--format", "isg"])
        .args(["--pose", "B=30,C=45", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stdout(
            predicate::str::contains(
                "isg: ISG kernel / Beckhoff TwinCAT CNC volumetric compensation",
            )
            .and(predicate::str::contains("pose                   B=30 C=45"))
            .and(predicate::str::contains(
                "the spindle errors, which have no ISG parameter, are folded",
            )),
        );
    for name in [
        "vol_comp_0.lis",
        "volcomp_errors.csv",
        "hochlauf_volcomp.lis",
    ] {
        assert!(out.join(name).is_file(), "{name}");
    }
    no_temporaries(&out);
}

#[test]
fn bad_requests_exit_2_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let square = crate::common::fixture_path("squareness");
    let three = dir.path().join("three.toml");
    std::fs::write(
        &three,
        "name = \"three\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0.0, 400.0]\nEZX = { sum = [{ poly = [0.0, 1.0e-6] }, { poly = [0.0, 1.0e-6], of = \"Y\" }, { poly = [0.0, 1.0e-6], of = \"Z\" }] }\n[axes.Y]\nrange = [0.0, 300.0]\n[axes.Z]\nrange = [0.0, 200.0]\n",
    )
    .unwrap();
    let machine = |p: &std::path::Path| p.display().to_string();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "fanuc".into(), "--points".into(), "101".into(), "--point-numbers".into(), "0-599".into()],
            "error: --points: 101 points along X",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "fanuc".into(), "--point-numbers".into(), "0-10".into()],
            "error: --point-numbers: point numbers 0-10: six tables (X, Y, Z each way) need at least 12 numbers",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "fanuc".into(), "--point-numbers".into(), "0-10000".into()],
            "error: --point-numbers: point numbers 0-10000: they must lie within 0-9999",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "klipper".into(), "--point-numbers".into(), "0-99".into()],
            "error: --point-numbers: klipper does not number its compensation points",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "fanuc".into(), "--spacing".into(), "0.5".into()],
            "error: --spacing: a spacing of 0.5 mm is below the smallest a fanuc table takes: 1 mm",
        ),
        (
            vec!["--machine".into(), machine(&square), "--format".into(), "fanuc".into()],
            "error: --format: fanuc can hold none of this machine's errors",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "fanuc-3d".into(), "--points".into(), "102".into()],
            "error: --points: 102 points is more than a fanuc-3d table holds: at most 101",
        ),
        (
            vec!["--machine".into(), "vmc-li2015".into(), "--format".into(), "isg".into(), "--points".into(), "1".into()],
            "error: --points: 1 points is fewer than a isg table needs: at least 2",
        ),
        (
            vec!["--machine".into(), machine(&three), "--format".into(), "isg".into()],
            "error: --format: the isg export cannot hold this machine's errors: EZX depends on 3 axes at once (X, Y, Z)",
        ),
    ];
    for (flags, message) in cases {
        volmap()
            .arg("export")
            .args(&flags)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(predicate::str::starts_with(message));
        assert!(!out.exists(), "{flags:?} wrote {}", out.display());
    }
}

#[test]
fn isg_axis_writes_a_list_per_axis_and_the_start_up_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lists");
    volmap()
        .args(["export", "--machine", "gantry-2m", "--format", "isg-axis"])
        .args(["--approach", "Y=-", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("table Y leadscrew      21 points at 0 to 2000 mm, bilateral")
                .and(predicate::str::contains(
                    "table Y plane          21 x 21 points over X, Z at 150 x 50 mm",
                )),
        );
    for name in [
        "achskw_x.lis",
        "achskw_y.lis",
        "achskw_z.lis",
        "hochlauf_axis_comp.lis",
    ] {
        assert!(out.join(name).is_file(), "{name}");
    }
    let y = std::fs::read_to_string(out.join("achskw_y.lis")).unwrap();
    assert!(y.ends_with("End\n") && y.contains("kw.ssfk.bilateral                        1\n"));
    no_temporaries(&out);
}
