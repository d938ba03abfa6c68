//! NC programs as CAM posts write them: G53 homes, G28 G91 Z0, tool changes with G43 H, canned
//! cycles with G98/G99 and modal repeats; what is refused names its line.

use volmap::io::embedded;
use volmap::model::Machine;
use volmap::nc::{self, Options, ToolLengths};

/// A Fusion 360 style program: G53 home before each tool change, G43 H, G98 G81 with modal
/// repeats, G99 G83 pecking, G80, a Haas/Fanuc G91 G28 Z0 home at the end.
const FUSION: &str = "%
O1001 (FUSION STYLE)
G90 G94 G17
G21
G53 G0 Z0.
(DRILL1)
T1 M6
S3000 M3
G54
G0 X10. Y10.
G43 Z15. H1
G0 Z5.
G98 G81 X10. Y10. Z-5. R2. F200.
X30.
Y30.
G80
G0 Z15.
G53 G0 Z0.
T2 M6
S2000 M3
G0 X50. Y20.
G43 Z20. H2
G99 G83 X50. Y20. Z-5. R3. Q2. F100.
X70. Z-6.
G80
G1 Z10. F500
G91 G28 Z0.
G90
M30
%
";

/// A Haas style program: G28 G91 Z0 first, G82 dwelling and G85 boring with G98.
const HAAS: &str = "%
O02000 (HAAS STYLE)
G28 G91 Z0.
G90
T3 M06
G00 G17 G40 G49 G80 G90
G00 G54 X20. Y20. S1500 M03
G43 H03 Z25. M08
G98 G82 Z-4. R1. P500 F80.
X40.
G85 X60. Z-8. R2. F50.
G80
G28 G91 Z0.
G90
M30
%
";

/// A Mastercam style program: holes of a G81 in a subprogram, a contour subprogram called twice,
/// the subprograms after the program end.
const MASTERCAM: &str = "%
O0100 (MASTERCAM STYLE)
G21 G0 G17 G40 G49 G80 G90
T1 M6
G0 G90 G54 X0. Y0. S1000 M3
G43 H1 Z10.
G98 G81 X0. Y0. Z-3. R1. F150.
M98 P1001
G80
G0 Z10.
G1 Z-1. F300.
M98 P1002 L2
G0 Z10.
M30
O1001 (HOLES)
X20. Y0.
X20. Y20.
M99
O1002 (CONTOUR)
G1 X30. Y30.
G1 X0. Y0.
M99
%
";

/// A pocket corner programmed in a system turned by G68 30° about (10, 10), with an arc.
const ROTATED: &str = "%
O0300 (G68 ROTATION)
G90 G17 G21
T1 M6
G54 G0 X0. Y0.
G43 H1 Z10.
G68 X10. Y10. R30.
G0 X40. Y10.
G1 Z-1. F300.
Y30.
G2 X40. Y50. I0. J10.
G69
G0 Z10.
M30
%
";

fn options() -> Options {
    Options {
        decimals: Some(4),
        tool_lengths: ToolLengths::parse("T1=80,T2=100,T3=90").unwrap(),
        work_offsets: [(54, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0])].into(),
        ..Options::default()
    }
}

/// The program coordinates of the moves the input's `line` makes.
fn moves_of(points: &[nc::TracePoint], line: usize) -> Vec<[f64; 3]> {
    points
        .iter()
        .filter(|p| p.line == line)
        .map(|p| [p.program[0], p.program[1], p.program[2]])
        .collect()
}

/// Every end point the input means is reached, in order, by the real tip at an end point of the
/// output: the largest miss (mm). On the input's lines `xy_only` (moves with Z standing at a G53
/// machine position, which the output leaves uncorrected) only X and Y count.
fn largest_miss(
    machine: &Machine,
    (input, xy_only): (&str, &[usize]),
    output: &str,
    options: &Options,
) -> f64 {
    let meant = nc::trace(machine, input.as_bytes(), "in.nc", options).unwrap();
    let landed = nc::trace(machine, output.as_bytes(), "out.nc", options).unwrap();
    let mut from = 0;
    let mut worst: f64 = 0.0;
    assert!(!meant.is_empty());
    for m in &meant {
        let counted = if xy_only.contains(&m.line) { 2 } else { 3 };
        let (k, miss) = landed[from..]
            .iter()
            .enumerate()
            .map(|(k, l)| (k, (l.real - m.ideal).rows(0, counted).norm()))
            .find(|&(_, miss)| miss < 1e-3)
            .unwrap_or_else(|| panic!("line {}: no output point reaches it", m.line));
        worst = worst.max(miss);
        from += k + 1;
    }
    worst
}

/// Compensating rounds every word to 4 decimals: the real tip may miss by that rounding.
const ROUNDING_MM: f64 = 1e-6 + 0.5e-4 * 1.7321 * 1.01;

#[test]
fn a_fusion_style_program_with_homes_tool_changes_and_cycles_lands_every_point() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = options();
    let meant = nc::trace(&machine, FUSION.as_bytes(), "in.nc", &options).unwrap();
    // G98 G81 from Z5: over the hole at the initial level, R, the depth, back to the initial level.
    assert_eq!(
        moves_of(&meant, 13),
        [
            [10., 10., 5.],
            [10., 10., 2.],
            [10., 10., -5.],
            [10., 10., 5.]
        ]
    );
    assert_eq!(
        moves_of(&meant, 15),
        [
            [30., 30., 5.],
            [30., 30., 2.],
            [30., 30., -5.],
            [30., 30., 5.]
        ]
    );
    // G99 G83 from Z20, Q2 from R3 to -5: pecks to 1, -1, -3, -5, out to R between them and back
    // down to 0.254 mm above the last peck, out to R at the end.
    let z: Vec<f64> = moves_of(&meant, 23).iter().map(|p| p[2]).collect();
    let expected = [
        20., 3., 1., 3., 1.254, -1., 3., -0.746, -3., 3., -2.746, -5., 3.,
    ];
    assert_eq!(z.len(), expected.len(), "{z:?}");
    for (z, e) in z.iter().zip(expected) {
        assert!((z - e).abs() < 1e-9, "{z} against {e}");
    }
    // The modal repeat X70 Z-6 keeps R3 and Q2, and starts at R (G99).
    let z: Vec<f64> = moves_of(&meant, 24).iter().map(|p| p[2]).collect();
    assert_eq!(z[0], 3.0);
    assert_eq!(*z.last().unwrap(), 3.0);
    assert!((z[z.len() - 2] + 6.0).abs() < 1e-12);

    let out = nc::compensate(&machine, FUSION.as_bytes(), "fusion.nc", &options).unwrap();
    assert_eq!(out.report.cycle_holes_expanded, 5);
    assert!(out.report.not_compensated.is_empty());
    let lines: Vec<&str> = out.text.lines().collect();
    // Homes pass unchanged; no cycle code is left outside the comments that record them.
    assert_eq!(lines.iter().filter(|l| **l == "G53 G0 Z0.").count(), 2);
    assert!(lines.contains(&"G91 G28 Z0."));
    for line in &lines {
        let code = line.split('(').next().unwrap();
        assert!(!code.contains("G81") && !code.contains("G83"), "{line}");
    }
    // Uncompensated the tip misses by a tenth of a millimetre; compensated, by the rounding.
    let before = meant
        .iter()
        .map(|p| (p.real - p.ideal).norm())
        .fold(0.0, f64::max);
    assert!(before > 0.05, "{before}");
    let miss = largest_miss(&machine, (FUSION, &[10, 21]), &out.text, &options);
    assert!(miss < ROUNDING_MM, "{miss}");
    assert!(out.report.largest_error_after_mm <= options.chord_tolerance_mm);
}

#[test]
fn a_haas_style_program_dwells_and_feeds_out_of_its_holes() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = options();
    let meant = nc::trace(&machine, HAAS.as_bytes(), "in.nc", &options).unwrap();
    // G98 G82 from Z25: R1, the depth -4, (dwell), back to the initial level.
    assert_eq!(
        moves_of(&meant, 9),
        [[20., 20., 1.], [20., 20., -4.], [20., 20., 25.]]
    );
    // G85 feeds down to -8 and back up to R2 before the rapid to the initial level.
    assert_eq!(
        moves_of(&meant, 11),
        [
            [60., 20., 25.],
            [60., 20., 2.],
            [60., 20., -8.],
            [60., 20., 2.],
            [60., 20., 25.]
        ]
    );
    let out = nc::compensate(&machine, HAAS.as_bytes(), "haas.nc", &options).unwrap();
    assert_eq!(out.report.cycle_holes_expanded, 3);
    assert_eq!(out.text.matches("\nG4 P500\n").count(), 2, "{}", out.text);
    let miss = largest_miss(&machine, (HAAS, &[]), &out.text, &options);
    assert!(miss < ROUNDING_MM, "{miss}");
}

#[test]
fn a_mastercam_style_program_runs_its_subprograms_in_place() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = options();
    let meant = nc::trace(&machine, MASTERCAM.as_bytes(), "in.nc", &options).unwrap();
    // The holes of O1001 under the caller's G98 G81, from the initial level Z10.
    assert_eq!(
        moves_of(&meant, 16),
        [
            [20., 0., 10.],
            [20., 0., 1.],
            [20., 0., -3.],
            [20., 0., 10.]
        ]
    );
    assert_eq!(moves_of(&meant, 17).len(), 4);
    // O1002 runs twice (L2).
    assert_eq!(moves_of(&meant, 20), [[30., 30., -1.], [30., 30., -1.]]);
    assert_eq!(moves_of(&meant, 21), [[0., 0., -1.], [0., 0., -1.]]);
    let out = nc::compensate(&machine, MASTERCAM.as_bytes(), "mc.nc", &options).unwrap();
    assert_eq!(out.report.cycle_holes_expanded, 3);
    // The bodies stand unchanged after the program end.
    assert!(
        out.text.ends_with("M30\nO1001 (HOLES)\nX20. Y0.\nX20. Y20.\nM99\nO1002 (CONTOUR)\nG1 X30. Y30.\nG1 X0. Y0.\nM99\n%\n"),
        "{}",
        out.text
    );
    let miss = largest_miss(&machine, (MASTERCAM, &[]), &out.text, &options);
    assert!(miss < ROUNDING_MM, "{miss}");
}

#[test]
fn what_posts_write_that_volmap_refuses_names_its_line() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = Options {
        tool_lengths: ToolLengths::default(),
        ..options()
    };
    let cases: [(&str, &str); 9] = [
        (
            "G0 X10 Y10 Z10\nM98 P2000\nM30\nO1000\nX5\nM99\n",
            "line 2: M98: subprogram O2000 is not in the file",
        ),
        (
            "G0 X10 Y10 Z10\nG65 P9000 A1\n",
            "line 2: G65: subprogram O9000 is not in the file",
        ),
        (
            "G0 X10 Y10 Z10\nG41 D1 G1 X20\n",
            "line 2: G41: cutter radius compensation is not supported: the path the control computes",
        ),
        ("G0 X10 Y10 Z10\nG53 G1 Z0\n", "line 2: G53 with a feed move"),
        (
            "G0 X10 Y10 Z10\nG84 X20 Z-5 R2 F100\n",
            "line 2: G84: tapping needs the spindle synchronised",
        ),
        (
            "G0 X10 Y10 Z10\nG91 G81 X20 Z-5 R2 F100\n",
            "line 2: G81: canned cycles in incremental distance (G91)",
        ),
        (
            "G0 X10 Y10 Z10\nG83 X20 Z-5 R2 F100\n",
            "line 2: G83: the cycle needs a positive peck depth Q",
        ),
        (
            "G0 X10 Y10 Z10\nG81 X20 Z-5 F100\n",
            "line 2: G81: the cycle needs its R plane",
        ),
        (
            "G0 X10 Y10\nG81 X20 Z-5 R2 F100\n",
            "line 2: G81: the cycle needs Z set before it",
        ),
    ];
    for (program, expected) in cases {
        let error = nc::compensate(&machine, program.as_bytes(), "bad.nc", &options)
            .unwrap_err()
            .to_string();
        assert!(error.contains(expected), "{expected}: {error}");
        assert!(error.starts_with("bad.nc: line 2"), "{error}");
    }
}

#[test]
fn passed_blocks_are_listed_and_what_they_may_move_is_left_alone() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = Options {
        tool_lengths: ToolLengths::default(),
        pass_unknown: true,
        ..options()
    };
    let program = "G0 X10 Y10 Z10\nG84 X20 Z-5 R2 F100\nX40\nG80\nG51 X0 Y0 P2\nG0 X50 Y50\n";
    let out = nc::compensate(&machine, program.as_bytes(), "p.nc", &options).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    // The tapping cycle and its modal repeat pass whole, R plane and all.
    assert_eq!(lines[1], "G84 X20 Z-5 R2 F100");
    assert_eq!(lines[2], "X40");
    assert_eq!(lines[4], "G51 X0 Y0 P2");
    let passed: Vec<(usize, &str)> = out
        .report
        .not_compensated
        .iter()
        .map(|p| (p.line, p.code.as_str()))
        .collect();
    assert_eq!(passed, [(2, "G84"), (3, "G84"), (5, "G51")]);
    // The move before them is compensated; the one after is not: the tapping cycle leaves Z at
    // a level volmap does not know (and G51 scales what follows), so it passes as it is, listed.
    assert_ne!(lines[0], "G0 X10 Y10 Z10");
    assert_eq!(lines[5], "G0 X50 Y50");
    let left: Vec<(usize, &str, usize)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str(), m.since_line))
        .collect();
    assert_eq!(left, [(6, "X Y Z", 2)]);
}

#[test]
fn linuxcnc_runs_the_compensated_post_programs() {
    if !crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    ) {
        return;
    }
    let machine = embedded::load("vmc-li2015").unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (name, program) in [
        ("fusion.nc", FUSION),
        ("haas.nc", HAAS),
        ("mastercam.nc", MASTERCAM),
        ("rotated.nc", ROTATED),
    ] {
        let out = nc::compensate(&machine, program.as_bytes(), name, &options()).unwrap();
        let file = dir.path().join(name);
        std::fs::write(&file, &out.text).unwrap();
        let canon = dir.path().join("canon.txt");
        let run = crate::common::rs274(&file, &canon);
        assert!(
            run.status.success(),
            "rs274 on {name}: {}\n{}",
            String::from_utf8_lossy(&run.stderr),
            out.text
        );
        // rs274 exits 0 after an error too: an error leaves no canonical program end.
        let canon = std::fs::read_to_string(&canon).unwrap();
        assert!(
            canon.contains("PROGRAM_END"),
            "{name}: {canon}\n{}",
            out.text
        );
        let moves = canon
            .lines()
            .filter(|l| l.contains("STRAIGHT_") || l.contains("ARC_FEED"))
            .count();
        // The interpreter stops at M30: the subprogram bodies after it are not read.
        let moving = out
            .text
            .lines()
            .take_while(|l| *l != "M30")
            .filter(|l| {
                let code = l.split('(').next().unwrap();
                code.contains(['X', 'Y', 'Z']) && !code.contains("G28") && !code.contains("G53")
            })
            .count();
        // Homes make two moves each (G28: through the intermediate point), G53 one.
        assert!(moves >= moving, "{name}: {moves} moves for {moving} lines");
    }
}

#[test]
fn with_g43_the_axes_stand_higher_by_the_tool_length() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = options();
    let with_g43 = "G53 G0 Z0.\nT2 M6\nG0 X10. Y10.\nG43 H2 Z20.\nG1 X50. Y30. Z15. F100.\nG49\n";
    let trace = nc::trace(&machine, with_g43.as_bytes(), "g43.nc", &options).unwrap();
    // Program + work offset (200, 200, 300) + T2's 100 mm along Z.
    let at = |line: usize| trace.iter().find(|p| p.line == line).unwrap().command;
    assert_eq!(&at(4)[..3], &[210.0, 210.0, 420.0]);
    assert_eq!(&at(5)[..3], &[250.0, 230.0, 415.0]);
    // Before G43 Z stands where `G53 G0 Z0.` left it, at machine 0 (by hand: program Z = 0 −
    // 300, the work offset, without G43), whatever the next Z is.
    assert_eq!(&at(3)[..3], &[210.0, 210.0, 0.0]);
    // The same machine positions programmed without G43 get the same corrections.
    let without = "G53 G0 Z0.\nT2 M6\nG0 X10. Y10.\nG0 Z120.\nG1 X50. Y30. Z115. F100.\n";
    let a = nc::compensate(&machine, with_g43.as_bytes(), "a.nc", &options).unwrap();
    let b = nc::compensate(&machine, without.as_bytes(), "b.nc", &options).unwrap();
    let words = |text: &str, line: usize, letter: char| -> f64 {
        let line = text.lines().nth(line).unwrap();
        let at = line.find(letter).unwrap() + 1;
        let end = line[at..].find(' ').map_or(line.len(), |e| at + e);
        line[at..end].parse().unwrap()
    };
    for (line, letter, shift) in [(4, 'X', 0.0), (4, 'Y', 0.0), (4, 'Z', 100.0)] {
        let (va, vb) = (words(&a.text, line, letter), words(&b.text, line, letter));
        assert!(
            (va + shift - vb).abs() < 1e-9,
            "{letter}: {va} {vb}\n{}\n{}",
            a.text,
            b.text
        );
    }
    assert!((a.report.largest_correction_mm - b.report.largest_correction_mm).abs() < 1e-9);
}

#[test]
fn a_rotated_program_moves_where_g68_turns_it_and_lands_every_point() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let meant = nc::trace(&machine, ROTATED.as_bytes(), "rotated.nc", &options()).unwrap();
    // By hand: (x, y) of the turned system is c + Rot(30°)((x, y) − c), c = (10, 10).
    let (s, c) = 30f64.to_radians().sin_cos();
    let turned = |x: f64, y: f64| {
        [
            10.0 + c * (x - 10.0) - s * (y - 10.0),
            10.0 + s * (x - 10.0) + c * (y - 10.0),
        ]
    };
    for (line, x, y) in [(8, 40.0, 10.0), (10, 40.0, 30.0), (11, 40.0, 50.0)] {
        let at = moves_of(&meant, line);
        let expected = turned(x, y);
        assert!(
            (at[0][0] - expected[0]).abs() < 1e-8 && (at[0][1] - expected[1]).abs() < 1e-8,
            "line {line}: {at:?} against {expected:?}"
        );
    }
    // After G69 the program's own system again: Z only.
    assert_eq!(moves_of(&meant, 13)[0][2], 10.0);
    let out = nc::compensate(&machine, ROTATED.as_bytes(), "rotated.nc", &options()).unwrap();
    assert!(
        !out.text.contains("\nG68") && out.text.contains("rotation applied"),
        "{}",
        out.text
    );
    let miss = largest_miss(&machine, (ROTATED, &[]), &out.text, &options());
    assert!(miss < ROUNDING_MM, "{miss}\n{}", out.text);
    // G68 outside the XY plane names its line.
    let error = nc::compensate(
        &machine,
        ROTATED.replace("G68 X10.", "G18 G68 X10.").as_bytes(),
        "rotated.nc",
        &options(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("rotated.nc: line 7") && error.contains("XY plane"),
        "{error}"
    );
}
