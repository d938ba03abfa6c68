//! `volmap compensate --orientation`: five-axis tool orientation compensation from the command
//! line, and LinuxCNC's interpreter on the programs it writes.

use predicates::prelude::*;

use super::volmap;

const PROGRAM: &str =
    "G21 G90 G17\nG0 X400. Y300. Z300. B30. C45.\nG1 X450. F500\nB35. C60.\nX420. Y320. Z280. B20. C90.\nM2\n";

#[test]
fn orientation_rewrites_the_rotary_words_and_reports_the_orientation_error() {
    let dir = tempfile::tempdir().unwrap();
    let (program, out, json) = (
        dir.path().join("p.nc"),
        dir.path().join("out.nc"),
        dir.path().join("r.json"),
    );
    std::fs::write(&program, PROGRAM).unwrap();
    let run = |extra: &[&str]| {
        let mut command = volmap();
        command
            .args(["compensate", "--machine", "5axis-hwang2014", "--program"])
            .arg(&program)
            .arg("--out")
            .arg(&out)
            .arg("--json")
            .arg(&json)
            .args(extra);
        command.assert()
    };
    run(&["--orientation"])
        .success()
        .stdout(predicate::str::contains(
            "µrad after (angular tolerance 10.000 µrad)",
        ));
    let report: serde_json::Value = super::json_result(&json);
    let before = report["largest_orientation_error_before_rad"]
        .as_f64()
        .unwrap();
    let after = report["largest_orientation_error_after_rad"]
        .as_f64()
        .unwrap();
    assert!(
        before > 1e-5 && after <= 1e-5 && after < before / 10.0,
        "{report}"
    );
    // Rotary words carry six decimals of a degree and are no longer the programmed ones.
    let text = std::fs::read_to_string(&out).unwrap();
    let last_move = text.lines().rev().find(|l| l.contains('X')).unwrap();
    let rotary: Vec<&str> = last_move
        .split(' ')
        .filter(|w| w.starts_with(['B', 'C']))
        .collect();
    assert_eq!(rotary.len(), 2, "{last_move}");
    assert!(
        !rotary.contains(&"B20.") && !rotary.contains(&"C90."),
        "{last_move}"
    );
    let six_decimals = text
        .split([' ', '\n'])
        .filter(|w| w.starts_with(['B', 'C']))
        .any(|w| w.split('.').nth(1).is_some_and(|d| d.len() == 6));
    assert!(six_decimals, "{text}");
    // Without the flag the rotary words stay as programmed.
    run(&[]).success();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("B20. C90."), "{text}");
    // A singular pose (B0: the tool along C) compensates; the orientation the bound on the
    // rotary correction leaves is reported with its line, and the bound is the flag's.
    std::fs::write(&program, "G0 X400. Y300. Z300. B30. C45.\nG1 B0. F500\n").unwrap();
    run(&["--orientation", "--max-rotary-correction", "0.5"])
        .success()
        .stdout(
            predicate::str::contains("(at most 0.500°)").and(predicate::str::contains(
                "orientation left            1 line (2) near a singular pose, where the rotary axes cannot turn the tool axis within 0.500°",
            ).and(predicate::str::contains("µrad at line 2"))),
        );
    let report: serde_json::Value = super::json_result(&json);
    assert_eq!(report["orientation_left"][0]["line"], 2, "{report}");
    assert!(report["largest_rotary_correction_deg"].as_f64().unwrap() <= 0.5);
    run(&["--orientation", "--max-rotary-correction", "0"])
        .code(2)
        .stderr(predicate::str::contains("--max-rotary-correction"));
    // A machine without two rotary axes names the flag.
    std::fs::write(&program, "G0 X10. Y10. Z10.\n").unwrap();
    volmap()
        .args([
            "compensate",
            "--machine",
            "vmc-li2015",
            "--orientation",
            "--program",
        ])
        .arg(&program)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--orientation")
                .and(predicate::str::contains("has 0 rotary axes")),
        );
    volmap()
        .args([
            "compensate",
            "--machine",
            "5axis-hwang2014",
            "--orientation",
        ])
        .args(["--angular-tolerance", "0", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--angular-tolerance"));
}

#[test]
fn linuxcnc_runs_the_orientation_compensated_program() {
    if !super::super::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (program, out, canon) = (
        dir.path().join("p.nc"),
        dir.path().join("out.nc"),
        dir.path().join("canon.txt"),
    );
    std::fs::write(&program, PROGRAM).unwrap();
    volmap()
        .args([
            "compensate",
            "--machine",
            "5axis-hwang2014",
            "--orientation",
        ])
        .arg("--program")
        .arg(&program)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let run = crate::common::rs274(&out, &canon);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        run.status.success(),
        "{}\n{text}",
        String::from_utf8_lossy(&run.stderr)
    );
    // Every move reaches the interpreter with its B and C as written (canon prints 4 decimals:
    // X Y Z A B C).
    let canon = std::fs::read_to_string(&canon).unwrap();
    let moves: Vec<Vec<f64>> = canon
        .lines()
        .filter(|l| l.contains("STRAIGHT_"))
        .map(crate::common::canon_numbers)
        .collect();
    let written: Vec<[f64; 2]> = text
        .lines()
        .filter(|l| l.contains('X') && !l.starts_with('('))
        .map(|l| {
            let word = |letter: char| -> f64 {
                let w = l.split(' ').find(|w| w.starts_with(letter)).unwrap();
                w[1..].parse().unwrap()
            };
            [word('B'), word('C')]
        })
        .collect();
    assert_eq!(moves.len(), written.len(), "{canon}\n{text}");
    for (m, w) in moves.iter().zip(&written) {
        assert!(
            (m[4] - w[0]).abs() <= 5e-5 && (m[5] - w[1]).abs() <= 5e-5,
            "{m:?} {w:?}"
        );
    }
}
