//! Ballbar diagnostics: the figures a ballbar user reads off a circular test, from the radial
//! deviation `dr(θ)` of one run (predicted or measured), by linear least squares on the shapes
//! each error draws on a circle of radius `r` about `(c_u, c_v)` in the plane of axes `u`, `v`:
//!
//! | term | shape in `dr(θ)` | figure |
//! |---|---|---|
//! | ballbar length, centring | `ρ + a cos θ + b sin θ` | (taken out) |
//! | squareness `α` (angle between +u and +v minus 90°) | `−α (r/2) sin 2θ` | `squareness_urad` |
//! | scales `k_u`, `k_v` | `(k_u − k_v)(r/2) cos 2θ` (+ a constant) | `scale_mismatch_ppm` = `k_u − k_v` |
//! | backlash `β_u` (↑ minus ↓ position error of `u`) | `(β_u/2) s_u(θ) cos θ`, `s_u` = ±1 as `u` moves ± | `backlash_um` |
//! | cyclic error of pitch `p` along `u` | `(A sin(2πx/p) + B cos(2πx/p)) cos θ`, `x = c_u + r cos θ` | `cyclic_um` = `√(A² + B²)` |
//!
//! (and the same with `sin θ` for `v`). At the points where an axis turns (the first axis at 0°
//! and 180°, the second at 90° and 270°) each run gets a reversal step: the jump of `dr` between
//! the samples on either side, less the jump of every fitted term but that axis's backlash, and a
//! spike: the largest residual of the whole fit within 10° of the point (a servo's transient,
//! which the model does not have).

use nalgebra::{DMatrix, DVector};

use super::direction_of;
use crate::model::inputs::Approach;

/// The figures of one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Diagnostics {
    /// The angle between the plane's first and second axes' motions minus 90°, µrad.
    pub squareness_urad: f64,
    /// The first axis's scale error minus the second's, µm/m.
    pub scale_mismatch_ppm: f64,
    /// The same over the test's radius, µm.
    pub scale_mismatch_um: f64,
    /// Each axis's backlash: its position error moving + minus moving −, µm.
    pub backlash_um: [f64; 2],
    /// Where an axis turns: the step and the spike, µm.
    pub reversals: Vec<Reversal>,
    /// The amplitude of each axis's cyclic error of the given pitch, µm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cyclic_um: Option<[f64; 2]>,
    /// Whether each cyclic error stands above [`Diagnostics::detection_um`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cyclic_detected: Option<[bool; 2]>,
    /// RMS of what the figures leave of the radial deviation, µm.
    pub residual_um: f64,
    /// What a local feature (a reversal's step or spike, a cyclic error) must exceed to be
    /// reported as found: [`DETECTION_FACTOR`] times the RMS the figures leave, and at least
    /// [`DETECTION_FLOOR_UM`], µm.
    pub detection_um: f64,
}

/// A reversal or cyclic error is found when its size exceeds this many times the RMS of what
/// the figures leave: below, the run's other errors could make it (a model without reversal
/// errors shows "spikes" of the fit's own leftovers).
pub const DETECTION_FACTOR: f64 = 3.0;
/// And at least this, µm: a fit that leaves nothing (a model whose errors the figures hold
/// exactly) still leaves the arithmetic's nanometres, which are no finding.
pub const DETECTION_FLOOR_UM: f64 = 0.01;

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Reversal {
    pub axis: char,
    pub angle_deg: f64,
    pub step_um: f64,
    pub spike_um: f64,
    /// Whether the step and the spike stand above [`Diagnostics::detection_um`].
    pub step_detected: bool,
    pub spike_detected: bool,
}

/// A circle's diagnostics, predicted and (where measured) measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BallbarReport {
    pub axes: [char; 2],
    pub radius_mm: f64,
    pub pitch_mm: Option<f64>,
    pub predicted: Diagnostics,
    pub measured: Option<Diagnostics>,
}

/// The circle a run went round: radius, centre on the plane's axes (mm), sense (+1
/// counter-clockwise) and the cyclic errors' pitch.
#[derive(Debug, Clone, Copy)]
pub struct Circle {
    /// The plane's first and second axes.
    pub axes: [char; 2],
    pub radius_mm: f64,
    pub centre_mm: [f64; 2],
    pub sense: f64,
    pub pitch_mm: Option<f64>,
}

/// The index of the first axis's backlash term (the second's follows).
const BACKLASH_TERMS: usize = 5;

/// `+1` for an axis moving `+` there, `−1` for `−`.
fn sign(a: Approach) -> f64 {
    match a {
        Approach::Positive => 1.0,
        Approach::Negative => -1.0,
    }
}

/// The basis functions at angle `t_deg`, in the order of the table above.
fn basis(t_deg: f64, circle: &Circle) -> Vec<f64> {
    let r = circle.radius_mm;
    let (s, c) = t_deg.to_radians().sin_cos();
    let (s2, c2) = (2.0 * t_deg).to_radians().sin_cos();
    let (du, dv) = circle_directions(t_deg, circle.sense);
    let mut row = vec![
        1.0,
        c,
        s,
        -0.5 * r * s2,
        0.5 * r * c2,
        0.5 * sign(du) * c,
        0.5 * sign(dv) * s,
    ];
    if let Some(p) = circle.pitch_mm {
        let x = circle.centre_mm[0] + r * c;
        let y = circle.centre_mm[1] + r * s;
        let (sx, cx) = (std::f64::consts::TAU * x / p).sin_cos();
        let (sy, cy) = (std::f64::consts::TAU * y / p).sin_cos();
        row.extend([sx * c, cx * c, sy * s, cy * s]);
    }
    row
}

/// The diagnostics of one run: `angles_deg` in the order of the run, `radial_mm` the radial
/// deviation there. `None` where the angles cannot separate the terms (too few, or not around
/// the circle).
pub fn diagnose(angles_deg: &[f64], radial_mm: &[f64], circle: &Circle) -> Option<Diagnostics> {
    let rows: Vec<Vec<f64>> = angles_deg.iter().map(|&t| basis(t, circle)).collect();
    let k = rows.first()?.len();
    if rows.len() <= k {
        return None;
    }
    let design = DMatrix::from_fn(rows.len(), k, |i, j| rows[i][j]);
    let observed = DVector::from_column_slice(radial_mm);
    let svd = design.clone().svd(true, true);
    let values = &svd.singular_values;
    if values.min() < 1e-9 * values.max() {
        return None;
    }
    let x = svd.solve(&observed, 1e-12).ok()?;
    let fitted = &design * &x;
    let residual = &observed - &fitted;
    let n = angles_deg.len();
    let residual_um = (residual.norm_squared() / n as f64).sqrt() * 1e3;
    let detection_um = (DETECTION_FACTOR * residual_um).max(DETECTION_FLOOR_UM);
    let mut reversals = Vec::new();
    for (axis, turning) in [(0, [0.0, 180.0]), (1, [90.0, 270.0])] {
        // Everything the fit explains but the turning axis's own backlash.
        let mut others = x.clone();
        others[BACKLASH_TERMS + axis] = 0.0;
        let smooth = &design * &others;
        for angle in turning {
            // The consecutive pair of the run (wrapping round) whose sweep passes the point: the
            // sample at the point itself still belongs to the side the axis arrived from.
            let crossing = (0..n).find(|&i| {
                let (a, b) = (angles_deg[i], angles_deg[(i + 1) % n]);
                let swept = (circle.sense * (b - a)).rem_euclid(360.0);
                let to_point = (circle.sense * (angle - a)).rem_euclid(360.0);
                swept > 0.0 && swept < 180.0 && to_point < swept
            });
            let Some(i) = crossing else { continue };
            let j = (i + 1) % n;
            let step = (radial_mm[j] - radial_mm[i]) - (smooth[j] - smooth[i]);
            let spike = (0..n)
                .filter(|&m| {
                    let d = (angles_deg[m] - angle).rem_euclid(360.0);
                    d.min(360.0 - d) <= 10.0
                })
                .map(|m| residual[m])
                .fold(0.0, |acc: f64, v| if v.abs() > acc.abs() { v } else { acc });
            reversals.push(Reversal {
                axis: circle.axes[axis],
                angle_deg: angle,
                step_um: step * 1e3,
                spike_um: spike * 1e3,
                step_detected: (step * 1e3).abs() > detection_um,
                spike_detected: (spike * 1e3).abs() > detection_um,
            });
        }
    }
    let cyclic = circle
        .pitch_mm
        .map(|_| [x[7].hypot(x[8]) * 1e3, x[9].hypot(x[10]) * 1e3]);
    Some(Diagnostics {
        squareness_urad: x[3] * 1e6,
        scale_mismatch_ppm: x[4] * 1e6,
        scale_mismatch_um: x[4] * circle.radius_mm * 1e3,
        backlash_um: [x[5] * 1e3, x[6] * 1e3],
        reversals,
        cyclic_um: cyclic,
        cyclic_detected: cyclic.map(|c| c.map(|a| a > detection_um)),
        residual_um,
        detection_um,
    })
}

/// The directions of the plane's first and second axes at angle `t_deg` of a circle run in
/// `sense` (+1 counter-clockwise): the signs of the velocity `sense·(−sin θ, cos θ)`; at a
/// turning point (an axis at the end of its diameter, velocity zero) the axis keeps the
/// direction it arrived in, towards that end: `+` at θ = 0° for the first axis and at 90° for
/// the second, `−` at 180° and 270°, whichever the sense.
pub fn circle_directions(t_deg: f64, sense: f64) -> (Approach, Approach) {
    let (s, c) = t_deg.to_radians().sin_cos();
    // sin and cos of a multiple of 90° in f64 leave a residue near 1e-16.
    let zero = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x };
    (
        direction_of(-sense * zero(s), c),
        direction_of(sense * zero(c), s),
    )
}
