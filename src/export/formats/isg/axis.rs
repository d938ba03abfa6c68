//! `isg-axis`: the axis compensation lists of the ISG kernel (Beckhoff TwinCAT 3 CNC, TF5200
//! "Axis compensation"), for controls without the volumetric option: one compensation value
//! list per linear axis (`achskw_x.lis` …) with
//! - the leadscrew error compensation (`kw.ssfk.*`, LSEC): the axis's ERROR at its set point
//!   (actual − nominal, as the vendor's example computes it), at free positions
//!   (`interval 0`, `table[i].setpoint`), per direction where the machine's correction differs by
//!   direction (`bilateral 1`: `pos` and `neg` at the same positions); the control subtracts it;
//! - the plane compensation (`kw.crosscomp2.*`): the CORRECTION added to the axis's set point as
//!   a function of the command positions of the other two axes (master 1, master 2), on a
//!   rectangular grid, bilinear between its points, the margin's values outside.
//!
//! Values and positions are whole 0.1 µm (`unit 1`). Between the LSEC positions the control
//! interpolates linearly and holds the end values outside. The LSEC table of axis `k` holds the
//! least-squares fit of its correction along its own travel (the grand mean with it); the plane
//! table the mean of the rest over the axis's own travel at each point of the other two: so the
//! pair holds `d_k ≈ f(t_k) + g(t_i, t_j)`: straightness, squareness and the angular errors'
//! effects on `k` along the other axes, with their interaction, not a dependence of `k`'s
//! correction on its own position together with another's.

use super::axis_lists::{
    list_name, AxisControl, AxisLists, LSEC_MAX_POINTS, PLANE_MAX_POINTS, STARTUP, UNIT_MM,
};
use super::axis_read::read_lists;
use crate::export::error::ExportError;
use crate::export::fitting::{
    breakpoints, others, uniform, Fitting, Structure, Term, AVERAGING_POINTS, LINEAR,
};
use crate::export::format::{Control, Format, Layout, Limits, Nodes, Spec, WrittenFile};
use crate::export::nodes::{candidates, free_nodes};
use crate::model::inputs::Approach;

pub struct IsgAxis;

const SPEC: Spec = Spec {
    name: "isg-axis",
    title: "ISG kernel / Beckhoff TwinCAT CNC axis compensation lists (leadscrew error and plane compensation)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Free,
        min_points: 2,
        max_points: 101,
        min_spacing_mm: 0.0,
        default_points: 21,
        source: "ISG plane compensation: 10201 points (101 x 101) by default, P-COMP-00061",
    },
    structure: Structure::AxisAndPlane,
    holds: "the leadscrew error compensation holds each linear axis's positioning error along its own travel (per direction where bilateral), the plane compensation its correction as a function of the other two axes (straightness, squareness, angular errors' effects at the tool length, their interaction); not a dependence on its own position together with another's, not the tool orientation; linear between the written points",
    uses_direction: true,
};

impl Format for IsgAxis {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([SPEC.limits.default_points; 3]);
        let mut lists = Vec::new();
        for axis in 0..3 {
            lists.push(fit_lists(fitting, axis, points, spacing_mm)?);
        }
        let mut files: Vec<WrittenFile> = lists
            .iter()
            .map(|l| WrittenFile {
                name: list_name(l.axis),
                text: list_text(fitting, l),
            })
            .collect();
        files.push(WrittenFile {
            name: STARTUP.into(),
            text: startup_text(fitting),
        });
        Ok(files)
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(AxisControl {
            lists: read_lists(files)?,
        }))
    }
}

fn units(mm: f64) -> i64 {
    (mm / UNIT_MM).round() as i64
}

/// Fits the LSEC and plane tables of `axis`.
fn fit_lists(
    fitting: &Fitting,
    axis: usize,
    points: [usize; 3],
    spacing_mm: Option<f64>,
) -> Result<AxisLists, ExportError> {
    let [lo, hi] = fitting.ranges[axis];
    let forward = fitting.field_approaching(axis, Approach::Positive)?;
    let backward = fitting.field_approaching(axis, Approach::Negative)?;
    let mut terms = [[Term::None; 3]; 3];
    terms[axis][axis] = Term::Curve;
    let own = |field, at: Vec<f64>| -> Result<Vec<f64>, ExportError> {
        let mut positions: [Vec<f64>; 3] = Default::default();
        positions[axis] = at;
        Ok(fitting.additive(field, terms, positions)?.table(axis, axis))
    };
    // The LSEC positions: free, the same both ways.
    let setpoints_mm: Vec<f64> = match spacing_mm {
        Some(s) => {
            let n = ((hi - lo) / s - 1e-9).ceil().max(1.0) as usize + 1;
            (0..n).map(|k| lo + k as f64 * s).collect()
        }
        None => {
            let n = points[axis].max(2);
            let m = (4 * (n - 1) + 1).clamp(101, 401);
            let q = candidates(lo, hi, m, &breakpoints(fitting.machine, LINEAR[axis]));
            let curves = [own(&forward, q.clone())?, own(&backward, q.clone())?];
            let refs: Vec<&[f64]> = curves.iter().map(Vec::as_slice).collect();
            free_nodes(&q, &refs, n, 0.0, 0.0)
                .into_iter()
                .map(|k| q[k])
                .collect()
        }
    };
    let setpoints: Vec<i64> = setpoints_mm.iter().map(|&x| units(x)).collect();
    let at: Vec<f64> = setpoints.iter().map(|&u| u as f64 * UNIT_MM).collect();
    let mut positions: [Vec<f64>; 3] = Default::default();
    positions[axis] = at.clone();
    let fit = fitting.additive(&forward, terms, positions)?;
    // The table holds the error: the correction with its sign reversed.
    let error = |c: Vec<f64>| -> Vec<i64> { c.into_iter().map(|v| units(-v)).collect() };
    let pos = error(fit.table(axis, axis));
    let neg = error(own(&backward, at)?);
    let neg = (neg != pos).then_some(neg);
    // The grand mean, which the LSEC table carries.
    let grand = fit.constant[axis];
    // The plane over the other two axes: the mean correction over the axis's own travel at each
    // grid point, less the grand mean the LSEC table carries.
    let (m1, m2) = others(axis);
    let grid = |d: usize| -> (i64, i64, usize) {
        let [a, b] = fitting.ranges[d];
        let n = match spacing_mm {
            Some(s) => ((b - a) / s - 1e-9).ceil().max(1.0) as usize + 1,
            None => points[d].max(2),
        };
        let step = spacing_mm.unwrap_or((b - a) / (n - 1) as f64);
        (units(a), units(step).max(1), n)
    };
    let (g1, g2) = (grid(m1), grid(m2));
    let own_travel = uniform(lo, hi, AVERAGING_POINTS);
    let mut targets = Vec::new();
    for j in 0..g2.2 {
        for i in 0..g1.2 {
            for &q in &own_travel {
                let mut t = [0.0; 3];
                t[axis] = q;
                t[m1] = (g1.0 + i as i64 * g1.1) as f64 * UNIT_MM;
                t[m2] = (g2.0 + j as i64 * g2.1) as f64 * UNIT_MM;
                targets.push(t);
            }
        }
    }
    let d = forward.corrections(&targets)?;
    let means: Vec<f64> = d
        .chunks(own_travel.len())
        .map(|c| c.iter().map(|v| v[axis]).sum::<f64>() / c.len() as f64)
        .collect();
    let correction: Vec<Vec<i64>> = means
        .chunks(g1.2)
        .map(|row| row.iter().map(|v| units(v - grand)).collect())
        .collect();
    Ok(AxisLists {
        axis,
        setpoints,
        pos,
        neg,
        masters: [m1, m2],
        start: [g1.0, g2.0],
        interval: [g1.1, g2.1],
        correction,
    })
}

/// Where the start-up lines say the lists lie on the control.
const FOLDER: &str = r"C:\axiscomp\";

fn line(key: &str, value: impl std::fmt::Display) -> String {
    format!("{key:<40} {value}\n")
}

/// One axis's compensation value list.
fn list_text(fitting: &Fitting, l: &AxisLists) -> String {
    let letter = LINEAR[l.axis];
    let mut text = String::new();
    for h in &fitting.header {
        text += &format!("# {h}\n");
    }
    text += &format!(
        "# volmap isg-axis: compensation value list of axis {letter} (logical axis {}), positions and values in 0.1 um\n",
        l.axis + 1
    );
    text += &line("kopf.achs_nr", l.axis + 1);
    text += &line("kopf.log_achs_name", letter);
    text += &format!("# leadscrew error compensation: the ERROR of {letter} at its set point (actual - nominal); the control subtracts it\n");
    text += &line("kw.ssfk.unit", 1);
    text += &line("kw.ssfk.max_points", LSEC_MAX_POINTS);
    text += &line("kw.ssfk.interval", 0);
    text += &line("kw.ssfk.kw_nr_max", l.setpoints.len());
    text += &line("kw.ssfk.bilateral", u8::from(l.neg.is_some()));
    text += &line("kw.ssfk.modulo", 0);
    for (i, s) in l.setpoints.iter().enumerate() {
        text += &line(&format!("kw.ssfk.table[{i}].setpoint"), s);
        text += &line(&format!("kw.ssfk.table[{i}].pos"), l.pos[i]);
        if let Some(neg) = &l.neg {
            text += &line(&format!("kw.ssfk.table[{i}].neg"), neg[i]);
        }
    }
    let [m1, m2] = l.masters;
    text += &format!(
        "# plane compensation: the CORRECTION added to the set point of {letter} over {} (master 1) and {} (master 2)\n",
        LINEAR[m1], LINEAR[m2]
    );
    text += &line("kw.crosscomp2.unit", 1);
    text += &line("kw.crosscomp2.grid", "RECTANGULAR");
    text += &line("kw.crosscomp2.interval1", l.interval[0]);
    text += &line("kw.crosscomp2.interval2", l.interval[1]);
    text += &line("kw.crosscomp2.start_position_master1", l.start[0]);
    text += &line("kw.crosscomp2.start_position_master2", l.start[1]);
    text += &line(
        "kw.crosscomp2.last_index_master1",
        l.correction[0].len() - 1,
    );
    text += &line("kw.crosscomp2.last_index_master2", l.correction.len() - 1);
    text += &line("kw.crosscomp2.master1_ax_nr", m1 + 1);
    text += &line("kw.crosscomp2.master2_ax_nr", m2 + 1);
    text += &line("kw.crosscomp2.n_cycles", 0);
    text += &line("kw.crosscomp2.max_points", PLANE_MAX_POINTS);
    for (j, row) in l.correction.iter().enumerate() {
        for (i, v) in row.iter().enumerate() {
            text += &line(&format!("kw.crosscomp2.table[{j}][{i}].correction"), v);
        }
    }
    text + "End\n"
}

/// The lines of the start-up list that name the lists.
fn startup_text(fitting: &Fitting) -> String {
    let mut text = String::new();
    for h in &fitting.header {
        text += &format!("# {h}\n");
    }
    text +=
        "# volmap isg-axis: the compensation value lists in the start-up list (hochlauf.lis);\n";
    text += "# activate them in each axis's parameters: lr_param.ssfk 1 (P-AXIS-00175), lr_param.crosscomp2 1 (P-AXIS-00174)\n";
    text += &line("zahl_kw", 3);
    for axis in 0..3 {
        text += &line(
            &format!("achs_kw[{axis}]"),
            format!("{FOLDER}{}", list_name(axis)),
        );
        text += &line(&format!("achs_kw_log_ax_nr[{axis}]"), axis + 1);
    }
    text
}
