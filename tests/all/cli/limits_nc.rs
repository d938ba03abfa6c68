//! The limits of `trace` and `compensate` (issue 33): a program's blocks counted before it is
//! read, memory bounded by the moves, and refusals that name the flag that is their cause.

use super::trace::SCALE;
use super::{refused, volmap, volmap_under};

/// A program of `moves` short feed moves (0.01 mm apart, rows of 700).
fn short_moves(moves: usize) -> String {
    let mut program = String::from("G90 G54 G0 X0 Y0 Z10\nG1 Z0 F500\n");
    for i in 0..moves {
        let (x, y) = ((i % 700) as f64 * 0.01, (i / 700) as f64 * 0.01);
        program.push_str(&format!("X{x:.3} Y{y:.3}\n"));
    }
    program + "M30\n"
}

fn setup(program: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.toml"), SCALE).unwrap();
    std::fs::write(dir.path().join("p.nc"), program).unwrap();
    dir
}

#[test]
fn a_program_of_more_blocks_than_the_limit_is_refused_before_it_is_read() {
    // 1,000,037 blocks, most of them empty lines (1 MB): over the limit of 1,000,000 by 37.
    let mut program = short_moves(30);
    program.push_str(&"\n".repeat(1_000_037 - 33));
    let dir = setup(&program);
    for command in [
        vec!["trace", "--machine", "m.toml", "--program", "p.nc"],
        vec![
            "compensate",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--out",
            "c.nc",
        ],
    ] {
        refused(
            &command,
            dir.path(),
            &["p.nc", "1000037 blocks", "more than the limit of 1000000"],
        );
        assert!(!dir.path().join("c.nc").exists());
    }
}

#[test]
fn trace_and_compensate_run_short_moves_in_memory_bounded_by_the_moves() {
    // 24,000 moves of 0.01 mm. The bound: 150 MiB for the binary and its threads (a program of
    // three moves compensates under it) and 5 KiB a move. Measured (docs/nc.md): about 1.2 KiB
    // a move for trace and 2.1 KiB for compensate at their peak; the reader held about 600
    // bytes a line for every copy of the program before (issue 33), and a run holds several.
    let moves = 24_000;
    let dir = setup(&short_moves(moves));
    let kib = 150 * 1024 + 5 * moves as u64;
    volmap_under(&format!("-v {kib}"))
        .current_dir(dir.path())
        .args(["trace", "--machine", "m.toml", "--program", "p.nc"])
        .assert()
        .code(0);
    volmap_under(&format!("-v {kib}"))
        .current_dir(dir.path())
        .args([
            "compensate",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--out",
            "c.nc",
        ])
        .assert()
        .code(0);
    // Every move written (the X correction changes each one): as many lines as the program.
    let written = std::fs::read_to_string(dir.path().join("c.nc")).unwrap();
    assert!(
        written.lines().count() >= moves + 3,
        "{}",
        written.lines().count()
    );
}

#[test]
fn decimals_whose_rounding_exceeds_the_chord_tolerance_are_refused_naming_decimals() {
    let dir = setup(&short_moves(3));
    // 1 decimal rounds by up to 0.05 mm, more than 0.01 mm; log10(0.5 / 0.01) = 1.7: 2 decimals.
    let message = refused(
        &[
            "compensate",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--out",
            "c.nc",
            "--decimals",
            "1",
            "--chord-tolerance",
            "0.01",
        ],
        dir.path(),
        &[
            "--decimals",
            "0.05 mm",
            "chord tolerance of 0.01 mm",
            "at least 2 decimals",
        ],
    );
    assert!(!message.contains("error: --chord-tolerance"), "{message}");
    // 0 decimals (the issue's) against the default 0.001 mm: 0.5 mm; 3 decimals are needed.
    refused(
        &[
            "trace",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--compensate",
            "--decimals",
            "0",
        ],
        dir.path(),
        &["--decimals", "0.5 mm", "at least 3 decimals"],
    );
    // Before the program is read or traced: a program trace would refuse at its second line is
    // not looked at.
    std::fs::write(dir.path().join("bad.nc"), "G0 X0 Y0 Z10\nG1 X F100\n").unwrap();
    refused(
        &[
            "trace",
            "--machine",
            "m.toml",
            "--program",
            "bad.nc",
            "--compensate",
            "--decimals",
            "0",
        ],
        dir.path(),
        &["error: --decimals", "at least 3 decimals"],
    );
    // 2 decimals round by 0.005 mm, within 0.01 mm: accepted.
    volmap()
        .current_dir(dir.path())
        .args([
            "compensate",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--out",
            "c.nc",
        ])
        .args(["--decimals", "2", "--chord-tolerance", "0.01"])
        .assert()
        .code(0);
}

#[test]
fn an_angular_tolerance_below_the_rounding_of_rotary_words_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.nc"),
        "G90 G0 X0 Y0 Z50 B10 C0\nG1 X20 Y10 B12 C5 F500\nM30\n",
    )
    .unwrap();
    // Rotary words carry 6 decimals of a degree: 0.5e-6° = 8.73e-9 rad of rounding.
    for tolerance in ["1e-300", "5e-9"] {
        refused(
            &[
                "compensate",
                "--machine",
                "5axis-hwang2014",
                "--program",
                "p.nc",
                "--out",
                "c.nc",
                "--orientation",
                "--angular-tolerance",
                tolerance,
            ],
            dir.path(),
            &[
                "--angular-tolerance",
                "6 decimals of a degree",
                "8.73e-9 rad",
            ],
        );
    }
    // With 9 decimals the rounding is 8.73e-12 rad: 5e-9 rad passes this check (whatever the
    // compensation then finds).
    let output = volmap()
        .current_dir(dir.path())
        .args([
            "compensate",
            "--machine",
            "5axis-hwang2014",
            "--program",
            "p.nc",
        ])
        .args([
            "--out",
            "c.nc",
            "--orientation",
            "--angular-tolerance",
            "5e-9",
        ])
        .args(["--decimals", "9"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("decimals of a degree"), "{stderr}");
}

#[test]
fn a_step_too_short_says_every_move_takes_four_samples() {
    // One move of 100 mm at a step of 1e-5 mm: 1e7 samples, and the first block (a rapid that
    // goes nowhere) one: 10,000,001, over the limit of 4,000,000.
    let dir = setup("G90 G0 X0 Y0 Z10\nG1 X100 F500\nM30\n");
    refused(
        &[
            "trace",
            "--machine",
            "m.toml",
            "--program",
            "p.nc",
            "--step",
            "1e-5",
        ],
        dir.path(),
        &[
            "--step",
            "10000001 samples",
            "take a longer step",
            "4 samples at least",
        ],
    );
}
