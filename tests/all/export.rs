//! `volmap export`: the correction field, the limits of table sizes, and the `grid-csv` round
//! trip: the written grid read back with trilinear interpolation written here, applied to the
//! model over a dense grid, gives the residual the export reports.

use volmap::export::{self, fitting, ExportError, Field, Request, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::model::{Command, Machine};
use volmap::reference::Twin;

use super::common::fixture;

pub fn machine(toml: &str) -> Machine {
    Machine::from_toml(toml, "test.toml", None).unwrap()
}

pub fn request<'a>(machine: &'a Machine, inputs: &'a Inputs, size: TableSize) -> Request<'a> {
    Request {
        machine,
        inputs,
        pose: [0.0; 6],
        size,
        evaluation_points: None,
        written_by: "Written by the tests".into(),
        file_name: None,
        tool_length_mm: None,
        control: None,
        point_numbers: None,
        probe_offset_mm: None,
    }
}

/// Every target of a grid of `n` per axis over the machine's travels, X fastest.
pub fn dense(machine: &Machine, n: usize) -> Vec<[f64; 3]> {
    let axes: Vec<Vec<f64>> = ["X", "Y", "Z"]
        .iter()
        .map(|l| {
            let a = machine
                .axes
                .iter()
                .find(|a| a.letter.to_string() == *l)
                .unwrap();
            fitting::uniform(a.range[0], a.range[1], n)
        })
        .collect();
    let mut out = Vec::new();
    for &z in &axes[2] {
        for &y in &axes[1] {
            for &x in &axes[0] {
                out.push([x, y, z]);
            }
        }
    }
    out
}

/// Largest and RMS of `|p_real(command(t)) − p_ideal(t)|` over `targets`.
pub fn residual(
    twin: &Twin,
    targets: &[[f64; 3]],
    command: impl Fn([f64; 3]) -> [f64; 3],
) -> (f64, f64) {
    let mut max: f64 = 0.0;
    let mut sum = 0.0;
    for &t in targets {
        let c = command(t);
        let at = |p: [f64; 3]| -> Command { [p[0], p[1], p[2], 0.0, 0.0, 0.0] };
        let miss = (twin.real_tip(&at(c)) - twin.ideal_tip(&at(t))).norm();
        max = max.max(miss);
        sum += miss * miss;
    }
    (max, (sum / targets.len() as f64).sqrt())
}

/// The grid of a `grid-csv` text, read here from the header comments' grammar: node positions
/// per axis and `(dX, dY, dZ)` at each node, X fastest.
fn read_grid(text: &str) -> ([Vec<f64>; 3], Vec<[f64; 3]>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next(), Some("X,Y,Z,dX,dY,dZ"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    let axis = |d: usize| {
        let mut q: Vec<f64> = rows.iter().map(|r| r[d]).collect();
        q.sort_by(f64::total_cmp);
        q.dedup();
        q
    };
    let axes = [axis(0), axis(1), axis(2)];
    assert_eq!(rows.len(), axes[0].len() * axes[1].len() * axes[2].len());
    (axes, rows.iter().map(|r| [r[3], r[4], r[5]]).collect())
}

/// Trilinear interpolation of a read grid at `p`.
fn trilinear(axes: &[Vec<f64>; 3], values: &[[f64; 3]], p: [f64; 3]) -> [f64; 3] {
    let cell = |d: usize| {
        let q = &axes[d];
        let x = p[d].clamp(q[0], q[q.len() - 1]);
        let i = (0..q.len() - 1).rfind(|&i| q[i] <= x).unwrap_or(0);
        (i, (x - q[i]) / (q[i + 1] - q[i]))
    };
    let (c0, c1, c2) = (cell(0), cell(1), cell(2));
    let (nx, ny) = (axes[0].len(), axes[1].len());
    let mut out = [0.0; 3];
    for corner in 0..8 {
        let pick = |(i, u): (usize, f64), bit: usize| {
            if corner >> bit & 1 == 1 {
                (i + 1, u)
            } else {
                (i, 1.0 - u)
            }
        };
        let ((i, wx), (j, wy), (k, wz)) = (pick(c0, 0), pick(c1, 1), pick(c2, 2));
        let v = values[i + nx * (j + ny * k)];
        for d in 0..3 {
            out[d] += wx * wy * wz * v[d];
        }
    }
    out
}

#[test]
fn the_correction_puts_the_real_tip_where_the_ideal_one_is() {
    // gantry-2m at warm temperatures and Y approaching `-`: sag, thermal and backlash terms.
    let gantry = embedded::load("gantry-2m").unwrap();
    let inputs = Inputs::parse("x_scale=26,spindle=35", "Y=-", &gantry).unwrap();
    let field = Field::new(gantry.at(&inputs), [0.0; 6]).unwrap();
    let twin = field.twin();
    for t in [
        [0.0, 0.0, 0.0],
        [1500.0, 1000.0, 500.0],
        [3000.0, 2000.0, 1000.0],
    ] {
        let d = field.correction(t).unwrap();
        let c = field.command([t[0] + d[0], t[1] + d[1], t[2] + d[2]]);
        let miss = (twin.real_tip(&c) - twin.ideal_tip(&field.command(t))).norm();
        assert!(miss < 1e-12, "{miss} mm at {t:?}");
        // Not the error: to first order the correction is −VE along each axis here.
        let ve = twin.deviation(&field.command(t)).volumetric_mm;
        assert!((d[0] + ve[0]).abs() < 0.1 * ve.norm() + 1e-4);
    }
}

#[test]
fn grid_csv_round_trip_gives_the_reported_residual() {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let exported = export::export(
        export::format_named("grid-csv").unwrap(),
        &request(&li, &inputs, TableSize::Points(9)),
    )
    .unwrap();
    let text = &exported.files[0].text;
    for said in [
        "machine: 3-axis VMC (Li et al. 2015, Table 3)",
        "inputs: approach X+ Y+ Z+",
        "ADDED to the command",
        "grid X: 9 points from 0.000000 to 1000.000000 mm, spacing 125.000000 mm",
    ] {
        assert!(text.contains(said), "the header says {said}:\n{text}");
    }
    let (axes, values) = read_grid(text);
    assert_eq!(axes.each_ref().map(|a| a.len()), [9, 9, 9]);
    let report = &exported.report;
    assert_eq!(report.grid.points, [41, 41, 41]);
    let twin = Twin::of(&li);
    let targets = dense(&li, 41);
    let (max, rms) = residual(&twin, &targets, |t| {
        let d = trilinear(&axes, &values, t);
        [t[0] + d[0], t[1] + d[1], t[2] + d[2]]
    });
    assert!(
        (max - report.residual.max_mm).abs() < 1e-12,
        "{max} vs {:?}",
        report.residual
    );
    assert!((rms - report.residual.rms_mm).abs() < 1e-12);
    let (before, _) = residual(&twin, &targets, |t| t);
    assert!((before - report.before.max_mm).abs() < 1e-12);
    assert!(max < 0.02 * before, "{max} of {before}");
    // Between the evaluation points too: a finer grid finds nothing much larger.
    let (finer, _) = residual(&twin, &dense(&li, 57), |t| {
        let d = trilinear(&axes, &values, t);
        [t[0] + d[0], t[1] + d[1], t[2] + d[2]]
    });
    assert!(finer < 1.1 * max, "{finer} vs {max}");
}

#[test]
fn grid_csv_holds_a_scale_error_to_rounding_with_the_hand_derived_correction() {
    // Real X tip at command c: c + 1e-4·c = x, so c = x / (1 + 1e-4) and dX = −1e-4·x / (1 + 1e-4):
    // linear, which a trilinear grid holds exactly; what is left is the 6 decimals.
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let exported = export::export(
        export::format_named("grid-csv").unwrap(),
        &request(&m, &inputs, TableSize::Spacing(100.0)),
    )
    .unwrap();
    let (axes, values) = read_grid(&exported.files[0].text);
    assert_eq!(axes[0], [0.0, 100.0, 200.0, 300.0, 400.0]);
    // A value per node of the lattice.
    assert_eq!(values.len(), axes.iter().map(Vec::len).product::<usize>());
    for (n, v) in values.iter().enumerate() {
        let x = axes[0][n % 5];
        let hand = -1e-4 * x / (1.0 + 1e-4);
        assert!((v[0] - hand).abs() <= 5e-7, "dX at {x}: {} vs {hand}", v[0]);
        assert_eq!((v[1], v[2]), (0.0, 0.0));
    }
    let r = &exported.report;
    assert!(r.before.max_mm > 0.039);
    assert!(r.residual.max_mm <= 5e-7 * 1.01, "{:?}", r.residual);
}

const SMOOTH: &str = r#"
name = "smooth"
chain = "FYXFZ"
[tool]
offset = [0.0, 0.0, -100.0]
[axes.X]
range = [0.0, 800.0]
EYX = { poly = [0.0, 1.0e-4, -1.25e-7] }
EBX = { poly = [0.0, 2.0e-8, -1.0e-11] }
[axes.Y]
range = [0.0, 600.0]
EZY = { poly = [0.0, 1.2e-4, -2.0e-7] }
EC0Y = 2.0e-5
[axes.Z]
range = [0.0, 400.0]
EXZ = { poly = [0.0, 8.0e-5, -2.0e-7] }
"#;

#[test]
fn grid_csv_residual_falls_with_the_square_of_the_spacing() {
    let m = machine(SMOOTH);
    let inputs = Inputs::default();
    let residual_at = |n: usize| {
        let mut r = request(&m, &inputs, TableSize::Points(n));
        r.evaluation_points = Some(4 * (n - 1) + 1);
        export::export(export::format_named("grid-csv").unwrap(), &r)
            .unwrap()
            .report
            .residual
            .max_mm
    };
    let (r3, r5, r9) = (residual_at(3), residual_at(5), residual_at(9));
    for (coarse, fine) in [(r3, r5), (r5, r9)] {
        let ratio = fine / coarse;
        assert!((0.2..0.3).contains(&ratio), "{fine} / {coarse} = {ratio}");
    }
}

fn refused(size: TableSize) -> ExportError {
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    match export::export(
        export::format_named("grid-csv").unwrap(),
        &request(&li, &inputs, size),
    ) {
        Err(e) => e,
        Ok(_) => panic!("{size:?} was accepted"),
    }
}

#[test]
fn table_sizes_beyond_the_format_limits_are_refused_saying_so() {
    let text = |size| refused(size).to_string();
    assert_eq!(
        text(TableSize::Points(102)),
        "102 points is more than a grid-csv table holds: at most 101 (volmap's limits for the generic grid)"
    );
    assert_eq!(
        text(TableSize::Points(1)),
        "1 points is fewer than a grid-csv table needs: at least 2"
    );
    assert_eq!(
        text(TableSize::Spacing(0.05)),
        "a spacing of 0.05 mm is below the smallest a grid-csv table takes: 0.1 mm (volmap's limits for the generic grid)"
    );
    assert_eq!(
        text(TableSize::Spacing(5.0)),
        "201 points along X (1000 mm at 5 mm) is more than a grid-csv table holds: at most 101 (volmap's limits for the generic grid)"
    );
    assert!(text(TableSize::Spacing(-2.0)).contains("it must be a positive number of mm"));
    assert!(matches!(
        refused(TableSize::Points(600)),
        ExportError::TooManyPoints { .. }
    ));
}

#[test]
fn a_machine_without_errors_has_nothing_to_hold() {
    let ideal = embedded::load("vmc-li2015").unwrap().without_errors();
    let inputs = Inputs::default();
    let e = export::export(
        export::format_named("grid-csv").unwrap(),
        &request(&ideal, &inputs, TableSize::Default),
    )
    .err()
    .expect("refused");
    assert!(
        e.to_string()
            .starts_with("grid-csv can hold none of this machine's errors"),
        "{e}"
    );
}

#[test]
fn an_unknown_format_lists_the_formats() {
    let e = export::format_named("sinumerik").err().unwrap().to_string();
    assert!(
        e.contains("`sinumerik` is not a format volmap exports (formats: grid-csv"),
        "{e}"
    );
}

#[test]
fn a_spacing_past_the_end_of_a_travel_covers_it() {
    let m = machine(&fixture("scale-x"));
    let inputs = Inputs::default();
    let exported = export::export(
        export::format_named("grid-csv").unwrap(),
        &request(&m, &inputs, TableSize::Spacing(150.0)),
    )
    .unwrap();
    let (axes, _) = read_grid(&exported.files[0].text);
    assert_eq!(axes[0], [0.0, 150.0, 300.0, 450.0]);
    assert_eq!(axes[1], [0.0, 150.0, 300.0]);
    assert_eq!(axes[2], [0.0, 150.0, 300.0]);
}
