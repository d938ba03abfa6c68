//! ISO 230-2 positioning of one linear axis: the simulated test, measured runs read in, and the
//! figures.
//!
//! The figures come from the deviations `x_ij = P_ij − P_i`
//! (actual minus target position) at targets `i`, runs `j`, approached in the positive (↑) and
//! negative (↓) direction:
//!
//! - `x̄_i↑`, `x̄_i↓`: the mean deviations; `x̄_i = (x̄_i↑ + x̄_i↓)/2`;
//! - `s_i↑`, `s_i↓`: the estimators of the standard uncertainty, `√(Σ_j (x_ij − x̄_i)² / (n − 1))`
//!   (0 for a single run);
//! - reversal value `B_i = x̄_i↑ − x̄_i↓`; `B = max |B_i|`; mean reversal value `B̄ = Σ B_i / m`;
//! - repeatability `R_i↑ = 4 s_i↑`, `R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)`, `R↑ = max R_i↑`,
//!   `R = max R_i`;
//! - systematic positioning error `E↑ = max x̄_i↑ − min x̄_i↑`,
//!   `E = max(x̄_i↑, x̄_i↓) − min(x̄_i↑, x̄_i↓)`;
//! - mean positioning error `M = max x̄_i − min x̄_i`;
//! - accuracy `A↑ = max(x̄_i↑ + 2 s_i↑) − min(x̄_i↑ − 2 s_i↑)`,
//!   `A = max(x̄_i↑ + 2 s_i↑, x̄_i↓ + 2 s_i↓) − min(x̄_i↑ − 2 s_i↑, x̄_i↓ − 2 s_i↓)`.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::Deserialize;

use super::measured::{Measured, Unit};
use super::{check_count, default_pose, figure, parameter, Setup, StandardsError, TestResult};
use crate::limits::{MAX_RUNS, MAX_TEST_POINTS};
use crate::model::inputs::Approach;
use crate::model::AxisLetter;

/// Deviations (mm) of a positioning test: `up[i][j]` at target `i`, run `j`, approached in the
/// positive direction; `down[i][j]` in the negative.
#[derive(Debug, Clone, PartialEq)]
pub struct PositioningData {
    pub targets_mm: Vec<f64>,
    pub up: Vec<Vec<f64>>,
    pub down: Vec<Vec<f64>>,
    /// Measured runs: the file they were read from and the line of each target's first row
    /// (what an error about a target names); `None` for predicted runs.
    pub read_from: Option<TargetLines>,
}

/// The file measured targets were read from, and the line of each target's first row.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetLines {
    pub path: String,
    pub lines: Vec<usize>,
}

impl PositioningData {
    /// `error`, about target `i`, naming the file and line it was read from (measured runs).
    pub fn at_target(&self, i: usize, error: StandardsError) -> StandardsError {
        match &self.read_from {
            Some(from) => StandardsError::Csv(crate::io::csv::CsvError {
                path: from.path.clone(),
                line: from.lines[i],
                message: error.to_string(),
            }),
            None => error,
        }
    }
}

/// The ISO 230-2 figures, mm.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PositioningFigures {
    pub a: f64,
    pub a_up: f64,
    pub a_down: f64,
    pub b: f64,
    pub b_mean: f64,
    pub e: f64,
    pub e_up: f64,
    pub e_down: f64,
    pub m: f64,
    pub r: f64,
    pub r_up: f64,
    pub r_down: f64,
}

impl PositioningFigures {
    /// `(name, value)` in the order the standard lists them.
    pub fn named(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("A", self.a),
            ("A↑", self.a_up),
            ("A↓", self.a_down),
            ("B", self.b),
            ("B̄", self.b_mean),
            ("E", self.e),
            ("E↑", self.e_up),
            ("E↓", self.e_down),
            ("M", self.m),
            ("R", self.r),
            ("R↑", self.r_up),
            ("R↓", self.r_down),
        ]
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

fn uncertainty(values: &[f64]) -> f64 {
    if values.len() < 2 {
        return 0.0;
    }
    let m = mean(values);
    (values.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (values.len() - 1) as f64).sqrt()
}

fn spread(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = values.fold(f64::INFINITY, f64::min);
    max - min
}

impl PositioningData {
    /// The mean deviations `x̄_i↑` and `x̄_i↓`.
    pub fn means(&self) -> (Vec<f64>, Vec<f64>) {
        (
            self.up.iter().map(|r| mean(r)).collect(),
            self.down.iter().map(|r| mean(r)).collect(),
        )
    }

    pub fn figures(&self) -> PositioningFigures {
        let (up, down) = self.means();
        let s_up: Vec<f64> = self.up.iter().map(|r| uncertainty(r)).collect();
        let s_down: Vec<f64> = self.down.iter().map(|r| uncertainty(r)).collect();
        let m = up.len();
        let reversal: Vec<f64> = (0..m).map(|i| up[i] - down[i]).collect();
        let r_i: Vec<f64> = (0..m)
            .map(|i| {
                (2.0 * s_up[i] + 2.0 * s_down[i] + reversal[i].abs())
                    .max(4.0 * s_up[i])
                    .max(4.0 * s_down[i])
            })
            .collect();
        let max_of = |v: &mut dyn Iterator<Item = f64>| v.fold(f64::NEG_INFINITY, f64::max);
        let min_of = |v: &mut dyn Iterator<Item = f64>| v.fold(f64::INFINITY, f64::min);
        let upper_up = (0..m).map(|i| up[i] + 2.0 * s_up[i]);
        let lower_up = (0..m).map(|i| up[i] - 2.0 * s_up[i]);
        let upper_down = (0..m).map(|i| down[i] + 2.0 * s_down[i]);
        let lower_down = (0..m).map(|i| down[i] - 2.0 * s_down[i]);
        PositioningFigures {
            a: max_of(&mut upper_up.clone().chain(upper_down.clone()))
                - min_of(&mut lower_up.clone().chain(lower_down.clone())),
            a_up: max_of(&mut upper_up.clone()) - min_of(&mut lower_up.clone()),
            a_down: max_of(&mut upper_down.clone()) - min_of(&mut lower_down.clone()),
            b: reversal.iter().fold(0.0, |b, r| b.max(r.abs())),
            b_mean: mean(&reversal),
            e: spread(up.iter().chain(&down).copied()),
            e_up: spread(up.iter().copied()),
            e_down: spread(down.iter().copied()),
            m: spread((0..m).map(|i| 0.5 * (up[i] + down[i]))),
            r: r_i.iter().copied().fold(0.0, f64::max),
            r_up: s_up.iter().fold(0.0, |r, s| r.max(4.0 * s)),
            r_down: s_down.iter().fold(0.0, |r, s| r.max(4.0 * s)),
        }
    }
}

/// ISO 230-2 positioning of one linear axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositioningSpec {
    /// The axis under test: X, Y or Z; A, B or C (see [`super::iso230_2_rotary`]).
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
    /// `-`; lengths may be `_um`); for a rotary axis `target_deg, direction, run,
    /// deviation_arcsec` (or `_urad`).
    pub csv: Option<PathBuf>,
}

fn default_runs() -> usize {
    5
}

/// The axis under test: linear (X Y Z) or rotary (A B C).
pub(super) fn parse_axis(name: &str) -> Result<AxisLetter, StandardsError> {
    let mut chars = name.trim().chars();
    match (chars.next().map(|c| c.to_ascii_uppercase()), chars.next()) {
        (Some(c), None) => AxisLetter::from_char(c),
        _ => None,
    }
    .ok_or_else(|| {
        parameter(format!(
            "`{}` is not an axis (X, Y or Z; A, B or C for a rotary axis)",
            name.trim()
        ))
    })
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

pub(super) fn positioning_from(m: &Measured) -> Result<PositioningData, StandardsError> {
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
                        crate::error::excerpt(&group.1),
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
            return Err(m.error(
                0,
                format!(
                    "no run in the {} direction: ISO 230-2 approaches every target from both sides",
                    if up { "+" } else { "-" }
                ),
            ));
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
                return Err(m.error(
                    0,
                    format!(
                        "run {} ({}) does not visit the same targets as the first run",
                        crate::error::excerpt(&run.1),
                        if up { "+" } else { "-" }
                    ),
                ));
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
    let lines = targets
        .iter()
        .map(|&t| {
            let row = (0..m.len())
                .find(|&row| (m.columns[0][row] - t).abs() <= 1e-9 * (1.0 + t.abs()))
                .expect("every target is a row's");
            m.lines[row]
        })
        .collect();
    Ok(PositioningData {
        targets_mm: targets,
        up,
        down,
        read_from: Some(TargetLines {
            path: m.path.clone(),
            lines,
        }),
    })
}

/// The test of linear axis `letter` (see [`super::positioning::positioning_with`]).
pub(super) fn linear_positioning_with(
    setup: &Setup,
    spec: &PositioningSpec,
    letter: AxisLetter,
    measured: Option<&PositioningData>,
) -> Result<TestResult, StandardsError> {
    let axis = setup.linear_axis(letter)?;
    let d = letter.direction_index();
    let (lo, hi) = setup.travel_box()?;
    let at = spec.at_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let targets: Vec<f64> = match measured {
        // Targets rounded a little beyond the travel's ends are read as the ends.
        Some(data) => data
            .targets_mm
            .iter()
            .map(|&t| super::clamp_to_ends(t, axis.range[0], axis.range[1]).unwrap_or(t))
            .collect(),
        None => {
            let [a, b] = axis.range;
            let count = match spec.targets {
                Some(n) => n as f64,
                None => ((b - a) / 1000.0 * 5.0).ceil().max(5.0),
            };
            if count < 2.0 {
                return Err(parameter("a positioning test needs at least 2 targets"));
            }
            let count = check_count("targets", "targets", count, MAX_TEST_POINTS)?;
            (0..count)
                .map(|i| a + (b - a) * i as f64 / (count - 1) as f64)
                .collect()
        }
    };
    if spec.runs == 0 {
        return Err(parameter("a positioning test needs at least one run"));
    }
    check_count("runs", "runs", spec.runs as f64, MAX_RUNS)?;
    // The ↑ runs approach every target with the axis moving `+`, the ↓ runs with it moving `−`;
    // the other axes stand still and approach as the inputs say.
    let mut up_directions = [None; 6];
    up_directions[letter.index()] = Some(Approach::Positive);
    let mut down_directions = [None; 6];
    down_directions[letter.index()] = Some(Approach::Negative);
    let mut up = Vec::with_capacity(targets.len());
    let mut down = Vec::with_capacity(targets.len());
    for (i, &t) in targets.iter().enumerate() {
        let mut p = at;
        p[d] = t;
        let command = setup.command(p);
        setup
            .check_travel(&command, &format!("positioning of {letter}, target {t}"))
            .map_err(|e| match &measured {
                Some(data) => data.at_target(i, e),
                None => e,
            })?;
        // The laser lies along the way the tool moves relative to the workpiece when the axis
        // moves: e_k at zero pose, turned with a work-side rotary axis.
        let laser = setup.ideal_direction(&command, Vector3::ith(d, 1.0));
        up.push(
            setup
                .deviation(&command, &up_directions)
                .volumetric_mm
                .dot(&laser),
        );
        down.push(
            setup
                .deviation(&command, &down_directions)
                .volumetric_mm
                .dot(&laser),
        );
    }
    let title = format!("ISO 230-2 positioning of {letter}");
    Ok(positioning_result(
        setup,
        spec,
        letter,
        (targets, up, down),
        measured,
        (title, format!("target {letter} (mm)")),
        super::ErrorUnit::Mm,
    ))
}

/// The test's result from the predicted deviations at each target, `(targets, up, down)` (↑ and
/// ↓, before the zero), zeroed at the first target of the first (↑) run.
pub(super) fn positioning_result(
    setup: &Setup,
    spec: &PositioningSpec,
    letter: AxisLetter,
    (targets, up, down): (Vec<f64>, Vec<f64>, Vec<f64>),
    measured: Option<&PositioningData>,
    (title, position_label): (String, String),
    unit: super::ErrorUnit,
) -> TestResult {
    // The laser is zeroed at the first target of the first (↑) run.
    let zero = up[0];
    let runs = |x: &f64| vec![x - zero; spec.runs];
    let predicted = PositioningData {
        targets_mm: targets.clone(),
        up: up.iter().map(runs).collect(),
        down: down.iter().map(runs).collect(),
        read_from: None,
    };
    let predicted_figures = predicted.figures();
    let measured_figures = measured.map(PositioningData::figures);
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
            let mut figure = figure(
                name,
                meanings[n],
                value,
                measured_figures.map(|f| f.named()[n].1),
            );
            figure.unit = unit;
            figure
        })
        .collect();
    let (up, down) = predicted.means();
    TestResult {
        unit,
        title: format!(
            "{title} ({} targets, {} runs each way)",
            targets.len(),
            measured.map_or(spec.runs, |m| m.up[0].len())
        ),
        position_label,
        positions: targets,
        curve_names: vec!["mean deviation ↑".into(), "mean deviation ↓".into()],
        predicted: vec![up, down],
        measured: measured.map(|m| {
            let (u, d) = m.means();
            vec![u, d]
        }),
        predicted_u: None,
        measured_2s: measured.map(|m| {
            let two_s = |runs: &[Vec<f64>]| runs.iter().map(|r| 2.0 * uncertainty(r)).collect();
            vec![two_s(&m.up), two_s(&m.down)]
        }),
        figures,
        polar: None,
        inputs: setup.describe_inputs(&[letter], "from the run (+ for ↑, − for ↓)"),
        ballbar: None,
        moving_axes: vec![letter.as_char()],
    }
}
