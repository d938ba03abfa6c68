//! Codes that name the point where the tool stands anew (G92, G10 L20) in a compensated program,
//! the level a canned cycle returns to after a setting, and arcs passed as they are (docs/nc.md,
//! "Reading"). The control takes the point it has, the compensated one: the shift or offset it
//! sets must be the program's, or every move after it is off by the correction there.

use volmap::model::Machine;
use volmap::nc::{self, NcError, Options};

fn machine() -> Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
}

fn options(pass_unknown: bool) -> Options {
    Options {
        work_offsets: [(54, [300.0, 200.0, 250.0, 0.0, 0.0, 0.0])].into(),
        pass_unknown,
        ..Options::default()
    }
}

/// The numbers of the words `letters` on `line`, in that order.
fn words(line: &str, letters: &str) -> Vec<f64> {
    letters
        .chars()
        .map(|l| {
            let at = line.find(l).unwrap_or_else(|| panic!("no {l} in `{line}`")) + 1;
            let end = line[at..]
                .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
                .map_or(line.len(), |e| at + e);
            line[at..end].parse().unwrap()
        })
        .collect()
}

/// By hand: the rapid to X10 Y10 Z10 is written as one block, at the compensated point (a, b, c);
/// the control reads that point as the G92 block's values, so volmap writes them moved by the
/// correction there: X(a − 10) Y(b − 10) Z(c − 10), and the shift the control sets is the
/// program's, (310, 210, 260) − 0 in machine coordinates less the offset.
#[test]
fn g92_names_the_written_point() {
    let program = "G90 G21 G17\nG0 X10 Y10 Z10\nG92 X0 Y0 Z0\nG1 X20 F100\nG92.1\nM30\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "g92.nc", &options(false)).unwrap();
    let lines: Vec<&str> = out.text.lines().filter(|l| !l.starts_with('(')).collect();
    let rapid = words(lines[1], "XYZ");
    let g92 = words(lines[2], "XYZ");
    assert!(lines[2].starts_with("G92 "), "{}", out.text);
    for d in 0..3 {
        assert!((g92[d] - (rapid[d] - 10.0)).abs() < 1e-9, "{}", out.text);
    }
    // The correction there is not nothing on this machine: the block was rewritten.
    assert_ne!(lines[2], "G92 X0 Y0 Z0");
}

/// LinuxCNC's `rs274` runs the original and the compensated program: the G92 shift and the G54
/// offset set by G10 L20 are the same in both (to rs274's 4 printed decimals and the rounding of
/// the written values, 1.5e-4 mm), and so far apart without the rewrite (the correction, more
/// than 1e-3 mm here).
#[test]
fn g92_and_g10_l20_agree_with_rs274() {
    if !crate::nc_unknown::rs274_available() {
        return;
    }
    let program = "G90 G21 G17\nG0 X10 Y10 Z10\nG1 X50 F100\nG92 X0 Y0 Z0\nG1 X20 Y5\nG92.1\nG1 Z30\nG10 L20 P1 Z2\nG1 Y40\nM30\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "s.nc", &options(false)).unwrap();
    let offsets = |text: &str| -> Vec<Vec<f64>> {
        let canon = crate::nc_unknown::rs274_canon(&format!("G10 L2 P1 X300 Y200 Z250\n{text}"));
        canon
            .lines()
            .filter(|l| l.contains("SET_G92_OFFSET(") || l.contains("SET_G5X_OFFSET("))
            .map(crate::common::canon_numbers)
            .collect()
    };
    let (original, compensated) = (offsets(program), offsets(&out.text));
    assert_eq!(original.len(), compensated.len());
    assert!(original.len() >= 4, "{original:?}");
    for (o, c) in original.iter().zip(&compensated) {
        assert_eq!(o.len(), c.len());
        for (a, b) in o.iter().zip(c) {
            assert!((a - b).abs() < 1.5e-4, "{original:?}\n{compensated:?}");
        }
    }
    // Written as given, the G92 shift would differ by the correction at X50 Y10 Z10.
    let plain = offsets(&out.text.replace(
        out.text.lines().find(|l| l.starts_with("G92 X")).unwrap(),
        "G92 X0 Y0 Z0",
    ));
    let g92 = |o: &[Vec<f64>]| o.iter().find(|v| v.len() == 6 && v[0] != 0.0).cloned();
    let (a, b) = (g92(&original).unwrap(), g92(&plain).unwrap());
    assert!((0..3).any(|d| (a[d] - b[d]).abs() > 1e-3), "{a:?} {b:?}");
}

/// A canned cycle returns (G98) to the level Z had before it, in the coordinates in force: after
/// G10 L2 raises G54's Z by 10 the tool at Z50 reads Z40; after G92 Z0 it reads 0, after G92.1
/// Z50 again. Every hole's last rapid ends at machine Z 300 (250 + 50), by hand.
#[test]
fn cycles_return_to_their_level_after_settings() {
    let program = "G90 G21 G17\nG0 X0 Y0 Z50\nG10 L2 P1 Z260\nG98 G81 X10 Y10 Z-5 R5 F100\nG80\nG10 L2 P1 Z250\nG92 Z0\nG98 G81 X20 Y10 Z-55 R-45 F100\nG80\nG92.1\nG98 G81 X30 Y10 Z-5 R5 F100\nG80\nM30\n";
    let points = nc::trace(&machine(), program.as_bytes(), "c.nc", &options(false)).unwrap();
    for line in [4, 8, 11] {
        let last = points.iter().rev().find(|p| p.line == line).unwrap();
        assert!(
            (last.command[2] - 300.0).abs() < 1e-9,
            "line {line}: {:?}",
            last.command
        );
    }
}

/// An absolute arc that depends on an axis a passed block left unknown passes as it is; after a
/// compensated move its start is not its programmed start in the arc's plane and its centre
/// words would not fit: refused naming the line. The same arc in G91 keeps its shape (centre and
/// end move with the start) and passes.
#[test]
fn an_arc_passed_after_a_compensated_move_is_refused() {
    let absolute = "G90 G21 G17\nG0 X10 Y10 Z10\nG1 X#100 F100\nG2 X20 Y10 I5 J0\nM30\n";
    match nc::compensate(&machine(), absolute.as_bytes(), "a.nc", &options(true)) {
        Err(NcError::Line { line, message, .. }) => {
            assert_eq!(line, 4);
            assert!(message.contains("centre words no longer fit"), "{message}");
        }
        other => panic!("expected a refusal of line 4, got {other:?}"),
    }
    let incremental = "G90 G21 G17\nG0 X10 Y10 Z10\nG1 X#100 F100\nG91 G2 X10 I5 J0\nM30\n";
    let out = nc::compensate(&machine(), incremental.as_bytes(), "i.nc", &options(true)).unwrap();
    assert!(out.text.contains("\nG91 G2 X10 I5 J0\n"), "{}", out.text);
}
