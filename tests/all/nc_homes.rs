//! Where the axes stand after a home: `G53` puts them at a machine position, and the moves after
//! it are evaluated there (trace and compensate); `G28` sends them to the control's reference
//! point, which the program does not give, and the moves that depend on it are neither traced nor
//! compensated, but listed.

use volmap::model::Machine;
use volmap::nc::{self, Options, ToolLengths};

/// X straightens with Z, and nothing else is wrong: the tip's deviation anywhere is 0.001 mm per
/// mm of machine Z, along X.
const X_WITH_Z: &str = r#"
name = "X error growing with Z"
chain = "FYXFZ"

[tool]
offset = [0.0, 0.0, 0.0]

[axes.X]
range = [0.0, 500.0]

[axes.Y]
range = [0.0, 500.0]

[axes.Z]
range = [0.0, 500.0]
EXZ = { poly = [0.0, 0.001] }
"#;

fn machine() -> Machine {
    Machine::from_toml(X_WITH_Z, "x-with-z.toml", None).unwrap()
}

/// G54 at machine (100, 100, 200); every tool 80 mm long.
fn options() -> Options {
    Options {
        tool_lengths: ToolLengths::parse("80").unwrap(),
        work_offsets: [(54, [100.0, 100.0, 200.0, 0.0, 0.0, 0.0])].into(),
        ..Options::default()
    }
}

/// A home in machine Z between two heights of the program: the X Y move after it runs at the
/// home, not at the next Z the program gives.
const HOMED: &str = "G21 G90 G17 G54
G0 X10 Y10 Z100
G53 G0 Z400.
G0 X20 Y30
G0 Z50
G1 X40 F100
M30
";

/// The same under G43 with T1: the home stands 80 mm lower in the program's coordinates.
const HOMED_G43: &str = "G21 G90 G17 G54
T1 M6
G43 H1
G0 X10 Y10 Z100
G53 G0 Z400.
G0 X20 Y30
G0 Z50
G1 X40 F100
M30
";

#[test]
fn the_moves_after_g53_are_traced_where_the_axis_stands() {
    let machine = machine();
    let points = nc::trace(&machine, HOMED.as_bytes(), "homed.nc", &options()).unwrap();
    let at = |line: usize| points.iter().find(|p| p.line == line).unwrap();
    // By hand: machine Z 400 is program Z 400 − 200 (G54's Z) = 200; the X Y move runs there,
    // and its deviation is 0.001 × 400 = 0.4 mm (before: at Z50, machine 250, 0.25 mm). The
    // figures are exact in binary up to the polynomial's evaluation: 1e-12.
    assert_eq!(at(4).program[..3], [20.0, 30.0, 200.0]);
    assert_eq!(at(4).command[..3], [120.0, 130.0, 400.0]);
    assert!(((at(4).real - at(4).ideal).norm() - 0.4).abs() < 1e-12);
    assert!(((at(5).real - at(5).ideal).norm() - 0.25).abs() < 1e-12);
    // Sampled along the move too: every sample of line 4 at the home's height.
    let samples = nc::trace_path(&machine, HOMED.as_bytes(), "homed.nc", &options(), 0.5).unwrap();
    let line4: Vec<_> = samples.iter().filter(|s| s.line == 4).collect();
    assert!(!line4.is_empty());
    for s in line4 {
        assert_eq!(s.program[2], 200.0);
        assert!((s.deviation_mm - 0.4).abs() < 1e-12, "{}", s.deviation_mm);
    }
    // Under G43 the axes stand at program + offset + length: machine 400 is program Z 400 −
    // 200 − 80 = 120, the command still 400.
    let points = nc::trace(&machine, HOMED_G43.as_bytes(), "g43.nc", &options()).unwrap();
    let at = |line: usize| points.iter().find(|p| p.line == line).unwrap();
    assert_eq!(at(6).program[..3], [20.0, 30.0, 120.0]);
    assert_eq!(at(6).command[..3], [120.0, 130.0, 400.0]);
    assert!(((at(6).real - at(6).ideal).norm() - 0.4).abs() < 1e-12);
}

/// LinuxCNC's `rs274` gives the same program positions (its canonical moves are in the work
/// coordinates): the G54 offset and T1's length set in the program, as volmap takes them from
/// its options.
#[test]
fn rs274_puts_the_moves_after_g53_where_volmap_does() {
    if !crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    ) {
        return;
    }
    let machine = machine();
    let dir = tempfile::tempdir().unwrap();
    for (name, program, line) in [("homed", HOMED, 4), ("homed-g43", HOMED_G43, 6)] {
        // G10 L2 sets G54, G10 L1 T1's length (both in mm under G21).
        let for_rs274 = format!("G21\nG10 L2 P1 X100 Y100 Z200\nG10 L1 P1 Z80\n{program}");
        let file = dir.path().join(format!("{name}.ngc"));
        let canon = dir.path().join(format!("{name}.canon"));
        std::fs::write(&file, for_rs274).unwrap();
        let run = crate::common::rs274(&file, &canon);
        assert!(run.status.success(), "{name}: {run:?}");
        let canon = std::fs::read_to_string(&canon).unwrap();
        assert!(canon.contains("PROGRAM_END"), "{name}: {canon}");
        // The traverses' X Y Z, in order: the program's moves (rs274 writes a G43 block's
        // offset, not a move).
        let traverses: Vec<[f64; 3]> = canon
            .lines()
            .filter_map(|l| l.split_once("STRAIGHT_TRAVERSE("))
            .map(|(_, args)| {
                let v: Vec<f64> = args
                    .trim_end_matches(')')
                    .split(',')
                    .map(|a| a.trim().parse().unwrap())
                    .collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        let points = nc::trace(&machine, program.as_bytes(), "p.nc", &options()).unwrap();
        let rapids: Vec<[f64; 3]> = points
            .iter()
            .filter(|p| p.line <= line + 1)
            .map(|p| [p.program[0], p.program[1], p.program[2]])
            .collect();
        // Three rapids by volmap (the G53 home passes), four traverses by rs274: the home's
        // own traverse is the second. rs274 prints 4 decimals.
        assert_eq!(traverses.len(), 4, "{name}: {canon}");
        let without_home = [traverses[0], traverses[2], traverses[3]];
        assert_eq!(rapids.len(), 3, "{name}: {rapids:?}");
        for (v, r) in rapids.iter().zip(without_home) {
            for k in 0..3 {
                assert!((v[k] - r[k]).abs() < 0.5e-4, "{name}: {v:?} against {r:?}");
            }
        }
        assert_eq!(rapids.len(), 3, "{name}");
    }
}

#[test]
fn the_moves_after_g53_are_compensated_where_the_axis_stands() {
    let machine = machine();
    let out = nc::compensate(&machine, HOMED.as_bytes(), "homed.nc", &options()).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    // The home passes; the X Y rapid after it gets an X corrected by the error at machine Z
    // 400 (by hand: 0.4 mm, against the 0.25 mm of the next Z), and no Z word: Z stays home.
    assert!(lines.contains(&"G53 G0 Z400."), "{}", out.text);
    let after = lines
        .iter()
        .skip_while(|l| !l.starts_with("G53"))
        .nth(1)
        .copied()
        .unwrap_or_else(|| panic!("{}", out.text));
    assert!(!after.contains('Z'), "{after}");
    let x: f64 = after
        .split_whitespace()
        .find_map(|w| w.strip_prefix('X'))
        .unwrap()
        .parse()
        .unwrap();
    // 4 decimals written: within 0.5e-4 of 20 ∓ 0.4.
    assert!(((x - 20.0).abs() - 0.4).abs() <= 0.5e-4, "{after}");
    assert!(out.report.not_compensated.is_empty());
}

/// A feed move with Z still at the home: Z gets no word before a block names it, so the move
/// cannot be held to the tolerance; it passes as it is and is listed. An arc there is refused.
#[test]
fn a_feed_move_at_the_g53_height_passes_listed() {
    let machine = machine();
    let program = "G21 G90 G54\nG0 X10 Y10 Z100\nG53 G0 Z400.\nG1 X20 Y30 F100\nG0 Z50\nM30\n";
    let out = nc::compensate(&machine, program.as_bytes(), "feed.nc", &options()).unwrap();
    assert!(out.text.contains("\nG1 X20 Y30 F100\n"), "{}", out.text);
    let listed: Vec<(usize, &str)> = out
        .report
        .not_compensated
        .iter()
        .map(|p| (p.line, p.code.as_str()))
        .collect();
    assert_eq!(
        listed,
        [(
            4,
            "a feed move with Z at the machine position of G53 on line 3"
        )]
    );
}

/// G28 goes to the control's reference point (LinuxCNC's parameters 5161–5166, a Fanuc's
/// parameters), which the program does not give: Z is unknown after it, as after a block volmap
/// does not follow, and the moves with Z there are not traced and not compensated but listed, up
/// to and with the one that sets Z again (it passes as it is; its path is not known); the rest as
/// always. A feed move that sets Z again passes and is listed likewise.
#[test]
fn the_moves_after_g28_are_listed_not_guessed() {
    let machine = machine();
    let program =
        "G21 G90 G54\nG0 X10 Y10 Z100\nG91 G28 Z0.\nG90 G0 X20 Y30\nG0 Z50\nG0 Z20\nG1 X40 F100\nM30\n";
    let points = nc::trace(&machine, program.as_bytes(), "g28.nc", &options()).unwrap();
    let lines: Vec<usize> = points.iter().map(|p| p.line).collect();
    assert_eq!(lines, [2, 6, 7]);
    let untraced = nc::moves_left_alone(&machine, program.as_bytes(), "g28.nc", &options())
        .unwrap()
        .iter()
        .map(|m| (m.line, m.unknown.clone(), m.since_line))
        .collect::<Vec<_>>();
    assert_eq!(untraced, [(4, "Z".into(), 3), (5, "Z".into(), 3)]);
    let out = nc::compensate(&machine, program.as_bytes(), "g28.nc", &options()).unwrap();
    let written: Vec<&str> = out.text.lines().collect();
    assert_eq!(written[3..5], ["G90 G0 X20 Y30", "G0 Z50"], "{}", out.text);
    assert!(out.report.not_compensated.is_empty());
    assert_eq!(out.report.moves_not_compensated, untraced_moves(&untraced));
    // By hand: X at program Z 20 (machine 220) is off by 0.22 mm; the rapid to Z20 gets an X
    // word for it (X is known), and the feed move runs on from there in one piece (the error
    // does not vary along X). 4 decimals written: within 0.5e-4.
    let x = |line: &str| -> f64 {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix('X'))
            .unwrap_or_else(|| panic!("{line}: {}", out.text))
            .parse()
            .unwrap()
    };
    assert!(written[5].starts_with("G0 Z20"), "{}", out.text);
    assert!(
        ((x(written[5]) - 20.0).abs() - 0.22).abs() <= 0.5e-4,
        "{}",
        out.text
    );
    assert!(
        ((x(written[6]) - 40.0).abs() - 0.22).abs() <= 0.5e-4,
        "{}",
        out.text
    );
    assert_eq!(written[7], "M30", "{}", out.text);
    let feed = "G0 X10 Y10 Z100\nG28 Z0.\nG1 Z50 F100\nG0 Z60\n";
    let out = nc::compensate(&machine, feed.as_bytes(), "feed.nc", &options()).unwrap();
    assert_eq!(out.text.lines().nth(2), Some("G1 Z50 F100"), "{}", out.text);
    assert_eq!(
        out.report.moves_not_compensated,
        untraced_moves(&[(3, "Z".into(), 2)])
    );
}

fn untraced_moves(listed: &[(usize, String, usize)]) -> Vec<nc::LeftMove> {
    listed
        .iter()
        .map(|(line, unknown, since_line)| nc::LeftMove {
            line: *line,
            unknown: unknown.clone(),
            since_line: *since_line,
        })
        .collect()
}
