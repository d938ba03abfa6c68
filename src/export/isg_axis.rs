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

use super::fitting::{breakpoints, others, uniform, Fitting, AVERAGING_POINTS, LINEAR};
use super::format::{Control, Format, Layout, Limits, Nodes, Structure, Term, WrittenFile};
use super::nodes::{candidates, free_nodes};
use super::ExportError;
use crate::model::inputs::Approach;

#[path = "isg_axis_read.rs"]
pub mod read;

pub struct IsgAxis;

/// The unit of the lists' positions and values: 0.1 µm, mm.
pub const UNIT_MM: f64 = 1e-4;
/// P-COMP-00059, the LSEC memory volmap reserves (`kw_nr_max` must stay below it).
pub const LSEC_MAX_POINTS: usize = 1500;
/// P-COMP-00061, the plane compensation's memory (101 × 101 by default).
pub const PLANE_MAX_POINTS: usize = 10201;
pub const STARTUP: &str = "hochlauf_axis_comp.lis";

/// The list of linear axis `axis` (0, 1, 2).
pub fn list_name(axis: usize) -> String {
    format!(
        "achskw_{}.lis",
        LINEAR[axis].to_string().to_ascii_lowercase()
    )
}

/// One axis's lists as written: positions and values in 0.1 µm.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLists {
    pub axis: usize,
    /// LSEC set points and the errors there travelling + and (bilateral) −.
    pub setpoints: Vec<i64>,
    pub pos: Vec<i64>,
    pub neg: Option<Vec<i64>>,
    /// The plane: its masters (axes), start positions, intervals, and
    /// `correction[j][i]` (j along master 2, i along master 1).
    pub masters: [usize; 2],
    pub start: [i64; 2],
    pub interval: [i64; 2],
    pub correction: Vec<Vec<i64>>,
}

impl Format for IsgAxis {
    fn name(&self) -> &'static str {
        "isg-axis"
    }

    fn title(&self) -> &'static str {
        "ISG kernel / Beckhoff TwinCAT CNC axis compensation lists (leadscrew error and plane compensation)"
    }

    fn layout(&self) -> Layout {
        Layout::Folder
    }

    fn limits(&self) -> Limits {
        Limits {
            nodes: Nodes::Free,
            min_points: 2,
            max_points: 101,
            min_spacing_mm: 0.0,
            default_points: 21,
            source: "ISG plane compensation: 10201 points (101 x 101) by default, P-COMP-00061",
        }
    }

    fn structure(&self) -> Structure {
        Structure::AxisAndPlane
    }

    fn holds(&self) -> &'static str {
        "the leadscrew error compensation holds each linear axis's positioning error along its own travel (per direction where bilateral), the plane compensation its correction as a function of the other two axes (straightness, squareness, angular errors' effects at the tool length, their interaction); not a dependence on its own position together with another's, not the tool orientation; linear between the written points"
    }

    fn uses_direction(&self) -> bool {
        true
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([self.limits().default_points; 3]);
        let mut lists = Vec::new();
        for axis in 0..3 {
            lists.push(fit_lists(fitting, axis, points, spacing_mm)?);
        }
        let mut files: Vec<WrittenFile> = lists
            .iter()
            .map(|l| WrittenFile {
                name: list_name(l.axis),
                text: read::list_text(fitting, l),
            })
            .collect();
        files.push(WrittenFile {
            name: STARTUP.into(),
            text: read::startup_text(fitting),
        });
        Ok(files)
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(read::AxisControl {
            lists: read::read_lists(files)?,
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
