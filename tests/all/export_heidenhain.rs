//! `volmap export --format heidenhain`: the `*.COM` tables and `config.cma` read back here from
//! their form (a `BEGIN` line, a line of column names, fixed-width rows under them, `[END]`;
//! HEIDENHAIN's nonlinear axis error compensation: `[column axis] = F(axis of the .CMA column
//! naming the table)`, AXISPOS the points, linear between them; the value is the error, "positive
//! if the table travel is too long") and applied to the model: the residual the export
//! reports, hand-derived values, free points that find a kink, and the requests it refuses.

use predicates::prelude::*;
use volmap::export::{self, format::WrittenFile, ExportError, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::{Approach, Inputs};
use volmap::reference::Twin;

use crate::cli::volmap;
use crate::common::fixture;
use crate::export::{dense, machine, request, residual};

/// The column names of a table and its rows, each field the text under its column's name up to
/// the next name.
fn fixed_width(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("BEGIN "), "{}", lines[0]);
    assert_eq!(*lines.last().unwrap(), "[END]");
    let header = lines[1];
    let starts: Vec<usize> = (0..header.len())
        .filter(|&i| &header[i..i + 1] != " " && (i == 0 || &header[i - 1..i] == " "))
        .collect();
    let names = header.split_whitespace().map(String::from).collect();
    let rows = lines[2..lines.len() - 1]
        .iter()
        .map(|line| {
            (0..starts.len())
                .map(|c| {
                    let from = starts[c].min(line.len());
                    let to = if c + 1 < starts.len() {
                        starts[c + 1].min(line.len())
                    } else {
                        line.len()
                    };
                    line[from..to].trim().to_string()
                })
                .collect()
        })
        .collect();
    (names, rows)
}

/// One `*.COM` table as read here.
#[derive(Debug, Clone, PartialEq)]
struct Com {
    input: usize,
    axispos: Vec<f64>,
    columns: Vec<Vec<f64>>,
    backlash: Option<Vec<f64>>,
}

fn file<'a>(files: &'a [WrittenFile], name: &str) -> &'a str {
    &files.iter().find(|f| f.name == name).unwrap().text
}

/// The tables of the active row of `config.cma`, by the axis of the column naming them.
fn tables(files: &[WrittenFile]) -> Vec<Com> {
    let (names, rows) = fixed_width(file(files, "config.cma"));
    assert_eq!(names, ["NR", "ACTIVE", "X", "Y", "Z"]);
    let active: Vec<&Vec<String>> = rows.iter().filter(|r| r[1] == "*").collect();
    assert_eq!(active.len(), 1);
    (0..3)
        .map(|input| {
            let (names, rows) = fixed_width(file(files, &active[0][2 + input]));
            // BACKLASH declared exactly where the rows carry it.
            assert_eq!(names[..5], ["NR", "AXISPOS", "X", "Y", "Z"]);
            assert!(names.len() == 5 || names[5..] == ["BACKLASH"], "{names:?}");
            let col =
                |c: usize| -> Vec<f64> { rows.iter().map(|r| r[c].parse().unwrap()).collect() };
            for (n, r) in rows.iter().enumerate() {
                assert_eq!(r[0], n.to_string());
                assert!(r.iter().all(|cell| !cell.is_empty()), "row {n}: {r:?}");
            }
            let backlash = (names.len() == 6).then(|| col(5));
            Com {
                input,
                axispos: col(1),
                columns: (2..5).map(col).collect(),
                backlash,
            }
        })
        .collect()
}

/// Linear between the points, the end values beyond.
fn interpolate(q: &[f64], v: &[f64], x: f64) -> f64 {
    if x <= q[0] {
        return v[0];
    }
    for s in 1..q.len() {
        if x <= q[s] {
            let f = (x - q[s - 1]) / (q[s] - q[s - 1]);
            return v[s - 1] + f * (v[s] - v[s - 1]);
        }
    }
    v[v.len() - 1]
}

/// The command for target `t`: each axis moved by minus the errors its columns hold, the own
/// column of a table read from BACKLASH while its axis approaches −.
fn command(tables: &[Com], t: [f64; 3], approach: [Approach; 3]) -> [f64; 3] {
    let mut c = t;
    for table in tables {
        let i = table.input;
        for (k, column) in table.columns.iter().enumerate() {
            let values = match (&table.backlash, k == i && approach[i] == Approach::Negative) {
                (Some(b), true) => b,
                _ => column,
            };
            c[k] -= interpolate(&table.axispos, values, t[i]);
        }
    }
    c
}

fn heidenhain() -> &'static dyn export::Format {
    export::format_named("heidenhain").unwrap()
}

#[test]
fn heidenhain_round_trip_gives_the_reported_residual_with_backlash() {
    let gantry = embedded::load("gantry-2m").unwrap();
    let targets = dense(&gantry, 41);
    let inputs = Inputs::parse("", "Y=-", &gantry).unwrap();
    let exported = export::export(
        heidenhain(),
        &request(&gantry, &inputs, TableSize::Points(17)),
    )
    .unwrap();
    let read = tables(&exported.files);
    assert!(read[1].backlash.is_some() && read[0].backlash.is_none());
    assert!(read
        .iter()
        .all(|t| t.axispos.len() <= 17 && t.axispos.len() >= 2));
    let report = &exported.report;
    assert_eq!(report.grid.points, [41, 41, 41]);
    let twin = Twin::of(&gantry.at(&inputs));
    let negative_y = [Approach::Positive, Approach::Negative, Approach::Positive];
    let (max, rms) = residual(&twin, &targets, |t| command(&read, t, negative_y));
    assert!(
        (max - report.residual.max_mm).abs() < 1e-12,
        "{max} vs {:?}",
        report.residual
    );
    assert!((rms - report.residual.rms_mm).abs() < 1e-12);
    let (before, _) = residual(&twin, &targets, |t| t);
    assert!((before - report.before.max_mm).abs() < 1e-12);
    assert!(max < 0.3 * before, "{max} of {before}");
    // Without BACKLASH the 6 µm reversal of Y stays; with it Y moves back by it.
    let plus = [Approach::Positive; 3];
    let (_, without) = residual(&twin, &targets, |t| command(&read, t, plus));
    assert!(without > rms + 0.002, "{without} vs {rms}");
    for &t in targets.iter().step_by(97) {
        let dy = command(&read, t, negative_y)[1] - command(&read, t, plus)[1];
        assert!((dy + 0.006).abs() <= 1.5e-4, "{dy} at {t:?}");
    }
    // The BACKLASH column is Y's own column plus the reversal, +6 µm (the error grows).
    let y = &read[1];
    assert_eq!(y.backlash.as_ref().unwrap().len(), y.columns[1].len());
    assert!(!y.columns[1].is_empty());
    for (b, v) in y.backlash.as_ref().unwrap().iter().zip(&y.columns[1]) {
        assert!((b - v - 0.006).abs() <= 1.5e-4, "{b} vs {v}");
    }
}

#[test]
fn heidenhain_holds_a_pure_positioning_error_with_hand_derived_values() {
    // EXX = k·x: the error at command x is k·x/(1 + k) to the correction's first digits,
    // positive (X travels too far). Free points: a straight line needs its two ends.
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let free = export::export(heidenhain(), &request(&m, &inputs, TableSize::Default)).unwrap();
    let x = &tables(&free.files)[0];
    assert_eq!(x.axispos, [0.0, 400.0]);
    assert_eq!(x.columns, [vec![0.0, 0.04], vec![0.0, 0.0], vec![0.0, 0.0]]);
    assert!(
        free.report.residual.max_mm <= 5e-6,
        "{:?}",
        free.report.residual
    );
    // At a spacing asked, every 100 mm: k·x/(1 + k) to 4 decimals.
    let spaced = export::export(
        heidenhain(),
        &request(&m, &inputs, TableSize::Spacing(100.0)),
    )
    .unwrap();
    let text = file(&spaced.files, "x.com");
    let k = 1e-4;
    for (n, x) in [0.0, 100.0, 200.0, 300.0, 400.0].iter().enumerate() {
        let hand = format!("{:+.4}", k * x / (1.0 + k));
        let row = format!(
            "{n:<6}{:<14}{hand:<13}+0.0000      +0.0000",
            format!("{x:+.4}")
        );
        assert!(text.lines().any(|l| l == row), "{row} in\n{text}");
    }
    assert!(spaced.report.residual.max_mm <= 5e-5 * 1.01);
}

#[test]
fn heidenhain_holds_a_pure_squareness_in_the_x_column_of_y() {
    // EC0Y = γ: the X error as a function of Y is −y·tan γ (see the siemens test): −0.006 mm
    // at Y = 300, in y.com's X column; nothing else.
    let m = machine(&fixture("squareness"));
    let inputs = Inputs::default();
    let exported = export::export(heidenhain(), &request(&m, &inputs, TableSize::Default)).unwrap();
    let read = tables(&exported.files);
    assert_eq!(read[1].axispos, [0.0, 300.0]);
    assert_eq!(read[1].columns[0], [0.0, -0.006]);
    for t in &read {
        for (k, c) in t.columns.iter().enumerate() {
            if (t.input, k) != (1, 0) {
                assert!(c.iter().all(|&v| v == 0.0), "{t:?}");
            }
        }
    }
    let r = &exported.report;
    assert!(r.before.max_mm > 0.0059);
    assert!(r.residual.max_mm <= 5e-5, "{:?}", r.residual);
}

const KINK: &str = r#"
name = "kinked pitch error"
chain = "FYXFZ"
[axes.X]
range = [0.0, 400.0]
EXX = { table = [[0, 0.0], [137, 0.010], [400, -0.004]], interp = "linear" }
[axes.Y]
range = [0.0, 300.0]
[axes.Z]
range = [0.0, 200.0]
"#;

#[test]
fn heidenhain_free_points_find_a_kink_that_equidistant_points_miss() {
    let m = machine(KINK);
    let inputs = Inputs::default();
    let free = export::export(heidenhain(), &request(&m, &inputs, TableSize::Points(5))).unwrap();
    let x = &tables(&free.files)[0];
    assert_eq!(x.axispos, [0.0, 137.0, 400.0]);
    assert_eq!(x.columns[0], [0.0, 0.01, -0.004]);
    let even = export::export(
        heidenhain(),
        &request(&m, &inputs, TableSize::Spacing(100.0)),
    )
    .unwrap();
    assert_eq!(tables(&even.files)[0].axispos.len(), 5);
    let (free_r, even_r) = (free.report.residual.max_mm, even.report.residual.max_mm);
    assert!(free_r <= 5e-6, "{free_r}");
    assert!(even_r > 2e-3, "{even_r}");
}

#[test]
fn heidenhain_tables_have_the_fixed_width_form_line_by_line() {
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::default();
    let exported = export::export(
        heidenhain(),
        &request(&gantry, &inputs, TableSize::Points(9)),
    )
    .unwrap();
    let names: Vec<&str> = exported.files.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        ["x.com", "y.com", "z.com", "config.cma", "volmap.txt"]
    );
    for (n, axis) in ["X", "Y", "Z"].iter().enumerate() {
        let text = &exported.files[n].text;
        assert!(text.is_ascii() && !text.contains('\r'));
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], format!("BEGIN {axis}       .COM     MM"));
        // gantry-2m: Y alone has a reversal.
        let header = "NR    AXISPOS       X            Y            Z";
        if *axis == "Y" {
            assert_eq!(lines[1], format!("{header}            BACKLASH"));
        } else {
            assert_eq!(lines[1], header);
        }
        assert_eq!(*lines.last().unwrap(), "[END]");
        let rows = &lines[2..lines.len() - 1];
        assert!(rows.len() >= 2 && rows.len() <= 9);
        for (r, line) in rows.iter().enumerate() {
            // NR, then each number signed with 4 decimals at its column's start.
            assert_eq!(line[..6].trim_end(), r.to_string(), "{line}");
            let mut fields = vec![(6, 20), (20, 33), (33, 46), (46, line.len().min(59))];
            if line.len() > 59 {
                fields.push((59, line.len()));
            }
            assert_eq!(
                fields.len(),
                lines[1].split_whitespace().count() - 1,
                "{line}"
            );
            for (from, to) in fields {
                let field = &line[from..to];
                assert!(!field.starts_with(' '), "{line}");
                let number = field.trim_end();
                let (sign, rest) = number.split_at(1);
                assert!(sign == "+" || sign == "-", "{line}");
                let (whole, decimals) = rest.split_once('.').unwrap();
                assert!(whole.chars().all(|c| c.is_ascii_digit()) && decimals.len() == 4);
                assert!(decimals.chars().all(|c| c.is_ascii_digit()), "{line}");
                assert_ne!(number, "-0.0000");
            }
        }
        let first: f64 = rows[0][6..20].trim().parse().unwrap();
        let last: f64 = rows[rows.len() - 1][6..20].trim().parse().unwrap();
        assert_eq!((first, last), (0.0, [3000.0, 2000.0, 1000.0][n]));
    }
    assert_eq!(
        exported.files[3].text,
        "BEGIN CONFIG  .CMA     MM\nNR    ACTIVE  X        Y        Z\n0     *       x.com    y.com    z.com\n[END]\n"
    );
    let notes = &exported.files[4].text;
    for said in [
        "machine: 2 m gantry",
        "y.com: X, Y, Z = F(Y)",
        "BACKLASH: Y for the negative direction",
        "sign: each value is the ERROR, actual minus commanded position",
    ] {
        assert!(notes.contains(said), "{said}\n{notes}");
    }
}

#[test]
fn heidenhain_reader_refuses_what_the_control_would_not_load() {
    let m = machine(&fixture("squareness"));
    let inputs = Inputs::default();
    let exported = export::export(
        heidenhain(),
        &request(&m, &inputs, TableSize::Spacing(100.0)),
    )
    .unwrap();
    let refused = |name: &str, from: &str, to: &str| -> String {
        let mut files = exported.files.clone();
        let f = files.iter_mut().find(|f| f.name == name).unwrap();
        assert!(f.text.contains(from), "{from} in {}", f.text);
        f.text = f.text.replacen(from, to, 1);
        match heidenhain().read(&files, &[[0.0, 1000.0]; 3]) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{from} -> {to} was read"),
        }
    };
    let e = refused("config.cma", "0     *", "0      ");
    assert!(
        e.contains("config.cma: line 3: no row is active (*)"),
        "{e}"
    );
    let e = refused("y.com", "+100.0000", "+500.0000");
    assert!(
        e.contains("y.com: line 5: AXISPOS 200 does not increase"),
        "{e}"
    );
    let e = refused("x.com", "[END]\n", "");
    assert!(
        e.contains("x.com") && e.contains("does not end with [END]"),
        "{e}"
    );
    let e = refused(
        "z.com",
        "BEGIN Z       .COM     MM",
        "BEGIN Z       .COM     INCH",
    );
    assert!(
        e.contains("z.com: line 1: the unit is `INCH`: volmap writes MM"),
        "{e}"
    );
    let e = refused("config.cma", "y.com", "w.com");
    assert!(e.contains("the table w.com is missing"), "{e}");
}

#[test]
fn heidenhain_table_sizes_beyond_its_limits_are_refused_saying_so() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let refused = |size| match export::export(heidenhain(), &request(&li, &inputs, size)) {
        Err(e) => e,
        Ok(_) => panic!("{size:?} accepted"),
    };
    let e = refused(TableSize::Points(257));
    assert!(matches!(e, ExportError::TooManyPoints { max: 256, .. }));
    assert!(
        e.to_string().starts_with(
            "257 points is more than a heidenhain table holds: at most 256 (HEIDENHAIN"
        ),
        "{e}"
    );
    let e = refused(TableSize::Spacing(0.05)).to_string();
    assert!(
        e.starts_with(
            "a spacing of 0.05 mm is below the smallest a heidenhain table takes: 0.1 mm"
        ),
        "{e}"
    );
    let e = refused(TableSize::Spacing(2.0)).to_string();
    assert!(
        e.starts_with("501 points along X (1000 mm at 2 mm) is more than a heidenhain table holds"),
        "{e}"
    );
}

#[test]
fn heidenhain_export_from_the_command_line_writes_the_tables_or_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tnc");
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-dobariya2015",
            "--format",
            "heidenhain",
        ])
        .arg("--out")
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("error").not())
        .stdout(predicate::str::contains("table x.com").and(predicate::str::contains("residual")));
    for name in ["x.com", "y.com", "z.com", "config.cma", "volmap.txt"] {
        assert!(out.join(name).is_file(), "{name}");
    }
    let fresh = dir.path().join("refused");
    volmap()
        .args([
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "heidenhain",
        ])
        .args(["--points", "300", "--out"])
        .arg(&fresh)
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --points: 300 points is more than a heidenhain table holds: at most 256",
        ));
    assert!(!fresh.exists());
}
