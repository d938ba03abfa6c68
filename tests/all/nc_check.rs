//! The check of a compensated program before it is kept (`nc::check_written`): what the
//! compensation writes passes it; a written program tampered with fails it, naming the program's
//! line and what is wrong. The check reads only the two texts, so the tampered texts are the
//! compensation's own output with one thing changed by hand.

use volmap::io::embedded;
use volmap::nc::{self, CheckBounds, Options};

/// An arc first, so that tampering with a later block leaves every arc readable.
const PROGRAM: &str =
    "G90 G21 G17\nG0 X10 Y10 Z10\nG2 X30 Y30 I20 J0 F100\nG1 Y40\nG1 X50\nG0 Z50\nM30\n";

fn options(decimals: usize) -> Options {
    let (n, offset) = nc::parse_work_offset("G54=300,200,250").unwrap();
    let mut options = Options {
        decimals: Some(decimals),
        pass_unknown: true,
        ..Options::default()
    };
    options.work_offsets.insert(n, offset);
    options
}

fn corpus(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(name);
    std::fs::read_to_string(path).unwrap()
}

/// `PROGRAM` compensated on vmc-li2015 (4 decimals), its lines, their origins and the bounds.
fn compensated() -> (Vec<String>, Vec<usize>, CheckBounds) {
    let machine = embedded::load("vmc-li2015").unwrap();
    let options = options(4);
    let out = nc::compensate(&machine, PROGRAM.as_bytes(), "p.nc", &options).unwrap();
    let bounds = CheckBounds::of(out.report.largest_correction_mm, &options);
    (
        out.text.lines().map(str::to_string).collect(),
        out.origins,
        bounds,
    )
}

fn check(lines: &[String], bounds: CheckBounds) -> Result<(), String> {
    let machine = embedded::load("vmc-li2015").unwrap();
    let written = lines.join("\n") + "\n";
    nc::check_written(
        &machine,
        PROGRAM.as_bytes(),
        written.as_bytes(),
        "p.nc",
        &options(4),
        bounds,
    )
    .map_err(|e| e.to_string())
}

/// The value of axis word `letter` on a written line, and where its number stands.
fn word_at(line: &str, letter: char) -> (f64, std::ops::Range<usize>) {
    let start = line.find(letter).unwrap() + 1;
    let end = line[start..]
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .map_or(line.len(), |e| start + e);
    (line[start..end].parse().unwrap(), start..end)
}

fn word(line: &str, letter: char) -> f64 {
    word_at(line, letter).0
}

#[test]
fn what_the_compensation_writes_passes_the_check() {
    // Lines, arcs, take-ups (gantry-2m has reversal errors), G68 rotations, cycles, subprograms,
    // posts' programs, at 4 and 7 decimals and with the header comment the command line adds.
    for name in [
        "arcs",
        "mastercam",
        "rotated",
        "haas",
        "fusion",
        "test-piece",
    ] {
        let program = corpus(&format!("tests/fuzz-corpus/gcode/{name}.nc"));
        for machine in ["vmc-li2015", "gantry-2m"] {
            let machine = embedded::load(machine).unwrap();
            for decimals in [4, 7] {
                let options = options(decimals);
                let out = nc::compensate(&machine, program.as_bytes(), name, &options).unwrap();
                let text = nc::with_note(&out.text, "compensated by volmap");
                let bounds = CheckBounds::of(out.report.largest_correction_mm, &options);
                // The bound is the size of the machine's errors (0.12 mm on vmc-li2015 and 0.01
                // mm on gantry-2m, the reports' "before"), not a number that lets anything by.
                assert!(bounds.linear_mm < 0.2, "{name}: {bounds:?}");
                nc::check_written(
                    &machine,
                    program.as_bytes(),
                    text.as_bytes(),
                    name,
                    &options,
                    bounds,
                )
                .unwrap_or_else(|e| panic!("{name} at {decimals} decimals: {e}"));
            }
        }
    }
    let (lines, _, bounds) = compensated();
    check(&lines, bounds).unwrap();
}

#[test]
fn an_added_move_fails_the_check() {
    let (lines, origins, bounds) = compensated();
    // vmc-li2015's corrections are about 0.12 mm (its error before): every tampering below is
    // 1 mm or more, far beyond the bound of about 0.12 mm + 1 µm + rounding.
    assert!(bounds.linear_mm < 0.2, "{bounds:?}");
    let last_of = |origin: usize| origins.iter().rposition(|&o| o == origin).unwrap();
    // A move along X after line 4 (Y30 to Y40 at X30), which moves Y only: the 20 mm to X10.
    let mut added = lines.clone();
    added.insert(last_of(4) + 1, "G1 X10".into());
    // Past line 4's end it would begin line 5 (X30 to X50), which it leaves backwards; nor is
    // it line 4, which holds X at 30: by hand 30 - 10 = 20 mm.
    let error = check(&added, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 5: "), "{error}");
    assert!(error.contains("`G1 X10`"), "{error}");
    assert!(error.contains("from the programmed path"), "{error}");
    assert!(
        error.contains("nor does it continue line 4 (moves X by 20.0000 mm"),
        "{error}"
    );
    // A move after the last one (the rapid of line 6).
    let mut after = lines.clone();
    after.insert(last_of(6) + 1, "G0 Z60".into());
    let error = check(&after, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 6: "), "{error}");
    assert!(
        error.contains("comes after the program's last move"),
        "{error}"
    );
    assert!(error.contains("adds a move to a rapid (G0)"), "{error}");
    // A move before the first: the written program then starts somewhere else.
    let mut before = lines.clone();
    before.insert(last_of(2), "G0 X0 Y0 Z0".into());
    let error = check(&before, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 2: "), "{error}");
    assert!(error.contains("its first move"), "{error}");
}

#[test]
fn an_axis_the_program_does_not_move_fails_the_check() {
    let (lines, origins, bounds) = compensated();
    // Line 4 (G1 Y40 from X30 Y30) moves Y only: its first written piece given X29, moves X by
    // 1 mm (by hand: 30 - 29) where the bound is about 0.12 mm.
    let first = origins.iter().position(|&o| o == 4).unwrap();
    let mut moved = lines.clone();
    moved[first] = format!("G1 Y{} X29", word(&lines[first], 'Y'));
    let error = check(&moved, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 4: "), "{error}");
    assert!(error.contains("moves X by 1.0000 mm"), "{error}");
    assert!(
        error.contains("where the program's block does not move it"),
        "{error}"
    );
}

#[test]
fn an_end_point_beyond_the_bound_fails_the_check() {
    let (lines, origins, bounds) = compensated();
    // Line 4's last piece ends 0.5 mm further along Y than written: 0.5 mm beyond Y40 (the
    // compensated Y is within the 0.12 mm correction of it), past the end of the path.
    let last = origins.iter().rposition(|&o| o == 4).unwrap();
    let (y, at) = word_at(&lines[last], 'Y');
    let mut off = lines.clone();
    off[last].replace_range(at, &format!("{:.4}", y + 0.5));
    assert_ne!(off[last], lines[last]);
    let error = check(&off, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 4: "), "{error}");
    // 0.5 mm from the end, less up to 0.12 mm of correction the other way.
    let passes = error.find("passes ").map(|i| &error[i + 7..i + 13]);
    let mm: f64 = passes.unwrap().parse().unwrap();
    assert!((0.38..=0.62).contains(&mm), "{error}");
}

#[test]
fn a_rapid_turned_into_a_feed_fails_the_check() {
    let (lines, origins, bounds) = compensated();
    let rapid = origins.iter().position(|&o| o == 6).unwrap();
    assert!(lines[rapid].starts_with("G0 "), "{}", lines[rapid]);
    let mut fed = lines.clone();
    fed[rapid] = lines[rapid].replacen("G0", "G1", 1);
    let error = check(&fed, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 6: "), "{error}");
    assert!(
        error.contains("feeds where the program has a rapid (G0)"),
        "{error}"
    );
    // And a feed turned into a rapid (line 5's first piece; the next gets its G1 back).
    let feed = origins.iter().position(|&o| o == 5).unwrap();
    let mut rapid_feed = lines.clone();
    rapid_feed[feed] = format!("G0 {}", lines[feed].replacen("G1", "", 1).trim());
    rapid_feed.insert(feed + 1, "G1".into());
    let error = check(&rapid_feed, bounds).unwrap_err();
    assert!(error.starts_with("p.nc: line 5: "), "{error}");
    assert!(
        error.contains("is a rapid (G0) where the program feeds"),
        "{error}"
    );
}

#[test]
fn an_axis_a_passed_block_leaves_unknown_is_not_written() {
    // The texts by hand: after a line volmap cannot read, or a code it does not follow naming an
    // axis, where that axis stands is not known; the written program may not name it where the
    // program does not, and a move from there is one move.
    let machine = embedded::load("vmc-li2015").unwrap();
    let bounds = CheckBounds {
        linear_mm: 0.01,
        rotary_deg: 1e-4,
    };
    let check = |original: &str, written: &str| {
        nc::check_written(
            &machine,
            original.as_bytes(),
            written.as_bytes(),
            "u.nc",
            &options(4),
            bounds,
        )
        .map_err(|e| e.to_string())
    };
    let original = "G0 X10 Y10 Z10\nG1 X[1+2] Y20 F100\nG1 Y40\n";
    check(original, original).unwrap();
    let error = check(
        original,
        "G0 X10 Y10 Z10\nG1 X[1+2] Y20 F100\nG1 Y40 X10.002\n",
    )
    .unwrap_err();
    assert!(error.starts_with("u.nc: line 3: "), "{error}");
    assert!(
        error.contains("`G1 Y40` passes as it is, but the output has `G1 Y40 X10.002` (line 3 of the output) in its place"),
        "{error}"
    );
    // G10 L2 sets G54's X to 5 and moves nothing: the move after it runs from where the machine
    // stands (machine X 310) to machine X 55; a written move to X4.93 (machine X 9.93) strays
    // 45 mm from that path.
    let original = "G0 X10 Y10 Z10\nG10 L2 P1 X5\nG1 X50 F100\n";
    check(original, "G0 X10 Y10 Z10\nG10 L2 P1 X5\nG1 X50.001 F100\n").unwrap();
    let error = check(
        original,
        "G0 X10 Y10 Z10\nG10 L2 P1 X5\nG1 X4.93 F100\nX50.001\n",
    )
    .unwrap_err();
    assert!(error.starts_with("u.nc: line 3: "), "{error}");
    // A block passed as it is and left out of the output.
    let original = "G0 X10 Y10 Z10\nG1 X[1+2] Y20 F100\nG1 Y40\n";
    let error = check(original, "G0 X10 Y10 Z10\nG1 X[1+2] Y20 F100\n").unwrap_err();
    assert!(
        error.contains("line 3: ")
            && error.contains("`G1 Y40` passes as it is, but the output lacks it"),
        "{error}"
    );
}
