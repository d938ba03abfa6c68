//! `volmap compensate`.

use predicates::prelude::*;

use super::volmap;

#[test]
fn compensate_writes_a_new_program_and_never_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dobariya2015");
    let out = dir.path().join("compensated.nc");
    let json = dir.path().join("report.json");
    volmap()
        .args(["compensate", "--machine"])
        .arg(example.join("machine.toml"))
        .arg("--program")
        .arg(example.join("test-piece.nc"))
        .args(["--work-offset", "G54=0,0,10", "--out"])
        .arg(&out)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("largest correction")
                .and(predicate::str::contains("blocks changed"))
                .and(predicate::str::contains("µm before")),
        );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("N60 X39.8168 F200 (SLOT ALONG X: 30 MM BETWEEN ITS CENTRES)"),
        "{text}"
    );
    let report: serde_json::Value = super::json_result(&json);
    assert!(report["largest_error_after_mm"].as_f64().unwrap() <= 1e-3);
    // The input is never the output.
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X20\n").unwrap();
    volmap()
        .args(["compensate", "--machine", "vmc-li2015", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&program)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("never writes over it"));
    assert_eq!(
        std::fs::read_to_string(&program).unwrap(),
        "G0 X10 Y10 Z10\nG1 X20\n"
    );
    // A bad program: the line and the reason, exit 2, nothing written.
    std::fs::write(&program, "G0 X10 Y10 Z10\nG2 X20 Y20\n").unwrap();
    let never = dir.path().join("never.nc");
    volmap()
        .args(["compensate", "--machine", "vmc-li2015", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "p.nc: line 2: an arc (G2) needs its centre",
        ));
    std::fs::write(&program, [0u8, 159, 146, 150]).unwrap();
    volmap()
        .args(["compensate", "--machine", "vmc-li2015", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not a text file"));
    assert!(!never.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        3,
        "no temporary files left"
    );
}

/// A gantry whose X scale grows 11.5 µm/m per kelvin and whose X has a 10 µm backlash.
const THERMAL_GANTRY: &str = r#"
name = "gantry"
chain = "FFXYZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale"]
[axes.X]
range = [0.0, 2000.0]
EXX = { value = 0.0, reverse = 0.010, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }
[axes.Y]
range = [0.0, 1500.0]
[axes.Z]
range = [0.0, 800.0]
"#;

#[test]
fn compensate_takes_the_temperatures_and_the_starting_directions() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("gantry.toml");
    std::fs::write(&machine, THERMAL_GANTRY).unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G90 G0 X100. Y10. Z10.\nG1 Y20. F500\nX500.\n").unwrap();
    let (out, json) = (dir.path().join("out.nc"), dir.path().join("r.json"));
    let run = |extra: &[&str]| {
        let mut command = volmap();
        command
            .args(["compensate", "--machine"])
            .arg(&machine)
            .arg("--program")
            .arg(&program)
            .arg("--out")
            .arg(&out)
            .arg("--json")
            .arg(&json)
            .args(extra);
        command.assert()
    };
    run(&["--temperatures", "x_scale=30", "--approach", "X=-"])
        .success()
        .stdout(
            predicate::str::contains("approach X- Y+ Z+; temperatures x_scale=30 °C")
                .and(predicate::str::contains("take-ups at reversals       1")),
        );
    // Hand-derived: at 30 °C the tip lies at q·(1 + 11.5e-6·10); X starts approaching `−`
    // (tip W = 0.010 further), so X100 is commanded at (100 − 0.010)/1.000115 = 99.9785;
    // X500 approached `+`: 500/1.000115 = 499.9425 (the expansion α·x·ΔT = 0.0575 removed).
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // The program records what it was compensated for, as a comment of its own.
    assert_eq!(
        lines[0],
        "(compensated by volmap for gantry at approach X- Y+ Z+; temperatures x_scale=30 C [reference 20 C]; each axis then approaches in the direction it moves)"
    );
    assert_eq!(lines[1], "G90 G0 X99.9785 Y10.0 Z10.0", "{text}");
    assert_eq!(lines[2], "G1 Y20.0 F500", "{text}");
    assert_eq!(lines.last().unwrap(), &"X499.9425", "{text}");
    let report: serde_json::Value = super::json_result(&json);
    let inputs = &report["inputs"];
    assert_eq!(inputs["temperatures_c"]["x_scale"], 30.0);
    assert_eq!(inputs["approach_at_start"]["X"], "-");
    assert_eq!(inputs["reference_c"], 20.0);
    assert_eq!(report["take_ups"], 1);
    // Bad values: exit 2, the flag named, nothing written.
    std::fs::remove_file(&out).unwrap();
    for (flag, value, message) in [
        ("--temperatures", "spindle=30", "not a thermal input"),
        ("--temperatures", "x_scale=warm", "not a finite number"),
        ("--temperatures", "x_scale", "NAME=VALUE"),
        ("--approach", "X=up", "the approach direction is + or -"),
        ("--approach", "B=-", "not an axis of this machine"),
    ] {
        run(&[flag, value]).code(2).stderr(
            predicate::str::contains(format!("{flag}: ")).and(predicate::str::contains(message)),
        );
        assert!(!out.exists());
    }
}

#[test]
fn linuxcnc_runs_the_compensated_programs_without_an_error() {
    if !super::super::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("gantry.toml");
    std::fs::write(&machine, THERMAL_GANTRY).unwrap();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dobariya2015");
    // Lines, arcs both ways with reversals on them, and the tape delimiters.
    let arcs = dir.path().join("arcs.nc");
    std::fs::write(
        &arcs,
        "%\nG21 G90 G17 G0 X80. Y50. Z10.\nG1 X100. F500\nG2 X100. Y50. I-20. J0\nG3 X60. Y50. R20.\nG1 X70. Y40.\nM2\n%\n",
    )
    .unwrap();
    // Arcs of every kind split into compensated arcs on an embedded machine: I J K and R
    // pieces, G18, a helix.
    let split = dir.path().join("split.nc");
    std::fs::write(
        &split,
        "G90 G17 G21 G54\nG0 X0 Y0 Z5.\nG1 Z-2. F300\nG1 X40. F800\nG3 X40. Y0 I-40. J0\nG2 X0 Y40. R40.\nG1 X-30.\nG3 X-60. Y10. I-15. J-15.\nG18 G2 X-90. Z-2. I-15. K0\nG17 G2 X-90. Y10. Z-5. I20. J0\nG0 Z5.\nM2\n",
    )
    .unwrap();
    for (machine, program, extra) in [
        (
            machine.clone(),
            arcs.clone(),
            vec!["--temperatures", "x_scale=28"],
        ),
        (
            std::path::PathBuf::from("gantry-2m"),
            split,
            vec!["--work-offset", "G54=400,300,100"],
        ),
        (machine.clone(), arcs, vec!["--approach", "X=-,Y=-"]),
        (
            example.join("machine.toml"),
            example.join("test-piece.nc"),
            vec!["--work-offset", "G54=0,0,10"],
        ),
    ] {
        let out = dir.path().join("out.nc");
        volmap()
            .args(["compensate", "--machine"])
            .arg(&machine)
            .arg("--program")
            .arg(&program)
            .arg("--out")
            .arg(&out)
            .args(&extra)
            .assert()
            .success();
        let canon = dir.path().join("canon.txt");
        let run = crate::common::rs274(&out, &canon);
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(
            run.status.success(),
            "rs274 on {}: {}\n{text}",
            program.display(),
            String::from_utf8_lossy(&run.stderr)
        );
        // The interpreter read the record and every move: one canonical move per moving line.
        let canon = std::fs::read_to_string(&canon).unwrap();
        assert!(
            canon.contains("COMMENT(\"compensated by volmap for"),
            "{canon}"
        );
        let moves = canon
            .lines()
            .filter(|l| l.contains("STRAIGHT_") || l.contains("ARC_FEED"))
            .count();
        let moving_lines = text.lines().filter(|l| has_axis_word(l)).count();
        assert_eq!(moves, moving_lines, "{canon}\n{text}");
    }
}

/// Whether an NC line, its comments left out, has an X, Y or Z word.
fn has_axis_word(line: &str) -> bool {
    let mut code = String::new();
    let mut depth = 0;
    for c in line.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            c if depth == 0 => code.push(c),
            _ => {}
        }
    }
    let bytes = code.as_bytes();
    bytes.windows(2).any(|w| {
        matches!(w[0], b'X' | b'Y' | b'Z') && (w[1].is_ascii_digit() || matches!(w[1], b'-' | b'.'))
    })
}

#[test]
fn the_report_lists_expanded_holes_and_blocks_passed_uncompensated() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(
        &program,
        "G90 G17 G21\nG0 X10 Y10 Z10\nG98 G81 X20 Y10 Z-5 R2 F100\nX40\nG80\nG51 X0 Y0 P2\nG0 X50 Y50\nM30\n",
    )
    .unwrap();
    volmap()
        .args([
            "compensate",
            "--machine",
            "vmc-li2015",
            "--work-offset",
            "G54=200,200,300",
        ])
        .arg("--program")
        .arg(&program)
        .arg("--out")
        .arg(dir.path().join("out.nc"))
        .arg("--pass-unknown")
        .assert()
        .success()
        .stdout(
            predicate::str::contains("canned cycle holes          2 expanded").and(
                predicate::str::contains(
                    "not compensated             1 blocks passed as they are, lines 6 (G51)",
                ),
            ),
        );
}

/// The issue's reproducer through the command line: the passed block and the move after it that
/// depends on it are listed on stdout and in `--json`, and `trace` says the same move is not
/// traced.
#[test]
fn moves_after_a_passed_block_are_listed_on_stdout_and_in_json() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("unk.nc");
    std::fs::write(
        &program,
        "G90 G21 G17\nG0 X10 Y10 Z10\nG10 L2 P1 X5\nG1 X50 F100\nG1 X[1+2] Y20\nG1 Y40\nM30\n",
    )
    .unwrap();
    let json = dir.path().join("r.json");
    volmap()
        .args(["compensate", "--machine", "vmc-li2015"])
        .args(["--work-offset", "G54=300,200,250", "--pass-unknown"])
        .arg("--program")
        .arg(&program)
        .arg("--out")
        .arg(dir.path().join("out.nc"))
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "moves left as they are      1, lines 6 (X Y not known since line 5)",
        ));
    let report: serde_json::Value = super::json_result(&json);
    assert_eq!(report["not_compensated"][0]["line"], 5);
    assert_eq!(report["moves_not_compensated"][0]["line"], 6);
    assert_eq!(report["moves_not_compensated"][0]["unknown"], "X Y");
    assert_eq!(report["moves_not_compensated"][0]["since_line"], 5);
    volmap()
        .args(["trace", "--machine", "vmc-li2015"])
        .args(["--work-offset", "G54=300,200,250", "--pass-unknown"])
        .arg("--program")
        .arg(&program)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "not traced     1 moves, lines 6 (X Y not known since line 5)",
        ));
}
