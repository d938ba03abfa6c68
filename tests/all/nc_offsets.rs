//! A change of work offset moves nothing: the axes stand where they stood and read, in the new
//! offset's coordinates, machine position − new offset (docs/nc.md, "Reading the program").
//! Expected figures by hand from the offsets; the rs274 corpus (`nc_rs274`, features
//! "offset-change" and "offset-direction") checks the same at random against LinuxCNC.

use volmap::model::inputs::Approach;
use volmap::model::Machine;
use volmap::nc::{self, Options};

fn gantry() -> Machine {
    volmap::io::embedded::embedded("gantry-2m")
        .unwrap()
        .unwrap()
}

fn options() -> Options {
    Options {
        work_offsets: [
            (54, [400.0, 300.0, 250.0, 0.0, 0.0, 0.0]),
            (55, [410.0, 290.0, 255.0, 0.0, 0.0, 0.0]),
        ]
        .into(),
        ..Options::default()
    }
}

/// The value of `letter` in a written block, if it has one.
fn word(block: &str, letter: char) -> Option<f64> {
    block
        .split_whitespace()
        .find(|w| w.starts_with(letter))
        .map(|w| w[1..].parse().unwrap())
}

/// The reproducer: G55 alone, then a move naming Y only. The machine stands at X 385.8407,
/// Z 271.8763 (G54: −14.1593 + 400, 21.8763 + 250), which G55 reads as X −24.1593 (385.8407 −
/// 410), Z 16.8763 (271.8763 − 255). Every X and Z word written after G55 is that plus at most
/// the largest correction (the compensation's small moves about where the machine stands; the
/// bound is volmap's own largest correction, 0.01 mm here, against the offsets' 10 mm and 5 mm
/// difference the fault wrote).
#[test]
fn a_work_offset_changed_alone_moves_no_axis_the_next_block_does_not_name() {
    let program = "G90 G21 G17\nG0 X-14.1593 Y83.5742 Z21.8763\nG55\nG1 Y1.1815 F100\nM30\n";
    let out = nc::compensate(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let bound = out.report.largest_correction_mm + 1e-4;
    assert!(bound < 0.05, "largest correction {bound}");
    let lines: Vec<&str> = out.text.lines().collect();
    let g55 = lines.iter().position(|l| *l == "G55").expect("G55 passes");
    let after: Vec<&str> = lines[g55 + 1..]
        .iter()
        .copied()
        .filter(|l| !l.starts_with('M'))
        .collect();
    assert!(!after.is_empty(), "{}", out.text);
    let mut ends_y = None;
    for block in &after {
        for (letter, stands) in [('X', -24.1593), ('Z', 16.8763)] {
            if let Some(v) = word(block, letter) {
                assert!(
                    (v - stands).abs() <= bound,
                    "{block}: {letter} off {stands}\n{}",
                    out.text
                );
            }
        }
        ends_y = word(block, 'Y').or(ends_y);
    }
    // The move ends at the programmed Y (in G55) plus its correction.
    assert!((ends_y.unwrap() - 1.1815).abs() <= bound, "{}", out.text);
    // The same where the next block names X and Y: Z stays.
    let program = "G0 X0 Y0 Z20\nG55\nG1 X5 Y5 F100\nM30\n";
    let out = nc::compensate(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let bound = out.report.largest_correction_mm + 1e-4;
    for block in out.text.lines().skip_while(|l| *l != "G55") {
        if let Some(z) = word(block, 'Z') {
            // 20 + 250 − 255.
            assert!((z - 15.0).abs() <= bound, "{block}\n{}", out.text);
        }
    }
}

/// The first positioning block under another offset than G54: the axes start where it puts
/// them (the program does not move them on the way there), and the next move names X only: Y
/// and Z keep the G55 values the first block gave, plus the correction.
#[test]
fn a_program_that_starts_under_g55_starts_where_its_first_block_says() {
    let program = "G55 G0 X10 Y20 Z30\nG1 X50 F100\nM30\n";
    let out = nc::compensate(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let bound = out.report.largest_correction_mm + 1e-4;
    for block in out
        .text
        .lines()
        .filter(|l| l.starts_with('G') || l.starts_with('X'))
    {
        for (letter, value) in [('Y', 20.0), ('Z', 30.0)] {
            if let Some(v) = word(block, letter) {
                assert!((v - value).abs() <= bound, "{block}\n{}", out.text);
            }
        }
    }
}

/// Trace reads the program as compensate does: after G55 alone, a move naming Y keeps the
/// machine's X and Z (the commands equal those before it, by hand from the offsets), and the
/// direction each axis approaches in is that of the machine: G54 Y5 is machine Y 305, G55 Y10 is
/// machine Y 300, so Y arrives going −, though its program coordinate grew.
#[test]
fn trace_carries_the_position_over_a_change_of_offset_in_machine_coordinates() {
    let program = "G0 X-14.1593 Y83.5742 Z21.8763\nG55\nG1 Y1.1815 F100\nM30\n";
    let points = nc::trace(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let last = points.last().unwrap();
    assert_eq!(last.line, 3);
    for (d, machine) in [(0, 385.8407), (1, 291.1815), (2, 271.8763)] {
        assert!(
            (last.command[d] - machine).abs() < 1e-9,
            "{:?}",
            last.command
        );
    }
    assert!(
        (last.program[0] + 24.1593).abs() < 1e-9,
        "{:?}",
        last.program
    );
    // X and Z do not move: they keep the initial direction (+); Y goes −.
    assert_eq!(
        last.approach[..3],
        [Approach::Positive, Approach::Negative, Approach::Positive]
    );

    let program = "G0 X0 Y5 Z20\nG55 G0 X10 Y10 Z20\nM30\n";
    let points = nc::trace(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let last = points.last().unwrap();
    // X: 400 → 420 (+); Y: 305 → 300 (−); Z: 270 → 275 (+).
    assert_eq!(
        last.approach[..3],
        [Approach::Positive, Approach::Negative, Approach::Positive]
    );
    let first = &points[0];
    assert_eq!(first.approach[1], Approach::Positive);
    let program = "G0 X0 Y20 Z20\nG55 G0 X10 Y5 Z20\nG54 G0 Y12\nM30\n";
    let points = nc::trace(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    // Y: 320 → 295 (−) → 312 (+), and back in G54 the program Y is the machine's − 300.
    assert_eq!(points[1].approach[1], Approach::Negative);
    assert_eq!(points[2].approach[1], Approach::Positive);
    assert!(
        (points[2].command[0] - 420.0).abs() < 1e-9,
        "{:?}",
        points[2].command
    );
}

/// A drilling cycle after G55 alone retracts (G98) to where Z stood before it: machine Z 300
/// (G54 Z50), which G55 reads as 45 (300 − 255); the expanded retract is that plus at most the
/// largest correction, not the 50 of the old offset.
#[test]
fn a_cycle_after_a_change_of_offset_retracts_to_where_z_stood() {
    let program = "G0 X0 Y0 Z50\nG55\nG98 G81 X10 Y10 Z-5 R2 F100\nG80\nM30\n";
    let out = nc::compensate(&gantry(), program.as_bytes(), "p.nc", &options()).unwrap();
    let bound = out.report.largest_correction_mm + 1e-4;
    let last_z = out
        .text
        .lines()
        .take_while(|l| *l != "G80")
        .filter_map(|l| word(l, 'Z'))
        .last()
        .unwrap();
    assert!((last_z - 45.0).abs() <= bound, "{}", out.text);
}
