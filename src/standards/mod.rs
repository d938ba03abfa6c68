//! Standard accuracy tests predicted from a machine model, and compared with measured results:
//! ISO 230-2 positioning of one axis, ISO 230-6 body and face diagonals, ISO 230-4 circular
//! tests (ballbar) and the R-test of a rotary axis (Hwang et al., seed 001, Figs. 14–15).
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

pub mod build;
pub mod fit;
pub mod iso230_2;
pub mod measured;

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

use crate::grid::{self, GridError};
use crate::machine::{AxisLetter, Command, Machine};
use crate::reference;
use iso230_2::PositioningData;
use measured::{Measured, Unit};

#[derive(Debug, thiserror::Error)]
pub enum StandardsError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Csv {
        path: String,
        line: usize,
        message: String,
    },
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

fn parameter(message: impl Into<String>) -> StandardsError {
    StandardsError::Parameter(message.into())
}

/// The machine under test, its ideal twin, and the positions of the rotary axes not tested.
pub struct Setup<'a> {
    pub machine: &'a Machine,
    ideal: Machine,
    pub pose: Command,
}

impl<'a> Setup<'a> {
    /// `pose`: positions of rotary axes, `B=30,C=60` (degrees; not named: 0).
    pub fn new(machine: &'a Machine, pose: &str) -> Result<Setup<'a>, StandardsError> {
        Ok(Setup {
            machine,
            ideal: machine.without_errors(),
            pose: grid::parse_pose(pose, machine)?,
        })
    }

    pub fn deviation(&self, command: &Command) -> reference::Deviation {
        reference::deviation_against(self.machine, &self.ideal, command)
    }

    /// The commanded position with X Y Z at `xyz` and the rotary axes at the pose.
    pub fn command(&self, xyz: Vector3<f64>) -> Command {
        let mut command = self.pose;
        command[..3].copy_from_slice(xyz.as_slice());
        command
    }

    fn linear_axis(&self, letter: AxisLetter) -> Result<&crate::machine::Axis, StandardsError> {
        self.machine.axis(letter).ok_or_else(|| {
            parameter(format!(
                "the machine (chain {}) has no {letter} axis",
                self.machine.chain.hwang_notation()
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
        for axis in &self.machine.axes {
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
    /// frame), rotary axes as in `command`. Nominal linear axes are translations, so the tip is
    /// affine in X, Y, Z at fixed rotary positions and three probes give the exact solve.
    pub fn nominal_command_for_tip(
        &self,
        tip: Vector3<f64>,
        command: &Command,
    ) -> Result<Command, StandardsError> {
        let at = |xyz: [f64; 3]| {
            let mut c = *command;
            c[..3].copy_from_slice(&xyz);
            reference::tool_pose(&self.ideal, &c).0
        };
        let base = at([0.0; 3]);
        let jacobian = Matrix3::from_columns(&[
            at([1.0, 0.0, 0.0]) - base,
            at([0.0, 1.0, 0.0]) - base,
            at([0.0, 0.0, 1.0]) - base,
        ]);
        let xyz = jacobian.lu().solve(&(tip - base)).ok_or_else(|| {
            parameter(
                "the machine's linear axes do not span X, Y and Z: no position reaches the tip",
            )
        })?;
        let mut c = *command;
        c[..3].copy_from_slice(xyz.as_slice());
        Ok(c)
    }

    /// The ideal tool orientation (spindle frame → workpiece frame) at `command`.
    pub fn ideal_rotation(&self, command: &Command) -> Matrix3<f64> {
        reference::tool_pose(&self.ideal, command).1
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

// ---------------------------------------------------------------------------------------------
// ISO 230-2 positioning

/// ISO 230-2 positioning of one linear axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositioningSpec {
    /// The axis under test: X, Y or Z.
    pub axis: String,
    /// Target positions, evenly spaced over the travel (ends included); default: 5 per metre
    /// of travel, at least 5 (the standard's minimum).
    pub targets: Option<usize>,
    /// Runs per approach direction (the standard asks for 5).
    #[serde(default = "default_runs")]
    pub runs: usize,
    /// Where the other linear axes stand (mm, `[X, Y, Z]`; the tested axis's entry is
    /// ignored); default: the middle of their travels.
    pub at_mm: Option<[f64; 3]>,
    /// Rotary axes' positions, `B=0,C=0`.
    #[serde(default = "default_pose")]
    pub pose: String,
    /// Measured results: columns `target_mm, direction, run, deviation_mm` (direction `+` or
    /// `-`; lengths may be `_um`).
    pub csv: Option<PathBuf>,
}

fn default_runs() -> usize {
    5
}

fn parse_linear(name: &str) -> Result<AxisLetter, StandardsError> {
    match name.trim() {
        "X" | "x" => Ok(AxisLetter::X),
        "Y" | "y" => Ok(AxisLetter::Y),
        "Z" | "z" => Ok(AxisLetter::Z),
        other => Err(parameter(format!(
            "`{other}` is not a linear axis (X, Y or Z)"
        ))),
    }
}

/// Reads a positioning test's measured results: for each (direction, run) the targets in the
/// order of approach (rising for `+`, falling for `-`), every run over the same targets.
pub fn read_positioning(path: &Path) -> Result<PositioningData, StandardsError> {
    let m = Measured::read(
        path,
        &[
            ("target", Unit::Length),
            ("direction", Unit::None),
            ("run", Unit::None),
            ("deviation", Unit::Length),
        ],
    )?;
    positioning_from(&m)
}

/// One run of a positioning test: its direction (`true`: positive), its label and its
/// `(target, deviation)` pairs in the order of approach.
type Run = (bool, String, Vec<(f64, f64)>);

fn positioning_from(m: &Measured) -> Result<PositioningData, StandardsError> {
    let mut groups: Vec<Run> = Vec::new();
    for row in 0..m.len() {
        let up = match m.text[1][row].as_str() {
            "+" | "up" | "↑" => true,
            "-" | "down" | "↓" => false,
            other => {
                return Err(m.error(row, format!("direction `{other}`: write + or -")));
            }
        };
        let run = m.text[2][row].clone();
        let (target, deviation) = (m.columns[0][row], m.columns[3][row]);
        let group = match groups.iter_mut().find(|(u, r, _)| *u == up && *r == run) {
            Some(g) => g,
            None => {
                groups.push((up, run, Vec::new()));
                groups.last_mut().expect("just pushed")
            }
        };
        if let Some(&(last, _)) = group.2.last() {
            let in_order = if up { target > last } else { target < last };
            if !in_order {
                return Err(m.error(
                    row,
                    format!(
                        "target {target} after {last} in run {} ({}): rows of a run come in the order of approach, {}",
                        group.1,
                        if up { "+" } else { "-" },
                        if up { "rising" } else { "falling" }
                    ),
                ));
            }
        }
        group.2.push((target, deviation));
    }
    let mut targets: Vec<f64> = groups[0].2.iter().map(|&(t, _)| t).collect();
    targets.sort_by(f64::total_cmp);
    let directions = [true, false];
    let mut per_direction: Vec<Vec<Vec<f64>>> = Vec::new();
    for up in directions {
        let runs: Vec<&Run> = groups.iter().filter(|g| g.0 == up).collect();
        if runs.is_empty() {
            return Err(StandardsError::Csv {
                path: m.path.clone(),
                line: m.lines[0],
                message: format!(
                    "no run in the {} direction: ISO 230-2 approaches every target from both sides",
                    if up { "+" } else { "-" }
                ),
            });
        }
        let mut by_target = vec![Vec::new(); targets.len()];
        for run in runs {
            let mut these: Vec<f64> = run.2.iter().map(|&(t, _)| t).collect();
            these.sort_by(f64::total_cmp);
            if these.len() != targets.len()
                || these
                    .iter()
                    .zip(&targets)
                    .any(|(a, b)| (a - b).abs() > 1e-9 * (1.0 + b.abs()))
            {
                return Err(StandardsError::Csv {
                    path: m.path.clone(),
                    line: m.lines[0],
                    message: format!(
                        "run {} ({}) does not visit the same targets as the first run",
                        run.1,
                        if up { "+" } else { "-" }
                    ),
                });
            }
            for &(t, x) in &run.2 {
                let i = targets
                    .iter()
                    .position(|&u| (u - t).abs() <= 1e-9 * (1.0 + u.abs()))
                    .expect("the same targets");
                by_target[i].push(x);
            }
        }
        per_direction.push(by_target);
    }
    let down = per_direction.pop().expect("two directions");
    let up = per_direction.pop().expect("two directions");
    Ok(PositioningData {
        targets_mm: targets,
        up,
        down,
    })
}

pub fn positioning(setup: &Setup, spec: &PositioningSpec) -> Result<TestResult, StandardsError> {
    let letter = parse_linear(&spec.axis)?;
    let axis = setup.linear_axis(letter)?;
    let d = letter.direction_index();
    let (lo, hi) = setup.travel_box()?;
    let at = spec.at_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let measured = spec.csv.as_deref().map(read_positioning).transpose()?;
    let targets: Vec<f64> = match &measured {
        Some(data) => data.targets_mm.clone(),
        None => {
            let [a, b] = axis.range;
            let count = spec
                .targets
                .unwrap_or_else(|| ((b - a) / 1000.0 * 5.0).ceil().max(5.0) as usize);
            if count < 2 {
                return Err(parameter("a positioning test needs at least 2 targets"));
            }
            (0..count)
                .map(|i| a + (b - a) * i as f64 / (count - 1) as f64)
                .collect()
        }
    };
    if spec.runs == 0 {
        return Err(parameter("a positioning test needs at least one run"));
    }
    let mut deviations = Vec::with_capacity(targets.len());
    for &t in &targets {
        let mut p = at;
        p[d] = t;
        let command = setup.command(p);
        setup.check_travel(&command, &format!("positioning of {letter}, target {t}"))?;
        deviations.push(setup.deviation(&command).volumetric_mm[d]);
    }
    // The laser is zeroed at the first target.
    let zero = deviations[0];
    let deviations: Vec<f64> = deviations.iter().map(|x| x - zero).collect();
    let runs = |x: f64| vec![x; spec.runs];
    let predicted = PositioningData {
        targets_mm: targets.clone(),
        up: deviations.iter().map(|&x| runs(x)).collect(),
        down: deviations.iter().map(|&x| runs(x)).collect(),
    };
    let predicted_figures = predicted.figures();
    let measured_figures = measured.as_ref().map(PositioningData::figures);
    let meanings = [
        "accuracy, bidirectional",
        "accuracy, ↑",
        "accuracy, ↓",
        "reversal value",
        "mean reversal value",
        "systematic positioning error, bidirectional",
        "systematic positioning error, ↑",
        "systematic positioning error, ↓",
        "mean bidirectional positioning error",
        "repeatability, bidirectional",
        "repeatability, ↑",
        "repeatability, ↓",
    ];
    let figures = predicted_figures
        .named()
        .into_iter()
        .enumerate()
        .map(|(n, (name, value))| {
            figure(
                name,
                meanings[n],
                value,
                measured_figures.map(|f| f.named()[n].1),
            )
        })
        .collect();
    let (up, down) = predicted.means();
    Ok(TestResult {
        title: format!(
            "ISO 230-2 positioning of {letter} ({} targets, {} runs each way)",
            targets.len(),
            measured.as_ref().map_or(spec.runs, |m| m.up[0].len())
        ),
        position_label: format!("target {letter} (mm)"),
        positions: targets,
        curve_names: vec!["mean deviation ↑".into(), "mean deviation ↓".into()],
        predicted: vec![up, down],
        measured: measured.map(|m| {
            let (u, d) = m.means();
            vec![u, d]
        }),
        figures,
        polar: None,
    })
}

// ---------------------------------------------------------------------------------------------
// ISO 230-6 diagonals

/// ISO 230-6 displacement along a body or face diagonal.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagonalSpec {
    /// Body diagonals `PPP NPP PNP PPN` (the sign of each axis's motion from the start
    /// corner), face diagonals `XY-PP XY-NP YZ-PP YZ-NP ZX-PP ZX-NP` (in the middle of the
    /// third axis's travel). Spans the travel box unless `from_mm` and `to_mm` are given.
    pub diagonal: Option<String>,
    pub from_mm: Option<[f64; 3]>,
    pub to_mm: Option<[f64; 3]>,
    /// Points along the diagonal, ends included.
    #[serde(default = "default_diagonal_points")]
    pub points: usize,
    #[serde(default = "default_pose")]
    pub pose: String,
    /// Measured results: columns `position_mm, deviation_mm` (position along the diagonal
    /// from its start, rising).
    pub csv: Option<PathBuf>,
}

fn default_diagonal_points() -> usize {
    21
}

/// The start and end of a named diagonal in the travel box.
pub fn diagonal_ends(
    name: &str,
    lo: Vector3<f64>,
    hi: Vector3<f64>,
) -> Result<(Vector3<f64>, Vector3<f64>), StandardsError> {
    let mid = (lo + hi) / 2.0;
    let from_signs = |signs: [bool; 3], free: [bool; 3]| {
        let mut a = mid;
        let mut b = mid;
        for d in 0..3 {
            if free[d] {
                (a[d], b[d]) = if signs[d] {
                    (lo[d], hi[d])
                } else {
                    (hi[d], lo[d])
                };
            }
        }
        (a, b)
    };
    let name = name.trim().to_ascii_uppercase();
    let body = |s: &str| -> Option<[bool; 3]> {
        let c: Vec<char> = s.chars().collect();
        (c.len() == 3 && c.iter().all(|&c| c == 'P' || c == 'N'))
            .then(|| [c[0] == 'P', c[1] == 'P', c[2] == 'P'])
    };
    if let Some(signs) = body(&name) {
        if !matches!(name.as_str(), "PPP" | "NPP" | "PNP" | "PPN") {
            return Err(parameter(format!(
                "diagonal `{name}`: ISO 230-6 names the four body diagonals PPP, NPP, PNP, PPN"
            )));
        }
        return Ok(from_signs(signs, [true; 3]));
    }
    let face = match name.split_once('-') {
        Some((plane, signs)) => {
            let axes = match plane {
                "XY" => Some((0, 1)),
                "YZ" => Some((1, 2)),
                "ZX" => Some((2, 0)),
                _ => None,
            };
            let s: Vec<char> = signs.chars().collect();
            match (axes, s.as_slice()) {
                (Some((u, v)), [first, 'P']) if *first == 'P' || *first == 'N' => {
                    let mut signs = [true; 3];
                    let mut free = [false; 3];
                    signs[u] = *first == 'P';
                    free[u] = true;
                    free[v] = true;
                    Some(from_signs(signs, free))
                }
                _ => None,
            }
        }
        None => None,
    };
    face.ok_or_else(|| {
        parameter(format!(
            "diagonal `{name}`: body diagonals PPP NPP PNP PPN, face diagonals XY-PP XY-NP YZ-PP YZ-NP ZX-PP ZX-NP"
        ))
    })
}

pub fn read_profile(
    path: &Path,
    position: (&str, Unit),
    values: &[&str],
) -> Result<Measured, StandardsError> {
    let mut wanted = vec![position];
    wanted.extend(values.iter().map(|v| (*v, Unit::Length)));
    let m = Measured::read(path, &wanted)?;
    m.require_increasing(0, position.0)?;
    Ok(m)
}

pub fn diagonal(setup: &Setup, spec: &DiagonalSpec) -> Result<TestResult, StandardsError> {
    let (lo, hi) = setup.travel_box()?;
    let (from, to, label) = match (&spec.diagonal, spec.from_mm, spec.to_mm) {
        (name, Some(a), Some(b)) => (
            Vector3::from(a),
            Vector3::from(b),
            name.clone().unwrap_or_else(|| "diagonal".into()),
        ),
        (Some(name), None, None) => {
            let (a, b) = diagonal_ends(name, lo, hi)?;
            (a, b, name.to_ascii_uppercase())
        }
        _ => {
            return Err(parameter(
                "name the diagonal (PPP, XY-PP, ...) or give both its start and its end",
            ))
        }
    };
    let length = (to - from).norm();
    if length <= 0.0 {
        return Err(parameter("the diagonal's start and end coincide"));
    }
    let direction = (to - from) / length;
    for (end, what) in [(from, "start"), (to, "end")] {
        setup.check_travel(
            &setup.command(end),
            &format!("diagonal {label}, its {what}"),
        )?;
    }
    let measured = spec
        .csv
        .as_deref()
        .map(|p| read_profile(p, ("position", Unit::Length), &["deviation"]))
        .transpose()?;
    let positions: Vec<f64> = match &measured {
        Some(m) => {
            for (row, &s) in m.columns[0].iter().enumerate() {
                if s < -1e-9 || s > length + 1e-9 {
                    return Err(m.error(
                        row,
                        format!("position {s} lies off the diagonal (0 to {length:.3} mm)"),
                    ));
                }
            }
            m.columns[0].clone()
        }
        None => {
            if spec.points < 2 {
                return Err(parameter("a diagonal needs at least 2 points"));
            }
            (0..spec.points)
                .map(|i| length * i as f64 / (spec.points - 1) as f64)
                .collect()
        }
    };
    let along = |s: f64| {
        setup
            .deviation(&setup.command(from + s * direction))
            .volumetric_mm
            .dot(&direction)
    };
    // The laser is zeroed at the start of the diagonal.
    let zero = along(0.0);
    let predicted: Vec<f64> = positions.iter().map(|&s| along(s) - zero).collect();
    let measured_values = measured.map(|m| m.columns[1].clone());
    let end = |v: &[f64]| v[v.len() - 1] - v[0];
    Ok(TestResult {
        title: format!(
            "ISO 230-6 diagonal {label}: ({:.1}, {:.1}, {:.1}) to ({:.1}, {:.1}, {:.1}) mm, {length:.1} mm",
            from.x, from.y, from.z, to.x, to.y, to.z
        ),
        position_label: format!("position along {label} (mm)"),
        positions,
        curve_names: vec!["displacement error".into()],
        figures: vec![
            figure(
                "D",
                "range of the displacement error along the diagonal",
                range_of(&predicted),
                measured_values.as_deref().map(range_of),
            ),
            figure(
                "end − start",
                "change of the displacement error over the diagonal",
                end(&predicted),
                measured_values.as_deref().map(end),
            ),
        ],
        predicted: vec![predicted],
        measured: measured_values.map(|v| vec![v]),
        polar: None,
    })
}

// ---------------------------------------------------------------------------------------------
// ISO 230-4 circular tests

/// ISO 230-4 circular test (ballbar) in one plane.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircularSpec {
    /// XY, YZ or ZX.
    pub plane: String,
    /// Default: the middle of the travels.
    pub centre_mm: Option<[f64; 3]>,
    /// Default: 100 mm, or less where the travel is shorter (40% of the shorter travel).
    pub radius_mm: Option<f64>,
    /// Points around the circle.
    #[serde(default = "default_circle_points")]
    pub points: usize,
    /// The feed direction: `ccw` (angles rising, G3) or `cw` (falling, G2).
    #[serde(default = "default_direction")]
    pub direction: String,
    /// Where the run starts, degrees from the plane's first axis.
    #[serde(default)]
    pub start_deg: f64,
    #[serde(default = "default_pose")]
    pub pose: String,
    /// Measured results: columns `angle_deg, deviation_mm` (radial deviation, angles in the
    /// order of the run: rising counter-clockwise, falling clockwise).
    pub csv: Option<PathBuf>,
}

fn default_direction() -> String {
    "ccw".into()
}

fn default_circle_points() -> usize {
    360
}

/// The plane's two axes (indices into X Y Z), first to second in the sense of rising angles.
pub fn plane_axes(plane: &str) -> Result<(usize, usize), StandardsError> {
    match plane.trim().to_ascii_uppercase().as_str() {
        "XY" => Ok((0, 1)),
        "YZ" => Ok((1, 2)),
        "ZX" => Ok((2, 0)),
        other => Err(parameter(format!("plane `{other}`: XY, YZ or ZX"))),
    }
}

/// Least-squares circle of radial deviations `dr(θ)` (linearised: deviations far below the
/// radius): `dr ≈ ρ + a cos θ + b sin θ`, with `(a, b)` the centre's offset and `ρ` the radius
/// deviation. Returns `(ρ, a, b)` and the residuals.
pub fn least_squares_circle(
    angles_deg: &[f64],
    radial: &[f64],
) -> Result<([f64; 3], Vec<f64>), StandardsError> {
    let mut normal = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for (&t, &r) in angles_deg.iter().zip(radial) {
        let (s, c) = t.to_radians().sin_cos();
        let row = Vector3::new(1.0, c, s);
        normal += row * row.transpose();
        rhs += row * r;
    }
    let solution = normal
        .cholesky()
        .map(|c| c.solve(&rhs))
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .ok_or_else(|| parameter("the angles do not determine a circle (at least 3 distinct angles spread around it)"))?;
    let residuals = angles_deg
        .iter()
        .zip(radial)
        .map(|(&t, &r)| {
            let (s, c) = t.to_radians().sin_cos();
            r - (solution[0] + solution[1] * c + solution[2] * s)
        })
        .collect();
    Ok(([solution[0], solution[1], solution[2]], residuals))
}

pub fn circular(setup: &Setup, spec: &CircularSpec) -> Result<TestResult, StandardsError> {
    let (u, v) = plane_axes(&spec.plane)?;
    let plane = spec.plane.trim().to_ascii_uppercase();
    let (lo, hi) = setup.travel_box()?;
    let centre = spec.centre_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let radius = spec
        .radius_mm
        .unwrap_or_else(|| 100f64.min(0.4 * (hi[u] - lo[u]).min(hi[v] - lo[v])));
    if radius.is_nan() || radius <= 0.0 {
        return Err(parameter(format!(
            "radius {radius} mm: it must be positive"
        )));
    }
    let sense = match spec.direction.trim().to_ascii_lowercase().as_str() {
        "ccw" => 1.0,
        "cw" => -1.0,
        other => {
            return Err(parameter(format!(
                "direction `{other}`: ccw (counter-clockwise, G3) or cw (clockwise, G2)"
            )))
        }
    };
    let measured = spec
        .csv
        .as_deref()
        .map(|p| {
            let m = Measured::read(p, &[("angle", Unit::Angle), ("deviation", Unit::Length)])?;
            m.require_monotonic(0, "angle", sense > 0.0)?;
            Ok::<_, StandardsError>(m)
        })
        .transpose()?;
    let angles: Vec<f64> = match &measured {
        Some(m) => m.columns[0].clone(),
        None => {
            if spec.points < 3 {
                return Err(parameter("a circle needs at least 3 points"));
            }
            (0..spec.points)
                .map(|i| spec.start_deg + sense * 360.0 * i as f64 / spec.points as f64)
                .collect()
        }
    };
    let (mut e1, mut e2) = (Vector3::zeros(), Vector3::zeros());
    e1[u] = 1.0;
    e2[v] = 1.0;
    let mut predicted = Vec::with_capacity(angles.len());
    for &t in &angles {
        let (s, c) = t.to_radians().sin_cos();
        let p = centre + radius * (c * e1 + s * e2);
        let command = setup.command(p);
        setup.check_travel(&command, &format!("circle in {plane} at {t}°"))?;
        let ve = setup.deviation(&command).volumetric_mm;
        predicted.push((p + ve - centre).norm() - radius);
    }
    let figures_of = |radial: &[f64]| -> Result<[f64; 3], StandardsError> {
        let (_, residuals) = least_squares_circle(&angles, radial)?;
        let max = radial.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = radial.iter().copied().fold(f64::INFINITY, f64::min);
        Ok([range_of(&residuals), max, min])
    };
    let p = figures_of(&predicted)?;
    let m = measured
        .as_ref()
        .map(|m| figures_of(&m.columns[1]))
        .transpose()?;
    Ok(TestResult {
        title: format!(
            "ISO 230-4 circular test in {plane}, {}: centre ({:.1}, {:.1}, {:.1}) mm, radius {radius} mm",
            if sense > 0.0 { "counter-clockwise" } else { "clockwise" },
            centre.x, centre.y, centre.z
        ),
        position_label: "angle (deg)".into(),
        positions: angles,
        curve_names: vec!["radial deviation".into()],
        predicted: vec![predicted],
        measured: measured.map(|m| vec![m.columns[1].clone()]),
        figures: vec![
            figure(
                "G",
                "circular deviation (about the least-squares centre)",
                p[0],
                m.map(|m| m[0]),
            ),
            figure(
                "F max",
                "largest radial deviation from the nominal circle",
                p[1],
                m.map(|m| m[1]),
            ),
            figure(
                "F min",
                "smallest radial deviation from the nominal circle",
                p[2],
                m.map(|m| m[2]),
            ),
        ],
        polar: Some([['X', 'Y', 'Z'][u], ['X', 'Y', 'Z'][v]]),
    })
}

// ---------------------------------------------------------------------------------------------
// R-test

/// The R-test of a rotary axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RTestSpec {
    /// The rotary axis under test: A, B or C.
    pub axis: String,
    /// The sphere's centre in the workpiece frame (commanded coordinates at the pose); default:
    /// where the tool tip is at the middle of the linear travels.
    pub sphere_mm: Option<[f64; 3]>,
    /// Angles from, to and step (degrees); default: the axis's travel in 10° steps.
    pub from_deg: Option<f64>,
    pub to_deg: Option<f64>,
    #[serde(default = "default_step")]
    pub step_deg: f64,
    /// The other rotary axes' positions, `B=-30`.
    #[serde(default = "default_pose")]
    pub pose: String,
    /// Measured results: columns `angle_deg, dX_mm, dY_mm, dZ_mm` (angles rising).
    pub csv: Option<PathBuf>,
}

fn default_step() -> f64 {
    10.0
}

pub fn rtest(setup: &Setup, spec: &RTestSpec) -> Result<TestResult, StandardsError> {
    let letter = match spec.axis.trim() {
        "A" | "a" => AxisLetter::A,
        "B" | "b" => AxisLetter::B,
        "C" | "c" => AxisLetter::C,
        other => {
            return Err(parameter(format!(
                "`{other}` is not a rotary axis (A, B or C)"
            )))
        }
    };
    let axis = setup.machine.axis(letter).ok_or_else(|| {
        parameter(format!(
            "the machine (chain {}) has no {letter} axis",
            setup.machine.chain.hwang_notation()
        ))
    })?;
    let (lo, hi) = setup.travel_box()?;
    let sphere = match spec.sphere_mm {
        Some(s) => Vector3::from(s),
        None => {
            let mid = setup.command((lo + hi) / 2.0);
            reference::tool_pose(&setup.ideal, &mid).0
        }
    };
    let measured = spec
        .csv
        .as_deref()
        .map(|p| read_profile(p, ("angle", Unit::Angle), &["dX", "dY", "dZ"]))
        .transpose()?;
    let angles: Vec<f64> = match &measured {
        Some(m) => m.columns[0].clone(),
        None => {
            let from = spec.from_deg.unwrap_or(axis.range[0]);
            let to = spec.to_deg.unwrap_or(axis.range[1]);
            if spec.step_deg.is_nan() || spec.step_deg <= 0.0 || to < from {
                return Err(parameter(format!(
                    "angles from {from}° to {to}° in steps of {}°: the step must be positive and the end not below the start",
                    spec.step_deg
                )));
            }
            let steps = ((to - from) / spec.step_deg + 1e-9).floor() as usize;
            (0..=steps)
                .map(|i| from + i as f64 * spec.step_deg)
                .collect()
        }
    };
    let mut curves: Vec<Vec<f64>> = vec![Vec::new(); 3];
    for &angle in &angles {
        let mut command = setup.pose;
        command[letter.index()] = angle;
        let command = setup.nominal_command_for_tip(sphere, &command)?;
        setup.check_travel(
            &command,
            &format!("R-test of {letter} at {letter}={angle}°"),
        )?;
        let ve = setup.deviation(&command).volumetric_mm;
        let reading = -(setup.ideal_rotation(&command).transpose() * ve);
        for d in 0..3 {
            curves[d].push(reading[d]);
        }
    }
    // The probes are zeroed at the first angle.
    for curve in &mut curves {
        let zero = curve[0];
        curve.iter_mut().for_each(|v| *v -= zero);
    }
    let measured_curves = measured.map(|m| m.columns[1..].to_vec());
    let figures = ["dX", "dY", "dZ"]
        .iter()
        .enumerate()
        .map(|(d, name)| {
            figure(
                &format!("{name} range"),
                &format!(
                    "range of the sphere's displacement along the spindle frame's {}",
                    ['x', 'y', 'z'][d]
                ),
                range_of(&curves[d]),
                measured_curves.as_ref().map(|m| range_of(&m[d])),
            )
        })
        .collect();
    Ok(TestResult {
        title: format!(
            "R-test of {letter}: sphere at ({:.1}, {:.1}, {:.1}) mm (workpiece frame)",
            sphere.x, sphere.y, sphere.z
        ),
        position_label: format!("{letter} (deg)"),
        positions: angles,
        curve_names: vec!["dX".into(), "dY".into(), "dZ".into()],
        predicted: curves,
        measured: measured_curves,
        figures,
        polar: None,
    })
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

// ---------------------------------------------------------------------------------------------
// The deformed workspace grid (Hwang et al., Fig. 9)

/// The grid lines of a workspace, nominal and with the magnified error added.
#[derive(Debug, Clone, PartialEq)]
pub struct DeformedGrid {
    pub nominal: Vec<Vec<[f64; 3]>>,
    pub deformed: Vec<Vec<[f64; 3]>>,
    /// The magnification of the error.
    pub scale: f64,
    /// The largest |VE| on the lines, mm.
    pub largest_mm: f64,
}

/// The lines of `grid` along X, Y and Z (each cell cut into 8 so the lines show their bends),
/// and the tool tip's actual positions `p + scale·VE(p)`. `scale` defaults to drawing the
/// largest error as 8% of the workspace's diagonal.
pub fn deformed_grid(
    machine: &Machine,
    grid: &crate::grid::Grid,
    scale: Option<f64>,
) -> DeformedGrid {
    const CUTS: usize = 8;
    let ideal = machine.without_errors();
    let position = |d: usize, t: f64| grid.origin_mm[d] + t * grid.spacing_mm[d];
    let mut nominal = Vec::new();
    for along in 0..3 {
        let (a, b) = ((along + 1) % 3, (along + 2) % 3);
        let n = grid.dims[along];
        if n < 2 {
            continue;
        }
        for ia in 0..grid.dims[a] {
            for ib in 0..grid.dims[b] {
                let line = (0..=(n - 1) * CUTS)
                    .map(|s| {
                        let mut p = [0.0; 3];
                        p[along] = position(along, s as f64 / CUTS as f64);
                        p[a] = position(a, ia as f64);
                        p[b] = position(b, ib as f64);
                        p
                    })
                    .collect();
                nominal.push(line);
            }
        }
    }
    let errors: Vec<Vec<[f64; 3]>> = nominal
        .iter()
        .map(|line: &Vec<[f64; 3]>| {
            line.iter()
                .map(|p| {
                    let mut command = grid.pose;
                    command[..3].copy_from_slice(p);
                    let ve = reference::deviation_against(machine, &ideal, &command).volumetric_mm;
                    [ve.x, ve.y, ve.z]
                })
                .collect()
        })
        .collect();
    let largest = errors
        .iter()
        .flatten()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .fold(0.0, f64::max);
    let diagonal = (0..3)
        .map(|d| ((grid.dims[d].max(1) - 1) as f64 * grid.spacing_mm[d]).powi(2))
        .sum::<f64>()
        .sqrt();
    let scale = scale.unwrap_or(if largest > 0.0 {
        0.08 * diagonal / largest
    } else {
        1.0
    });
    let deformed = nominal
        .iter()
        .zip(&errors)
        .map(|(line, e)| {
            line.iter()
                .zip(e)
                .map(|(p, e)| std::array::from_fn(|d| p[d] + scale * e[d]))
                .collect()
        })
        .collect();
    DeformedGrid {
        nominal,
        deformed,
        scale,
        largest_mm: largest,
    }
}
