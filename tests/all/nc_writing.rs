//! What a compensated program keeps of its blocks (docs/nc.md, "Writing" and "Reading"): the note
//! volmap writes at its head after the program number, and every word of a block it rewrites.

use volmap::nc;

/// FANUC-family controls expect the program number first after `%`: the note goes after the `O`
/// line (and after `%`), and at the very head where there is neither (by hand).
#[test]
fn the_note_goes_after_the_program_number() {
    assert_eq!(
        nc::with_note("%\nO1234 (PART)\nG0 X0\n%\n", "made"),
        "%\nO1234 (PART)\n(made)\nG0 X0\n%\n"
    );
    assert_eq!(
        nc::with_note("O0001\r\nG0 X0\r\n", "made"),
        "O0001\r\n(made)\nG0 X0\r\n"
    );
    assert_eq!(
        nc::with_note(":42\nG0 X0\n", "made"),
        ":42\n(made)\nG0 X0\n"
    );
    assert_eq!(nc::with_note("%\nG0 X0\n", "made"), "%\n(made)\nG0 X0\n");
    assert_eq!(nc::with_note("G0 X0\n", "made"), "(made)\nG0 X0\n");
    // An `O` that is not a program number (a word of a block) stays below the note.
    assert_eq!(
        nc::with_note("G0 X0\nO12\n", "made"),
        "(made)\nG0 X0\nO12\n"
    );
    // A program of one number line without a line end.
    assert_eq!(nc::with_note("O12", "made"), "O12\n(made)\n");
}

fn machine() -> volmap::model::Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
}

fn options() -> nc::Options {
    nc::Options {
        work_offsets: [(54, [300.0, 200.0, 250.0, 0.0, 0.0, 0.0])].into(),
        ..nc::Options::default()
    }
}

/// The end point (program coordinates, X Y Z) and line of every move `trace` follows.
fn traced(program: &str) -> Vec<(usize, [f64; 3])> {
    nc::trace(&machine(), program.as_bytes(), "p.nc", &options())
        .unwrap()
        .iter()
        .map(|p| (p.line, [p.program[0], p.program[1], p.program[2]]))
        .collect()
}

/// `M98 P1 S1000 M8 T2` keeps spindle speed, coolant and tool on a block of their own before the
/// body; `M98 P1 X30.` moves to X30 before the body runs, as FANUC runs it (by hand: from X0 Y0
/// Z5 to X30, then the body's G1 Y5 from there).
#[test]
fn a_call_keeps_its_other_words_and_its_move_comes_first() {
    let program = "G0 X0 Y0 Z5\nM98 P1 S1000 M8 T2\nM98 P1 X30.\nM30\nO1\nG1 Y5 F100\nM99\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "c.nc", &options()).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    let call = lines
        .iter()
        .position(|l| l.contains("M98 P1 S1000"))
        .unwrap();
    assert!(lines[call].starts_with('('), "{}", out.text);
    assert_eq!(lines[call + 1], "S1000 M8 T2");
    assert!(lines[call + 2].starts_with("G1 Y4.9"), "{}", out.text);
    let call = lines
        .iter()
        .position(|l| l.contains("M98 P1 X30."))
        .unwrap();
    assert!(lines[call + 1].starts_with("X29.9"), "{}", out.text);
    let points = traced(program);
    assert_eq!(
        points,
        [
            (1, [0.0, 0.0, 5.0]),
            (6, [0.0, 5.0, 5.0]),
            (3, [30.0, 5.0, 5.0]),
            (6, [30.0, 5.0, 5.0]),
        ]
    );
}

/// `G68 X0 Y0 R30 M3 S1000 T1` keeps the spindle start, its speed and the tool on a block of their
/// own after the rotation's comment, and `G69 M5` the spindle stop; the move between is turned
/// by 30° (by hand: X10 is (10 cos 30°, 10 sin 30°) = (8.660254, 5)).
#[test]
fn a_rotation_keeps_its_other_words() {
    let program = "G0 X0 Y0 Z5\nG68 X0 Y0 R30 M3 S1000 T1\nG1 X10 F100\nG69 M5\nM30\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "r.nc", &options()).unwrap();
    let lines: Vec<&str> = out.text.lines().collect();
    assert!(lines[1].starts_with("(G68"), "{}", out.text);
    assert_eq!(lines[2], "M3 S1000 T1");
    let stop = lines.iter().position(|l| l.starts_with("(G69")).unwrap();
    assert_eq!(lines[stop + 1], "M5");
    let points = traced(program);
    let (line, end) = points[1];
    assert_eq!(line, 3);
    // The rotation is applied with 9 decimals (docs/nc.md).
    assert!((end[0] - 8.660254038).abs() < 1e-9 && (end[1] - 5.0).abs() < 1e-9);
}

/// G68 about another axis than the XY plane's (I1 J0 K0: about X) is refused naming its line;
/// I0 J0 K2 is the XY plane's axis and turns as without I J K.
#[test]
fn a_rotation_about_another_axis_is_refused() {
    let about_x = "G0 X0 Y0 Z5\nG68 X0 Y0 Z0 I1 J0 K0 R30\nG1 X10 F100\n";
    match nc::compensate(&machine(), about_x.as_bytes(), "r.nc", &options()) {
        Err(nc::NcError::Line { line, message, .. }) => {
            assert_eq!(line, 2);
            assert!(message.contains("I J K"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let about_z = "G0 X0 Y0 Z5\nG68 X0 Y0 I0 J0 K2 R30\nG1 X10 F100\n";
    let end = traced(about_z)[1].1;
    assert!((end[0] - 8.660254038).abs() < 1e-9 && (end[1] - 5.0).abs() < 1e-9);
}

/// Words added to a line of one word are spaced (a line of one word has no gap to follow), and
/// to an unspaced line unspaced.
#[test]
fn added_words_follow_the_line_or_take_a_space() {
    let program = "G90 G21 G17\nG0 X10 Y10 Z10\nG1 X50 F100\nY35.\nG1Y40.\nM30\n";
    let out = nc::compensate(&machine(), program.as_bytes(), "w.nc", &options()).unwrap();
    let lines: Vec<&str> = out.text.lines().filter(|l| !l.starts_with('(')).collect();
    assert!(lines[3].starts_with('Y'), "{}", out.text);
    assert!(lines[3].contains(" X"), "{}", out.text);
    assert!(!lines[4].contains(' '), "{}", out.text);
    assert!(lines[4].contains('X'), "{}", out.text);
}
