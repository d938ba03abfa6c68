//! `volmap export --format isg-axis`: the ISG kernel's compensation value lists (leadscrew error
//! compensation `kw.ssfk`, plane compensation `kw.crosscomp2`) read back here with their
//! documented meaning (the LSEC table the error, linear between its set points, subtracted; the
//! plane table the correction, bilinear, added; 0.1 µm) and applied over a dense grid: the
//! residual the export reports. Hand-derived signs, what the lists hold to rounding, the line
//! syntax.

use std::collections::BTreeMap;

use super::export::{dense, machine, request, residual};
use volmap::export::{self, format::WrittenFile, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::reference::Twin;

const UNIT: f64 = 1e-4;

fn isg_axis() -> &'static dyn export::Format {
    export::format_named("isg-axis").unwrap()
}

/// One list's `name value` entries, checked line by line against the documented form.
fn entries(text: &str) -> BTreeMap<String, i64> {
    let mut out = BTreeMap::new();
    let mut lines = text.lines().filter(|l| !l.starts_with("# "));
    for line in lines.by_ref() {
        if line == "End" {
            break;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(words.len(), 2, "{line}");
        assert!(
            words[0].starts_with("kopf.")
                || words[0].starts_with("kw.ssfk.")
                || words[0].starts_with("kw.crosscomp2."),
            "{line}"
        );
        let value = match words[1] {
            "X" | "Y" | "Z" | "RECTANGULAR" => 0,
            v => v.parse().unwrap_or_else(|_| panic!("{line}")),
        };
        assert!(out.insert(words[0].to_string(), value).is_none(), "{line}");
    }
    assert_eq!(lines.next(), None, "nothing after End");
    out
}

/// One axis's lists as read here: LSEC set points and errors (mm), the plane (mm).
struct Lists {
    axis: usize,
    setpoints: Vec<f64>,
    pos: Vec<f64>,
    neg: Option<Vec<f64>>,
    masters: [usize; 2],
    start: [f64; 2],
    interval: [f64; 2],
    /// `plane[j][i]`: j along master 2.
    plane: Vec<Vec<f64>>,
}

fn lists(files: &[WrittenFile]) -> Vec<Lists> {
    files
        .iter()
        .filter(|f| f.name.starts_with("achskw_"))
        .map(|f| {
            let e = entries(&f.text);
            let n = e["kw.ssfk.kw_nr_max"];
            let column = |w: &str| -> Vec<f64> {
                (0..n)
                    .map(|i| e[&format!("kw.ssfk.table[{i}].{w}")] as f64 * UNIT)
                    .collect()
            };
            let last = [
                e["kw.crosscomp2.last_index_master1"],
                e["kw.crosscomp2.last_index_master2"],
            ];
            Lists {
                axis: e["kopf.achs_nr"] as usize - 1,
                setpoints: column("setpoint"),
                pos: column("pos"),
                neg: (e["kw.ssfk.bilateral"] == 1).then(|| column("neg")),
                masters: [
                    e["kw.crosscomp2.master1_ax_nr"] as usize - 1,
                    e["kw.crosscomp2.master2_ax_nr"] as usize - 1,
                ],
                start: [
                    e["kw.crosscomp2.start_position_master1"] as f64 * UNIT,
                    e["kw.crosscomp2.start_position_master2"] as f64 * UNIT,
                ],
                interval: [
                    e["kw.crosscomp2.interval1"] as f64 * UNIT,
                    e["kw.crosscomp2.interval2"] as f64 * UNIT,
                ],
                plane: (0..=last[1])
                    .map(|j| {
                        (0..=last[0])
                            .map(|i| {
                                e[&format!("kw.crosscomp2.table[{j}][{i}].correction")] as f64
                                    * UNIT
                            })
                            .collect()
                    })
                    .collect(),
            }
        })
        .collect()
}

fn linear(q: &[f64], v: &[f64], x: f64) -> f64 {
    let n = q.len();
    if x <= q[0] {
        return v[0];
    }
    if x >= q[n - 1] {
        return v[n - 1];
    }
    let i = (1..n).find(|&i| q[i] > x).unwrap();
    v[i - 1] + (x - q[i - 1]) / (q[i] - q[i - 1]) * (v[i] - v[i - 1])
}

impl Lists {
    fn plane_at(&self, a: f64, b: f64) -> f64 {
        let cell = |k: usize, x: f64, n: usize| {
            let u = ((x - self.start[k]) / self.interval[k]).clamp(0.0, (n - 1) as f64);
            let i = (u.floor() as usize).min(n - 2);
            (i, u - i as f64)
        };
        let (i, u) = cell(0, a, self.plane[0].len());
        let (j, w) = cell(1, b, self.plane.len());
        let p = &self.plane;
        (1.0 - w) * ((1.0 - u) * p[j][i] + u * p[j][i + 1])
            + w * ((1.0 - u) * p[j + 1][i] + u * p[j + 1][i + 1])
    }

    /// The set point the control moves axis `axis` to: the target less the LSEC error plus the
    /// plane correction.
    fn command(&self, t: [f64; 3], negative: bool) -> f64 {
        let values = match (&self.neg, negative) {
            (Some(neg), true) => neg,
            _ => &self.pos,
        };
        t[self.axis] - linear(&self.setpoints, values, t[self.axis])
            + self.plane_at(t[self.masters[0]], t[self.masters[1]])
    }
}

const HAND: &str = r#"
name = "scale and squareness"
chain = "FYXFZ"
[axes.X]
range = [0.0, 400.0]
EXX = { poly = [0.0, 1.0e-5] }
[axes.Y]
range = [0.0, 300.0]
EC0Y = 2.0e-5
[axes.Z]
range = [0.0, 200.0]
"#;

#[test]
fn isg_axis_holds_a_scale_error_and_a_squareness_with_their_signs() {
    // X runs 1e-5 too far: its LSEC table holds that ERROR, +10 × 0.1 µm per 100 mm. Y leans
    // towards −X by 2e-5: X must be commanded +2e-5·y, a CORRECTION of +20 × 0.1 µm per 100 mm
    // of Y in X's plane table. Both are linear: the lists hold them to the 0.1 µm rounding.
    let m = machine(HAND);
    let inputs = Inputs::default();
    let exported =
        export::export(isg_axis(), &request(&m, &inputs, TableSize::Spacing(100.0))).unwrap();
    let found = lists(&exported.files);
    let x = found.iter().find(|l| l.axis == 0).unwrap();
    assert_eq!(x.setpoints, [0.0, 100.0, 200.0, 300.0, 400.0]);
    // Each value is rounded on its own: a step is the hand step give or take one unit.
    let steps_near = |v: &[f64], step: i64| {
        v.windows(2)
            .all(|w| (((w[1] - w[0]) / UNIT).round() as i64 - step).abs() <= 1)
    };
    assert!(steps_near(&x.pos, 10), "{:?}", x.pos);
    assert!((x.pos[4] - x.pos[0] - 40.0 * UNIT).abs() <= 1.01 * UNIT);
    assert_eq!(x.masters, [1, 2]);
    assert!(!x.plane.is_empty());
    for row in &x.plane {
        assert!(steps_near(row, 20), "{row:?}");
        assert!((row[3] - row[0] - 60.0 * UNIT).abs() <= 1.01 * UNIT);
    }
    assert!(x.neg.is_none());
    // Together they give the correction at every point, to the rounding.
    for (xi, &p) in x.setpoints.iter().enumerate() {
        for (yi, y) in [0.0, 100.0, 200.0, 300.0].iter().enumerate() {
            let held = -x.pos[xi] + x.plane[0][yi];
            let hand = -1e-5 * p / (1.0 + 1e-5) + 2e-5 * y;
            assert!(
                (held - hand).abs() <= 1.01 * UNIT,
                "{p} {y}: {held} vs {hand}"
            );
        }
    }
    let r = &exported.report;
    assert!(r.before.max_mm > 0.0059, "{:?}", r.before);
    assert!(r.residual.max_mm < 1.5 * UNIT, "{:?}", r.residual);
}

#[test]
fn isg_axis_round_trip_gives_the_reported_residual() {
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::parse("", "Y=-", &gantry).unwrap();
    let exported =
        export::export(isg_axis(), &request(&gantry, &inputs, TableSize::Points(9))).unwrap();
    let found = lists(&exported.files);
    assert_eq!(found.len(), 3);
    assert!(found[1].neg.is_some(), "Y's reversal: a bilateral table");
    let report = &exported.report;
    let twin = Twin::new(gantry.at(&inputs));
    let targets = dense(&gantry, report.grid.points[0]);
    let (max, rms) = residual(&twin, &targets, |t| {
        let mut c = t;
        for l in &found {
            c[l.axis] = l.command(t, l.axis == 1);
        }
        c
    });
    assert!(
        (max - report.residual.max_mm).abs() < 1e-12,
        "{max} vs {:?}",
        report.residual
    );
    assert!((rms - report.residual.rms_mm).abs() < 1e-12);
    assert!(max < 0.5 * report.before.max_mm);
    // What no table size holds is about what these lists leave, and less than what sums of
    // one-axis tables leave: a plane list also holds the interaction of its two masters.
    assert!(
        report.structural_mm > 0.5 * max && report.structural_mm < 1.1 * max,
        "{} vs {max}",
        report.structural_mm
    );
    let siemens = export::export(
        export::format_named("siemens").unwrap(),
        &request(&gantry, &inputs, TableSize::Points(9)),
    )
    .unwrap();
    assert!(
        report.structural_mm < 0.9 * siemens.report.structural_mm,
        "{} vs {}",
        report.structural_mm,
        siemens.report.structural_mm
    );
    let startup = &exported
        .files
        .iter()
        .find(|f| f.name == "hochlauf_axis_comp.lis")
        .unwrap()
        .text;
    for line in startup.lines().filter(|l| !l.starts_with("# ")) {
        assert_eq!(line.split_whitespace().count(), 2, "{line}");
    }
    assert!(startup.contains("achskw_y.lis"));
}

#[test]
fn isg_axis_refuses_more_plane_points_than_it_holds() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let e = export::export(isg_axis(), &request(&li, &inputs, TableSize::Points(102)))
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.starts_with(
            "102 points is more than a isg-axis table holds: at most 101 (ISG plane compensation"
        ),
        "{e}"
    );
}
