//! Offline NC compensation: the test piece of Dobariya, Patel and Jani (2015), programs in the
//! styles people write, uniform errors that keep arcs, five axes, inch, and bad programs.

use std::path::Path;

use nalgebra::Vector3;
use volmap::io::embedded;
use volmap::model::{AxisLetter, ErrorFunction, Machine};
use volmap::nc::{self, Options, ToolLengths};

fn options(decimals: usize) -> Options {
    Options {
        decimals: Some(decimals),
        ..Options::default()
    }
}

/// Every move of the input lands, run from the output, where the input meant it: the real tip
/// at the last output line of each input block against the ideal tip of that block (mm).
fn largest_landing_error(
    machine: &Machine,
    input: &str,
    output: &nc::Compensated,
    options: &Options,
) -> f64 {
    let meant = nc::trace(machine, input.as_bytes(), "in.nc", options).unwrap();
    let landed = nc::trace(machine, output.text.as_bytes(), "out.nc", options).unwrap();
    let mut worst: f64 = 0.0;
    assert!(!meant.is_empty());
    for m in &meant {
        // The last output line that comes from this input line.
        let last = output
            .origins
            .iter()
            .rposition(|&o| o == m.line)
            .expect("every block is written")
            + 1;
        let l = landed
            .iter()
            .find(|p| p.line == last)
            .expect("the block's last line moves");
        worst = worst.max((l.real - m.ideal).norm());
    }
    worst
}

/// The line without its coordinates and motion words: what must not change.
fn without_coordinates(line: &str) -> String {
    // Comments stay whole; `;` comments run to the end of the line.
    let (code, comment) = match line.find(';') {
        Some(i) => (&line[..i], &line[i..]),
        None => (line, ""),
    };
    let chars: Vec<char> = code.chars().collect();
    let mut kept = String::new();
    let mut i = 0;
    let number_end = |mut j: usize| {
        while j < chars.len() && (chars[j].is_ascii_digit() || matches!(chars[j], '.' | '-' | '+'))
        {
            j += 1;
        }
        j
    };
    while i < chars.len() {
        let c = chars[i];
        if c == '(' {
            let close = chars[i..]
                .iter()
                .position(|&d| d == ')')
                .map_or(chars.len(), |p| i + p + 1);
            kept.extend(&chars[i..close]);
            i = close;
            continue;
        }
        let upper = c.to_ascii_uppercase();
        if "XYZIJKR".contains(upper) && c.is_ascii_alphabetic() {
            i = number_end(i + 1);
            continue;
        }
        if upper == 'G' {
            let j = number_end(i + 1);
            let code: String = chars[i + 1..j].iter().collect();
            if matches!(code.parse::<f64>().ok(), Some(g) if g < 4.0) {
                i = j;
                continue;
            }
        }
        if c != ' ' {
            kept.push(c);
        }
        i += 1;
    }
    kept + comment
}

fn check_only_coordinates_change(input: &str, output: &nc::Compensated) {
    let inputs: Vec<&str> = input.lines().collect();
    let outputs: Vec<&str> = output.text.lines().collect();
    assert_eq!(outputs.len(), output.origins.len());
    let mut seen = std::collections::HashSet::new();
    for (text, &origin) in outputs.iter().zip(&output.origins) {
        let original = inputs[origin - 1];
        if seen.insert(origin) {
            assert_eq!(
                without_coordinates(text),
                without_coordinates(original),
                "line {origin}: {original} became {text}"
            );
        } else {
            assert!(
                without_coordinates(text).is_empty(),
                "an added line holds only G1 and coordinates: {text} (after line {origin})"
            );
        }
    }
}

#[test]
fn the_dobariya_test_piece_comes_out_within_a_micrometre() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dobariya2015");
    let machine = Machine::from_path(&dir.join("machine.toml")).unwrap();
    let program = std::fs::read_to_string(dir.join("test-piece.nc")).unwrap();
    let mut options = options(4);
    options
        .work_offsets
        .insert(54, [0.0, 0.0, 10.0, 0.0, 0.0, 0.0]);
    let out = nc::compensate(&machine, program.as_bytes(), "test-piece.nc", &options).unwrap();
    let length_error = |text: &str, from_line: usize, to_line: usize, nominal: f64| {
        let trace = nc::trace(&machine, text.as_bytes(), "p.nc", &options).unwrap();
        let at = |line: usize| trace.iter().find(|p| p.line == line).unwrap().real;
        (at(to_line) - at(from_line)).x - nominal
    };
    // Lines 8–9 cut the 30 mm slot (N50 plunges at X10, N60 ends at X40), 12–13 the 60 mm one.
    let before = [
        length_error(&program, 8, 9, 30.0),
        length_error(&program, 12, 13, 60.0),
    ];
    // Table 4 measured 0.28 mm and 0.07 mm before compensation: the predictions are of that size.
    assert!(
        (before[0] - 30.0 * 0.358 / 80.0).abs() < 1e-9
            && (before[1] - 60.0 * 0.358 / 80.0).abs() < 1e-9,
        "{before:?}"
    );
    let last = |origin: usize| out.origins.iter().rposition(|&o| o == origin).unwrap() + 1;
    let after = [
        length_error(&out.text, last(8), last(9), 30.0),
        length_error(&out.text, last(12), last(13), 60.0),
    ];
    assert!(
        after.iter().all(|e| e.abs() < 1e-3),
        "after compensation: {after:?} mm"
    );
    // With the default four decimals every point lands within their rounding (0.05 µm per axis).
    assert!(largest_landing_error(&machine, &program, &out, &options) < 1e-4);
    assert!(out.report.largest_error_before_mm > 0.3 && out.report.largest_error_after_mm <= 1e-3);
    check_only_coordinates_change(&program, &out);
}

/// A program in the styles CAM systems and hand programmers write.
const REAL_PROGRAM: &str = "%
O0100 (POCKET AND BOSS)
(T1 D10 FLAT END MILL)
N5 G21 G17 G90 G40 G49 G80
N10 T1 M6
N15 G54 G0 X100. Y100. S4000 M3
N20 G43 H1 Z250.
N25 Z205.
N30 G1 Z200. F300.
N35 X300. F800 ; FLOOR PASS
N40 G2 X350. Y150. I0. J50.
N45 G3 X300. Y200. R50.
N50 G1 X100.
N55 G91 Y-25.
N60 X50. Y-25.
N65 G90 G18 G2 X200. Z150. I50. K0.
N70 G19 G3 Y175. Z175. J25. K0.
N75 G17
n80 g1x120.y120.f500
N85 X120.5Y120.5(no spaces)
N90 G0 Z250.
N95 T2 M6 (SECOND TOOL)
N100 G0 X400. Y300.
N105 Z210.
N110 G1 Z200. F200
N115 G2 X400. Y300. I30. J0. (FULL CIRCLE)
N120 G0 Z250. M9
N125 M30
%
";

#[test]
fn real_programs_change_only_coordinates_and_land_on_the_programmed_points() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let mut options = options(7);
    options
        .work_offsets
        .insert(54, [10.0, 20.0, 30.0, 0.0, 0.0, 0.0]);
    options.tool_lengths = ToolLengths::parse("T1=80,T2=120").unwrap();
    let out = nc::compensate(&machine, REAL_PROGRAM.as_bytes(), "real.nc", &options).unwrap();
    check_only_coordinates_change(REAL_PROGRAM, &out);
    // Lines that move nothing pass byte for byte.
    for (n, line) in REAL_PROGRAM.lines().enumerate() {
        let moves = ["X", "Y", "Z", "x", "y", "z"]
            .iter()
            .any(|a| line.split(['(', ';']).next().unwrap().contains(a));
        if !moves {
            let first = out.origins.iter().position(|&o| o == n + 1).unwrap();
            assert_eq!(out.text.lines().nth(first).unwrap(), line);
        }
    }
    let landing = largest_landing_error(&machine, REAL_PROGRAM, &out, &options);
    assert!(landing < 1e-6, "a point misses by {landing} mm");
    assert!(
        out.report.largest_error_before_mm > 0.05,
        "{:?}",
        out.report
    );
    assert!(
        out.report.largest_error_after_mm <= 1e-3,
        "{:?}",
        out.report
    );
    assert!(out.report.blocks_added > 0 && out.report.blocks_changed > 10);
    // Added pieces of straight moves lie on the straight line (the real tip, within 1 µm).
    let meant = nc::trace(&machine, REAL_PROGRAM.as_bytes(), "in.nc", &options).unwrap();
    let landed = nc::trace(&machine, out.text.as_bytes(), "out.nc", &options).unwrap();
    let line_35 = out
        .origins
        .iter()
        .enumerate()
        .filter(|(_, &o)| o == 10)
        .map(|(n, _)| n + 1)
        .collect::<Vec<_>>();
    let (a, b): (Vector3<f64>, Vector3<f64>) = (
        meant.iter().find(|p| p.line == 9).unwrap().ideal,
        meant.iter().find(|p| p.line == 10).unwrap().ideal,
    );
    for line in line_35 {
        let p = landed.iter().find(|t| t.line == line).unwrap().real;
        let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
        assert!((p - (a + t * (b - a))).norm() <= 1e-3 + 1e-7);
    }
    // Incremental sections stay incremental, lower case stays lower case.
    let text: Vec<&str> = out.text.lines().collect();
    let at = |origin: usize| text[out.origins.iter().position(|&o| o == origin).unwrap()];
    assert!(
        at(14).starts_with("N55 G91 Y-2") || at(14).starts_with("N55 G91 X"),
        "{}",
        at(14)
    );
    assert!(at(19).starts_with("n80 g1x1"), "{}", at(19));
}

#[test]
fn uniform_errors_keep_arcs_as_arcs() {
    let mut machine = Machine::nominal(
        "offset",
        "FYXFZ",
        &[
            (AxisLetter::X, [-500.0, 500.0]),
            (AxisLetter::Y, [-500.0, 500.0]),
            (AxisLetter::Z, [-500.0, 500.0]),
        ],
    )
    .unwrap();
    machine.axis_mut(AxisLetter::X).unwrap().components[0] = Some(ErrorFunction::Constant(0.02));
    machine.axis_mut(AxisLetter::Y).unwrap().components[1] = Some(ErrorFunction::Constant(-0.01));
    let program = "G90 G17 G0 X0 Y0 Z0\nG1 X10. F100\nG2 X20. Y10. I0 J10.\nG3 X10. Y20. R10.\nG18 G2 X0 Z-10. I-10. K0\n";
    let options = options(6);
    let out = nc::compensate(&machine, program.as_bytes(), "arcs.nc", &options).unwrap();
    assert_eq!(out.report.blocks_added, 0, "{}", out.text);
    let lines: Vec<&str> = out.text.lines().collect();
    assert_eq!(lines[2], "G2 X19.98 Y10.01 I0.0 J10.0");
    assert_eq!(lines[3], "G3 X9.98 Y20.01 R10.0");
    assert!(
        lines[4].starts_with("G18 G2 X-0.02 Z-10.0 I-10.0 K0.0"),
        "{}",
        lines[4]
    );
    assert!(largest_landing_error(&machine, program, &out, &options) < 1e-6);
}

#[test]
fn five_axis_programs_keep_their_rotary_words_and_land_the_tool_tip() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let program =
        "G90 G0 X400. Y300. Z300. B0 C0\nG1 X450. F500\nB30. C45.\nX420. Y320. Z280. B-20. C90.\n";
    let options = options(7);
    let out = nc::compensate(&machine, program.as_bytes(), "five.nc", &options).unwrap();
    assert!(largest_landing_error(&machine, program, &out, &options) < 1e-6);
    let last = out.text.lines().last().unwrap();
    assert!(last.contains("B-20.") && last.contains("C90."), "{last}");
    // A block that only turns the rotary axes gets the linear words that keep the tip in place;
    // split, each piece turns its share and the last ends where the program does.
    let lines: Vec<&str> = out.text.lines().collect();
    let first = lines[out.origins.iter().position(|&o| o == 3).unwrap()];
    let end = lines[out.origins.iter().rposition(|&o| o == 3).unwrap()];
    assert!(first.contains('X') && first.contains('B'), "{first}");
    assert!(end.contains("B30.") && end.contains("C45."), "{end}");
}

#[test]
fn inch_programs_are_compensated_in_inch() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let program = "G20 G90 G0 X10. Y10. Z10.\nG1 X20. F20.\nG2 X22. Y12. I0 J2.\n";
    let options = options(8);
    let out = nc::compensate(&machine, program.as_bytes(), "inch.nc", &options).unwrap();
    assert!(largest_landing_error(&machine, program, &out, &options) < 1e-6);
    let first = out.text.lines().next().unwrap();
    // Corrections of some 0.1 mm are a few thousandths of an inch.
    assert!(
        first.starts_with("G20 G90 G0 X9.99") || first.starts_with("G20 G90 G0 X10.00"),
        "{first}"
    );
}

fn error_of(program: &[u8], options: &Options) -> String {
    let machine = embedded::load("vmc-li2015").unwrap();
    nc::compensate(&machine, program, "bad.nc", options)
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_programs_name_the_line() {
    let o = options(4);
    let cases: [(&[u8], &str); 9] = [
        (b"G0 X10 Y10 Z10\nG92.3\n", "line 2: G92.3 is not supported"),
        (
            b"G0 X10 Y10 Z10\nG2 X20 Y20\n",
            "line 2: an arc (G2) needs its centre",
        ),
        (
            b"G0 X10 Y10 Z10\nG1 X2000\n",
            "line 2: the programmed point: X=2000",
        ),
        (
            b"G0 X10 Y10 Z10\nG1 X20 \x00\x01\n",
            "line 2: not a text file",
        ),
        (b"G0 X10 Y10 Z10\n\xff\xfe\n", "line 2: not a text file"),
        (b"G0 X10 Y10 Z10 (unclosed\n", "line 1: a comment"),
        (
            b"G0 X10 Y10 Z10\nG55 G0 X20\n",
            "line 2: G55 is active but its work offset was not given",
        ),
        (
            b"G0 X10 Y10 Z10\nG2 X30 Y10 I5 J0\n",
            "line 2: the arc's end is not on its circle",
        ),
        (
            b"G91 G0 X10 Y10 Z10\n",
            "line 1: X moves incrementally before",
        ),
    ];
    for (program, expected) in cases {
        let error = error_of(program, &o);
        assert!(error.contains(expected), "{expected}: {error}");
        assert!(error.starts_with("bad.nc: line"), "{error}");
    }
    let mut tools = options(4);
    tools.tool_lengths = ToolLengths::parse("T1=80").unwrap();
    let error = error_of(b"T2 M6\nG0 X10 Y10 Z10\n", &tools);
    assert!(error.contains("line 2: no length for tool T2"), "{error}");
    // --pass-unknown passes what volmap does not follow, unchanged.
    let mut passing = options(4);
    passing.pass_unknown = true;
    let machine = embedded::load("vmc-li2015").unwrap();
    let out = nc::compensate(
        &machine,
        b"G0 X10 Y10 Z10\nG65 P9000 (MACRO)\nG1 X20\n",
        "p.nc",
        &passing,
    )
    .unwrap();
    assert_eq!(out.text.lines().nth(1).unwrap(), "G65 P9000 (MACRO)");
}

#[test]
fn a_work_offset_turning_an_axis_the_machine_lacks_is_refused_by_the_library() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let program = b"G0 X10 Y10 Z10\nG1 X20\n";
    let mut turned = options(4);
    turned
        .work_offsets
        .insert(56, [0.0, 0.0, 0.0, 0.0, 0.0, 12.5]);
    turned
        .work_offsets
        .insert(55, [0.0, 0.0, 0.0, 0.0, -3.0, 0.0]);
    // Lowest offset number first, whichever path of the library is taken.
    for error in [
        error_of(program, &turned),
        nc::trace(&machine, program, "bad.nc", &turned)
            .unwrap_err()
            .to_string(),
    ] {
        assert_eq!(
            error,
            "G55 turns B by -3°, but the machine (chain FFXYZ) has no B axis"
        );
    }
    // Zeros for a missing axis are taken.
    let mut zeros = options(4);
    zeros
        .work_offsets
        .insert(54, [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    nc::compensate(&machine, program, "ok.nc", &zeros).unwrap();
}

#[test]
fn reference_returns_and_unreadable_blocks() {
    let machine = embedded::load("vmc-li2015").unwrap();
    // The way Fanuc posts begin and end: G91 G28 Z0 (home Z through the current position).
    let program = "%\nG91 G28 Z0.\nG90 G54 G0 X100. Y100.\nZ50.\nG1 Z20. F100\nX200.\nG91 G28 Z0.\nG28 X0. Y0.\nM30\n%\n";
    let options = options(7);
    let out = nc::compensate(&machine, program.as_bytes(), "fanuc.nc", &options).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    assert_eq!(lines[1], "G91 G28 Z0.");
    assert_eq!(lines[lines.len() - 4], "G91 G28 Z0.");
    assert_eq!(lines[lines.len() - 3], "G28 X0. Y0.");
    // Z is at its reference until the program names it: the first move does not add a Z word.
    assert!(!lines[2].contains('Z'), "{}", lines[2]);
    assert!(largest_landing_error(&machine, program, &out, &options) < 1e-6);
    // Z's place after G28 is the control's reference point, unknown to volmap: an incremental
    // move of it passes as it is, listed (Z unknown since the G28 block).
    let out = nc::compensate(
        &machine,
        b"G0 X10 Y10 Z10\nG91 G28 Z0\nZ-5\n",
        "p.nc",
        &options,
    )
    .unwrap();
    assert_eq!(out.text.lines().nth(2), Some("Z-5"), "{}", out.text);
    let listed: Vec<(usize, &str, usize)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str(), m.since_line))
        .collect();
    assert_eq!(listed, [(3, "Z", 2)]);
    // A line volmap cannot read is an error, or passed unread with --pass-unknown.
    let unread = b"G0 X10 Y10 Z10\n#100=5\nG1 X20\n";
    let error = nc::compensate(&machine, unread, "p.nc", &options)
        .unwrap_err()
        .to_string();
    assert!(error.contains("line 2: `#`"), "{error}");
    let mut passing = options.clone();
    passing.pass_unknown = true;
    let out = nc::compensate(&machine, unread, "p.nc", &passing).unwrap();
    assert_eq!(out.text.lines().nth(1).unwrap(), "#100=5");
}
