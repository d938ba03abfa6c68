//! Standard accuracy tests predicted from a machine model, and compared with measured results:
//! ISO 230-2 positioning of one axis, ISO 230-6 body and face diagonals, ISO 230-4 circular
//! tests (ballbar) and the R-test of a rotary axis (Hwang et al. 2014, Figs. 14–15).
//!
//! Every test commands positions, asks the model for `VE` there (the f64 reference of MODEL.md,
//! workpiece frame), and turns it into what the test's instrument reads:
//!
//! - positioning of axis `k` (laser along `k`, zeroed at the first target `t0`):
//!   `x(t) = VE(t)·e_k − VE(t0)·e_k`, the deviation of the actual from the target position; the
//!   model has no backlash or scatter, so every run and both approach directions give the same
//!   deviation (`B = R = 0`, `A = E = M`);
//! - diagonal from `p0` to `p1` (laser along the diagonal `d = (p1 − p0)/|p1 − p0|`, zeroed at
//!   `p0`): the displacement error `VE(p0 + s·d)·d − VE(p0)·d` at distance `s` along it;
//! - circular test about centre `c` with radius `r` in a plane (ballbar between a ball at `c` on
//!   the table and one at the tool tip): the radial deviation `|p + VE(p) − c| − r` at
//!   `p = c + r(cos θ e1 + sin θ e2)`, `θ` from the plane's first axis towards its second
//!   (XY: from +X to +Y; YZ: from +Y to +Z; ZX: from +Z to +X);
//! - R-test of rotary axis `k` (a sphere fixed on the workpiece side at `s`, a nest of three
//!   probes in the spindle, the linear axes commanded to follow the sphere): at each angle the
//!   linear axes are where the ideal machine puts the tool tip at `s`, and the probes read the
//!   sphere's displacement relative to the nest in the spindle frame, `−R_idealᵀ · VE`, zeroed
//!   at the first angle.
//!
//! Measured curves are compared as they come: zero them where the prediction is zeroed.

pub mod iso230_2;
pub mod iso230_4;
pub mod iso230_6;
pub mod measured;
pub mod rtest;

pub use iso230_2::{positioning, read_positioning, PositioningSpec};
pub use iso230_4::{circular, least_squares_circle, plane_axes, CircularSpec};
pub use iso230_6::{diagonal, diagonal_ends, read_profile, DiagonalSpec};
pub use rtest::{rtest, RTestSpec};

use nalgebra::Vector3;

use crate::error::input_errors;
use crate::io::csv::CsvError;
use crate::io::FileError;
use crate::model::grid::{self, GridError};
use crate::model::{AxisLetter, Command, Machine};
use crate::reference::Twin;

#[derive(Debug, thiserror::Error)]
pub enum StandardsError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Csv(#[from] CsvError),
    #[error("{0}")]
    Parameter(String),
    #[error("{what}: {axis}={value} lies outside the travel of {axis} ({lo} to {hi})")]
    OutsideTravel {
        what: String,
        axis: AxisLetter,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(transparent)]
    Pose(#[from] GridError),
}

input_errors!(StandardsError);

fn parameter(message: impl Into<String>) -> StandardsError {
    StandardsError::Parameter(message.into())
}

/// The machine under test with its ideal twin, and the positions of the rotary axes not tested.
pub struct Setup {
    twin: Twin,
    pub pose: Command,
}

impl Setup {
    /// `pose`: positions of rotary axes, `B=30,C=60` (degrees; not named: 0).
    pub fn new(machine: &Machine, pose: &str) -> Result<Setup, StandardsError> {
        Ok(Setup {
            pose: grid::parse_pose(pose, machine)?,
            twin: Twin::of(machine),
        })
    }

    /// The machine under test.
    pub fn machine(&self) -> &Machine {
        self.twin.real()
    }

    /// The machine under test with its ideal twin.
    pub fn twin(&self) -> &Twin {
        &self.twin
    }

    /// The commanded position with X Y Z at `xyz` and the rotary axes at the pose.
    pub fn command(&self, xyz: Vector3<f64>) -> Command {
        let mut command = self.pose;
        command[..3].copy_from_slice(xyz.as_slice());
        command
    }

    fn linear_axis(&self, letter: AxisLetter) -> Result<&crate::model::Axis, StandardsError> {
        self.machine().axis(letter).ok_or_else(|| {
            parameter(format!(
                "the machine (chain {}) has no {letter} axis",
                self.machine().chain.hwang_notation()
            ))
        })
    }

    /// The travel box of the linear axes, `(low corner, high corner)`.
    pub fn travel_box(&self) -> Result<(Vector3<f64>, Vector3<f64>), StandardsError> {
        let mut lo = Vector3::zeros();
        let mut hi = Vector3::zeros();
        for (d, letter) in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z]
            .into_iter()
            .enumerate()
        {
            let axis = self.linear_axis(letter)?;
            lo[d] = axis.range[0];
            hi[d] = axis.range[1];
        }
        Ok((lo, hi))
    }

    /// Checks every axis position of `command` against its travel.
    pub fn check_travel(&self, command: &Command, what: &str) -> Result<(), StandardsError> {
        for axis in &self.machine().axes {
            let value = command[axis.letter.index()];
            let [lo, hi] = axis.range;
            let slack = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
            if value < lo - slack || value > hi + slack {
                return Err(StandardsError::OutsideTravel {
                    what: what.to_string(),
                    axis: axis.letter,
                    value,
                    lo,
                    hi,
                });
            }
        }
        Ok(())
    }

    /// The commanded X Y Z at which the ideal machine puts the tool tip at `tip` (workpiece
    /// frame), rotary axes as in `command`.
    pub fn nominal_command_for_tip(
        &self,
        tip: Vector3<f64>,
        command: &Command,
    ) -> Result<Command, StandardsError> {
        self.twin.ideal_command_for(tip, command).ok_or_else(|| {
            parameter(
                "the machine's linear axes do not span X, Y and Z: no position reaches the tip",
            )
        })
    }
}

/// One figure of a test, predicted and (where given) measured, mm.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Figure {
    pub name: String,
    pub meaning: String,
    pub predicted_mm: f64,
    pub measured_mm: Option<f64>,
}

/// A test's result: the error curve(s) at each position, predicted and measured, and the
/// standard's figures.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TestResult {
    pub title: String,
    /// What the positions are, with the unit: `target X (mm)`, `angle (deg)`.
    pub position_label: String,
    pub positions: Vec<f64>,
    /// One name per curve: `deviation`, `radial deviation`, `dX`.
    pub curve_names: Vec<String>,
    /// `[curve][position]`, mm.
    pub predicted: Vec<Vec<f64>>,
    /// `[curve][position]`, mm, where measured results were given.
    pub measured: Option<Vec<Vec<f64>>>,
    pub figures: Vec<Figure>,
    /// Circular tests are drawn as polar plots: the plane's first and second axes.
    pub polar: Option<[char; 2]>,
}

fn figure(name: &str, meaning: &str, predicted: f64, measured: Option<f64>) -> Figure {
    Figure {
        name: name.to_string(),
        meaning: meaning.to_string(),
        predicted_mm: predicted,
        measured_mm: measured,
    }
}

fn range_of(values: &[f64]) -> f64 {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    max - min
}

fn default_pose() -> String {
    String::new()
}

/// The largest difference between measured and predicted, over every curve and point.
pub fn largest_difference(result: &TestResult) -> Option<f64> {
    result.measured.as_ref().map(|m| {
        m.iter()
            .zip(&result.predicted)
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max)
    })
}
