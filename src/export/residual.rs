//! What a table leaves: the control's command run through the model over a dense grid of the
//! workspace, against the error before; and which of the machine's errors a format's structure
//! cannot hold.
//!
//! Residual at target `t`: `|p_real(c_ctrl(t)) − p_ideal(t)|`, workpiece frame, with
//! `c_ctrl(t)` the command the control moves to with the tables as written ([`Control`]);
//! before: `|VE(t)| = |p_real(t) − p_ideal(t)|`.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::error::ExportError;
use super::fitting::{structural_remainder, uniform, Field, Structure, AVERAGING_POINTS};
use super::format::Control;
use crate::model::inputs::Approach;
use crate::model::perturbation::SPINDLE_NAMES;
use crate::model::{Command, Machine};

/// The fewest and the most points per linear axis of the evaluation grid by default.
pub const MIN_EVALUATION_POINTS: usize = 41;
pub const MAX_EVALUATION_POINTS: usize = 81;

/// The most points per linear axis a residual grid may be asked for (8 million points, fifteen
/// times the densest default): checked before the grid is made.
pub const MAX_RESIDUAL_GRID_POINTS: usize = 201;

/// The grid the residual is measured on: `points` per linear axis over the travels.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvaluationGrid {
    pub points: [usize; 3],
    pub spacing_mm: [f64; 3],
}

impl EvaluationGrid {
    /// `points` per axis over `ranges`.
    pub fn new(points: [usize; 3], ranges: &[[f64; 2]; 3]) -> EvaluationGrid {
        EvaluationGrid {
            points,
            spacing_mm: std::array::from_fn(|d| {
                if points[d] > 1 {
                    (ranges[d][1] - ranges[d][0]) / (points[d] - 1) as f64
                } else {
                    0.0
                }
            }),
        }
    }

    /// The default for tables of at most `table_points` nodes along an axis: the nodes and the
    /// midpoints between them (`2·(n − 1) + 1`), at least [`MIN_EVALUATION_POINTS`] and at most
    /// [`MAX_EVALUATION_POINTS`] per axis.
    pub fn default_points(table_points: usize) -> usize {
        (2 * table_points.saturating_sub(1) + 1).clamp(MIN_EVALUATION_POINTS, MAX_EVALUATION_POINTS)
    }

    pub fn total(&self) -> usize {
        self.points.iter().product()
    }
}

/// Largest and RMS of a distance over the grid, and where the largest is (X, Y, Z).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Figures {
    pub max_mm: f64,
    pub rms_mm: f64,
    pub at_mm: [f64; 3],
}

impl Figures {
    fn of(values: &[f64], targets: &[[f64; 3]]) -> Figures {
        let mut max = 0.0;
        let mut at = targets.first().copied().unwrap_or_default();
        let mut sum = 0.0;
        for (v, t) in values.iter().zip(targets) {
            sum += v * v;
            if *v > max {
                max = *v;
                at = *t;
            }
        }
        Figures {
            max_mm: max,
            rms_mm: (sum / values.len().max(1) as f64).sqrt(),
            at_mm: at,
        }
    }
}

/// The residual and the error before over `grid`, and the largest correction the control
/// applied (zero: the tables correct nothing).
pub struct Measured {
    pub before: Figures,
    pub residual: Figures,
    /// The same less their mean vector over the grid: what is left after a work offset (a
    /// touch-off) takes up the constant part.
    pub before_offset_free: Figures,
    pub residual_offset_free: Figures,
    pub largest_applied_mm: f64,
}

/// Every target of `grid` over `ranges`.
pub fn targets(grid: &EvaluationGrid, ranges: &[[f64; 2]; 3]) -> Vec<[f64; 3]> {
    let axes: Vec<Vec<f64>> = (0..3)
        .map(|d| uniform(ranges[d][0], ranges[d][1], grid.points[d]))
        .collect();
    let mut t = Vec::with_capacity(grid.total());
    for &z in &axes[2] {
        for &y in &axes[1] {
            for &x in &axes[0] {
                t.push([x, y, z]);
            }
        }
    }
    t
}

/// At one target: the error before, the residual (vectors, mm) and the size of the correction
/// the control applied.
type PointFigures = (Vector3<f64>, Vector3<f64>, f64);

/// The residual of `control` on the machine of `field` (at the inputs asked, axes approaching
/// in `approach`) over `grid`.
pub fn measure(
    field: &Field,
    control: &dyn Control,
    approach: &[Approach; 6],
    grid: &EvaluationGrid,
    ranges: &[[f64; 2]; 3],
) -> Measured {
    let targets = targets(grid, ranges);
    let twin = field.twin();
    let per_point: Vec<PointFigures> = targets
        .par_iter()
        .map(|&xyz| {
            let t: Command = field.command(xyz);
            let ideal = twin.ideal_tip(&t);
            let before = twin.real_tip(&t) - ideal;
            let c = control.command(&t, approach);
            let after = twin.real_tip(&c) - ideal;
            let applied =
                ((c[0] - t[0]).powi(2) + (c[1] - t[1]).powi(2) + (c[2] - t[2]).powi(2)).sqrt();
            (before, after, applied)
        })
        .collect();
    let figures = |pick: fn(&PointFigures) -> Vector3<f64>| {
        let vectors: Vec<Vector3<f64>> = per_point.iter().map(pick).collect();
        let mean = vectors.iter().sum::<Vector3<f64>>() / vectors.len().max(1) as f64;
        let plain: Vec<f64> = vectors.iter().map(|v| v.norm()).collect();
        let offset_free: Vec<f64> = vectors.iter().map(|v| (v - mean).norm()).collect();
        (
            Figures::of(&plain, &targets),
            Figures::of(&offset_free, &targets),
        )
    };
    let (before, before_offset_free) = figures(|p| p.0);
    let (residual, residual_offset_free) = figures(|p| p.1);
    Measured {
        before,
        residual,
        before_offset_free,
        residual_offset_free,
        largest_applied_mm: per_point.iter().map(|p| p.2).fold(0.0, f64::max),
    }
}

/// One error of the machine that a format's structure cannot hold (all of it or a part).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NotHeld {
    /// The error's key: `EC0Y`, `EBX`, `EZS`.
    pub error: String,
    /// The largest |VE| it causes alone over the averaging grid, mm.
    pub alone_mm: f64,
    /// The largest part of its correction no table of the format holds, mm.
    pub not_held_mm: f64,
}

/// Remainders below this are the Newton solve's and arithmetic's, not the structure's, mm.
const NEGLIGIBLE_MM: f64 = 1e-6;

/// Each error of `machine` (at its inputs) alone on the ideal machine: how much of its
/// correction `structure` cannot hold at any table size, over a grid of
/// [`AVERAGING_POINTS`] per axis at the pose; those above a nanometre, the largest first.
pub fn not_held(
    machine: &Machine,
    structure: Structure,
    pose: Command,
    ranges: &[[f64; 2]; 3],
) -> Result<Vec<NotHeld>, ExportError> {
    if structure == Structure::Grid {
        return Ok(Vec::new());
    }
    let grid: [Vec<f64>; 3] =
        std::array::from_fn(|d| uniform(ranges[d][0], ranges[d][1], AVERAGING_POINTS));
    let mut found = Vec::new();
    for (key, alone) in single_errors(machine) {
        let field = Field::new(alone, pose)?;
        let not_held_mm = structural_remainder(&field, structure, &grid)?;
        if not_held_mm < NEGLIGIBLE_MM {
            continue;
        }
        let twin = field.twin();
        let mut alone_mm: f64 = 0.0;
        for &x in &grid[0] {
            for &y in &grid[1] {
                for &z in &grid[2] {
                    let ve = twin.deviation(&field.command([x, y, z])).volumetric_mm;
                    alone_mm = alone_mm.max(ve.norm());
                }
            }
        }
        found.push(NotHeld {
            error: key,
            alone_mm,
            not_held_mm,
        });
    }
    found.sort_by(|a, b| b.not_held_mm.total_cmp(&a.not_held_mm));
    Ok(found)
}

/// Every non-zero error value of `machine` (at its inputs), each alone on the ideal machine.
fn single_errors(machine: &Machine) -> Vec<(String, Machine)> {
    let ideal = machine.without_errors();
    let mut out = Vec::new();
    for axis in &machine.axes {
        for n in 0..6 {
            if let Some(f) = axis.components[n].as_ref().filter(|f| !f.is_zero()) {
                let mut m = ideal.clone();
                if let Some(a) = m.axis_mut(axis.letter) {
                    a.components[n] = Some(f.clone());
                }
                out.push((axis.component_key(n), m));
            }
            if axis.location[n] != 0.0 {
                let mut m = ideal.clone();
                if let Some(a) = m.axis_mut(axis.letter) {
                    a.location[n] = axis.location[n];
                }
                out.push((axis.location_key(n), m));
            }
        }
    }
    for (n, name) in SPINDLE_NAMES.iter().enumerate() {
        if machine.spindle[n] != 0.0 {
            let mut m = ideal.clone();
            m.spindle[n] = machine.spindle[n];
            out.push((name.to_string(), m));
        }
    }
    out
}
