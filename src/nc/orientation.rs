//! Five-axis tool orientation compensation (`Options::orientation_tolerance_rad`): the commanded
//! linear AND rotary positions whose real tool tip and real tool axis match the ideal tip and
//! axis of the programmed point.
//!
//! Five equations — the tip (3) and the direction of the tool axis (2: its components across the
//! intended axis) — in five unknowns, X, Y, Z and the machine's two rotary axes, solved by Newton
//! steps with the real machine's Jacobian (central differences) from the programmed command until
//! the tip agrees to 1e-10 mm and the axis to 1e-10 rad. The tool axis is the spindle frame's z
//! (docs/model.md: the tool lies along it). Where the two rotary axes cannot turn the tool axis
//! in both directions across it (the tool axis along a rotary axis, or the rotary axes parallel)
//! the pose is singular and the point cannot be compensated. A block's points are solved so
//! through `Block::compensate_pose` (`block`).

use nalgebra::{Matrix2, SMatrix, SVector, Vector3};

use super::error::{NcError, NcOption};
use super::kinematics::Kinematics;
use super::options::Options;
use super::program::modal::{Directions, AXIS_LETTERS};
use crate::model::{Command, Machine};
use crate::reference::tool_pose;

/// Newton steps stop when the real tip is this close to the ideal one (mm) and the real tool
/// axis this close in angle to the ideal one (rad).
const TIP_TOLERANCE_MM: f64 = 1e-10;
const AXIS_TOLERANCE_RAD: f64 = 1e-10;

/// A pose is singular where the smallest singular value of the tool axis's derivative in the two
/// rotary axes (rad per rad) is below this (the tool within about 0.6° of a rotary axis): the
/// correction would turn the rotary axes by more than a hundred times the orientation error, and
/// exactly along the rotary axis no turn corrects it.
const SINGULAR: f64 = 1e-2;

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

/// Why a pose could not be solved.
pub(super) enum PoseFailure {
    /// The tool axis cannot be turned across itself by the rotary axes here.
    Singular(String),
    NoConvergence,
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

    /// The command (linear and rotary) whose real tool tip and tool axis, approaching in
    /// `directions`, are the ideal tip and axis of `q`.
    pub(super) fn compensate_pose(
        &self,
        q: &Command,
        directions: &Directions,
    ) -> Result<Command, PoseFailure> {
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
        let mut c = *q;
        for iteration in 0..50 {
            let f = residual(&c);
            let tip_miss = f.fixed_rows::<3>(0).norm();
            let axis_miss = f.fixed_rows::<2>(3).norm();
            if tip_miss < TIP_TOLERANCE_MM && axis_miss < AXIS_TOLERANCE_RAD {
                return Ok(c);
            }
            let mut jacobian = SMatrix::<f64, 5, 5>::zeros();
            for (k, &d) in unknowns.iter().enumerate() {
                let (mut plus, mut minus) = (c, c);
                plus[d] += STEP;
                minus[d] -= STEP;
                jacobian.set_column(k, &((residual(&plus) - residual(&minus)) / (2.0 * STEP)));
            }
            if iteration == 0 {
                check_singular(&jacobian, &rotary, q)?;
            }
            let step = jacobian.lu().solve(&f).ok_or(PoseFailure::NoConvergence)?;
            for (k, &d) in unknowns.iter().enumerate() {
                c[d] -= step[k];
            }
        }
        Err(PoseFailure::NoConvergence)
    }
}

/// A singular pose: the tool axis's derivative in the rotary axes (rad per rad) nearly loses
/// rank.
fn check_singular(
    jacobian: &SMatrix<f64, 5, 5>,
    rotary: &[usize],
    q: &Command,
) -> Result<(), PoseFailure> {
    let per_rad = 180.0 / std::f64::consts::PI;
    let turns: Matrix2<f64> = jacobian.fixed_view::<2, 2>(3, 3) * per_rad;
    let smallest = turns
        .singular_values()
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    if smallest >= SINGULAR {
        return Ok(());
    }
    // The rotary axis that turns the tool axis least is the one it lies along.
    let (a, b) = (turns.column(0).norm(), turns.column(1).norm());
    let along = if a <= b { rotary[0] } else { rotary[1] };
    let (r0, r1) = (AXIS_LETTERS[rotary[0]], AXIS_LETTERS[rotary[1]]);
    Err(PoseFailure::Singular(format!(
        "singular pose at {r0}={:.4} {r1}={:.4} (machine): the tool axis lies along the {} axis (or the rotary axes are parallel), so no turn of {r0} and {r1} corrects its orientation (sensitivity {smallest:.1e} rad/rad)",
        q[rotary[0]], q[rotary[1]], AXIS_LETTERS[along]
    )))
}
