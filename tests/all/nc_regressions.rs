//! What the fuzzing campaigns found in NC programs (docs/testing.md, "Fuzzing"): canned cycles and
//! subprogram calls as the reader expands them, and compensated programs that must read back;
//! each kept as the input that showed it (`tests/fuzz-regressions/`) or a hand-made one like it,
//! with what volmap does now.

use volmap::model::Machine;
use volmap::nc::{self, NcError, Options};

use super::common::fuzz_regression as regression;

fn embedded(name: &str) -> Machine {
    volmap::io::embedded::embedded(name).unwrap().unwrap()
}

fn machine() -> Machine {
    embedded("vmc-li2015")
}

/// The options of the campaign's `gcode` target.
fn options() -> Options {
    Options {
        tool_lengths: nc::ToolLengths::parse("T1=80,T2=100,T3=90").unwrap(),
        work_offsets: [(54, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0])].into(),
        ..Options::default()
    }
}

/// Work offset G54 alone, as the first findings were pinned.
fn g54_only() -> Options {
    Options {
        work_offsets: [(54, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0])].into(),
        ..Options::default()
    }
}

fn line_error(result: Result<impl std::fmt::Debug, NcError>) -> (usize, String) {
    match result {
        Err(NcError::Line { line, message, .. }) => (line, message),
        other => panic!("expected an error naming a line, got {other:?}"),
    }
}

/// Compensates `program` on vmc-li2015 and reads the result back as the campaign does; the
/// compensated text.
fn compensated_reads_back(program: &[u8]) -> String {
    let machine = embedded("vmc-li2015");
    let out = nc::compensate(&machine, program, "in.nc", &options()).unwrap();
    if let Err(e) = nc::trace(&machine, out.text.as_bytes(), "out.nc", &options()) {
        panic!(
            "the compensated program does not read back: {e}\n{}",
            out.text
        );
    }
    out.text
}

/// Compensates `program` on `machine` with tool T1 and reads the result back; the compensated
/// text.
fn compensated_reads_back_on(machine: &Machine, program: &[u8]) -> String {
    let options = Options {
        tool_lengths: nc::ToolLengths::parse("T1=80").unwrap(),
        ..g54_only()
    };
    let out = nc::compensate(machine, program, "in.nc", &options).unwrap();
    if let Err(e) = nc::trace(machine, out.text.as_bytes(), "out.nc", &options) {
        panic!(
            "the compensated program does not read back: {e}\n{}",
            out.text
        );
    }
    out.text
}

/// A G83 hole 6 km deep in pecks of 2 mm made three million pecks (a 4 GB allocation, then an
/// abort): a hole takes at most 10,000 pecks.
#[test]
fn pecks_past_the_limit_are_refused_naming_the_block() {
    let program = regression("gcode-pecks.nc");
    let (line, message) = line_error(nc::compensate(&machine(), &program, "p.nc", &g54_only()));
    assert_eq!(line, 24);
    assert_eq!(
        message,
        "G83: a peck depth Q2 from R3 to Z-6000000 makes 3000002 pecks, more than the 10000 a hole may take"
    );
    // A peck depth of a ten-thousandth of a micrometre in a 7 mm hole.
    let tiny = b"G0 X10 Y10 Z10\nG83 X10 Y10 Z-5 R2 Q0.0000001\nG80\nM30\n";
    let (line, message) = line_error(nc::blocks_as_run(tiny, "q.nc", false));
    assert_eq!(line, 2);
    assert!(
        message.contains("makes 70000000 pecks, more than the 10000"),
        "{message}"
    );
}

/// A peck smaller than the last digit of the levels it pecks between went on for ever: each
/// peck left the level where it was. Such a peck now goes to the depth.
#[test]
fn pecks_below_the_resolution_of_their_levels_end() {
    let program = b"G0 X10 Y10 Z1e17\nG83 X10 Y10 Z99999999999999990 R1e17 Q2\nG80\nM30\n";
    let blocks = nc::blocks_as_run(program, "deep.nc", false).unwrap();
    let feeds: Vec<&str> = blocks
        .iter()
        .map(|b| b.text.trim())
        .filter(|t| t.starts_with("G1 Z"))
        .collect();
    // The depth as an f64 holds it (its last digit is 16).
    assert_eq!(feeds, ["G1 Z99999999999999984"], "{blocks:#?}");
}

/// Subprograms calling subprograms a thousand times each expanded three million blocks from
/// 30 lines (1.25 GB and 7 s to compensate); calls and cycles add at most four million words
/// and blocks (a block counting eight), which a million blocks of eight words (700 MB, 1 s to
/// read) also passed. A million calls of a body of two comments, when a block counted one, took
/// 600 MB and over a second on a busy machine.
#[test]
fn calls_and_cycles_add_at_most_four_million_words_and_blocks() {
    let program = regression("gcode-calls.nc");
    let (line, message) = line_error(nc::blocks_as_run(&program, "c.nc", false));
    assert_eq!(line, 8, "the outermost call");
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    let words = regression("gcode-words.nc");
    let (line, message) = line_error(nc::blocks_as_run(&words, "w.nc", false));
    assert_eq!(line, 18);
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    // Canned cycles count against the same bound: 1000 repeats of 1000 pecks.
    let cycles = b"G0 X10 Y10 Z10\nG83 X10 Y10 Z-999 R1 Q1 L1000\nG80\nM30\n";
    let (line, message) = line_error(nc::blocks_as_run(cycles, "h.nc", false));
    assert_eq!(line, 2);
    assert_eq!(
        message,
        "the subprogram calls and canned cycles add more than 4000000 words and blocks to the program"
    );
    // Blocks of nothing but comments count as blocks: the outermost call is refused.
    let empty = regression("gcode-empty-calls.nc");
    let (line, message) = line_error(nc::blocks_as_run(&empty, "e.nc", false));
    assert_eq!(line, 7);
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    // Long blocks count for their length: a 6 kB block repeated a million times.
    let long = format!(
        "G0 X10 Y10 Z10\nM98 P1 L1000\nM30\nO1\nM98 P2 L1000\nM99\nO2\nG1 X11 ({})\nM99\n",
        "x".repeat(6000)
    );
    let (line, _) = line_error(nc::blocks_as_run(long.as_bytes(), "l.nc", false));
    assert_eq!(line, 2);
    // A program's own blocks do not count: 990,000 of them (twice what the calls may add at
    // eight words a block, 500,000), within the limit of 1,000,000 blocks, are read as they are.
    let mut own = String::from("G0 X10 Y10 Z10\nM98 P1\nM30\nO1\nG1 X11 F100\nM99\n");
    own.push_str(&"G1 X12\n".repeat(990_000));
    let blocks = nc::blocks_as_run(own.as_bytes(), "own.nc", false).unwrap();
    assert!(blocks.len() > 990_000);
}

/// A last line without a line end whose arc was split: the added pieces were written onto it,
/// one block of two arcs (`X59.9299 Y19.7988 I-9.8263 X49.9317 …`) that no reader takes.
#[test]
fn pieces_after_a_last_line_without_a_line_end_start_lines_of_their_own() {
    let program = regression("gcode-last-line.nc");
    assert!(!program.ends_with(b"\n"));
    let text = compensated_reads_back_on(&machine(), &program);
    for line in text.lines() {
        assert!(line.matches('X').count() <= 1, "{line}\n{text}");
    }
}

/// A half circle by R (`G3 X40 Y0 R10` from X20): compensated, its written R (9.9999) fell
/// short of half its written chord (10.0000), which the reader refuses; the planner now holds
/// a written R to the reader's rule and splits such an arc.
#[test]
fn compensated_half_circles_by_radius_read_back() {
    let five = volmap::io::embedded::embedded("5axis-hwang2014")
        .unwrap()
        .unwrap();
    compensated_reads_back_on(&five, &regression("gcode-half-circle-r.nc"));
}

/// An arc in the XZ plane after `G53 G0 Z0` and no Z word since: its K was written relative to
/// a Z the output had not written, as `KNaN`. Such an arc starts where the control has Z, not at
/// a point of the program: it is refused now, naming its line and the G53 block
/// (`an_arc_from_a_homed_axis_is_refused_naming_both_lines`); with Z set again before it, its centre words are numbers.
#[test]
fn centre_words_after_a_reference_return_are_numbers() {
    let program = regression("gcode-arc-after-home.nc");
    let (line, message) = line_error(nc::compensate(&machine(), &program, "p.nc", &g54_only()));
    // The XY arc after the home is refused first now: Z stands at the home, uncorrected.
    assert_eq!(line, 8);
    assert!(message.contains("on line 7"), "{message}");
    let set = String::from_utf8(program)
        .unwrap()
        .replace("G53 G0 Z0.", "G53 G0 Z0.\nG0 Z-1");
    let text = compensated_reads_back_on(&machine(), set.as_bytes());
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
}

/// `G28 G91 Z0.` then moves in G91 before the program names Z again: the compensator added an
/// incremental `Z-0.0005` to `G91 G1 X5 Y5`, for a Z at the reference point that the reader
/// (rightly) does not know a start of. The rule docs/nc.md states holds now: an axis sent home gets
/// no word until a block names it; and the moves with Z at the reference point (the control's,
/// not in the program, so Z is unknown) are not compensated at all: they pass as they are, listed
/// as the moves after a block volmap does not follow are, up to the one that sets Z again.
#[test]
fn a_homed_axis_gets_no_word_before_the_program_names_it_again() {
    let program = regression("gcode-home-then-incremental.nc");
    let text = compensated_reads_back(&program);
    let lines: Vec<&str> = text.lines().collect();
    for line in [
        "G28 G91 Z0.",
        "G00 G54 X20. Y20. S1500 M03",
        "G91 G1 X5 Y5",
        "G90 G0 Z10",
    ] {
        assert!(lines.contains(&line), "{line}: {text}");
    }
    let out = nc::compensate(&embedded("vmc-li2015"), &program, "in.nc", &options()).unwrap();
    let listed: Vec<(usize, &str, usize)> = out
        .report
        .moves_not_compensated
        .iter()
        .map(|m| (m.line, m.unknown.as_str(), m.since_line))
        .collect();
    assert_eq!(listed, [(7, "Z", 3), (8, "Z", 3), (9, "Z", 3)]);
}

/// The same for an axis the program has not named yet: its start is, for the reader, the first
/// value the program gives it, so the output adds no word for it before that (an incremental
/// one would not read back; an absolute one would move it from where it stands).
#[test]
fn an_axis_not_yet_named_gets_no_word_before_the_program_names_it() {
    let program =
        b"G21 G90 G54\nT1 M6\nG0 X10 Y20\nG91 G1 X50 Y50 F300\nG90 G0 Z10\nG1 X100 Y100\nM30\n";
    let text = compensated_reads_back(program);
    let line = |start: &str| {
        text.lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no line {start}: {text}"))
    };
    assert!(!line("G0 X").contains('Z'), "{text}");
    assert!(!line("G91 G1 X").contains('Z'), "{text}");
    assert!(line("G90 G0 Z9.9").len() > 8, "{text}");
    // Once named, Z gets the words its compensation needs.
    assert!(line("G1 X").contains(" Z"), "{text}");
}

/// An arc whose start has an X the program never set (`G43 H1 Y20 Z-1 J10 K0`, then
/// `G2 X40 Y20 I-10 J0`): the compensator took X at its compensated start, the reader of the
/// output at the first X written, and the output's arc did not close. A control starts such an
/// arc wherever X stands, so the program is refused, naming the arc's line.
#[test]
fn an_arc_from_an_axis_never_set_is_refused_naming_its_line() {
    let machine = embedded("vmc-li2015");
    let program = regression("gcode-arc-from-unset-axis.nc");
    let expected = "an arc (G2) starts where X is not known: the program has not set it before this block, so the arc's start and centre are not known; set X before the arc";
    let (line, message) = line_error(nc::compensate(&machine, &program, "p.nc", &options()));
    assert_eq!((line, message.as_str()), (6, expected));
    let (line, message) = line_error(nc::trace(&machine, &program, "p.nc", &options()));
    assert_eq!((line, message.as_str()), (6, expected));
    // With X set first it is a program, and compensated it reads back.
    let set = String::from_utf8(program)
        .unwrap()
        .replace("G43 H1 Y20", "G43 H1 X40 Y20");
    let text = compensated_reads_back(set.as_bytes());
    assert!(text.contains("G17 G2 X"), "{text}");
}

/// An arc in the plane of an axis sent to a machine position (`G53 G0 Z0.`, then an XZ arc)
/// starts where the control has that axis, which is not a point of the program: refused
/// likewise, naming the block that sent it. An arc in XY there is refused by the compensation:
/// Z stands at its machine position, uncorrected (no Z word is added before a block names Z),
/// so the arc cannot be held to the tolerance; traced, it is evaluated at that height.
#[test]
fn an_arc_from_a_homed_axis_is_refused_naming_both_lines() {
    let machine = embedded("vmc-li2015");
    let program =
        b"G21 G90 G54\nT1 M6\nG0 X0 Y0 Z10\nG1 Z-1 F300\nG53 G0 Z0.\nG18 G2 X20 Z-1 I10 K0\nM30\n";
    let (line, message) = line_error(nc::compensate(&machine, program, "p.nc", &options()));
    assert_eq!(line, 6);
    assert_eq!(
        message,
        "an arc (G2) starts where Z is not known: it went to the reference point or a machine position on line 5 and the program has not set it since, so the arc's start and centre are not known; set Z before the arc"
    );
    let in_xy =
        b"G21 G90 G54\nT1 M6\nG0 X0 Y0 Z10\nG53 G0 Z0.\nG17 G2 X20 Y0 I10 J0 F300\nG0 Z10\nM30\n";
    let (line, message) = line_error(nc::compensate(&machine, in_xy, "p.nc", &options()));
    assert_eq!(line, 5);
    assert_eq!(
        message,
        "an arc (G2) with Z at the machine position of G53 on line 4: the output writes no Z word before a block names it, so the arc cannot be compensated; set Z before the arc"
    );
    let traced = nc::trace(&machine, in_xy, "p.nc", &options()).unwrap();
    let arc = traced.iter().find(|p| p.line == 5).unwrap();
    // By hand: machine Z 0, the work offset's Z taken off (T1 without G43 adds nothing).
    assert_eq!(arc.command[2], 0.0);
}

/// A million blocks (`M98 P8654 L1000` calling `M98 P8655 L1000`) under `G68`: the calls
/// stayed within their limit, but rotating every block they added took 1.6 s. Rotating what
/// calls add now counts against the same limit, naming the G68 block.
#[test]
fn rotating_what_calls_add_counts_against_their_limit() {
    // As found, the calls alone now pass their limit (a block counts eight): 400 inner repeats
    // are within it, and rotating what they add is not.
    let found = regression("gcode-rotated-calls.nc");
    assert!(nc::blocks_as_run(&found, "p.nc", false).is_err());
    let program = String::from_utf8(found)
        .unwrap()
        .replace("M98 P8655 L1000", "M98 P8655 L400")
        .into_bytes();
    let (line, message) = line_error(nc::blocks_as_run(&program, "p.nc", false));
    assert_eq!(line, 5);
    assert_eq!(
        message,
        format!(
            "G68: the blocks it rotates, with what subprogram calls and canned cycles add, come to more than {} words and blocks",
            nc::MAX_EXPANDED_WORDS
        )
    );
    // Without the rotation the same calls are within the limit.
    let plain = String::from_utf8(program)
        .unwrap()
        .replace("G68 X10. Y10. R30.", "");
    let blocks = nc::blocks_as_run(plain.as_bytes(), "p.nc", false).unwrap();
    assert!(blocks.len() > 400_000, "{}", blocks.len());
    // Calls under a rotation within it are rotated: 100 blocks `Y30.` turned by 30° about
    // (10, 10) from X40 Y10.
    let small = plain
        .replace("L1000", "L10")
        .replace("L400", "L10")
        .replace("G0 X40. Y10.", "G68 X10. Y10. R30.\nG0 X40. Y10.");
    let blocks = nc::blocks_as_run(small.as_bytes(), "p.nc", false).unwrap();
    let rotated = blocks
        .iter()
        .filter(|b| b.text.contains("(G68: Y30.)"))
        .count();
    assert_eq!(rotated, 101, "one in the file, 100 from the calls");
}

/// A program number of 343 digits (`G65 P0.000…1`) was written out whole in the message saying it
/// is not one.
#[test]
fn a_program_number_of_many_digits_is_quoted_in_part() {
    let program = regression("gcode-long-program-number.nc");
    let (line, message) = line_error(nc::blocks_as_run(&program, "p.nc", false));
    assert_eq!(line, 9);
    assert!(message.starts_with("G65: `P0.000"), "{message}");
    assert!(
        message.ends_with("`: not a program number") && message.contains('…'),
        "{message}"
    );
    assert!(message.len() < 200, "{} bytes: {message}", message.len());
}

/// A word of an axis the machine lacks (A on `FYXCFZB`), 307 digits long, is passed by, but the
/// compensation rounded it to six decimals of a degree, which overflowed: it wrote `A-inf`, which
/// no reader takes. A value too large to round stays as written.
#[test]
fn a_huge_word_passed_by_is_written_as_a_number() {
    let program = regression("gcode-huge-passed-word.nc");
    let machine = embedded("5axis-hwang2014");
    let options = Options {
        orientation_tolerance_rad: Some(nc::DEFAULT_ANGULAR_TOLERANCE_RAD),
        work_offsets: (54..=59)
            .map(|n| (n, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0]))
            .collect(),
        ..options()
    };
    let out = nc::compensate(&machine, &program, "in.nc", &options).unwrap();
    let line = out
        .text
        .lines()
        .find(|l| l.starts_with("G55"))
        .expect("the G55 block");
    assert!(line.starts_with("G55 A-1000000000"), "{line}");
    assert!(!line.contains("inf"), "{line}");
    nc::trace(&machine, out.text.as_bytes(), "out.nc", &options).unwrap();
}
