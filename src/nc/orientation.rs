//! Five-axis tool orientation compensation (`Options::orientation_tolerance_rad`): the commanded
//! linear AND rotary positions whose real tool tip is the ideal tip of the programmed point and
//! whose real tool axis is its ideal axis as far as a bounded turn of the rotary axes reaches.
//!
//! Five equations — the tip (3) and the direction of the tool axis (2: its components across the
//! intended axis) — in five unknowns, X, Y, Z and the machine's two rotary axes. The tip is always
//! solved exactly (X, Y, Z to 1e-10 mm). The rotary correction (the turns of the two rotary axes
//! from their programmed positions) minimises the axis error plus `mu²` times its own square, by
//! Gauss-Newton steps with the real machine's Jacobian (central differences) from the programmed
//! command, X, Y, Z eliminated through the tip equations.
//!
//! Why damped and not clipped: near a singular pose (the tool axis along a rotary axis, B0 on a C
//! table) one rotary axis turns the tool axis by `sigma` rad per rad, `sigma -> 0`, and the full
//! correction of the error `e` across that direction turns it by `e / sigma`; its sign flips as a
//! move crosses the
//! singular pose. Clipping it to the bound would jump from +bound to -bound there (a swing of the
//! table between two pieces); damping with `mu² = eps² - sigma²` below `eps = |e| / bound` turns it
//! by `sigma e / eps²` instead, which fades to 0 at the singular pose, stays within the bound, and
//! meets the full correction `e / eps` at `sigma = eps`. Above `eps` nothing is damped and the axis
//! is solved to 1e-10 rad as before. What the bound leaves uncorrected is reported, never refused.
//! A block's points are solved so through `Block::compensate_pose` (`block`).

use std::f64::consts::PI;

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use super::error::{NcError, NcOption};
use super::kinematics::Kinematics;
use super::options::{Options, MAX_ROTARY_CORRECTION_DEG};
use super::program::modal::Directions;
use crate::model::{Command, Machine};
use crate::reference::tool_pose;

/// The steps stop when the real tip is this close to the ideal one (mm).
const TIP_TOLERANCE_MM: f64 = 1e-10;

/// Gauss-Newton stops when a step turns the rotary axes by less than this (rad), or turns the
/// tool axis by less than `AXIS_STEP_TOLERANCE_RAD` (at a singular pose the rotary axes may turn
/// it so little that the residual's rounding alone moves them by more).
const ROTARY_STEP_TOLERANCE_RAD: f64 = 1e-12;
const AXIS_STEP_TOLERANCE_RAD: f64 = 1e-14;

/// A point counts as held back by the bound where it leaves more than this of the tool axis's
/// error (rad): the full solve's own accuracy.
const LEFT_REPORTED_RAD: f64 = 1e-10;

/// Steps of the central differences: mm for linear axes, degrees for rotary ones.
const STEP: f64 = 1e-4;

/// The program axes (3..6) of the machine's rotary axes.
pub(super) fn rotary_axes(machine: &Machine) -> Vec<usize> {
    machine
        .chain
        .axes()
        .map(|l| l.index())
        .filter(|&d| d >= 3)
        .collect()
}

/// The orientation option checked against the machine: a positive angular tolerance and a
/// machine with exactly two rotary axes.
pub(super) fn check_options(machine: &Machine, options: &Options) -> Result<(), NcError> {
    let Some(tolerance) = options.orientation_tolerance_rad else {
        return Ok(());
    };
    if !(tolerance > 0.0 && tolerance <= 1.0) {
        return Err(NcError::Option {
            option: NcOption::AngularTolerance,
            value: crate::error::shown(tolerance),
            message: "it must be positive and at most 1 rad".into(),
        });
    }
    // Rotary words are written to 6 decimals of a degree at least (`write`): a tolerance below
    // their rounding cannot be met however the moves are split.
    let rotary_decimals = options.decimals.unwrap_or(0).max(6);
    let rounding_rad = (0.5 * 10f64.powi(-(rotary_decimals as i32))).to_radians();
    if tolerance < rounding_rad {
        return Err(NcError::Option {
            option: NcOption::AngularTolerance,
            value: crate::limits::number_words(tolerance),
            message: format!(
                "rotary words are written to {rotary_decimals} decimals of a degree, rounded by up to {rounding_rad:.2e} rad, more than this tolerance: no split of the moves meets it; give at least {rounding_rad:.2e} rad"
            ),
        });
    }
    let bound = options.max_rotary_correction_deg;
    if !(bound > 0.0 && bound <= MAX_ROTARY_CORRECTION_DEG) {
        return Err(NcError::Option {
            option: NcOption::MaxRotaryCorrection,
            value: crate::error::shown(bound),
            message: format!("it must be positive and at most {MAX_ROTARY_CORRECTION_DEG}°"),
        });
    }
    let rotary = rotary_axes(machine);
    if rotary.len() != 2 {
        return Err(NcError::Option {
            option: NcOption::Orientation,
            value: machine.name.clone(),
            message: format!(
                "the machine has {} rotary {}: the tool orientation is compensated on machines with two (five axes: tip 3 and axis direction 2 equations, X Y Z and two rotary unknowns)",
                rotary.len(),
                if rotary.len() == 1 { "axis" } else { "axes" }
            ),
        });
    }
    Ok(())
}

/// A pose could not be solved: the steps do not converge.
pub(super) struct NoConvergence;

/// A solved pose: the command, the angle left between its real tool axis and the intended one
/// (rad), the rotary correction (degrees, the two axes as a vector), and whether the bound held
/// the correction back (leaving more than the full solve's 1e-10 rad).
pub(super) struct Pose {
    pub(super) command: Command,
    pub(super) left_rad: f64,
    pub(super) rotary_correction_deg: f64,
    pub(super) bounded: bool,
}

/// The unit tool axis (spindle z) in the workpiece frame.
fn tool_axis(machine: &Machine, c: &Command) -> Vector3<f64> {
    tool_pose(machine, c).1.column(2).into_owned()
}

/// Two unit vectors across `axis`.
fn across(axis: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if axis.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = axis.cross(&helper).normalize();
    (e1, axis.cross(&e1))
}

impl Kinematics {
    /// The ideal tool axis at command `q`.
    pub(super) fn ideal_axis(&self, q: &Command) -> Vector3<f64> {
        tool_axis(self.twin(&Directions::default()).ideal(), q)
    }

    /// The angle (rad) between the real tool axis at command `c`, approaching in `directions`,
    /// and the ideal tool axis at command `q`.
    pub(super) fn axis_miss(&self, c: &Command, q: &Command, directions: &Directions) -> f64 {
        let real = tool_axis(self.twin(directions).real(), c);
        let ideal = self.ideal_axis(q);
        real.cross(&ideal).norm().atan2(real.dot(&ideal))
    }

    /// The command (linear and rotary) whose real tool tip, approaching in `directions`, is the
    /// ideal tip of `q` and whose real tool axis is the ideal axis of `q` as far as a rotary
    /// correction of at most `bound_deg` (degrees, the two rotary axes as a vector) reaches.
    pub(super) fn compensate_pose(
        &self,
        q: &Command,
        directions: &Directions,
        bound_deg: f64,
    ) -> Result<Pose, NoConvergence> {
        let rotary = rotary_axes(self.machine());
        let unknowns = [0, 1, 2, rotary[0], rotary[1]];
        let real = self.twin(directions).real();
        let tip = self.ideal_tip(q);
        let (e1, e2) = across(&self.ideal_axis(q));
        let residual = |c: &Command| -> SVector<f64, 5> {
            let (p, r) = tool_pose(real, c);
            let a = r.column(2);
            let d = p - tip;
            SVector::<f64, 5>::new(d.x, d.y, d.z, e1.dot(&a), e2.dot(&a))
        };
        let bound_rad = bound_deg.to_radians();
        let turned = |c: &Command| -> Vector2<f64> {
            Vector2::new(c[rotary[0]] - q[rotary[0]], c[rotary[1]] - q[rotary[1]])
                .map(f64::to_radians)
        };
        let mut c = *q;
        let mut damping: Option<f64> = None;
        let mut converged = false;
        for _ in 0..60 {
            let f = residual(&c);
            let mut jacobian = SMatrix::<f64, 5, 5>::zeros();
            for (k, &d) in unknowns.iter().enumerate() {
                let (mut plus, mut minus) = (c, c);
                plus[d] += STEP;
                minus[d] -= STEP;
                let per_unit = (residual(&plus) - residual(&minus)) / (2.0 * STEP);
                // Rotary columns per radian: the correction is solved and bounded in radians.
                let scale = if k >= 3 { 180.0 / PI } else { 1.0 };
                jacobian.set_column(k, &(per_unit * scale));
            }
            // The tip's equations solved for X, Y, Z leave the axis error `g + s dr` in the
            // rotary turn `dr` alone.
            let a: Matrix3<f64> = jacobian.fixed_view::<3, 3>(0, 0).into_owned();
            let b: SMatrix<f64, 3, 2> = jacobian.fixed_view::<3, 2>(0, 3).into_owned();
            let cx: SMatrix<f64, 2, 3> = jacobian.fixed_view::<2, 3>(3, 0).into_owned();
            let d: Matrix2<f64> = jacobian.fixed_view::<2, 2>(3, 3).into_owned();
            let a_inverse = a.try_inverse().ok_or(NoConvergence)?;
            let (f_tip, f_axis) = (
                f.fixed_rows::<3>(0).into_owned(),
                f.fixed_rows::<2>(3).into_owned(),
            );
            let s = d - cx * a_inverse * b;
            let g = f_axis - cx * a_inverse * f_tip;
            let svd = s.svd(true, true);
            let mu2 = *damping.get_or_insert_with(|| {
                // The error across the direction the rotary axes turn the tool axis least.
                let weakest = svd.singular_values.imin();
                let sigma = svd.singular_values[weakest];
                let error = svd.u.map_or(g.norm(), |u| u.column(weakest).dot(&g).abs());
                let eps = error / bound_rad;
                (eps * eps - sigma * sigma).max(0.0)
            });
            let v_t = svd.v_t.ok_or(NoConvergence)?;
            // (sᵀs + mu²)⁻¹ (sᵀg + mu² turned), through the singular values of s.
            let rhs = s.transpose() * g + turned(&c) * mu2;
            let mut in_v = v_t * rhs;
            for i in 0..2 {
                let sv = svd.singular_values[i];
                let denominator = sv * sv + mu2;
                in_v[i] = if denominator > 1e-24 {
                    in_v[i] / denominator
                } else {
                    0.0
                };
            }
            let dr = -(v_t.transpose() * in_v);
            let dx = -(a_inverse * (f_tip + b * dr));
            for k in 0..3 {
                c[k] += dx[k];
            }
            for k in 0..2 {
                c[rotary[k]] += dr[k].to_degrees();
            }
            let settled =
                dr.norm() < ROTARY_STEP_TOLERANCE_RAD || (s * dr).norm() < AXIS_STEP_TOLERANCE_RAD;
            if f_tip.norm() < TIP_TOLERANCE_MM && settled {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(NoConvergence);
        }
        let mut bounded = damping.is_some_and(|mu2| mu2 > 0.0);
        // Beyond the bound only where the steps' curvature carried it there: brought back onto
        // it (radially, so continuously), and X, Y, Z solved again for the tip there.
        let turn = turned(&c);
        if turn.norm() > bound_rad {
            bounded = true;
            let back = turn * (bound_rad / turn.norm());
            for k in 0..2 {
                c[rotary[k]] = q[rotary[k]] + back[k].to_degrees();
            }
            c = self.tip_at(&c, tip, directions).ok_or(NoConvergence)?;
        }
        if (self.twin(directions).real_tip(&c) - tip).norm() >= 10.0 * TIP_TOLERANCE_MM {
            return Err(NoConvergence);
        }
        let left_rad = self.axis_miss(&c, q, directions);
        Ok(Pose {
            command: c,
            left_rad,
            rotary_correction_deg: turned(&c).norm().to_degrees(),
            bounded: bounded && left_rad > LEFT_REPORTED_RAD,
        })
    }

    /// The command with the rotary positions of `c` whose real tip lands on `tip`.
    fn tip_at(&self, c: &Command, tip: Vector3<f64>, directions: &Directions) -> Option<Command> {
        let inverse = self
            .twin(&Directions::default())
            .ideal_jacobian(c)
            .try_inverse()?;
        self.twin(directions).real_command_for(tip, c, &inverse)
    }
}
