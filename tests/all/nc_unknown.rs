//! Blocks volmap does not model and codes that set coordinates without moving (docs/nc.md,
//! "Reading"): no move is invented after them. Passed blocks leave the axes they may move
//! unknown, moves that depend on them pass as they are and are listed; G10 L2/L20, G52, G92 and
//! a change of work offset are applied where their meaning is definite, checked against LinuxCNC's
//! `rs274`, and refused otherwise.

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

fn line_error(result: Result<impl std::fmt::Debug, NcError>) -> (usize, String) {
    match result {
        Err(NcError::Line { line, message, .. }) => (line, message),
        other => panic!("expected an error naming a line, got {other:?}"),
    }
}

pub fn rs274_available() -> bool {
    crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    )
}

/// What `rs274` makes of `program`: its canonical output, run to the end.
pub fn rs274_canon(program: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("p.ngc");
    std::fs::write(&file, program).unwrap();
    let canon = dir.path().join("canon.txt");
    let run = crate::common::rs274(&file, &canon);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let canon = std::fs::read_to_string(&canon).unwrap();
    assert!(canon.contains("PROGRAM_END"), "{canon}");
    canon
}

/// The machine position (X Y Z) at the end of every straight move `rs274` makes of `program`:
/// its canonical positions are in the coordinates in force, so the work offset and the G92/G52
/// offset it reports are added.
fn rs274_machine_points(program: &str) -> Vec<[f64; 3]> {
    let canon = rs274_canon(program);
    let numbers = crate::common::canon_numbers;
    let (mut g5x, mut g92) = ([0.0; 3], [0.0; 3]);
    let mut points = Vec::new();
    for l in canon.lines() {
        if l.contains("SET_G5X_OFFSET(") {
            let n = numbers(l);
            g5x = [n[1], n[2], n[3]];
        } else if l.contains("SET_G92_OFFSET(") {
            let n = numbers(l);
            g92 = [n[0], n[1], n[2]];
        } else if l.contains("STRAIGHT_TRAVERSE(") || l.contains("STRAIGHT_FEED(") {
            let n = numbers(l);
            points.push(std::array::from_fn(|d| n[d] + g5x[d] + g92[d]));
        }
    }
    points
}

/// The reproducer: `G10 L2 P1 X5` sets G54's X and moves nothing; `G1 X[1+2] Y20` passes
/// and leaves X and Y unknown, so `G1 Y40` is written as it is (no X word: the control is at X3
/// there) and listed; the report lists both.
#[test]
fn the_reproducer_writes_no_invented_move() {
    let program =
        "G90 G21 G17\nG0 X10 Y10 Z10\nG10 L2 P1 X5\nG1 X50 F100\nG1 X[1+2] Y20\nG1 Y40\nM30\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "unk.nc", &options(true)).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    assert!(lines.contains(&"G10 L2 P1 X5"), "{}", out.text);
    assert!(lines.contains(&"G1 X[1+2] Y20"), "{}", out.text);
    assert!(lines.contains(&"G1 Y40"), "{}", out.text);
    let passed: Vec<usize> = out.report.not_compensated.iter().map(|p| p.line).collect();
    assert_eq!(passed, [5]);
    let left: Vec<(usize, &str, usize)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str(), m.since_line))
        .collect();
    assert_eq!(left, [(6, "X Y", 5)]);
    // The G1 X50 after the G10 goes, on the control, from machine X 310 (X10 under G54 X=300)
    // to machine X 55 (X50 under G54 X=5): volmap reads its start as X305 in the new
    // coordinates, so the compensated move ends within the largest correction (0.13 mm on this
    // machine, well above the 0.12 mm reported) of X50, not 5 mm short of it (the invented
    // backward feed of the issue ended at X4.93).
    let after_g10 = lines.iter().position(|l| *l == "G10 L2 P1 X5").unwrap();
    let last_piece = lines[after_g10 + 1..]
        .iter()
        .take_while(|l| !l.contains('['))
        .last()
        .unwrap();
    let x: f64 = last_piece
        .split_whitespace()
        .find_map(|w| w.strip_prefix('X'))
        .unwrap()
        .parse()
        .unwrap();
    assert!((x - 50.0).abs() < 0.13, "{last_piece}");
    if rs274_available() {
        // LinuxCNC runs original and compensated alike to the end: the last point is where the
        // passed block and `G1 Y40` put it, X3 Y40 (exactly: both are written as they are), Z
        // within the largest correction of 10.
        let g54 = "G10 L2 P1 X300 Y200 Z250\n";
        let original = rs274_machine_points(&format!("{g54}{program}"));
        let compensated = rs274_machine_points(&format!("{g54}{}", out.text));
        let (a, b) = (original.last().unwrap(), compensated.last().unwrap());
        assert_eq!((a[0], a[1]), (5.0 + 3.0, 200.0 + 40.0));
        assert_eq!((b[0], b[1]), (a[0], a[1]));
        assert!((b[2] - a[2]).abs() < 0.13, "{a:?} {b:?}");
        // No point of the compensated program strays from the original's path by more than the
        // largest correction: every one lies within 0.13 mm of a point of the original's moves
        // (sampled every 0.01 mm).
        assert!(!compensated.is_empty());
        for p in &compensated {
            let near = original.windows(2).any(|w| {
                (0..=10_000).any(|k| {
                    let t = k as f64 / 10_000.0;
                    (0..3)
                        .map(|d| (w[0][d] + (w[1][d] - w[0][d]) * t - p[d]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                        < 0.13
                })
            });
            assert!(near, "{p:?} is off the original path {original:?}");
        }
    }
}

/// `#100=5` and `G1 X#100`: refused naming the line without passing unknown blocks; with it both
/// are passed and listed, the assignment moves nothing, and the moves after `X#100` that do not
/// set X again are left as they are.
#[test]
fn macro_variables_are_refused_or_passed_and_listed() {
    let program = "G90 G0 X0 Y0 Z5\n#100=5\nG1 X#100 F100\nG1 Y10\nG1 X20 Y20\nG1 X30\nM30\n";
    let (line, message) = line_error(nc::compensate(
        &machine(),
        program.as_bytes(),
        "m.nc",
        &options(false),
    ));
    assert_eq!(line, 2);
    assert!(message.contains("macro"), "{message}");
    let out = nc::compensate(&machine(), program.as_bytes(), "m.nc", &options(true)).unwrap();
    let passed: Vec<usize> = out.report.not_compensated.iter().map(|p| p.line).collect();
    assert_eq!(passed, [2, 3]);
    // `G1 Y10` depends on X; `G1 X20 Y20` sets X again but starts where X is not known; `G1
    // X30` starts from a known point and is compensated.
    let left: Vec<(usize, &str)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str()))
        .collect();
    assert_eq!(left, [(4, "X"), (5, "X")]);
    let lines: Vec<&str> = out.text.lines().collect();
    assert!(lines.contains(&"G1 Y10") && lines.contains(&"G1 X20 Y20"));
    assert!(!lines.contains(&"G1 X30"), "{}", out.text);
}

/// A code volmap does not follow that names no axis (G12.1, polar interpolation) may move any
/// axis: every axis the program names is unknown after it, until each is set absolutely.
#[test]
fn an_unknown_code_without_axis_words_leaves_every_axis_unknown() {
    let program = "G90 G0 X0 Y0 Z5\nG12.1\nG1 X10 F100\nG1 Y10 Z2\nG1 X5\nG1 X0 Y0 Z0\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "u.nc", &options(true)).unwrap();
    let left: Vec<(usize, &str)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str()))
        .collect();
    assert_eq!(left, [(3, "X Y Z"), (4, "Y Z")]);
    // Line 5 starts with X Y Z all set by lines 3 and 4: compensated.
    let lines: Vec<&str> = out.text.lines().collect();
    assert_eq!(lines[3], "G1 Y10 Z2");
    assert_ne!(lines[4], "G1 X5");
}

/// G10 L2 and L20, G92, G92.1, G52 and a change of work offset move nothing; the moves after
/// them go where LinuxCNC's `rs274` puts them. `volmap trace` gives the machine command of every
/// move's end: equal to `rs274`'s to its 4 printed decimals (5e-5 mm).
#[test]
fn coordinate_settings_agree_with_rs274() {
    let program = "G90 G21 G17\nG0 X10 Y10 Z10\nG10 L2 P1 X5 Y-3\nG1 X50 F100\nG10 L20 P1 Z2\nG1 Y40\nG92 X0 Y0\nG1 X20 Y5\nG92.1\nG1 X30\nG52 X7 Z-1\nG1 Y12\nG52 X0 Z0\nG0 Z30\nG10 L2 P2 X1 Y2 Z3\nG55\nG0 X0 Y0\nG54\nG0 X1\nM30\n";
    let points = nc::trace(&machine(), program.as_bytes(), "s.nc", &options(false)).unwrap();
    let volmap: Vec<[f64; 3]> = points
        .iter()
        .map(|p| [p.command[0], p.command[1], p.command[2]])
        .collect();
    // By hand, the first moves: X10 Y10 Z10 under G54 (300, 200, 250) is machine (310, 210,
    // 260); after G10 L2 P1 X5 Y-3 the axes stand at X305 Y213 in the new coordinates, and
    // G1 X50 goes to machine (55, 210, 260): Y and Z do not move.
    assert_eq!(volmap[0], [310.0, 210.0, 260.0]);
    assert!((volmap[1][0] - 55.0).abs() < 1e-9 && (volmap[1][1] - 210.0).abs() < 1e-9);
    assert!((volmap[1][2] - 260.0).abs() < 1e-9);
    if !rs274_available() {
        return;
    }
    let linuxcnc = rs274_machine_points(&format!("G10 L2 P1 X300 Y200 Z250\n{program}"));
    assert_eq!(volmap.len(), linuxcnc.len(), "{volmap:?}\n{linuxcnc:?}");
    for (v, l) in volmap.iter().zip(&linuxcnc) {
        for d in 0..3 {
            assert!((v[d] - l[d]).abs() < 5e-5, "{volmap:?}\n{linuxcnc:?}");
        }
    }
}

/// G92 names the current point anew: where that point is not known (before the program sets the
/// axis, or after a passed block) it is refused naming the line; so are tool data (G10 L1)
/// without passing unknown blocks, and G10 L2 of an offset not given with only some of X Y Z.
#[test]
fn indefinite_settings_are_refused_naming_the_line() {
    let m = machine();
    let run =
        |program: &str, pass: bool| nc::compensate(&m, program.as_bytes(), "r.nc", &options(pass));
    let (line, message) = line_error(run("G92 X0 Y0 Z0\nG0 X10 Y10 Z10\n", false));
    assert_eq!(line, 1);
    assert!(message.contains("G92 needs where X stands"), "{message}");
    let (line, _) = line_error(run("G0 X0 Y0 Z5\nG1 X[#1] F100\nG92 X0\n", true));
    assert_eq!(line, 3);
    assert!(matches!(
        run("G0 X0 Y0 Z5\nG10 L1 P1 Z80\nG1 X5 F100\n", false),
        Err(NcError::Unsupported { line: 2, .. })
    ));
    let (line, message) = line_error(run("G0 X0 Y0 Z5\nG10 L2 P2 X5\nG55 G0 X1 Y1 Z1\n", false));
    assert_eq!(line, 2);
    assert!(message.contains("only some"), "{message}");
}

/// Tool data passed (G10 L1) leaves the moves under G43 uncompensated: the tool's length the
/// control uses is not known.
#[test]
fn passed_tool_data_leaves_moves_under_g43_alone() {
    let program = "G0 X0 Y0 Z50\nG10 L1 P1 Z80\nG43 H1 Z40\nG1 X10 F100\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "t.nc", &options(true)).unwrap();
    let lines: Vec<usize> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| m.line)
        .collect();
    assert_eq!(lines, [3, 4]);
    assert_eq!(out.text.lines().nth(3), Some("G1 X10 F100"));
}

/// `trace` follows the same rule: the moves left alone are not traced, and are listed.
#[test]
fn trace_skips_and_lists_the_moves_left_alone() {
    let program = "G90 G0 X0 Y0 Z5\nG1 X[1+2] F100\nG1 Y10\nG1 X20\nG1 Y0\n";
    let lines: Vec<usize> = nc::trace(&machine(), program.as_bytes(), "t.nc", &options(true))
        .unwrap()
        .iter()
        .map(|p| p.line)
        .collect();
    assert_eq!(lines, [1, 5]);
    let left: Vec<(usize, String, usize)> =
        nc::moves_left_alone(&machine(), program.as_bytes(), "t.nc", &options(true))
            .unwrap()
            .into_iter()
            .map(|m| (m.line, m.unknown, m.since_line))
            .collect();
    assert_eq!(left, [(3, "X".to_string(), 2), (4, "X".to_string(), 2)]);
}
