//! Compensation checked by an interpreter that shares no code with volmap: LinuxCNC's `rs274`
//! runs the original and the compensated program, and the canonical motion of the compensated
//! one must follow the original's (issue 29, item 3).
//!
//! For each program (the example and test programs, and programs generated at random from a
//! grammar, `grammar`), on `vmc-li2015` and `gantry-2m`:
//! - rs274 runs both (work offsets and the G28 position set in its parameters, the same for
//!   both), and its `STRAIGHT_TRAVERSE`, `STRAIGHT_FEED` and `ARC_FEED` are read as moves in
//!   machine coordinates (`canon`);
//! - each original move is made by one or more consecutive compensated moves that stay, sampled
//!   every 0.5 mm, within the bound of its path going forward, the last ending within it of its
//!   end; no compensated rapid where the original feeds, no feed where it makes a rapid, one
//!   rapid per rapid (a rapid is not split), no move left over (`check::pair`). The bound is the
//!   largest correction (1.1 × the largest distance of the real tool tip from the ideal one
//!   along the original's moves, both approach directions, from the model: the correction
//!   solves `real(q') = ideal(q)`, and the real machine differs from the ideal one by at most
//!   that, the factor covering the change of the error across the correction, a gradient of
//!   1e-4 at most on these machines) plus the chord tolerance plus 0.2 µm (rs274 prints 4
//!   decimals: each printed point within 0.087 µm of the exact one, in both programs);
//! - the machine model at rs274's positions (`check::tips`): the real tool tip of the
//!   compensated program, each axis approaching as it last moved, lies within the chord
//!   tolerance plus 0.2 µm (the printing, as above) of the original's ideal path at the end of
//!   every compensated move and along every feed move, and of the original's ideal end at the
//!   end of each original move. Rapids to a machine position (G28, G53), the moves volmap leaves
//!   uncorrected after them by design (`text::left_after_homes`), the blocks volmap passes
//!   and the moves it lists as left alone (they depend on an axis a macro, an expression or a
//!   G28 left unknown: `listed_left_alone`), and moves before the program has named every axis
//!   (where the axis stands is the machine's start, which volmap cannot know), are only paired.
//! - volmap may refuse a program for one reason only: an absolute arc it must pass as it is
//!   after a compensated move (its centre words would not fit); at most one program in ten.
//!
//! A failure names the program, saved with its compensated text and both canonical outputs
//! under the test's target folder (`nc_rs274/`), and the first sample out of bound.

mod canon;
mod check;
mod grammar;
mod text;

use std::path::{Path, PathBuf};

use volmap::io::embedded;
use volmap::model::Machine;
use volmap::nc::{self, Options};

use text::{all_axes_named, as_linuxcnc, numbered_lines, with_line_numbers, with_x};

/// What the generated programs are made of.
const FEATURES: &[&str] = &[
    // G0 and G1, absolute; G91 sections.
    "lines",
    "incremental",
    // G2/G3 with I J K (whole circles too) or R, in G17, G18 and G19; helical; R < 0 (more
    // than half a turn).
    "arcs",
    "arcs-r-over-180",
    "planes",
    "helices",
    // G54–G59 on a block naming every axis, and alone (the axes stand where they are).
    // The change of offset moves an axis the other way than its program coordinates do.
    "work-offsets",
    "offset-change",
    "offset-direction",
    // G81 and G83 with G98/G99, modal repeats, G80.
    "cycles",
    // M98 P.. L.. and O..M99 (volmap), o.. sub / o.. call (rs274).
    "subprograms",
    // G4 P and G64 P: blocks that do not move.
    "dwell-g64",
    // `G53 G0 Z..` and `G91 G28`, then moves naming some axes only.
    "g53",
    "g28",
    // G10 L2 (work offsets set in the program), G92 shifts, macro variables, expressions:
    // volmap passes them with --pass-unknown.
    "g10",
    "g92",
    "macros",
    "expressions",
];

/// Features that need volmap's --pass-unknown.
const PASSED: &[&str] = &["g10", "g92", "macros", "expressions"];

/// Generated programs per machine, and blocks per program.
const PROGRAMS: u64 = 100;
const BLOCKS: usize = 24;

fn rs274_installed() -> bool {
    crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v rs274"]),
        "LinuxCNC's rs274 interpreter",
    )
}

/// A program to check: as volmap reads it and as rs274 reads it.
struct Case {
    name: String,
    volmap: String,
    rs274: String,
    options: Options,
}

/// The lines rs274 reads before a program (after its `%`): the work offsets of `options`
/// (G10 L2, in mm) and the G28 position (parameters 5161–5163, which rs274 keeps in inches).
fn prelude(options: &Options) -> String {
    let mut text = String::from("G21\n");
    for (d, v) in grammar::HOME_MM.iter().enumerate() {
        text += &format!("#{}={}\n", 5161 + d, v / 25.4);
    }
    let mut numbers: Vec<&u32> = options.work_offsets.keys().collect();
    numbers.sort();
    for n in numbers {
        let o = options.work_offsets[n];
        text += &format!("G10 L2 P{} X{} Y{} Z{}\n", n - 53, o[0], o[1], o[2]);
    }
    text
}

fn with_prelude(program: &str, prelude: &str) -> String {
    match program.strip_prefix("%\n") {
        Some(rest) => format!("%\n{prelude}{rest}"),
        None => format!("{prelude}{program}"),
    }
}

/// Runs rs274 on `text` (in its own folder) and reads its moves.
fn run_rs274(dir: &Path, name: &str, text: &str) -> (Result<Vec<canon::Move>, String>, String) {
    let program = dir.join(format!("{name}.ngc"));
    std::fs::write(&program, text).unwrap();
    let canon_path = dir.join(format!("{name}.canon"));
    // Tools of length 0: rs274's own table has lengths that volmap, without --tool-length,
    // does not apply.
    let tools = dir.join("tools.tbl");
    let table: String = (0..100).map(|t| format!("T{t} P{t} Z0 ;\n")).collect();
    std::fs::write(&tools, table).unwrap();
    let run = std::process::Command::new("rs274")
        .env("HOME", dir) // rs274 maps $HOME/.tool.mmap: one home per run (see common::rs274)
        .arg("-g")
        .arg("-t")
        .arg(&tools)
        .arg(&program)
        .arg(&canon_path)
        .output()
        .expect("rs274 starts");
    let out = std::fs::read_to_string(&canon_path).unwrap_or_default();
    if !run.status.success() {
        return (
            Err(format!(
                "rs274 failed: {}{}",
                String::from_utf8_lossy(&run.stdout),
                String::from_utf8_lossy(&run.stderr)
            )),
            out,
        );
    }
    (canon::read(&out), out)
}

/// Checks one program; `Err` says what failed, with the files saved.
fn check_case(
    machine_name: &str,
    machine: &Machine,
    model: &mut check::Model,
    case: &Case,
) -> Result<String, String> {
    let keep = |what: &str, files: &[(&str, &str)]| -> String {
        let saved = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .join("nc_rs274")
            .join(format!("{machine_name}-{}", case.name));
        std::fs::create_dir_all(&saved).unwrap();
        for (file, text) in files {
            std::fs::write(saved.join(file), text).unwrap();
        }
        format!(
            "{machine_name}, {}: {what} (files in {})",
            case.name,
            saved.display()
        )
    };
    let compensated =
        match nc::compensate(machine, case.volmap.as_bytes(), &case.name, &case.options) {
            Ok(c) => c,
            // The one refusal the grammar can make: an absolute arc volmap must pass as it
            // is (it depends on an axis not known) after a compensated move.
            Err(e) if e.to_string().contains("its centre words no longer fit") => {
                return Ok(format!("{machine_name}, {}: refused: {e}", case.name))
            }
            Err(e) => {
                return Err(keep(
                    &format!("volmap refused it: {e}"),
                    &[("program.nc", &case.volmap)],
                ))
            }
        };
    let listed = listed_left_alone(&case.volmap, &compensated.report)
        .map_err(|m| keep(&m, &[("program.nc", &case.volmap)]))?;
    check_compensated(model, case, &compensated.text, &listed, keep)
        .map(|s| format!("{machine_name}, {s}"))
}

/// The N words of the blocks volmap passed as they are and of the moves it lists as left alone
/// (they depend on an axis a passed block left unknown): they are only paired. Each must come
/// at or after a block the harness knows volmap does not follow (`#`, `[`) or a G28 (the
/// reference point is the control's), or the list is wrong.
fn listed_left_alone(
    program: &str,
    report: &nc::Report,
) -> Result<std::collections::HashSet<u32>, String> {
    let lines: Vec<&str> = program.lines().collect();
    let first_unfollowed = lines
        .iter()
        .position(|l| l.contains('#') || l.contains('[') || l.contains("G28"))
        .map(|i| i + 1);
    let mut listed = std::collections::HashSet::new();
    let passed = report.not_compensated.iter().map(|b| b.line);
    let left = report.moves_not_compensated.iter().map(|m| m.line);
    for line in passed.chain(left) {
        if first_unfollowed.is_none_or(|first| line < first) {
            return Err(format!(
                "volmap lists line {line} as left alone, before any block it cannot follow"
            ));
        }
        if let Some(n) = text::label(lines[line - 1]) {
            listed.insert(n);
        }
    }
    Ok(listed)
}

/// Checks `compensated`, the compensation of `case`; `keep` saves the files of a failure and
/// says where.
fn check_compensated(
    model: &mut check::Model,
    case: &Case,
    compensated: &str,
    listed: &std::collections::HashSet<u32>,
    keep: impl Fn(&str, &[(&str, &str)]) -> String,
) -> Result<String, String> {
    let dir = tempfile::tempdir().unwrap();
    let prelude = prelude(&case.options);
    let original_text = with_prelude(&case.rs274, &prelude);
    let compensated_text = with_prelude(compensated, &prelude);
    let (orig, orig_canon) = run_rs274(dir.path(), "original", &original_text);
    let (comp, comp_canon) = run_rs274(dir.path(), "compensated", &compensated_text);
    let files = [
        ("program.nc", case.volmap.as_str()),
        ("original.ngc", original_text.as_str()),
        ("compensated.ngc", compensated_text.as_str()),
        ("original.canon", orig_canon.as_str()),
        ("compensated.canon", comp_canon.as_str()),
    ];
    let (orig, comp) = match (orig, comp) {
        (Ok(o), Ok(c)) => (o, c),
        (Err(e), _) => return Err(keep(&format!("the original: {e}"), &files)),
        (_, Err(e)) => return Err(keep(&format!("the compensated program: {e}"), &files)),
    };
    let chord = case.options.chord_tolerance_mm;
    let printing_mm = 2e-4;
    let bound = 1.1 * model.largest_error_mm(&orig) + chord + printing_mm;
    // Take-ups (the command crossing a reversal while the tip stands) and moves this short
    // lie within the bound wherever they are.
    let tiny = 2.0 * bound;
    let groups = check::pair(&orig, &comp, bound, tiny).map_err(|m| keep(&m, &files))?;
    let lines = numbered_lines(&case.volmap);
    let all_named = all_axes_named(&case.volmap);
    let left = text::left_after_homes(&case.volmap);
    let compensated_by_design: Vec<bool> = orig
        .iter()
        .map(|m| {
            m.label
                .is_none_or(|n| n >= all_named && !left.contains(&n) && !listed.contains(&n))
                && m.label
                    .and_then(|n| lines.get(&n))
                    .is_none_or(|l| !l.contains("G28") && !l.contains("G53"))
        })
        .collect();
    let largest = check::tips(
        model,
        &orig,
        &comp,
        &groups,
        &compensated_by_design,
        chord + printing_mm,
        tiny,
    )
    .map_err(|m| keep(&m, &files))?;
    Ok(format!(
        "{}: {} moves, {} compensated, tip within {:.5} mm",
        case.name,
        orig.len(),
        comp.len(),
        largest
    ))
}

fn options(pass_unknown: bool) -> Options {
    Options {
        work_offsets: grammar::work_offsets()
            .into_iter()
            .map(|(n, [x, y, z])| (n, [x, y, z, 0.0, 0.0, 0.0]))
            .collect(),
        pass_unknown,
        ..Options::default()
    }
}

/// Checks the generated programs of `features` on both machines; the failures, the programs
/// checked, and of those the ones volmap refused as it should (see `check_case`).
fn generated(features: &[&'static str], programs: u64) -> (Vec<String>, usize, usize) {
    let mut failures = Vec::new();
    let (mut checked, mut refused) = (0, 0);
    for machine_name in ["vmc-li2015", "gantry-2m"] {
        let machine = embedded::load(machine_name).unwrap();
        let mut model = check::Model::new(&machine);
        for seed in 0..programs {
            let program = grammar::program(seed, BLOCKS, features);
            let case = Case {
                name: format!("random-{seed}"),
                options: options(program.used.iter().any(|f| PASSED.contains(f))),
                volmap: program.volmap,
                rs274: program.rs274,
            };
            match check_case(machine_name, &machine, &mut model, &case) {
                Ok(summary) => {
                    checked += 1;
                    refused += usize::from(summary.contains(": refused: "));
                }
                Err(failure) => failures.push(format!("[{}] {failure}", program.used.join(" "))),
            }
        }
    }
    (failures, checked, refused)
}

#[test]
fn rs274_follows_the_compensated_random_programs() {
    if !rs274_installed() {
        return;
    }
    let features = FEATURES.to_vec();
    let (failures, checked, refused) = generated(&features, PROGRAMS);
    assert!(
        failures.is_empty(),
        "{} of {} programs fail:\n{}",
        failures.len(),
        failures.len() + checked,
        failures.join("\n")
    );
    eprintln!("{checked} programs checked, {refused} of them refused");
    // Refusals are the exception: most programs with unknown blocks are compensated.
    assert!(
        refused * 10 < checked,
        "{refused} of {checked} programs refused"
    );
    // The grammar made what it says: every feature in some program.
    let mut seen = std::collections::HashSet::new();
    for seed in 0..PROGRAMS {
        seen.extend(grammar::program(seed, BLOCKS, &features).used);
    }
    for f in &features {
        assert!(seen.contains(f), "no program uses {f}");
    }
}

/// The example and test programs: (path from the crate root, machine).
const CORPUS: &[(&str, &str)] = &[
    ("tests/fuzz-corpus/gcode/arcs.nc", "vmc-li2015"),
    ("tests/fuzz-corpus/gcode/arcs.nc", "gantry-2m"),
    ("tests/fuzz-corpus/gcode/fusion.nc", "vmc-li2015"),
    ("tests/fuzz-corpus/gcode/fusion.nc", "gantry-2m"),
    ("tests/fuzz-corpus/gcode/haas.nc", "vmc-li2015"),
    ("tests/fuzz-corpus/gcode/haas.nc", "gantry-2m"),
    ("tests/fuzz-corpus/gcode/mastercam.nc", "vmc-li2015"),
    ("tests/fuzz-corpus/gcode/mastercam.nc", "gantry-2m"),
    ("tests/identity/inputs/program.nc", "vmc-li2015"),
    ("tests/identity/inputs/program.nc", "gantry-2m"),
    ("examples/dobariya2015/test-piece.nc", "vmc-li2015"),
    ("examples/dobariya2015/test-piece.nc", "gantry-2m"),
    (
        "examples/dobariya2015/test-piece.nc",
        "examples/dobariya2015/machine.toml",
    ),
];

/// Checks the corpus; the failures and the number checked.
fn corpus() -> (Vec<String>, usize) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut failures = Vec::new();
    let mut checked = 0;
    for (file, machine_name) in CORPUS {
        let text = std::fs::read_to_string(root.join(file)).unwrap();
        let numbered = with_line_numbers(&text);
        let machine = embedded::load(&root.join(machine_name).to_string_lossy())
            .or_else(|_| embedded::load(machine_name))
            .unwrap();
        let mut options = options(false);
        if machine_name.ends_with(".toml") {
            // The example's work zero, as its comment gives it.
            options.work_offsets = [(54, [0.0, 0.0, 10.0, 0.0, 0.0, 0.0])].into();
        }
        let case = Case {
            name: Path::new(file)
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .into(),
            rs274: as_linuxcnc(&numbered),
            volmap: numbered,
            options,
        };
        let label = Path::new(machine_name)
            .file_stem()
            .unwrap()
            .to_string_lossy();
        match check_case(&label, &machine, &mut check::Model::new(&machine), &case) {
            Ok(summary) => {
                eprintln!("{summary}");
                checked += 1;
            }
            Err(failure) => failures.push(failure),
        }
    }
    (failures, checked)
}

#[test]
fn rs274_follows_the_compensated_example_and_test_programs() {
    if !rs274_installed() {
        return;
    }
    let (failures, checked) = corpus();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(checked, CORPUS.len());
}

/// The harness finds what it is for: a compensated program with a move nobody programmed, one
/// point moved off the path by 0.3 mm, or by 0.01 mm (within the pairing bound on
/// `gantry-2m`, not within the tip's tolerance), fails.
#[test]
fn the_rs274_harness_finds_an_invented_or_misplaced_move() {
    if !rs274_installed() {
        return;
    }
    let machine = embedded::load("gantry-2m").unwrap();
    let mut model = check::Model::new(&machine);
    let program =
        "N1 G21 G90 G17 G54\nN2 G0 X10 Y10 Z10\nN3 G1 X50 F100\nN4 G1 Y40\nN5 G0 Z20\nN6 M30\n";
    let case = Case {
        name: "tampered".into(),
        volmap: program.into(),
        rs274: program.into(),
        options: options(false),
    };
    check_case("gantry-2m", &machine, &mut model, &case).expect("the program as compensated");
    let compensated = nc::compensate(&machine, program.as_bytes(), "t.nc", &case.options)
        .unwrap()
        .text;
    let n4 = compensated
        .lines()
        .find(|l| l.starts_with("N4 "))
        .unwrap()
        .to_string();
    for (what, tampered, message) in [
        (
            "an added move",
            compensated.replace("N4 ", "G1 X30\nN4 "),
            "from the original's path",
        ),
        (
            "a point 0.3 mm off",
            compensated.replace(&n4, &with_x(&n4, 50.3)),
            "from the original's path",
        ),
        (
            "a point 0.01 mm off",
            compensated.replace(&n4, &with_x(&n4, 50.01)),
            "the real tool tip",
        ),
    ] {
        assert_ne!(tampered, compensated, "{what}");
        let failure =
            check_compensated(&mut model, &case, &tampered, &Default::default(), |m, _| {
                m.to_string()
            })
            .expect_err(what);
        assert!(failure.contains(message), "{what}: {failure}");
    }
}
