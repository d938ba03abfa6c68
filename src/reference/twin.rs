//! A machine and its ideal twin: the same machine with every error value zero (nominal offsets,
//! directions and tool kept), docs/model.md's ideal machine. The volumetric error is the real tool
//! tip against the ideal one; a standard test commands where the ideal machine puts the tip; NC
//! compensation finds the command whose real tip lands where the ideal one would.

use nalgebra::{Matrix3, Vector3};

use super::{deviation_against, tip_jacobian, tool_pose, Deviation};
use crate::model::{Command, Machine};

/// A machine with its ideal twin, both in f64.
#[derive(Debug, Clone, PartialEq)]
pub struct Twin {
    real: Machine,
    ideal: Machine,
}

/// Newton steps stop when the real tip is this close to the target, mm.
const TIP_TOLERANCE_MM: f64 = 1e-10;

impl Twin {
    pub fn new(machine: Machine) -> Twin {
        let ideal = machine.without_errors();
        Twin {
            real: machine,
            ideal,
        }
    }

    /// The twin of a machine the caller keeps.
    pub fn of(machine: &Machine) -> Twin {
        Twin::new(machine.clone())
    }

    /// The machine with its errors.
    pub fn real(&self) -> &Machine {
        &self.real
    }

    /// The same machine without them.
    pub fn ideal(&self) -> &Machine {
        &self.ideal
    }

    /// VE and OE at a commanded position (workpiece frame).
    pub fn deviation(&self, command: &Command) -> Deviation {
        deviation_against(&self.real, &self.ideal, command)
    }

    /// Where the real machine puts the tool tip (workpiece frame, mm).
    pub fn real_tip(&self, command: &Command) -> Vector3<f64> {
        tool_pose(&self.real, command).0
    }

    /// Where the ideal machine puts the tool tip (workpiece frame, mm).
    pub fn ideal_tip(&self, command: &Command) -> Vector3<f64> {
        tool_pose(&self.ideal, command).0
    }

    /// The ideal tool orientation, spindle frame to workpiece frame.
    pub fn ideal_rotation(&self, command: &Command) -> Matrix3<f64> {
        tool_pose(&self.ideal, command).1
    }

    /// The derivative of the ideal tool tip in the commanded X, Y, Z: exact and the same at every
    /// X, Y, Z for fixed rotary positions (the ideal linear axes are translations).
    pub fn ideal_jacobian(&self, command: &Command) -> Matrix3<f64> {
        tip_jacobian(&self.ideal, command)
    }

    /// The command with the rotary axes of `command` at which the ideal machine puts the tool tip
    /// at `tip`: one exact step; `None` where the linear axes do not span X, Y and Z.
    pub fn ideal_command_for(&self, tip: Vector3<f64>, command: &Command) -> Option<Command> {
        let step = self
            .ideal_jacobian(command)
            .lu()
            .solve(&(tip - self.ideal_tip(command)))?;
        let mut c = *command;
        for d in 0..3 {
            c[d] += step[d];
        }
        Some(c)
    }

    /// The command with the rotary axes of `command` whose real tool tip lands on `tip`, by Newton
    /// steps from `command` with `inverse`, the inverse of [`Twin::ideal_jacobian`] there, until
    /// they agree to 1e-10 mm; `None` when they do not within 50 steps.
    pub fn real_command_for(
        &self,
        tip: Vector3<f64>,
        command: &Command,
        inverse: &Matrix3<f64>,
    ) -> Option<Command> {
        let mut c = *command;
        for _ in 0..50 {
            let miss = self.real_tip(&c) - tip;
            if miss.norm() < TIP_TOLERANCE_MM {
                return Some(c);
            }
            let step = inverse * miss;
            for d in 0..3 {
                c[d] -= step[d];
            }
        }
        None
    }
}
