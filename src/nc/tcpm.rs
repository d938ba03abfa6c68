//! Programs written for tool-centre-point control (G43.4, G43.5, G234; `program::tcpm` reads
//! the codes). Under it X Y Z are the tool tip in the workpiece frame and the control solves the
//! axes with its nominal kinematics, the machine file's ideal chain: the rotary axes as their words
//! say (G43.4, G234) or as the tool vector I J K needs them (G43.5: the solution nearest the
//! previous pose), then X Y Z so that the ideal tip is the programmed point. A programmed point
//! `p` means the tip where the ideal machine puts it at the linear command `p + offset` (work
//! offset and tool length, as in any block) with every rotary axis at 0: with the rotary axes at
//! 0 a TCPM program and an ordinary one say the same.
//!
//! Compensating is then what it is for any program, with that map from program points to machine
//! commands (`tcpm_command`) and back (`tcpm_point`): the command whose real tip (and axis, with
//! the orientation) is the intended one is solved, and the words written are those the control's
//! nominal kinematics turns into it. Between points the control moves the tip on a straight line
//! in the workpiece frame and every rotary axis linearly between its positions at the ends (for
//! G43.5, those solved from the vectors at the ends); the pieces are checked against that.

use nalgebra::Vector3;

use super::block::Block;
use super::error::NcError;
use super::kinematics::{Compensator, Kinematics};
use super::options::Options;
use super::orientation::rotary_axes;
use super::program::modal::{AxisSet, Directions, Motion, State, AXIS_LETTERS};
use super::program::parse::Line;
use super::program::reader::end_position;
use super::program::tcpm::{tool_vector, Tcpm};
use super::write::write_block;
use crate::model::{AxisLetter, Command, Machine};

/// Decimals of the tool vector's I J K written (at least 9: rounding turns the axis by at most
/// 9e-10 rad).
pub(super) fn vector_decimals(options: &Options) -> usize {
    options.decimals.unwrap_or(0).max(9)
}

/// The largest difference (degrees) between the rotary positions planned for a point and those the
/// control solves from the tool vector written for it.
const SOLVED_AGREE_DEG: f64 = 1e-5;

impl Kinematics {
    fn ideal_machine(&self) -> &Machine {
        self.twin(&Directions::default()).ideal()
    }

    /// The machine command at which the ideal machine puts the tool tip where the TCPM program
    /// point `p` says, with the rotary axes at `p`'s (one exact step: the ideal tip is affine in
    /// X, Y, Z at fixed rotary positions); not numbers where the linear axes do not span X Y Z.
    pub(super) fn tcpm_command(&self, p: &[f64; 6], offset: &[f64; 6]) -> Command {
        let mut q: Command = std::array::from_fn(|d| p[d] + offset[d]);
        let at_zero: Command = std::array::from_fn(|d| if d < 3 { q[d] } else { 0.0 });
        let target = self.ideal_tip(&at_zero);
        match self.inverse_jacobian(&q) {
            Some(inverse) => {
                let step = inverse * (target - self.ideal_tip(&q));
                for d in 0..3 {
                    q[d] += step[d];
                }
            }
            None => q = [f64::NAN; 6],
        }
        q
    }

    /// The TCPM program point of the machine command `c`: the inverse of
    /// [`Kinematics::tcpm_command`].
    pub(super) fn tcpm_point(&self, c: &Command, offset: &[f64; 6]) -> [f64; 6] {
        let at_zero: Command = std::array::from_fn(|d| if d < 3 { c[d] } else { 0.0 });
        let Some(zero) = self
            .twin(&Directions::default())
            .ideal_command_for(self.ideal_tip(c), &at_zero)
        else {
            return [f64::NAN; 6];
        };
        std::array::from_fn(|d| {
            if d < 3 {
                zero[d] - offset[d]
            } else {
                c[d] - offset[d]
            }
        })
    }

    /// The ideal tool axis (from the tip towards the spindle, workpiece frame) with the rotary
    /// axes at `p`'s.
    pub(super) fn tool_vector_at(&self, p: &[f64; 6]) -> Vector3<f64> {
        self.ideal_axis(&std::array::from_fn(|d| if d < 3 { 0.0 } else { p[d] }))
    }

    /// `p` with its rotary axes where the ideal machine's tool axis is `vector`: of the solutions
    /// within the travels, the one nearest `p`'s rotary positions (the smallest sum of the two
    /// axes' turns), as the control chooses it. Two rotary axes about x, y or z turn the tool
    /// axis `t0` (at 0) to `Rot(u1, θ1)·Rot(u2, θ2)·t0` (product order): `w = Rot(u2, θ2)·t0` keeps
    /// its component along u2 and has `v`'s along u1, which leaves two `w` (one where they
    /// meet); an angle that does not move its vector (the tool along the axis) stays where it is.
    pub(super) fn rotaries_for(
        &self,
        vector: &Vector3<f64>,
        p: &[f64; 6],
    ) -> Result<[f64; 6], String> {
        let machine = self.ideal_machine();
        let axes: Vec<_> = machine
            .axes_in_product_order()
            .into_iter()
            .filter(|a| !a.letter.is_linear())
            .collect();
        let [first, second] = axes[..] else {
            return Err(format!(
                "a tool vector (G43.5) is solved for two rotary axes; the machine has {}",
                axes.len()
            ));
        };
        let v = vector.normalize();
        let (u1, u2) = (
            Vector3::from(first.unit_vector()),
            Vector3::from(second.unit_vector()),
        );
        let t0 = self.tool_vector_at(&[0.0; 6]);
        let (a, b) = (u1.dot(&v), u2.dot(&t0));
        let across = u1.cross(&u2);
        let g2 = 1.0 - a * a - b * b;
        let (d1, d2) = (first.letter.index(), second.letter.index());
        let names = (AXIS_LETTERS[d1], AXIS_LETTERS[d2]);
        if g2 < -1e-9 {
            return Err(format!(
                "the tool vector I{:.6} J{:.6} K{:.6} cannot be reached by turning {} and {}",
                v.x, v.y, v.z, names.0, names.1
            ));
        }
        let g = g2.max(0.0).sqrt();
        let mut best: Option<([f64; 2], f64)> = None;
        let mut outside = None;
        for sign in if g > 0.0 { [1.0, -1.0] } else { [1.0, 1.0] } {
            let w = a * u1 + b * u2 + sign * g * across;
            let theta2 = angle_about(&u2, &t0, &w).unwrap_or(p[d2]);
            let theta1 = angle_about(&u1, &w, &v).unwrap_or(p[d1]);
            let (c1, c2) = (
                nearest_within(theta1, p[d1], first.range),
                nearest_within(theta2, p[d2], second.range),
            );
            let (Some(c1), Some(c2)) = (c1, c2) else {
                outside = Some((theta1, theta2));
                continue;
            };
            let turn = (c1 - p[d1]).abs() + (c2 - p[d2]).abs();
            if best.is_none_or(|(_, t)| turn < t) {
                best = Some(([c1, c2], turn));
            }
        }
        let Some(([c1, c2], _)) = best else {
            let (t1, t2) = outside.unwrap_or_default();
            return Err(format!(
                "the tool vector needs {}={t1:.4} {}={t2:.4} (or turns of them), outside their travels",
                names.0, names.1
            ));
        };
        let mut solved = *p;
        solved[d1] = c1;
        solved[d2] = c2;
        let reached = self.tool_vector_at(&solved);
        let miss = reached.cross(&v).norm().atan2(reached.dot(&v));
        if miss > 1e-9 {
            return Err(format!(
                "the tool vector cannot be solved for {} and {} on this machine's chain (missed by {miss:.1e} rad)",
                names.0, names.1
            ));
        }
        Ok(solved)
    }
}

/// The angle (degrees) by which a turn about the unit `u` takes `from` to `to` (both with the same
/// component along `u`); `None` where either lies along `u`.
fn angle_about(u: &Vector3<f64>, from: &Vector3<f64>, to: &Vector3<f64>) -> Option<f64> {
    let a = from - u * u.dot(from);
    let b = to - u * u.dot(to);
    if a.norm() < 1e-12 || b.norm() < 1e-12 {
        return None;
    }
    Some(u.dot(&a.cross(&b)).atan2(a.dot(&b)).to_degrees())
}

/// Of `theta` and its whole turns, the one nearest `near` within `range` (degrees).
fn nearest_within(theta: f64, near: f64, range: [f64; 2]) -> Option<f64> {
    let k = ((near - theta) / 360.0).round();
    [k - 1.0, k, k + 1.0]
        .into_iter()
        .map(|k| theta + 360.0 * k)
        .filter(|c| (range[0] - 1e-6..=range[1] + 1e-6).contains(c))
        .min_by(|a, b| (a - near).abs().total_cmp(&(b - near).abs()))
}

/// The machine command of a program point in the mode of `tcpm` (`offset`: work offset and tool
/// length).
pub(super) fn command_of(kin: &Kinematics, tcpm: bool, offset: &[f64; 6], p: &[f64; 6]) -> Command {
    if tcpm {
        kin.tcpm_command(p, offset)
    } else {
        std::array::from_fn(|d| p[d] + offset[d])
    }
}

/// The point `p` written as the control reads it under G43.5: its rotary positions those the
/// control solves from the tool vector as written (rounded).
pub(super) fn written_rotaries(kin: &Kinematics, p: &[f64; 6], options: &Options) -> [f64; 6] {
    let v = rounded(&kin.tool_vector_at(p), vector_decimals(options));
    kin.rotaries_for(&v, p).unwrap_or(*p)
}

fn rounded(v: &Vector3<f64>, decimals: usize) -> Vector3<f64> {
    let scale = 10f64.powi(decimals as i32);
    v.map(|c| (c * scale).round() / scale)
}

/// The work offset and tool length of a block under TCPM; a work offset that turns a rotary axis
/// is refused (how the control places the workpiece frame then is not known).
fn tcpm_offset(comp: &Compensator, state: &State, line: usize) -> Result<[f64; 6], NcError> {
    let offset = comp.offset(state, line)?;
    if let Some(d) = (3..6).find(|&d| offset[d] != 0.0) {
        return Err(NcError::line(
            comp.path,
            line,
            format!(
                "G{} turns {} by {}° under tool-centre-point control: how the control then places the workpiece frame is not known; set the rotary part of the work offset to 0",
                state.offset, AXIS_LETTERS[d], offset[d]
            ),
        ));
    }
    Ok(offset)
}

/// Whether every axis of `machine` among `axes` has a value in `p`.
fn known(machine: &Machine, p: &[f64; 6], axes: std::ops::Range<usize>) -> bool {
    axes.filter(|&d| machine.axis(AxisLetter::ALL[d]).is_some())
        .all(|d| !p[d].is_nan())
}

/// A line that switches tool-centre-point control on or off (or changes its tool length): the
/// axes stand still, so where they stand, in the program and in the output, is taken from the
/// coordinates before the line (`before`, the state before its modal words) into those after.
/// Where the program has not set every axis yet, X Y Z are not known under TCPM (not numbers)
/// until a block gives them all; cancelling TCPM then is refused.
pub(super) fn follow(
    line: &Line,
    before: Option<State>,
    state: &mut State,
    comp: &mut Compensator,
) -> Result<(), NcError> {
    let Some(before) = before else {
        return Ok(());
    };
    if before.tcpm.is_none() && state.tcpm.is_none() {
        return Ok(());
    }
    let n = line.number;
    let (offset_before, offset_after) = if before.tcpm.is_some() {
        (tcpm_offset(comp, &before, n)?, comp.offset(state, n)?)
    } else {
        (comp.offset(&before, n)?, tcpm_offset(comp, state, n)?)
    };
    let machine = comp.kinematics(before.tool, n)?.machine().clone();
    let set =
        |d: usize| machine.axis(AxisLetter::ALL[d]).is_none() || before.set[d] == AxisSet::Yes;
    let program_known = (0..6).all(set) && known(&machine, &before.position, 0..6);
    let written_known = known(&machine, &before.written, 0..6);
    let stand = |comp: &mut Compensator, p: &[f64; 6]| -> Result<Command, NcError> {
        let kin = comp.kinematics(before.tool, n)?;
        Ok(command_of(kin, before.tcpm.is_some(), &offset_before, p))
    };
    let (program, written) = (
        stand(comp, &before.position)?,
        stand(comp, &before.written)?,
    );
    let kin = comp.kinematics(state.tool, n)?;
    let point = |q: &Command| -> [f64; 6] {
        if state.tcpm.is_some() {
            kin.tcpm_point(q, &offset_after)
        } else {
            std::array::from_fn(|d| q[d] - offset_after[d])
        }
    };
    let (program, written) = (point(&program), point(&written));
    if !program_known && state.tcpm.is_none() {
        return Err(NcError::line(
            comp.path,
            n,
            "tool-centre-point control is cancelled here before a block under it gave the tool tip's X Y Z: where the axes stand is not known".into(),
        ));
    }
    for d in 0..3 {
        state.position[d] = if program_known { program[d] } else { f64::NAN };
        state.written[d] = if written_known { written[d] } else { f64::NAN };
    }
    Ok(())
}

/// The end of a move (program coordinates) under tool-centre-point control: under G43.5 the
/// rotary positions the control solves from the block's tool vector, nearest where they stand.
/// What TCPM needs is checked: the rotary axes set, no reversal errors (their directions would be
/// those of the machine's axes, which volmap does not follow under TCPM), and where X Y Z are not
/// known yet, a rapid that gives them all.
pub(super) fn move_end(
    line: &Line,
    state: &mut State,
    comp: &mut Compensator,
) -> Result<[f64; 6], NcError> {
    let mut end = end_position(line, state);
    let Some(mode) = state.tcpm else {
        return Ok(end);
    };
    let (path, n) = (comp.path, line.number);
    tcpm_offset(comp, state, n)?;
    let kin = comp.kinematics(state.tool, n)?;
    if let Some(d) = (0..6).find(|&d| kin.reversing()[d]) {
        return Err(NcError::line(
            path,
            n,
            format!(
                "{} has a reversal error: under tool-centre-point control the direction each machine axis approaches a point in is not the program's, and volmap does not follow it",
                AXIS_LETTERS[d]
            ),
        ));
    }
    if let Some(&d) = rotary_axes(kin.machine())
        .iter()
        .find(|&&d| state.set[d] != AxisSet::Yes)
    {
        return Err(NcError::line(
            path,
            n,
            format!(
                "{} is not known here: under tool-centre-point control the axes the control solves depend on where it stands; set it before (or, under G43.4, on) this block",
                AXIS_LETTERS[d]
            ),
        ));
    }
    if mode == Tcpm::Vector {
        if let Some(v) = tool_vector(line, path)? {
            let solved = kin
                .rotaries_for(&v, &state.position)
                .map_err(|m| NcError::line(path, n, m))?;
            end[3..].copy_from_slice(&solved[3..]);
        }
    }
    let machine = kin.machine();
    if !known(machine, &state.position, 0..3) {
        let linear = (0..3).filter(|&d| machine.axis(AxisLetter::ALL[d]).is_some());
        let gives_all = linear.clone().all(|d| line.has(AXIS_LETTERS[d]));
        if !(state.absolute && gives_all && state.motion == Motion::Rapid) {
            return Err(NcError::line(
                path,
                n,
                "where the tool tip is under tool-centre-point control is not known yet (the program had not set every axis when it was switched on): the first move under it must be a rapid (G0) that gives X Y Z absolutely".into(),
            ));
        }
        // The rapid's path is not held: it starts where it ends, as a program's first move.
        for d in linear {
            state.position[d] = end[d];
        }
    }
    Ok(end)
}

/// Writes a block (see `write::write_block`); under G43.5 the rotary positions of its pieces
/// become the tool vectors I J K, and the control must solve each vector written back to the
/// positions planned (else the block is refused).
pub(super) fn write(
    block: &Block,
    line: &Line,
    state: &mut State,
    from: &[f64; 6],
    pieces: &[[f64; 6]],
    arcs: &[(usize, [f64; 2])],
    out: &mut String,
) -> Result<usize, NcError> {
    let (kin, options) = (block.kin, block.options);
    if state.tcpm != Some(Tcpm::Vector) {
        return write_block(line, state, from, pieces, arcs, out, options);
    }
    let rotary = rotary_axes(kin.machine());
    let mut near = state.written;
    for piece in pieces {
        if near[3..].iter().any(|v| v.is_nan()) {
            near = *piece;
        }
        let v = rounded(&kin.tool_vector_at(piece), vector_decimals(options));
        let solved = kin.rotaries_for(&v, &near).unwrap_or([f64::NAN; 6]);
        if let Some(&d) = rotary.iter().find(|&&d| {
            let gap = (solved[d] - piece[d]).abs();
            gap.is_nan() || gap > SOLVED_AGREE_DEG
        }) {
            return Err(NcError::line(
                block.path,
                line.number,
                format!(
                    "the tool vector written for {}={:.6} would be solved by the control to {}={:.6}: the compensated orientation is not reached from here",
                    AXIS_LETTERS[d], piece[d], AXIS_LETTERS[d], solved[d]
                ),
            ));
        }
        near = solved;
    }
    let vector = |p: &[f64; 6]| -> [f64; 6] {
        let v = kin.tool_vector_at(p);
        [p[0], p[1], p[2], v.x, v.y, v.z]
    };
    let (position, written) = (state.position, state.written);
    state.position = vector(&position);
    state.written = vector(&written);
    let vectors: Vec<[f64; 6]> = pieces.iter().map(vector).collect();
    let result = write_block(line, state, &vector(from), &vectors, arcs, out, options);
    state.position = position;
    let linear = state.written;
    state.written = near;
    state.written[..3].copy_from_slice(&linear[..3]);
    result
}
