//! What the fuzzing campaigns found in NC compensation and in the measured runs of the
//! positioning tests (README "Fuzzing"), each kept as the input that showed it
//! (`tests/fuzz-regressions/`) or a hand-made one like it, with what volmap does now.

use std::path::PathBuf;

use volmap::model::Machine;
use volmap::nc::{self, NcError, Options};
use volmap::standards::{self, PositioningSpec, Setup};

fn regression(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-regressions")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn embedded(name: &str) -> Machine {
    volmap::io::embedded::embedded(name).unwrap().unwrap()
}

/// The options of the campaign's `gcode` target.
fn options() -> Options {
    Options {
        tool_lengths: nc::ToolLengths::parse("T1=80,T2=100,T3=90").unwrap(),
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

/// `G28 G91 Z0.` then moves in G91 before the program names Z again: the compensator added an
/// incremental `Z-0.0005` to `G91 G1 X5 Y5`, for a Z at the reference point that the reader
/// (rightly) does not know a start of. The rule README states holds now: an axis sent home gets
/// no word until a block names it.
#[test]
fn a_homed_axis_gets_no_word_before_the_program_names_it_again() {
    let text = compensated_reads_back(&regression("gcode-home-then-incremental.nc"));
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines.contains(&"G28 G91 Z0."), "{text}");
    assert!(lines.contains(&"G91 G1 X4.9997 Y4.9997"), "{text}");
    assert!(lines.contains(&"G90 G0 Z9.9305"), "{text}");
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
/// likewise, naming the block that sent it.
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
    // An arc in XY there leaves Z where it is: it reads back.
    compensated_reads_back(
        b"G21 G90 G54\nT1 M6\nG0 X0 Y0 Z10\nG53 G0 Z0.\nG17 G2 X20 Y0 I10 J0 F300\nG0 Z10\nM30\n",
    );
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

fn five_axis_setup() -> Setup {
    Setup::new(&embedded("5axis-hwang2014"), "").unwrap()
}

fn positioning_error(axis: &str, csv: &[u8]) -> (PathBuf, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.csv");
    std::fs::write(&path, csv).unwrap();
    let spec = PositioningSpec {
        axis: axis.into(),
        targets: None,
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: Some(path.clone()),
    };
    let error = standards::positioning(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    (path, error, dir)
}

/// Measured runs of C with a target of 450° (C turns 0 to 360°): the error named the target
/// but not the file; it names the file and the line of the target's first row now.
#[test]
fn a_measured_target_beyond_the_travel_names_its_file_and_line() {
    let (path, error, _dir) =
        positioning_error("C", &regression("measured-rotary-target-beyond-travel.csv"));
    assert_eq!(
        error,
        format!(
            "{}: line 6: positioning of C, target 450°: C=450 lies outside the travel of C (0 to 360)",
            path.display()
        )
    );
    // A linear axis likewise: X to 5000 mm on its second row.
    let mut csv = String::from("target_mm,direction,run,deviation_um\n");
    for run in 1..=5 {
        csv += &format!("0,+,{run},1\n5000,+,{run},2\n5000,-,{run},2\n0,-,{run},1\n");
    }
    let (path, error, _dir) = positioning_error("X", csv.as_bytes());
    let prefix = format!(
        "{}: line 3: positioning of X, target 5000: X=5000 lies outside the travel of X",
        path.display()
    );
    assert!(error.starts_with(&prefix), "{error}");
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
