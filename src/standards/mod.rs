//! Standard accuracy tests predicted from a machine model, and compared with measured results:
//! ISO 230-2 positioning of one axis, ISO 230-6 body and face diagonals, ISO 230-4 circular
//! tests (ballbar) and the R-test of a rotary axis (Hwang et al. 2014, Figs. 14–15).
//!
//! Every test commands positions, asks the model for `VE` there (the f64 reference of
//! docs/model.md, workpiece frame), and turns it into what the test's instrument reads. The
//! instruments sit between tool and workpiece, so they see the ideal tool tip `p_w(q)` in the
//! workpiece frame and the direction `d_w = normalise(∂p_w/∂q · v)` in which it moves when the
//! linear axes move along `v`; at zero pose (and without work-side rotary axes) `p_w` is the
//! commanded position plus constant offsets and `d_w = v`, with a work-side rotary axis turned
//! both turn with it:
//!
//! - positioning of axis `k` (laser along the tool's motion `d_w` of `e_k`, zeroed at the first
//!   target `t0` of the ↑ run): `x↑(t) = VE↑(t)·d_w − VE↑(t0)·d_w` with `k` approaching `+`,
//!   `x↓(t) = VE↓(t)·d_w − VE↑(t0)·d_w` with `k` approaching `−`; the model has no scatter, so the
//!   runs of one direction repeat exactly, and a reversal (`reverse`) error gives `B`, `R` and the
//!   bidirectional figures;
//! - diagonal from `p0` to `p1` (commanded; laser along the tool's motion `d_w` of
//!   `d = (p1 − p0)/|p1 − p0|`, zeroed at `p0`): the displacement error
//!   `VE(p0 + s·d)·d_w − VE(p0)·d_w` at distance `s` along it;
//! - circular test about the commanded centre `c` with radius `r` in a plane (ballbar between a
//!   ball on the table and one at the tool tip): the centre ball sits where the set-up put the tool
//!   tip, `b = p_w(c) + VE(c)` (every axis approaching as the inputs say), the tool ball at
//!   `p_w(p) + VE(p)`, and the reading is `|p_w(p) + VE(p) − b| − r` at
//!   `p = c + r(cos θ e1 + sin θ e2)`, `θ` from the plane's first axis towards its second
//!   (XY: from +X to +Y; YZ: from +Y to +Z; ZX: from +Z to +X); F max and F min are its extremes
//!   (about the centre ball), G the range of its residuals from the geometric least-squares circle;
//! - R-test of rotary axis `k` (a sphere fixed on the workpiece side at `s`, a nest of three
//!   probes in the spindle, the linear axes commanded to follow the sphere): at each angle the
//!   linear axes are where the ideal machine puts the tool tip at `s`, and the probes read the
//!   sphere's displacement relative to the nest in the spindle frame, `−R_idealᵀ · VE`, zeroed
//!   at the first angle.
//!
//! Every test evaluates the model at its evaluation inputs (docs/model.md, "Evaluation inputs"):
//! the temperatures given apply to every point; each axis the test moves approaches in the
//! direction the path moves it at that point ([`Directions`]), and the axes it does not move
//! approach as the inputs say (default `+`).
//!
//! Measured curves are compared as they come: zero them where the prediction is zeroed.

pub mod ballbar;
pub mod iso230_2;
mod iso230_2_rotary;
pub mod iso230_4;
pub mod iso230_6;
pub mod measured;
pub mod positioning;
pub mod rtest;
pub mod uncertainty;

pub use iso230_2::{read_positioning, PositioningSpec};
pub use iso230_4::{circular, geometric_circle, least_squares_circle, plane_axes, CircularSpec};
pub use iso230_6::{diagonal, diagonal_ends, read_profile, DiagonalSpec};
pub use positioning::{positioning, read_positioning_of};
pub use rtest::{rtest, RTestSpec};

use std::sync::OnceLock;

use nalgebra::Vector3;

use crate::error::input_errors;
use crate::io::csv::CsvError;
use crate::io::FileError;
use crate::limits;
use crate::model::grid::GridError;
use crate::model::inputs::{Approach, Inputs};
use crate::model::perturbation::ErrorTarget;
use crate::model::poses;
use crate::model::{AxisLetter, Command, Machine, MachineSource};
use crate::reference::{Deviation, Twin};

#[derive(Debug, thiserror::Error)]
pub enum StandardsError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Csv(#[from] CsvError),
    #[error("{0}")]
    Parameter(String),
    #[error("{what}: {axis}={} lies outside the travel of {axis} ({lo} to {hi})", position_shown(*.value))]
    OutsideTravel {
        what: String,
        axis: AxisLetter,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(transparent)]
    Pose(#[from] GridError),
    /// A count the spec implies beyond its limit (see [`crate::limits`]); `key` names the
    /// spec's keys it comes from.
    #[error("{key}: {message}")]
    Limit { key: &'static str, message: String },
    /// A result that is not a number (a backstop: machine files and measurements are bounded
    /// as they are read).
    #[error("{title}: {what} is not a finite number")]
    NotFinite { title: String, what: String },
}

input_errors!(StandardsError);

fn parameter(message: impl Into<String>) -> StandardsError {
    StandardsError::Parameter(message.into())
}

/// `count` (in f64, from the spec's `key`) of `what` within `limit`.
fn check_count(
    key: &'static str,
    what: &str,
    count: f64,
    limit: u64,
) -> Result<usize, StandardsError> {
    limits::within(count, limit)
        .map(|c| c as usize)
        .map_err(|e| StandardsError::Limit {
            key,
            message: format!(
                "{} {what} are more than the limit of {}",
                limits::count_words(e.count),
                e.limit
            ),
        })
}

/// The direction each axis moves in at a point of a test's path, indexed by
/// [`AxisLetter::index`]; `None` for an axis the test does not move (it approaches as the
/// evaluation inputs say).
pub type Directions = [Option<Approach>; 6];

/// The direction of an axis whose commanded position changes by `velocity` (any positive
/// multiple of its rate); a zero velocity is a turning point, where the axis keeps the direction
/// it arrived in, `arrived`.
pub(crate) fn direction_of(velocity: f64, arrived: f64) -> Approach {
    let sign = if velocity != 0.0 { velocity } else { arrived };
    if sign < 0.0 {
        Approach::Negative
    } else {
        Approach::Positive
    }
}

/// The machine under test at its evaluation inputs, with its ideal twin, and the positions of
/// the rotary axes not tested.
pub struct Setup {
    /// The machine as given, with its input-dependent error values.
    machine: Machine,
    /// The temperatures, and the approach of the axes a test does not move.
    inputs: Inputs,
    /// The axes with a `reverse` value: the only ones whose direction changes the machine.
    reversing: Vec<AxisLetter>,
    /// The machine at the inputs, one per combination of the reversing axes' directions (bit
    /// `n` set: `reversing[n]` approaches `−`), made when first asked for.
    twins: Vec<OnceLock<Twin>>,
    /// Perturbations of the machine's uncertain quantities (one per quantity, by number) added
    /// at the inputs: a copy of the set-up the uncertainty of a test is propagated through.
    deviations: Option<Vec<f64>>,
    pub pose: Command,
}

impl Setup {
    /// `pose`: positions of rotary axes, `B=30,C=60` (degrees; not named: 0). The machine at the
    /// default inputs (every axis `+`, every thermal input at `reference_C`).
    pub fn new(machine: &Machine, pose: &str) -> Result<Setup, StandardsError> {
        Setup::with_inputs(machine, pose, &Inputs::default())
    }

    /// [`Setup::new`] at the evaluation inputs `inputs`: their temperatures hold for every
    /// point, their approach directions for the axes a test does not move.
    pub fn with_inputs(
        machine: &Machine,
        pose: &str,
        inputs: &Inputs,
    ) -> Result<Setup, StandardsError> {
        let mut reversing: Vec<AxisLetter> = machine
            .dependent
            .iter()
            .filter(|d| d.reverse.is_some())
            .filter_map(|d| match d.target {
                ErrorTarget::Component { axis, .. } => Some(axis),
                _ => None,
            })
            .collect();
        reversing.sort();
        reversing.dedup();
        Ok(Setup {
            pose: poses::parse_pose(pose, machine)?,
            twins: (0..1usize << reversing.len())
                .map(|_| OnceLock::new())
                .collect(),
            reversing,
            machine: machine.clone(),
            inputs: inputs.clone(),
            deviations: None,
        })
    }

    /// The same set-up on the machine with perturbations `e` of its uncertain quantities (one
    /// per quantity of [`Machine::uncertainty`], by number), added at each twin's inputs so a
    /// part used for one approach direction, or a `per_kelvin` coefficient, counts as there.
    pub fn perturbed(&self, e: &[f64]) -> Setup {
        let mut machine = self.machine.clone();
        // Each perturbed copy would only carry the files the machine came from along.
        machine.source = MachineSource::default();
        Setup {
            machine,
            inputs: self.inputs.clone(),
            reversing: self.reversing.clone(),
            twins: self.twins.iter().map(|_| OnceLock::new()).collect(),
            deviations: Some(e.to_vec()),
            pose: self.pose,
        }
    }

    /// Whether this is a perturbed copy ([`Setup::perturbed`]).
    pub fn is_perturbed(&self) -> bool {
        self.deviations.is_some()
    }

    /// The machine under test, as given (its values at the default inputs).
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The evaluation inputs: the temperatures, and the approach of axes a test does not move.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// The machine at the inputs, with its ideal twin, every axis approaching as the inputs say.
    pub fn twin(&self) -> &Twin {
        self.twin_moving(&[None; 6])
    }

    /// The machine at the inputs with the axes the path moves approaching in `directions`.
    pub fn twin_moving(&self, directions: &Directions) -> &Twin {
        let approach =
            |l: AxisLetter| directions[l.index()].unwrap_or(self.inputs.approach[l.index()]);
        let index = self
            .reversing
            .iter()
            .enumerate()
            .filter(|&(_, &l)| approach(l) == Approach::Negative)
            .fold(0, |i, (n, _)| i | 1 << n);
        self.twins[index].get_or_init(|| {
            let mut inputs = self.inputs.clone();
            for l in AxisLetter::ALL {
                inputs.approach[l.index()] = approach(l);
            }
            let machine = self.machine.at(&inputs);
            Twin::new(match &self.deviations {
                Some(e) => machine.with_deviations(e),
                None => machine,
            })
        })
    }

    /// VE and OE at a commanded position with the axes the path moves approaching in
    /// `directions`.
    pub fn deviation(&self, command: &Command, directions: &Directions) -> Deviation {
        self.twin_moving(directions).deviation(command)
    }

    /// The inputs a test ran at, in words: `approach X Y from the path, Z+; temperatures
    /// hall=26 °C (reference 20 °C)`. `moving`: the axes the test moves.
    pub fn describe_inputs(&self, moving: &[AxisLetter], how: &str) -> String {
        let mut path = Vec::new();
        let mut fixed = Vec::new();
        for l in AxisLetter::ALL
            .into_iter()
            .filter(|&l| self.machine.chain.contains(l))
        {
            if moving.contains(&l) {
                path.push(l.to_string());
            } else {
                fixed.push(format!("{l}{}", self.inputs.approach[l.index()].sign()));
            }
        }
        let mut text = "approach".to_string();
        if !path.is_empty() {
            text += &format!(" {} {how}", path.join(" "));
            if !fixed.is_empty() {
                text += ",";
            }
        }
        if !fixed.is_empty() {
            text += &format!(" {}", fixed.join(" "));
        }
        if let Some(thermal) = &self.machine.thermal {
            let temperatures: Vec<String> = thermal
                .inputs
                .iter()
                .map(|i| {
                    format!(
                        "{i}={} °C",
                        self.inputs.temperature_c(i, thermal.reference_c)
                    )
                })
                .collect();
            text += &format!(
                "; temperatures {} (reference {} °C)",
                temperatures.join(", "),
                thermal.reference_c
            );
        }
        text
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
            // A position that is not a number lies on no travel.
            if !(value >= lo - slack && value <= hi + slack) {
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

    /// Where the ideal machine puts the tool tip at `command` (workpiece frame, mm): where an
    /// instrument between tool and workpiece sees the tool when the machine makes no error.
    pub fn ideal_tip(&self, command: &Command) -> Vector3<f64> {
        self.twin().ideal_tip(command)
    }

    /// The unit direction (workpiece frame) in which the ideal tool tip moves when the linear axes
    /// at `command` move along `commanded` (X Y Z): `d ideal(q)/ds`, normalised. With a work-side
    /// rotary axis turned it is not `commanded`; at zero pose it is.
    pub fn ideal_direction(&self, command: &Command, commanded: Vector3<f64>) -> Vector3<f64> {
        (self.twin().ideal_jacobian(command) * commanded).normalize()
    }

    /// The commanded X Y Z at which the ideal machine puts the tool tip at `tip` (workpiece
    /// frame), rotary axes as in `command`.
    pub fn nominal_command_for_tip(
        &self,
        tip: Vector3<f64>,
        command: &Command,
    ) -> Result<Command, StandardsError> {
        self.twin().ideal_command_for(tip, command).ok_or_else(|| {
            parameter(
                "the machine's linear axes do not span X, Y and Z: no position reaches the tip",
            )
        })
    }
}

/// Arc-seconds in a radian.
pub const ARCSEC_PER_RAD: f64 = 180.0 * 3600.0 / std::f64::consts::PI;

/// The unit of a test's curves and figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorUnit {
    /// Lengths, mm (shown in µm).
    Mm,
    /// Angles, arc-seconds: the positioning of a rotary axis (ISO 230-2).
    Arcsec,
}

impl ErrorUnit {
    /// The factor to the unit values are shown in, and its name: µm and µrad, as every error
    /// volmap prints ([`crate::report::numbers`]).
    pub fn shown(self) -> (f64, &'static str) {
        match self {
            ErrorUnit::Mm => (1000.0, "µm"),
            ErrorUnit::Arcsec => (1e6 / ARCSEC_PER_RAD, "µrad"),
        }
    }

    /// A value in this unit as volmap prints it, without the unit ([`Self::shown`] names it).
    pub fn printed(self, value: f64) -> String {
        match self {
            ErrorUnit::Mm => crate::report::numbers::error(value),
            ErrorUnit::Arcsec => crate::report::numbers::angle(value / ARCSEC_PER_RAD),
        }
    }

    fn suffix(self) -> &'static str {
        match self {
            ErrorUnit::Mm => "mm",
            ErrorUnit::Arcsec => "arcsec",
        }
    }
}

/// One figure of a test, predicted and (where given) measured, in `unit`; written to JSON as
/// `predicted_mm` and `measured_mm` (`predicted_arcsec`, … for a rotary axis).
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub name: String,
    pub meaning: String,
    pub predicted: f64,
    /// The standard uncertainty of `predicted` from the machine's (first order; `None` where the
    /// machine has no `u`): written to JSON as `predicted_u_mm` (`predicted_u_arcsec`).
    pub predicted_u: Option<f64>,
    pub measured: Option<f64>,
    pub unit: ErrorUnit,
}

impl serde::Serialize for Figure {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(None)?;
        map.serialize_entry("name", &self.name)?;
        map.serialize_entry("meaning", &self.meaning)?;
        let suffix = self.unit.suffix();
        map.serialize_entry(&format!("predicted_{suffix}"), &self.predicted)?;
        if let Some(u) = self.predicted_u {
            map.serialize_entry(&format!("predicted_u_{suffix}"), &u)?;
        }
        map.serialize_entry(&format!("measured_{suffix}"), &self.measured)?;
        map.end()
    }
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
    /// `[curve][position]`, in `unit`.
    pub predicted: Vec<Vec<f64>>,
    /// `[curve][position]`, in `unit`: the standard uncertainty of `predicted` from the
    /// machine's (first order, [`uncertainty`]), where the machine has any `u`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_u: Option<Vec<Vec<f64>>>,
    /// `[curve][position]`, in `unit`, where measured results were given.
    pub measured: Option<Vec<Vec<f64>>>,
    /// The unit of the curves and the figures: mm, or arc-seconds for a rotary axis's
    /// positioning.
    pub unit: ErrorUnit,
    /// `[curve][position]`, in `unit`: twice the measured runs' standard uncertainty `s` (ISO 230-2's
    /// ±2s about each mean), where measured runs give it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_2s: Option<Vec<Vec<f64>>>,
    pub figures: Vec<Figure>,
    /// Circular tests are drawn as polar plots: the plane's first and second axes.
    pub polar: Option<[char; 2]>,
    /// The evaluation inputs of the prediction, in words (see [`Setup::describe_inputs`]).
    pub inputs: String,
    /// The axes the test moves: their directions come from the path, not from the inputs.
    pub moving_axes: Vec<char>,
    /// A circular test's ballbar diagnostics.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ballbar: Option<ballbar::BallbarReport>,
}

impl TestResult {
    /// The result, where every position, curve and figure is a finite number.
    pub(crate) fn finite(self) -> Result<TestResult, StandardsError> {
        let error = |what: String| StandardsError::NotFinite {
            title: self.title.clone(),
            what,
        };
        if self.positions.iter().any(|v| !v.is_finite()) {
            return Err(error("a position".into()));
        }
        let curves = [
            ("predicted", Some(&self.predicted)),
            ("uncertainty of the predicted", self.predicted_u.as_ref()),
            ("measured", self.measured.as_ref()),
        ];
        for (kind, curves) in curves {
            for (name, curve) in self.curve_names.iter().zip(curves.into_iter().flatten()) {
                if curve.iter().any(|v| !v.is_finite()) {
                    return Err(error(format!("the {kind} `{name}`")));
                }
            }
        }
        for f in &self.figures {
            if !f.predicted.is_finite()
                || f.predicted_u.is_some_and(|u| !u.is_finite())
                || f.measured.is_some_and(|m| !m.is_finite())
            {
                return Err(error(format!("the figure {}", f.name)));
            }
        }
        Ok(self)
    }
}

fn figure(name: &str, meaning: &str, predicted: f64, measured: Option<f64>) -> Figure {
    Figure {
        name: name.to_string(),
        meaning: meaning.to_string(),
        predicted,
        predicted_u: None,
        measured,
        unit: ErrorUnit::Mm,
    }
}

fn range_of(values: &[f64]) -> f64 {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    max - min
}

/// Measured positions this close to an end of a test's range (mm) are read as that end: a CSV
/// rounded to the µm may put the last position of a diagonal a few nm beyond its exact length.
pub const END_TOLERANCE_MM: f64 = 1e-3;

/// `value` clamped to `[lo, hi]` where it lies within [`END_TOLERANCE_MM`] beyond an end;
/// `None` where it lies further out.
pub(crate) fn clamp_to_ends(value: f64, lo: f64, hi: f64) -> Option<f64> {
    if value < lo - END_TOLERANCE_MM || value > hi + END_TOLERANCE_MM || value.is_nan() {
        None
    } else {
        Some(value.clamp(lo, hi))
    }
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

/// A position in an error message: a computed one to 4 decimals (0.1 µm, 1e-4°), trailing
/// zeros cut; one of 1e7 or more, or not finite, as [`crate::error::shown`] writes it.
fn position_shown(value: f64) -> String {
    if value.is_finite() && value.abs() < 1e7 {
        let text = format!("{value:.4}");
        let text = text.trim_end_matches('0').trim_end_matches('.');
        if text == "-0" {
            "0".into()
        } else {
            text.into()
        }
    } else {
        crate::error::shown(value)
    }
}
