//! `volmap export --format fanuc` and `fanuc-3d`: the written parameters and pitch data read
//! back here with FANUC's documented meaning (increments summed from the reference position,
//! a staircase between compensation points, detection units × magnification; the 3-D lattice
//! trilinear in whole µm), applied to the model over a dense grid: the residual the export
//! reports. Hand-derived values, sign included; what the tables hold to rounding; the line
//! syntax; the requests refused.

use std::collections::BTreeMap;

use super::common::fixture;
use super::export::{dense, machine, request, residual};
use volmap::export::{self, format::WrittenFile, ExportError, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::reference::Twin;

const UM: f64 = 0.001;

fn file<'a>(files: &'a [WrittenFile], name: &str) -> &'a str {
    &files
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("{name} written"))
        .text
}

/// A pitch table as read here from the record's documented form.
#[derive(Debug)]
struct Pitch {
    reference_mm: f64,
    reference: i64,
    first: i64,
    last: i64,
    magnification: i64,
    interval_mm: f64,
    increments: Vec<i64>,
    /// 3626, 3627 and the increments of the negative-direction table.
    reverse: Option<(i64, i64, Vec<i64>)>,
}

/// `N0<no>Q1A<axis>P<value>…` blocks: parameter → axis (0-based) → value.
fn parameters(text: &str) -> BTreeMap<u32, BTreeMap<usize, String>> {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!((lines[0], lines[lines.len() - 1]), ("%", "%"));
    let mut out: BTreeMap<u32, BTreeMap<usize, String>> = BTreeMap::new();
    for line in &lines[1..lines.len() - 1] {
        let (number, rest) = line[1..].split_once("Q1").unwrap();
        for word in rest.split('A').skip(1) {
            let (axis, value) = word.split_once('P').unwrap();
            out.entry(number.parse().unwrap())
                .or_default()
                .insert(axis.parse::<usize>().unwrap() - 1, value.to_string());
        }
    }
    out
}

/// `N1<point>P<increment>` blocks: point → increment.
fn data(text: &str) -> BTreeMap<i64, i64> {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!((lines[0], lines[lines.len() - 1]), ("%", "%"));
    lines[1..lines.len() - 1]
        .iter()
        .map(|l| {
            let (n, v) = l[1..].split_once('P').unwrap();
            (n.parse::<i64>().unwrap() - 10000, v.parse().unwrap())
        })
        .collect()
}

fn pitch_tables(files: &[WrittenFile]) -> [Pitch; 3] {
    let p = parameters(file(files, "PITCHPRM.TXT"));
    let d = data(file(files, "PITCH.TXT"));
    let notes = file(files, "NOTES.TXT");
    let line = notes
        .lines()
        .find(|l| l.starts_with("reference position (machine coordinate, parameter 1240):"))
        .unwrap();
    let references: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.split_once('=').map(|(_, v)| v.parse().unwrap()))
        .collect();
    std::array::from_fn(|axis| {
        let int = |n: u32| p[&n][&axis].parse::<i64>().unwrap();
        let (first, last) = (int(3621), int(3622));
        let take = |from: i64| (from..=from + last - first).map(|n| d[&n]).collect();
        Pitch {
            reference_mm: references[axis],
            reference: int(3620),
            first,
            last,
            magnification: int(3623),
            interval_mm: p[&3624][&axis].parse().unwrap(),
            increments: take(first),
            reverse: p.get(&3626).and_then(|m| m.get(&axis)).map(|v| {
                let from: i64 = v.parse().unwrap();
                (from, int(3627), take(from))
            }),
        }
    })
}

impl Pitch {
    /// The compensation at `x` mm travelling `+` (or `−`): the increments summed from the
    /// reference position out to the point at or below `x` (positions in whole µm, as the
    /// control counts them); the outermost points' values beyond them.
    fn at(&self, x: f64, negative: bool) -> f64 {
        let (at_ref, increments) = match (&self.reverse, negative) {
            (Some((_, at_ref, inc)), true) => (*at_ref, inc),
            _ => (0, &self.increments),
        };
        let x = (x / UM).round() * UM;
        let j = (((x - self.reference_mm) / self.interval_mm) + 1e-9).floor() as i64;
        let j = j.clamp(self.first - self.reference - 1, self.last - self.reference);
        let v = |n: i64| increments[(n - self.first) as usize];
        let mut a = at_ref;
        if j > 0 {
            a += (self.reference + 1..=self.reference + j)
                .map(v)
                .sum::<i64>();
        } else {
            a -= (self.reference + j + 1..=self.reference)
                .map(v)
                .sum::<i64>();
        }
        (a * self.magnification) as f64 * UM
    }
}

fn fanuc() -> &'static dyn export::Format {
    export::format_named("fanuc").unwrap()
}

#[test]
fn fanuc_pitch_of_a_scale_error_by_hand() {
    // EXX = 1e-4·x: the real X is c(1 + 1e-4), so the correction is −1e-4·x/(1 + 1e-4):
    // −4.9995 µm per 50 mm, rounded −5, −10, …, −40: every increment −5 µm, NEGATIVE for an
    // axis that travels too far.
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let exported =
        export::export(fanuc(), &request(&m, &inputs, TableSize::Spacing(50.0))).unwrap();
    let files = &exported.files;
    assert_eq!(
        file(files, "PITCHPRM.TXT"),
        "%\nN03620Q1A1P0A2P170A3P340\nN03621Q1A1P0A2P170A3P340\nN03622Q1A1P8A2P176A3P344\n\
         N03623Q1A1P1A2P1A3P1\nN03624Q1A1P50.000A2P50.000A3P50.000\n%\n"
    );
    let d = data(file(files, "PITCH.TXT"));
    let x: Vec<i64> = (0..=8).map(|n| d[&n]).collect();
    assert_eq!(x, [0, -5, -5, -5, -5, -5, -5, -5, -5]);
    // Point numbers 0-1023 in six blocks of 170: Y's table from 170, Z's from 340.
    assert!((170..=176).chain(340..=344).all(|n| d[&n] == 0));
    assert_eq!(d.len(), 9 + 7 + 5);
    // The staircase holds −5j µm on [50j, 50j + 50): the error grows 1e-4 mm per mm inside the
    // interval. On the 41-point grid (10 mm) the worst is 40 mm into the first interval: 4 µm.
    let r = &exported.report;
    assert_eq!(r.grid.points, [41, 41, 41]);
    assert!((r.residual.max_mm - 0.004).abs() < 1e-9, "{:?}", r.residual);
    assert!((r.before.max_mm - 0.04).abs() < 1e-9);
}

#[test]
fn fanuc_points_span_the_travel() {
    // N points from the start of the travel span it in N − 1 intervals, the last at its end:
    // 11 points over 0–400 mm at 40 mm, 0–600 at 60, 0–200 at 20; where the travel does not
    // divide into whole µm, the interval is rounded up and the last point lies just beyond.
    let m = machine(&fixture("scale-x").replace("range = [0.0, 300.0]", "range = [0.0, 600.0]"));
    let inputs = Inputs::default();
    let exported = export::export(fanuc(), &request(&m, &inputs, TableSize::Points(11))).unwrap();
    let t = pitch_tables(&exported.files);
    assert_eq!(t.len(), 3);
    for (axis, (table, length)) in t.iter().zip([400.0, 600.0, 200.0]).enumerate() {
        let last_mm =
            table.reference_mm + (table.last - table.reference) as f64 * table.interval_mm;
        assert_eq!(table.last - table.first + 1, 11, "axis {axis}: {table:?}");
        assert!(
            (table.interval_mm - length / 10.0).abs() < 1e-9,
            "axis {axis}: {table:?}"
        );
        assert!(
            (last_mm - length).abs() < 1e-9,
            "axis {axis}: last point at {last_mm}"
        );
    }
    let odd = machine(&fixture("scale-x").replace("range = [0.0, 300.0]", "range = [0.0, 700.0]"));
    let exported = export::export(fanuc(), &request(&odd, &inputs, TableSize::Points(4))).unwrap();
    let y = &pitch_tables(&exported.files)[1];
    // 700 mm in 3 intervals: 233.334 mm (rounded up to the µm), the last point at 700.002 mm.
    assert!((y.interval_mm - 233.334).abs() < 1e-9, "{y:?}");
    assert_eq!(y.last - y.first + 1, 4);
    let x = &pitch_tables(&exported.files)[0];
    assert!(x.reference_mm + (x.last - x.reference) as f64 * x.interval_mm >= 400.0);
}

const STEPS: &str = r#"
name = "stepped X"
chain = "FYXFZ"
[axes.X]
range = [0.0, 200.0]
EXX = { table = [[0, 0.0], [49.999, 0.0], [50, -0.003], [99.999, -0.003], [100, -0.007], [149.999, -0.007], [150, -0.012], [200, -0.012]], interp = "linear", reverse = { table = [[0, -0.006], [49.999, -0.006], [50, -0.009], [99.999, -0.009], [100, -0.013], [149.999, -0.013], [150, -0.018], [200, -0.018]], interp = "linear" } }
[axes.Y]
range = [0.0, 100.0]
[axes.Z]
range = [0.0, 100.0]
"#;

#[test]
fn fanuc_holds_a_positioning_error_constant_between_its_points_to_rounding() {
    // The positioning error steps at the compensation points 0, 50, 100, 150 mm (the axis falls
    // short: 3, 7, 12 µm) and falls 6 µm shorter still approaching −: a staircase per
    // direction, which the bidirectional table holds exactly.
    let m = machine(STEPS);
    for approach in ["X=+", "X=-"] {
        let inputs = Inputs::parse("", approach, &m).unwrap();
        let exported =
            export::export(fanuc(), &request(&m, &inputs, TableSize::Spacing(50.0))).unwrap();
        let t = pitch_tables(&exported.files);
        assert_eq!(t[0].increments, [0, 3, 4, 5, 0]);
        let reverse = t[0].reverse.as_ref().expect("a bidirectional X table");
        // 3627: +6 µm at the reference position travelling −; its table from point 510 on
        // (the fourth block of 170).
        assert_eq!((reverse.0, reverse.1), (510, 6));
        assert_eq!(reverse.2, [0, 3, 4, 5, 0]);
        assert!(t[1].reverse.is_none() && t[2].reverse.is_none());
        let r = &exported.report;
        assert!(r.before.max_mm > 0.0119, "{approach} {:?}", r.before);
        assert!(r.residual.max_mm < 1e-9, "{approach} {:?}", r.residual);
        assert!(file(&exported.files, "PITCHPRM.TXT").contains("N03626Q1A1P510\nN03627Q1A1P6\n"));
    }
}

#[test]
fn fanuc_round_trip_gives_the_reported_residual() {
    // gantry-2m with Y approaching −: its 6 µm reversal makes Y bidirectional.
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::parse("", "Y=-", &gantry).unwrap();
    let exported =
        export::export(fanuc(), &request(&gantry, &inputs, TableSize::Points(17))).unwrap();
    let t = pitch_tables(&exported.files);
    assert!(t[1].reverse.is_some() && t[0].reverse.is_none());
    for p in &t {
        assert_eq!(
            p.first, p.reference,
            "the reference at the start of the travel"
        );
        assert!(p.last - p.first < 17);
    }
    let report = &exported.report;
    assert_eq!(report.grid.points, [41, 41, 41]);
    let twin = Twin::new(gantry.at(&inputs));
    let targets = dense(&gantry, 41);
    let (max, rms) = residual(&twin, &targets, |p| {
        let mut c = p;
        for (d, table) in t.iter().enumerate() {
            c[d] += table.at(p[d], d == 1);
        }
        c
    });
    assert!(
        (max - report.residual.max_mm).abs() < 1e-12,
        "{max} vs {:?}",
        report.residual
    );
    assert!((rms - report.residual.rms_mm).abs() < 1e-12);
    // The positioning errors it holds lower the RMS; what no per-axis table holds stays.
    assert!(report.residual.rms_mm < report.before.rms_mm);
    assert!(report.not_held.iter().any(|n| n.error == "EC0Y"));
}

#[test]
fn fanuc_magnification_rises_where_an_increment_outgrows_a_byte() {
    // 3 mm/m: −149.55 µm per 50 mm, beyond 127: magnification 2, increments of 2 µm units,
    // the rounding carried in the sums (−75, −150, −224 …).
    let m = machine(&fixture("scale-x").replace("1.0e-4", "3.0e-3"));
    let inputs = Inputs::default();
    let exported =
        export::export(fanuc(), &request(&m, &inputs, TableSize::Spacing(50.0))).unwrap();
    let t = pitch_tables(&exported.files);
    assert_eq!(t[0].magnification, 2);
    let absolute: Vec<i64> = t[0].increments[1..]
        .iter()
        .scan(0, |a, v| {
            *a += v;
            Some(*a)
        })
        .collect();
    let hand: Vec<i64> = (1..=8)
        .map(|j| (-3e-3 * 50.0 * j as f64 / 1.003 / 0.002).round() as i64)
        .collect();
    assert_eq!(absolute, hand);
    // The staircase of the hand values on the report's 10 mm grid: at least 3e-3 × 40 mm
    // (40 mm into the first interval, which holds 0), a little more where the rounding adds.
    let staircase = |x: f64| {
        let j = (x / 50.0).floor() as usize;
        if j == 0 {
            0.0
        } else {
            hand[j.min(8) - 1] as f64 * 0.002
        }
    };
    let worst = (0..=40)
        .map(|i| {
            let x = 10.0 * i as f64;
            ((x + staircase(x)) * 1.003 - x).abs()
        })
        .fold(0.0, f64::max);
    assert!(worst >= 0.12);
    assert!(
        (exported.report.residual.max_mm - worst).abs() < 1e-9,
        "{worst} vs {:?}",
        exported.report.residual
    );
}

#[test]
fn fanuc_lines_read_as_the_documented_blocks() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let exported = export::export(fanuc(), &request(&li, &inputs, TableSize::Default)).unwrap();
    let params = file(&exported.files, "PITCHPRM.TXT");
    let lines: Vec<&str> = params.lines().collect();
    assert_eq!((lines[0], lines[lines.len() - 1]), ("%", "%"));
    for line in &lines[1..lines.len() - 1] {
        // N + 5 digits + Q1, then A<axis>P<integer or real with 3 decimals> words.
        assert!(line.starts_with('N') && &line[6..8] == "Q1", "{line}");
        assert!(line[1..6].chars().all(|c| c.is_ascii_digit()), "{line}");
        for word in line[8..].split('A').skip(1) {
            let (axis, value) = word.split_once('P').expect(line);
            assert!(["1", "2", "3"].contains(&axis), "{line}");
            let digits = value.trim_start_matches('-');
            match digits.split_once('.') {
                Some((i, f)) => assert!(
                    f.len() == 3 && (i.chars().chain(f.chars())).all(|c| c.is_ascii_digit()),
                    "{line}"
                ),
                None => assert!(digits.chars().all(|c| c.is_ascii_digit()), "{line}"),
            }
        }
    }
    let pitch = file(&exported.files, "PITCH.TXT");
    let lines: Vec<&str> = pitch.lines().collect();
    assert_eq!((lines[0], lines[lines.len() - 1]), ("%", "%"));
    let mut previous = -1;
    for line in &lines[1..lines.len() - 1] {
        let (n, v) = line
            .strip_prefix("N1")
            .and_then(|l| l.split_once('P'))
            .expect(line);
        assert_eq!(n.len(), 4, "{line}");
        let n: i64 = n.parse().unwrap();
        assert!(n > previous, "{line}: points in increasing order");
        previous = n;
        let v: i64 = v.parse().expect(line);
        assert!((-128..=127).contains(&v), "{line}");
    }
    assert!(!params.contains('\r') && !pitch.contains('\r'));
}

#[test]
fn fanuc_refuses_what_its_tables_cannot_take() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let refused = |size| match export::export(fanuc(), &request(&li, &inputs, size)) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{size:?} accepted"),
    };
    let too_many = refused(TableSize::Points(171));
    assert!(
        too_many.starts_with("171 points along ")
            && too_many.contains(
                "is more than a fanuc table holds: at most 170 (FANUC pitch error compensation"
            ),
        "{too_many}"
    );
    assert!(refused(TableSize::Spacing(0.5))
        .starts_with("a spacing of 0.5 mm is below the smallest a fanuc table takes: 1 mm"));
    // A squareness is no axis's error along itself: the tables hold nothing of it.
    let square = machine(&fixture("squareness"));
    let e = export::export(fanuc(), &request(&square, &inputs, TableSize::Default))
        .err()
        .expect("refused");
    assert!(
        matches!(
            e,
            ExportError::NothingHeld {
                format: "fanuc",
                ..
            }
        ),
        "{e}"
    );
}

/// A lattice as read here: positions per axis and CX CY CZ in mm, X fastest.
fn lattice(text: &str) -> ([Vec<f64>; 3], Vec<[f64; 3]>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next(), Some("NO,X,Y,Z,CX,CY,CZ"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let axis = |d: usize| {
        let mut q: Vec<f64> = rows.iter().map(|r| r[d + 1].parse().unwrap()).collect();
        q.sort_by(f64::total_cmp);
        q.dedup();
        q
    };
    let axes = [axis(0), axis(1), axis(2)];
    for (n, r) in rows.iter().enumerate() {
        assert_eq!(r[0].parse::<usize>().unwrap(), n, "numbered X fastest");
    }
    let values = rows
        .iter()
        .map(|r| std::array::from_fn(|k| r[k + 4].parse::<i64>().unwrap() as f64 * UM))
        .collect();
    (axes, values)
}

/// FANUC's blend of the eight corners of the cell around `p` (clamped to the lattice).
fn trilinear(axes: &[Vec<f64>; 3], values: &[[f64; 3]], p: [f64; 3]) -> [f64; 3] {
    let cell = |d: usize| {
        let q = &axes[d];
        let x = p[d].clamp(q[0], q[q.len() - 1]);
        let i = (0..q.len() - 1).rfind(|&i| q[i] <= x).unwrap_or(0);
        (i, (x - q[i]) / (q[i + 1] - q[i]))
    };
    let c = [cell(0), cell(1), cell(2)];
    let (nx, ny) = (axes[0].len(), axes[1].len());
    let mut out = [0.0; 3];
    for corner in 0..8 {
        let mut w = 1.0;
        let mut at = [0; 3];
        for d in 0..3 {
            let (i, u) = c[d];
            let upper = corner >> d & 1 == 1;
            at[d] = i + usize::from(upper);
            w *= if upper { u } else { 1.0 - u };
        }
        let v = values[at[0] + nx * (at[1] + ny * at[2])];
        for k in 0..3 {
            out[k] += w * v[k];
        }
    }
    out
}

#[test]
fn fanuc_3d_round_trip_gives_the_reported_residual() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let exported = export::export(
        export::format_named("fanuc-3d").unwrap(),
        &request(&li, &inputs, TableSize::Points(6)),
    )
    .unwrap();
    let (axes, values) = lattice(&exported.files[0].text);
    assert_eq!(axes.each_ref().map(Vec::len), [6, 6, 6]);
    let report = &exported.report;
    let twin = Twin::of(&li);
    let targets = dense(&li, report.grid.points[0]);
    let (max, rms) = residual(&twin, &targets, |p| {
        let d = trilinear(&axes, &values, p);
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    });
    assert!(
        (max - report.residual.max_mm).abs() < 1e-12,
        "{max} vs {:?}",
        report.residual
    );
    assert!((rms - report.residual.rms_mm).abs() < 1e-12);
    assert!(max < 0.1 * report.before.max_mm);
}

#[test]
fn fanuc_3d_holds_a_scale_error_in_whole_microns() {
    // CX = −1e-4·x/(1 + 1e-4): −9.999 µm at 100 mm → −10, −39.996 at 400 → −40; linear, so
    // trilinear blending leaves only the rounding, at most 4 nm here.
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let exported = export::export(
        export::format_named("fanuc-3d").unwrap(),
        &request(&m, &inputs, TableSize::Spacing(100.0)),
    )
    .unwrap();
    let (axes, values) = lattice(&exported.files[0].text);
    assert_eq!(axes[0], [0.0, 100.0, 200.0, 300.0, 400.0]);
    // A value per node of the lattice.
    assert_eq!(values.len(), axes.iter().map(Vec::len).product::<usize>());
    for (n, v) in values.iter().enumerate() {
        let x = axes[0][n % 5];
        assert_eq!(v[0], (-1e-4 * x / 1.0001 / UM).round() * UM, "CX at {x}");
        assert_eq!((v[1], v[2]), (0.0, 0.0));
    }
    assert!(
        exported.report.residual.max_mm <= 4.01e-6,
        "{:?}",
        exported.report.residual
    );
    assert!(exported.files[0].text.contains("ADDED to the command"));
}

#[test]
fn fanuc_reading_back_names_the_file_and_line_of_what_does_not_read() {
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    let written = fanuc()
        .write(&fitting, Some([9, 7, 5]), Some(50.0))
        .unwrap();
    assert!(fanuc().read_for(&written, &fitting).is_ok());
    let broken = |name: &str, from: &str, to: &str| -> String {
        let mut files = written.clone();
        let f = files.iter_mut().find(|f| f.name == name).unwrap();
        assert!(f.text.contains(from), "{from}");
        f.text = f.text.replacen(from, to, 1);
        match fanuc().read_for(&files, &fitting) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{name}: `{to}` read"),
        }
    };
    assert_eq!(
        broken("PITCH.TXT", "N10003P-5\n", "N10003P300\n"),
        "reading back PITCH.TXT: line 5: 300 is outside -128…127"
    );
    assert_eq!(
        broken("PITCH.TXT", "N10003P-5\n", "N10003-5\n"),
        "reading back PITCH.TXT: line 5: a data block reads N<10000 + point>P<value>"
    );
    assert_eq!(
        broken("PITCHPRM.TXT", "N03621Q1A1P0", "N03621Q1A1P5"),
        "reading back PITCHPRM.TXT: line 2: axis 1: 3621 <= 3620 < 3622 within 0-9999 fails: 5, 0, 8"
    );
    assert_eq!(
        broken("PITCHPRM.TXT", "A3P50.000\n%\n", "A3P50.000\n"),
        "reading back PITCHPRM.TXT: line 6: no closing `%`"
    );
    // Y's table moved onto X's point numbers: the control would keep one value for both.
    let mut files = written.clone();
    let params = files.iter_mut().find(|f| f.name == "PITCHPRM.TXT").unwrap();
    for (from, to) in [
        ("N03620Q1A1P0A2P170", "N03620Q1A1P0A2P2"),
        ("N03621Q1A1P0A2P170", "N03621Q1A1P0A2P2"),
        ("N03622Q1A1P8A2P176", "N03622Q1A1P8A2P8"),
    ] {
        assert!(params.text.contains(from), "{from}");
        params.text = params.text.replacen(from, to, 1);
    }
    match fanuc().read_for(&files, &fitting) {
        Err(e) => assert_eq!(
            e.to_string(),
            "reading back PITCHPRM.TXT: line 3: the tables of axes 1 (0-8) and 2 (2-8) share point numbers"
        ),
        Ok(_) => panic!("overlapping tables read"),
    }
}

#[test]
fn fanuc_tables_take_six_blocks_of_the_point_numbers_given() {
    // 512-767: 256 numbers, six blocks of 42: X, Y, Z travelling + from 512, 554, 596; X's
    // bidirectional table from 638.
    let m = machine(STEPS);
    let inputs = Inputs::parse("", "X=-", &m).unwrap();
    let asked = |size| export::Request {
        point_numbers: Some([512, 767]),
        ..request(&m, &inputs, size)
    };
    let exported = export::export(fanuc(), &asked(TableSize::Spacing(50.0))).unwrap();
    let t = pitch_tables(&exported.files);
    assert_eq!(
        t.iter().map(|t| t.first).collect::<Vec<_>>(),
        [512, 554, 596]
    );
    assert_eq!(t[0].reverse.as_ref().expect("bidirectional").0, 638);
    assert!(exported.report.residual.max_mm < 1e-9);
    // 43 points fit no block of 42; 42 do.
    let refused = export::export(fanuc(), &asked(TableSize::Points(43)))
        .err()
        .expect("43 points refused")
        .to_string();
    assert!(
        refused.contains("at most 42 (FANUC pitch error compensation"),
        "{refused}"
    );
    assert!(export::export(fanuc(), &asked(TableSize::Points(42))).is_ok());
    // Numbers no table can take.
    let bad = export::Request {
        point_numbers: Some([0, 10]),
        ..request(&m, &inputs, TableSize::Default)
    };
    assert!(matches!(
        export::export(fanuc(), &bad),
        Err(ExportError::BadPointNumbers {
            first: 0,
            last: 10,
            ..
        })
    ));
}
