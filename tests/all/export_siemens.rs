//! `volmap export --format siemens`: the SINUMERIK programs read back here from the documented
//! form (Siemens, *Extended Functions*, K3: `$AA_ENC_COMP[e,N,AXi]` with `_STEP/_MIN/_MAX`,
//! `$AN_CEC[t,N]` with `_INPUT_AXIS/_OUTPUT_AXIS/_STEP/_MIN/_MAX/_DIRECTION`; points `MIN +
//! N·STEP`, linear between them, the end values beyond; the value is the error, "a positive
//! compensation value causes the corresponding machine axis to move in the negative
//! direction") and applied to the model: the residual the export reports, hand-derived values,
//! and the requests it refuses.

use std::collections::BTreeMap;

use predicates::prelude::*;
use volmap::export::{self, format::WrittenFile, ExportError, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::{Approach, Inputs};
use volmap::reference::Twin;

use crate::cli::volmap;
use crate::common::fixture;
use crate::export::{dense, machine, request, residual};

/// A table as read here: which axis it reads (at its actual position for MSEC, at the setpoint
/// for CEC), which it moves, in which direction of the input axis (0 both, −1 negative), its
/// points and the error at them.
#[derive(Debug, Clone, PartialEq)]
struct Table {
    actual: bool,
    input: usize,
    output: usize,
    direction: i32,
    min: f64,
    step: f64,
    max: f64,
    values: Vec<f64>,
}

const AXES: [&str; 3] = ["X1", "Y1", "Z1"];

fn axis(name: &str) -> usize {
    AXES.iter().position(|a| *a == name).unwrap()
}

/// `$NAME[a,b]=value` split into its name, indices and value.
fn split(line: &str) -> (&str, Vec<&str>, &str) {
    let code = line.split(';').next().unwrap().trim();
    let (name, rest) = code.strip_prefix('$').unwrap().split_once('[').unwrap();
    let (indices, value) = rest.split_once("]=").unwrap();
    (name, indices.split(',').collect(), value)
}

/// Every table of the programs, MSEC first (by axis), then CEC (by table number).
fn tables(files: &[WrittenFile]) -> Vec<Table> {
    let mut msec: BTreeMap<usize, Table> = BTreeMap::new();
    let mut cec: BTreeMap<usize, Table> = BTreeMap::new();
    let empty = Table {
        actual: false,
        input: 9,
        output: 9,
        direction: 0,
        min: f64::NAN,
        step: f64::NAN,
        max: f64::NAN,
        values: Vec::new(),
    };
    for file in files {
        for line in file.text.lines().filter(|l| l.starts_with('$')) {
            let (name, at, value) = split(line);
            let number = || value.parse::<f64>().unwrap();
            let set = |t: &mut Table, n: usize, v: f64| {
                if t.values.len() <= n {
                    t.values.resize(n + 1, f64::NAN);
                }
                t.values[n] = v;
            };
            if let Some(field) = name.strip_prefix("AA_ENC_COMP") {
                assert_eq!(at[0], "0", "measuring system 1: {line}");
                let k = axis(at[at.len() - 1]);
                let t = msec.entry(k).or_insert(Table {
                    actual: true,
                    input: k,
                    output: k,
                    ..empty.clone()
                });
                match field {
                    "" => set(t, at[1].parse().unwrap(), number()),
                    "_STEP" => t.step = number(),
                    "_MIN" => t.min = number(),
                    "_MAX" => t.max = number(),
                    "_IS_MODULO" => assert_eq!(value, "0"),
                    _ => panic!("{line}"),
                }
            } else {
                let field = name.strip_prefix("AN_CEC").unwrap();
                let t = cec.entry(at[0].parse().unwrap()).or_insert(empty.clone());
                let named = || axis(value.strip_prefix('(').unwrap().strip_suffix(')').unwrap());
                match field {
                    "" => set(t, at[1].parse().unwrap(), number()),
                    "_INPUT_AXIS" => t.input = named(),
                    "_OUTPUT_AXIS" => t.output = named(),
                    "_STEP" => t.step = number(),
                    "_MIN" => t.min = number(),
                    "_MAX" => t.max = number(),
                    "_DIRECTION" => t.direction = value.parse().unwrap(),
                    "_MULT_BY_TABLE" | "_IS_MODULO" => assert_eq!(value, "0"),
                    _ => panic!("{line}"),
                }
            }
        }
    }
    let all: Vec<Table> = msec.into_values().chain(cec.into_values()).collect();
    assert!(!all.is_empty());
    for t in &all {
        let k = (t.max - t.min) / t.step;
        assert!((k - k.round()).abs() < 1e-9, "{t:?}");
        assert_eq!(t.values.len(), k.round() as usize + 1, "{t:?}");
        assert!(t.values.iter().all(|v| v.is_finite()), "{t:?}");
    }
    all
}

/// The error a table holds at `x`: linear between its points, the end values beyond.
fn lookup(t: &Table, x: f64) -> f64 {
    let last = t.values.len() - 1;
    let u = ((x - t.min) / t.step).clamp(0.0, last as f64);
    let i = (u.floor() as usize).min(last.saturating_sub(1));
    if last == 0 {
        return t.values[0];
    }
    let f = u - i as f64;
    t.values[i] * (1.0 - f) + t.values[i + 1] * f
}

/// The command the control moves to for target `t`, the axes approaching as `approach` says:
/// each axis moved by minus the errors its CEC tables read at the setpoints, then by minus its
/// MSEC table's value at the position it ends up at (`c = s − v(c)`, by bisection here).
fn command(tables: &[Table], t: [f64; 3], approach: [Approach; 3]) -> [f64; 3] {
    let mut c = t;
    for table in tables.iter().filter(|t| !t.actual) {
        let read = match table.direction {
            0 => true,
            1 => approach[table.input] == Approach::Positive,
            _ => approach[table.input] == Approach::Negative,
        };
        if read {
            c[table.output] -= lookup(table, t[table.input]);
        }
    }
    for table in tables.iter().filter(|t| t.actual) {
        let s = c[table.output];
        let (mut lo, mut hi) = (s - 1.0, s + 1.0);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if mid + lookup(table, mid) < s {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        c[table.output] = 0.5 * (lo + hi);
    }
    c
}

fn siemens() -> &'static dyn export::Format {
    export::format_named("siemens").unwrap()
}

#[test]
fn siemens_round_trip_gives_the_reported_residual_in_both_directions() {
    // gantry-2m: straightness, squareness, sag and a 6 µm reversal of Y, read back and applied
    // with Y approaching − (the negative-direction tables read) and + (not read).
    let gantry = embedded::load("gantry-2m").unwrap();
    let targets = dense(&gantry, 41);
    let mut texts = Vec::new();
    for (y, approach) in [("Y=-", Approach::Negative), ("Y=+", Approach::Positive)] {
        let inputs = Inputs::parse("", y, &gantry).unwrap();
        let exported =
            export::export(siemens(), &request(&gantry, &inputs, TableSize::Points(9))).unwrap();
        let read = tables(&exported.files);
        let report = &exported.report;
        assert_eq!(report.grid.points, [41, 41, 41]);
        let twin = Twin::of(&gantry.at(&inputs));
        let approach3 = [Approach::Positive, approach, Approach::Positive];
        let (max, rms) = residual(&twin, &targets, |t| command(&read, t, approach3));
        assert!(
            (max - report.residual.max_mm).abs() < 1e-12,
            "{max} vs {:?}",
            report.residual
        );
        assert!((rms - report.residual.rms_mm).abs() < 1e-12);
        let (before, _) = residual(&twin, &targets, |t| t);
        assert!((before - report.before.max_mm).abs() < 1e-12);
        assert!(max < 0.3 * before, "{max} of {before}");
        // The negative-direction table of Y matters where Y approaches −: Y moves back by the
        // 6 µm it reverses by.
        if approach == Approach::Negative {
            let plus = [Approach::Positive; 3];
            let (_, without) = residual(&twin, &targets, |t| command(&read, t, plus));
            assert!(without > rms + 0.002, "{without} vs {rms}");
            for &t in targets.iter().step_by(97) {
                let dy = command(&read, t, approach3)[1] - command(&read, t, plus)[1];
                assert!((dy + 0.006).abs() < 2e-6, "{dy} at {t:?}");
            }
        }
        texts.push(
            exported
                .files
                .iter()
                .map(|f| {
                    f.text
                        .lines()
                        .filter(|l| !l.starts_with(';'))
                        .collect::<Vec<_>>()
                        .join("\n")
                })
                .collect::<Vec<_>>(),
        );
    }
    // The tables do not depend on the approach asked: the control picks them by direction.
    assert_eq!(texts[0], texts[1]);
}

#[test]
fn siemens_holds_a_pure_positioning_error_in_msec_with_hand_derived_values() {
    // EXX = k·x: the real X tip at command c is c·(1 + k); MSEC reads the actual position, so
    // its table is the error there, +k·c, as a laser measures it: positive where the axis
    // travels too far. The control then stands at c = x − k·c, whose tip is on x.
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let exported = export::export(siemens(), &request(&m, &inputs, TableSize::Points(5))).unwrap();
    let names: Vec<&str> = exported.files.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["AX_EEC.INI"], "no cross table to hold");
    let text = &exported.files[0].text;
    let k = 1e-4;
    for (n, x) in [0.0, 100.0, 200.0, 300.0, 400.0].iter().enumerate() {
        let hand = k * x;
        let line = format!("$AA_ENC_COMP[0,{n},X1]={hand:.6}");
        assert!(text.lines().any(|l| l == line), "{line} in\n{text}");
    }
    for line in [
        "$AA_ENC_COMP[0,4,X1]=0.040000",
        "$AA_ENC_COMP_STEP[0,X1]=100.0",
        "$AA_ENC_COMP_MIN[0,X1]=0.0",
        "$AA_ENC_COMP_MAX[0,X1]=400.0",
        "$AA_ENC_COMP_IS_MODULO[0,X1]=0",
        "$AA_ENC_COMP[0,4,Y1]=0.000000",
        "$AA_ENC_COMP_STEP[0,Z1]=50.0",
    ] {
        assert!(text.lines().any(|l| l == line), "{line}");
    }
    let r = &exported.report;
    assert!(r.before.max_mm > 0.039);
    // Linear in x, held exactly between points: what is left is the 6 decimals.
    assert!(r.residual.max_mm <= 5e-7 * 1.01, "{:?}", r.residual);
    assert!(r.not_held.is_empty() && r.structural_mm < 1e-9);
}

#[test]
fn siemens_holds_a_pure_squareness_in_one_cross_table_with_hand_derived_values() {
    // EC0Y = γ tilts +Y towards −X: the tip of command (x, y) is at (x − y·sin γ, y·cos γ), the
    // command putting it on (x, y) is (x + y·tan γ, y / cos γ): d_x = y·tan γ, and the X1 error
    // as a function of Y1, −y·tan γ (X lags by y·tan γ; a negative value moves X positive).
    let m = machine(&fixture("squareness"));
    let inputs = Inputs::default();
    let exported = export::export(siemens(), &request(&m, &inputs, TableSize::Points(5))).unwrap();
    let read = tables(&exported.files);
    assert_eq!(
        read.len(),
        4,
        "three MSEC tables and one CEC table: {read:?}"
    );
    for t in &read[..3] {
        assert!(t.values.iter().all(|&v| v == 0.0), "{t:?}");
    }
    let cec = &read[3];
    assert_eq!((cec.input, cec.output, cec.direction), (1, 0, 0));
    assert_eq!((cec.min, cec.step, cec.max), (0.0, 75.0, 300.0));
    let gamma: f64 = 2.0e-5;
    assert_eq!(cec.values.len(), 5);
    for (n, v) in cec.values.iter().enumerate() {
        let hand = -(75.0 * n as f64) * gamma.tan();
        assert!((v - hand).abs() <= 5e-7, "point {n}: {v} vs {hand}");
    }
    let cec_text = &exported.files[1].text;
    assert!(
        cec_text.contains("\n$AN_CEC[0,4]=-0.006000\n"),
        "{cec_text}"
    );
    let r = &exported.report;
    assert!(r.before.max_mm > 0.0059);
    assert!(r.residual.max_mm <= 5e-7 * 1.01, "{:?}", r.residual);
}

#[test]
fn siemens_programs_have_the_documented_form_line_by_line() {
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::parse("spindle=30", "", &gantry).unwrap();
    let exported = export::export(
        siemens(),
        &request(&gantry, &inputs, TableSize::Spacing(250.0)),
    )
    .unwrap();
    let files = &exported.files;
    assert_eq!(files.len(), 2);
    for (file, program) in files.iter().zip(["%_N_AX_EEC_INI", "%_N_NC_CEC_INI"]) {
        let text = &file.text;
        assert!(text.is_ascii() && !text.contains('\r'), "{}", file.name);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], program);
        assert_eq!(*lines.last().unwrap(), "M17");
        let chandata = lines.iter().position(|l| *l == "CHANDATA(1)").unwrap();
        assert!(lines[1..chandata].iter().all(|l| l.starts_with("; ")));
        let mut previous: Option<(String, usize)> = None;
        for line in &lines[chandata + 1..lines.len() - 1] {
            if line.starts_with("; ") {
                continue;
            }
            let (name, at, value) = split(line);
            assert!(!line.contains(' '), "one assignment, no blanks: {line}");
            let known = [
                "AA_ENC_COMP",
                "AA_ENC_COMP_STEP",
                "AA_ENC_COMP_MIN",
                "AA_ENC_COMP_MAX",
                "AA_ENC_COMP_IS_MODULO",
                "AN_CEC",
                "AN_CEC_INPUT_AXIS",
                "AN_CEC_OUTPUT_AXIS",
                "AN_CEC_STEP",
                "AN_CEC_MIN",
                "AN_CEC_MAX",
                "AN_CEC_DIRECTION",
                "AN_CEC_MULT_BY_TABLE",
                "AN_CEC_IS_MODULO",
            ];
            assert!(known.contains(&name), "{line}");
            match name {
                "AA_ENC_COMP" | "AN_CEC" => {
                    // Points in order from 0, each value a decimal number of mm, 6 decimals.
                    let (table, n) = if name == "AN_CEC" {
                        (at[0].to_string(), at[1].parse::<usize>().unwrap())
                    } else {
                        assert_eq!(at[0], "0");
                        (at[2].to_string(), at[1].parse::<usize>().unwrap())
                    };
                    let expected = match &previous {
                        Some((t, last)) if *t == table => last + 1,
                        _ => 0,
                    };
                    assert_eq!(n, expected, "{line}");
                    previous = Some((table, n));
                    let (_, decimals) = value.trim_start_matches('-').split_once('.').unwrap();
                    assert_eq!(decimals.len(), 6, "{line}");
                    assert!(value != "-0.000000");
                }
                "AN_CEC_INPUT_AXIS" | "AN_CEC_OUTPUT_AXIS" => {
                    assert!(["(X1)", "(Y1)", "(Z1)"].contains(&value), "{line}")
                }
                "AN_CEC_DIRECTION" => assert!(["0", "1", "-1"].contains(&value), "{line}"),
                _ => {
                    value.parse::<f64>().unwrap();
                }
            }
        }
    }
    // Every table covers the travel of its input axis from its start, at the spacing asked,
    // with a whole number of steps.
    let ranges = [3000.0, 2000.0, 1000.0];
    assert!(!tables(files).is_empty());
    for t in tables(files) {
        assert_eq!((t.min, t.step), (0.0, 250.0), "{t:?}");
        assert_eq!(t.max, ranges[t.input], "{t:?}");
    }
    // The header says what was written and the sign.
    let header = &files[0].text;
    for said in [
        "; machine: 2 m gantry",
        "spindle=30 degC",
        "; sign: each value is the ERROR, actual minus commanded position",
        "MD32700 ENC_COMP_ENABLE = 0",
    ] {
        assert!(header.contains(said), "{said}");
    }
    assert!(files[1].text.contains("SD41300 CEC_TABLE_ENABLE[t] = 1"));
}

#[test]
fn siemens_reversal_is_a_negative_direction_cec_table_of_the_axis_itself() {
    // gantry-2m's EYY reverses by 6 µm (`reverse = 0.006 + 3e-6·y`): while Y approaches −, Y
    // travels 6 µm further, an error of +0.006 mm along the whole travel, read only in the
    // negative direction of Y.
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::default();
    let exported =
        export::export(siemens(), &request(&gantry, &inputs, TableSize::Points(5))).unwrap();
    let read = tables(&exported.files);
    let negative: Vec<&Table> = read.iter().filter(|t| t.direction != 0).collect();
    assert!(!negative.is_empty());
    assert!(negative.iter().all(|t| t.direction == -1 && t.input == 1));
    let own = negative.iter().find(|t| t.output == 1).unwrap();
    for v in &own.values {
        assert!((v - 0.006).abs() < 2e-6, "{:?}", own.values);
    }
}

#[test]
fn siemens_reader_refuses_what_the_control_would_not_load() {
    let m = machine(&fixture("squareness"));
    let inputs = Inputs::default();
    let exported = export::export(siemens(), &request(&m, &inputs, TableSize::Points(5))).unwrap();
    let refused = |file: usize, from: &str, to: &str| -> String {
        let mut files = exported.files.clone();
        assert!(files[file].text.contains(from), "{from}");
        files[file].text = files[file].text.replacen(from, to, 1);
        match siemens().read(&files, &[[0.0, 1000.0]; 3]) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{from} -> {to} was read"),
        }
    };
    let e = refused(1, "$AN_CEC[0,2]=-0.003000\n", "");
    assert!(
        e.starts_with("reading back NC_CEC.INI: line ")
            && e.contains("CEC 0: interpolation point 2 has no value"),
        "{e}"
    );
    let e = refused(
        0,
        "$AA_ENC_COMP_STEP[0,Y1]=75.0",
        "$AA_ENC_COMP_STEP[0,Y1]=70.0",
    );
    assert!(
        e.contains(
            "MSEC Y1: (MAX - MIN) / STEP = 4.285714285714286 is not a whole number of steps"
        ),
        "{e}"
    );
    let e = refused(0, "M17\n", "");
    assert!(e.contains("the program does not end with M17"), "{e}");
    let e = refused(
        1,
        "$AN_CEC_INPUT_AXIS[0]=(Y1)",
        "$AN_CEC_INPUT_AXIS[0]=(Q1)",
    );
    assert!(
        e.contains("`Q1` is not a machine axis volmap writes (X1, Y1, Z1)"),
        "{e}"
    );
    let e = refused(
        1,
        "$AN_CEC_MULT_BY_TABLE[0]=0",
        "$AN_CEC_MULT_BY_TABLE[0]=2",
    );
    assert!(e.contains("volmap reads only 0 here"), "{e}");
    let e = refused(0, "%_N_AX_EEC_INI", "%_N_AX_EEC_MPF");
    assert!(
        e.contains("line 1: the program does not start with %_N_AX_EEC_INI"),
        "{e}"
    );
}

#[test]
fn siemens_table_sizes_beyond_its_limits_are_refused_saying_so() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let refused = |size| match export::export(siemens(), &request(&li, &inputs, size)) {
        Err(e) => e,
        Ok(_) => panic!("{size:?} accepted"),
    };
    let e = refused(TableSize::Points(2001));
    assert!(matches!(e, ExportError::TooManyPoints { max: 2000, .. }));
    assert!(
        e.to_string().starts_with("2001 points is more than a siemens table holds: at most 2000 (SINUMERIK MD38000/MD18342"),
        "{e}"
    );
    let e = refused(TableSize::Spacing(0.005)).to_string();
    assert!(
        e.starts_with("a spacing of 0.005 mm is below the smallest a siemens table takes: 0.01 mm"),
        "{e}"
    );
    let e = refused(TableSize::Spacing(0.4)).to_string();
    assert!(
        e.starts_with("2501 points along X (1000 mm at 0.4 mm) is more than a siemens table holds"),
        "{e}"
    );
    assert!(matches!(
        refused(TableSize::Points(1)),
        ExportError::TooFewPoints { .. }
    ));
    let ideal = li.without_errors();
    let e = export::export(siemens(), &request(&ideal, &inputs, TableSize::Default))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("siemens can hold none of this machine's errors"),
        "{e}"
    );
}

#[test]
fn siemens_export_from_the_command_line_writes_the_programs_or_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sinumerik");
    volmap()
        .args(["export", "--machine", "vmc-li2015", "--format", "siemens"])
        .args(["--points", "21", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("error").not())
        .stdout(
            predicate::str::contains(
                "table MSEC X1          X of X: 21 points, 0.0 to 1000.0 mm, step 50.0 mm",
            )
            .and(predicate::str::contains(
                "table CEC 0            Y of X: 21 points",
            ))
            .and(predicate::str::contains("cannot hold")),
        );
    assert!(out.join("AX_EEC.INI").is_file() && out.join("NC_CEC.INI").is_file());
    let fresh = dir.path().join("refused");
    for (flags, message) in [
        (
            ["--points", "2500"],
            "error: --points: 2500 points is more than a siemens table holds: at most 2000",
        ),
        (
            ["--spacing", "0.001"],
            "error: --spacing: a spacing of 0.001 mm is below the smallest a siemens table takes: 0.01 mm",
        ),
    ] {
        volmap()
            .args(["export", "--machine", "vmc-li2015", "--format", "siemens"])
            .args(flags)
            .arg("--out")
            .arg(&fresh)
            .assert()
            .code(2)
            .stderr(predicate::str::starts_with(message));
        assert!(!fresh.exists());
    }
}
