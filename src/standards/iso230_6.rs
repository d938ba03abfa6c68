//! ISO 230-6 displacement along body and face diagonals. Every axis moves one way from the
//! start to the end and approaches each point in that direction.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::Deserialize;

use super::measured::{Measured, Unit};
use super::uncertainty::with_uncertainty;
use super::{
    check_count, clamp_to_ends, default_pose, direction_of, figure, parameter, range_of, Setup,
    StandardsError, TestResult, END_TOLERANCE_MM,
};
use crate::limits::MAX_TEST_POINTS;
use crate::model::AxisLetter;
use crate::report::numbers;

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
    let measured = read_diagonal(spec)?;
    with_uncertainty(setup, |s| diagonal_with(s, spec, measured.as_ref()))?.finite()
}

/// A diagonal's measured results, where the spec names a file.
pub(crate) fn read_diagonal(spec: &DiagonalSpec) -> Result<Option<Measured>, StandardsError> {
    spec.csv
        .as_deref()
        .map(|p| read_profile(p, ("position", Unit::Length), &["deviation"]))
        .transpose()
}

/// What a diagonal is called in titles and messages: `diagonal PPP`, or `the diagonal` for one
/// given by its ends alone.
fn called(label: &str) -> String {
    match label {
        "" => "the diagonal".into(),
        name => format!("diagonal {name}"),
    }
}

/// [`diagonal`] with the measured results already read (a fit runs the test many times).
pub(crate) fn diagonal_with(
    setup: &Setup,
    spec: &DiagonalSpec,
    measured: Option<&Measured>,
) -> Result<TestResult, StandardsError> {
    let (lo, hi) = setup.travel_box()?;
    let (from, to, label) = match (&spec.diagonal, spec.from_mm, spec.to_mm) {
        (name, Some(a), Some(b)) => (
            Vector3::from(a),
            Vector3::from(b),
            name.clone().unwrap_or_default(),
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
            &format!("{}, its {what}", called(&label)),
        )?;
    }
    let positions: Vec<f64> = match measured {
        Some(m) => {
            // Positions rounded a little beyond an end (a CSV written to the µm) are that end.
            let mut positions = Vec::with_capacity(m.len());
            for (row, &s) in m.columns[0].iter().enumerate() {
                positions.push(clamp_to_ends(s, 0.0, length).ok_or_else(|| {
                    m.error(
                        row,
                        format!(
                            "position {s} lies off the diagonal (0 to {length:.6} mm, \
                             {END_TOLERANCE_MM} mm beyond an end read as the end)"
                        ),
                    )
                })?);
            }
            positions
        }
        None => {
            if spec.points < 2 {
                return Err(parameter("a diagonal needs at least 2 points"));
            }
            let points = check_count("points", "points", spec.points as f64, MAX_TEST_POINTS)?;
            (0..points)
                .map(|i| length * i as f64 / (points - 1) as f64)
                .collect()
        }
    };
    // Each axis moves one way from the start to the end; one that does not move approaches as
    // the inputs say.
    let letters = [AxisLetter::X, AxisLetter::Y, AxisLetter::Z];
    let mut directions = [None; 6];
    let mut moving = Vec::new();
    for (d, letter) in letters.into_iter().enumerate() {
        if direction[d] != 0.0 {
            directions[letter.index()] = Some(direction_of(direction[d], 0.0));
            moving.push(letter);
        }
    }
    // The laser lies along the way the tool moves relative to the workpiece on the commanded
    // diagonal: the diagonal itself at zero pose, turned with a work-side rotary axis.
    let laser = setup.ideal_direction(&setup.command(from), direction);
    let along = |s: f64| {
        setup
            .deviation(&setup.command(from + s * direction), &directions)
            .volumetric_mm
            .dot(&laser)
    };
    // The laser is zeroed at the start of the diagonal.
    let zero = along(0.0);
    let predicted: Vec<f64> = positions.iter().map(|&s| along(s) - zero).collect();
    let measured_values = measured.map(|m| m.columns[1].clone());
    let end = |v: &[f64]| v[v.len() - 1] - v[0];
    Ok(TestResult {
        ballbar: None,
        unit: super::ErrorUnit::Mm,
        title: format!(
            "ISO 230-6 {}: ({}, {}, {}) to ({}, {}, {}) mm, {}",
            called(&label).trim_start_matches("the "),
            numbers::length(from.x),
            numbers::length(from.y),
            numbers::length(from.z),
            numbers::length(to.x),
            numbers::length(to.y),
            numbers::length(to.z),
            numbers::length_mm(length)
        ),
        position_label: format!("position along {} (mm)", called(&label)),
        positions,
        curve_names: vec!["displacement error".into()],
        predicted_u: None,
        measured_2s: None,
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
        inputs: setup.describe_inputs(&moving, "from the path"),
        moving_axes: moving.iter().map(|l| l.as_char()).collect(),
    })
}
