//! `volmap compensate` keeps a program only after checking it: a written program that strays
//! from the program exits 1, one whose model trace is beyond the chord tolerance exits 4 unless
//! `--allow-residual`; neither writes anything.

use predicates::prelude::*;

use super::volmap;

/// A gantry whose X reversal error is negative (the tip runs 0.05 mm ahead of the command on the
/// way back): where a piece's compensated motion runs against the direction it was compensated
/// for, the machine misses it by up to that 0.05 mm, which the report's "after" does not see.
const MACHINE: &str = r#"name = "gantry"
chain = "FFXYZ"
[axes.X]
range = [0.0, 2000.0]
EXX = { poly = [0.0], reverse = { poly = [-0.05] } }
EYX = { poly = [0.0, 0.0, 1.0e-5] }
[axes.Y]
range = [0.0, 1500.0]
[axes.Z]
range = [0.0, 800.0]
"#;

const PROGRAM: &str =
    "G90 G21 G17\nG0 X100 Y100 Z10\nG1 X200 F100\nG1 Y200\nG1 X100\nG1 X100.02 Y300\nG0 Z50\nM30\n";

#[test]
fn a_residual_beyond_the_tolerance_exits_4_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let (machine, program, out) = (
        dir.path().join("m.toml"),
        dir.path().join("p.nc"),
        dir.path().join("out.nc"),
    );
    std::fs::write(&machine, MACHINE).unwrap();
    std::fs::write(&program, PROGRAM).unwrap();
    let run = |extra: &[&str]| {
        let mut command = volmap();
        command
            .args(["compensate", "--machine"])
            .arg(&machine)
            .arg("--program")
            .arg(&program)
            .arg("--out")
            .arg(&out)
            .args(extra);
        command.assert()
    };
    // By hand: lines 5 and 6 run X back (X200 to X100, then the 0.02 mm step of X forward after
    // it), where the compensated pieces run against the direction they were compensated for;
    // the reversal error is 0.05 mm, so the tip misses by 0.05 mm (to the 4 decimals shown).
    run(&[]).code(4).stderr(
        predicate::str::contains("up to 0.0500 mm from the intended path")
            .and(predicate::str::contains("on lines 5, 6"))
            .and(predicate::str::contains("nothing was written"))
            .and(predicate::str::contains("hint: --allow-residual")),
    );
    assert!(!out.exists());
    run(&["--allow-residual"]).success().stderr(
        predicate::str::contains("warning: ")
            .and(predicate::str::contains("on lines 5, 6"))
            .and(predicate::str::contains("--allow-residual")),
    );
    assert!(std::fs::read_to_string(&out).unwrap().contains("G1 Y"));
}

#[test]
fn a_written_program_that_strays_exits_1_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (program, out) = (dir.path().join("p.nc"), dir.path().join("out.nc"));
    std::fs::write(&program, "G90 G21 G17\nG0 X10 Y10 Z10\nG1 X50 F100\nM30\n").unwrap();
    let run = |corrupt: &str| {
        let mut command = volmap();
        command
            .env("VOLMAP_TEST_CORRUPT_OUTPUT", corrupt)
            .args(["compensate", "--machine", "vmc-li2015", "--work-offset"])
            .arg("G54=300,200,250")
            .arg("--program")
            .arg(&program)
            .arg("--out")
            .arg(&out);
        command.assert()
    };
    // The test hook appends `G1 X0 Y0 Z0 F100` to the output: a move after the program's last,
    // 40 mm away from it.
    run("1").code(1).stderr(
        predicate::str::contains("nothing was written to")
            .and(predicate::str::contains(
                "p.nc: line 3: the compensated program does not follow it",
            ))
            .and(predicate::str::contains("`G1 X0 Y0 Z0 F100`")),
    );
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 1, "{leftovers:?}");
    run("").success();
    assert!(out.exists());
    // `trace --compensate` traces what `compensate` would keep, checked the same way.
    volmap()
        .env("VOLMAP_TEST_CORRUPT_OUTPUT", "1")
        .args([
            "trace",
            "--compensate",
            "--machine",
            "vmc-li2015",
            "--work-offset",
        ])
        .arg("G54=300,200,250")
        .arg("--program")
        .arg(&program)
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "p.nc: line 3: the compensated program does not follow it",
        ));
}
