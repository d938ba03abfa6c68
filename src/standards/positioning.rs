//! ISO 230-2 positioning of one linear axis: the simulated test, and measured runs read in.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::Deserialize;

use super::iso230_2::PositioningData;
use super::measured::{Measured, Unit};
use super::{default_pose, figure, parameter, Setup, StandardsError, TestResult};
use crate::machine::AxisLetter;

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
    let measured = spec.csv.as_deref().map(read_positioning).transpose()?;
    positioning_with(setup, spec, measured.as_ref())
}

/// [`positioning`] with the measured runs already read (a fit runs the test many times).
pub(super) fn positioning_with(
    setup: &Setup,
    spec: &PositioningSpec,
    measured: Option<&PositioningData>,
) -> Result<TestResult, StandardsError> {
    let letter = parse_linear(&spec.axis)?;
    let axis = setup.linear_axis(letter)?;
    let d = letter.direction_index();
    let (lo, hi) = setup.travel_box()?;
    let at = spec.at_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let targets: Vec<f64> = match measured {
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
            measured.map_or(spec.runs, |m| m.up[0].len())
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
