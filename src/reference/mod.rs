//! The CPU reference: docs/model.md in f64 with nalgebra, exact transforms, written for clarity
//! rather than speed. It is the ground truth every other path is tested against, and [`Twin`], a
//! machine with its ideal twin, is how every part of volmap asks what the machine does against what
//! it should do.
//!
//! Frames: every transform maps coordinates of a child frame into its parent; products compose
//! from the workpiece outward, `E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)`, and the
//! result is the tool tip frame expressed in the workpiece frame.

mod twin;
pub mod uncertainty;

pub use twin::Twin;
pub use uncertainty::{MonteCarlo, Propagation};

use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, Vector3};

use crate::model::{Axis, Command, Machine};

pub type Transform = Matrix4<f64>;

/// `Trans(v)`: pure translation.
pub fn trans(v: Vector3<f64>) -> Transform {
    Matrix4::new_translation(&v)
}

/// `Rot(a, b, c) = Rx(a) · Ry(b) · Rz(c)`, exact.
pub fn rot(a: f64, b: f64, c: f64) -> Transform {
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), a);
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), b);
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), c);
    (rx * ry * rz).to_homogeneous()
}

/// `E(dx, dy, dz, ea, eb, ec) = Trans(dx, dy, dz) · Rot(ea, eb, ec)`: an error transform.
pub fn error_transform(e: [f64; 6]) -> Transform {
    trans(Vector3::new(e[0], e[1], e[2])) * rot(e[3], e[4], e[5])
}

/// `Rot_u(theta)`: rotation by `theta` (rad) about the unit axis direction `u`.
pub fn rot_about(u: Vector3<f64>, theta: f64) -> Transform {
    Rotation3::from_axis_angle(&Unit::new_normalize(u), theta).to_homogeneous()
}

/// `L_k = Trans(o_k + (EX0k, EY0k, EZ0k)) · Rot(EA0k, EB0k, EC0k)`: the axis location.
pub fn location(axis: &Axis) -> Transform {
    location_at(axis.offset_mm, axis.location)
}

/// [`location`] of an axis with nominal offset `offset_mm` and location errors `location`.
pub fn location_at(offset_mm: [f64; 3], location: [f64; 6]) -> Transform {
    let [ex, ey, ez, ea, eb, ec] = location;
    let o = Vector3::from(offset_mm);
    trans(o + Vector3::new(ex, ey, ez)) * rot(ea, eb, ec)
}

/// The relative transform `A_k(q)` of one axis whose errors depend on its own position only:
/// linear `L_k · Trans(q·u_k) · E_k(q)`, rotary `L_k · E_k(q) · Rot_u(q)` (q in degrees).
pub fn axis_transform(axis: &Axis, q: f64) -> Transform {
    axis_transform_at(axis, q, &[0.0; 6])
}

/// [`axis_transform`] with every axis at `command` (for errors of other axes' positions).
pub fn axis_transform_at(axis: &Axis, q: f64, command: &Command) -> Transform {
    let u = Vector3::from(axis.unit_vector());
    let errors = error_transform(axis.component_values_at(q, command));
    if axis.letter.is_linear() {
        location(axis) * trans(q * u) * errors
    } else {
        location(axis) * errors * rot_about(u, q.to_radians())
    }
}

/// The spindle error `S = E(EXS, EYS, EZS, EAS, EBS, 0)`.
pub fn spindle_error(machine: &Machine) -> Transform {
    spindle_error_at(machine.spindle)
}

/// [`spindle_error`] of the spindle errors `spindle`.
pub fn spindle_error_at(spindle: [f64; 5]) -> Transform {
    let [exs, eys, ezs, eas, ebs] = spindle;
    error_transform([exs, eys, ezs, eas, ebs, 0.0])
}

/// `Trans(tool)`: the tool tip in the spindle frame.
pub fn tool_translation(machine: &Machine) -> Transform {
    trans(Vector3::from(machine.tool_offset_mm))
}

/// `S · Trans(tool)`, the last factors of every chain, as one transform.
pub fn spindle_and_tool(machine: &Machine) -> Transform {
    spindle_and_tool_at(machine.spindle, machine.tool_offset_mm)
}

/// [`spindle_and_tool`] of the spindle errors `spindle` and the tool offset `tool_mm`.
pub fn spindle_and_tool_at(spindle: [f64; 5], tool_mm: [f64; 3]) -> Transform {
    spindle_error_at(spindle) * trans(Vector3::from(tool_mm))
}

/// `E_rel(q)` of docs/model.md for the machine at the commanded positions.
pub fn relative_transform(machine: &Machine, command: &Command) -> Transform {
    let chain = machine
        .axes_in_product_order()
        .into_iter()
        .fold(Transform::identity(), |acc, axis| {
            acc * axis_transform_at(axis, command[axis.letter.index()], command)
        });
    chain * spindle_error(machine) * tool_translation(machine)
}

/// The tool pose at a commanded position: tip position and orientation in the workpiece frame.
pub fn tool_pose(machine: &Machine, command: &Command) -> (Vector3<f64>, Matrix3<f64>) {
    let t = relative_transform(machine, command);
    (
        t.fixed_view::<3, 1>(0, 3).into_owned(),
        t.fixed_view::<3, 3>(0, 0).into_owned(),
    )
}

/// The derivative of the tool tip (workpiece frame) in the commanded X, Y, Z at `command`, from
/// unit steps: exact for a machine without errors, whose nominal linear axes are translations,
/// so that its tip is affine in X, Y, Z at fixed rotary positions.
pub fn tip_jacobian(machine: &Machine, command: &Command) -> Matrix3<f64> {
    let base = tool_pose(machine, command).0;
    let column = |d: usize| {
        let mut stepped = *command;
        stepped[d] += 1.0;
        tool_pose(machine, &stepped).0 - base
    };
    Matrix3::from_columns(&[column(0), column(1), column(2)])
}

/// The machine's error at one commanded position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// `VE = p_real − p_ideal`, workpiece frame, mm.
    pub volumetric_mm: Vector3<f64>,
    /// Rotation vector of `R_real · R_idealᵀ`, workpiece frame, rad.
    pub orientation_rad: Vector3<f64>,
}

/// The rotation vector (axis × angle, rad) of a rotation matrix. The angle comes from
/// `atan2(|s|, (tr R − 1)/2)` with `s` the axial vector of the skew part of `R`, which stays
/// accurate for the tiny rotations of machine errors (`acos` of the trace would not).
pub fn rotation_vector(r: &Matrix3<f64>) -> Vector3<f64> {
    let s = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) / 2.0;
    let sin = s.norm();
    let cos = (r.trace() - 1.0) / 2.0;
    let angle = sin.atan2(cos);
    if sin < 1e-300 {
        return Vector3::zeros();
    }
    s * (angle / sin)
}

/// VE and OE at one commanded position: the machine against the same machine with every error
/// value zero (for many positions, build a [`Twin`] once).
pub fn deviation(machine: &Machine, command: &Command) -> Deviation {
    Twin::of(machine).deviation(command)
}

/// [`deviation`] against an ideal machine the caller holds (see [`Twin::deviation`]).
pub(crate) fn deviation_against(
    machine: &Machine,
    ideal: &Machine,
    command: &Command,
) -> Deviation {
    let (p_real, r_real) = tool_pose(machine, command);
    let (p_ideal, r_ideal) = tool_pose(ideal, command);
    Deviation {
        volumetric_mm: p_real - p_ideal,
        orientation_rad: rotation_vector(&(r_real * r_ideal.transpose())),
    }
}
