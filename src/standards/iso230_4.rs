//! ISO 230-4 circular tests (ballbar) in the XY, YZ and ZX planes.
//!
//! Each of the plane's axes approaches every point in the direction it moves there along the
//! circle ([`circle_directions`]), so a reversal error of an axis shows as a step where the axis
//! turns (a ballbar's reversal spike).

use std::path::PathBuf;

use nalgebra::{Matrix3, Vector2, Vector3};
use serde::Deserialize;

use super::ballbar::{circle_directions, diagnose, BallbarReport, Circle};
use super::measured::{Measured, Unit};
use super::uncertainty::with_uncertainty;
use super::{
    check_count, default_pose, figure, parameter, range_of, Setup, StandardsError, TestResult,
};
use crate::limits::MAX_TEST_POINTS;
use crate::model::AxisLetter;
use crate::report::numbers::{length, length_mm};

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
    /// The pitch of the axes' cyclic error (a ballscrew's lead), mm: the ballbar diagnostics
    /// then give its amplitude per axis.
    pub pitch_mm: Option<f64>,
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

/// The geometric least-squares circle of a ballbar's readings: the points
/// `q_i = (r + dr_i)(cos θ_i, sin θ_i)` about the centre ball, and the circle (centre `(a, b)`,
/// radius `r + ρ`) minimising `Σ (|q_i − (a, b)| − (r + ρ))²`, by Gauss–Newton steps from the
/// linearised circle of [`least_squares_circle`]. Returns `(ρ, a, b)` and the residuals
/// `|q_i − (a, b)| − (r + ρ)`.
pub fn geometric_circle(
    angles_deg: &[f64],
    radial: &[f64],
    radius: f64,
) -> Result<([f64; 3], Vec<f64>), StandardsError> {
    let ([rho, a, b], _) = least_squares_circle(angles_deg, radial)?;
    let points: Vec<Vector2<f64>> = angles_deg
        .iter()
        .zip(radial)
        .map(|(&t, &r)| {
            let (s, c) = t.to_radians().sin_cos();
            (radius + r) * Vector2::new(c, s)
        })
        .collect();
    let residuals_about = |x: &Vector3<f64>| -> Vec<f64> {
        let centre = Vector2::new(x[1], x[2]);
        points
            .iter()
            .map(|q| (q - centre).norm() - (radius + x[0]))
            .collect()
    };
    let mut x = Vector3::new(rho, a, b);
    for _ in 0..50 {
        let centre = Vector2::new(x[1], x[2]);
        let mut normal = Matrix3::zeros();
        let mut rhs = Vector3::zeros();
        for q in &points {
            let offset = q - centre;
            let distance = offset.norm();
            // d residual / d (ρ, a, b)
            let row = Vector3::new(-1.0, -offset.x / distance, -offset.y / distance);
            normal += row * row.transpose();
            rhs += row * (distance - (radius + x[0]));
        }
        let Some(step) = normal.cholesky().map(|c| c.solve(&rhs)) else {
            break;
        };
        x -= step;
        if step.norm() <= 1e-15 * (1.0 + radius) {
            break;
        }
    }
    let residuals = residuals_about(&x);
    Ok(([x[0], x[1], x[2]], residuals))
}

pub fn circular(setup: &Setup, spec: &CircularSpec) -> Result<TestResult, StandardsError> {
    let measured = read_circular(spec)?;
    with_uncertainty(setup, |s| circular_with(s, spec, measured.as_ref()))?.finite()
}

/// +1 counter-clockwise, −1 clockwise.
fn sense_of(spec: &CircularSpec) -> Result<f64, StandardsError> {
    match spec.direction.trim().to_ascii_lowercase().as_str() {
        "ccw" => Ok(1.0),
        "cw" => Ok(-1.0),
        other => Err(parameter(format!(
            "direction `{other}`: ccw (counter-clockwise, G3) or cw (clockwise, G2)"
        ))),
    }
}

/// A circle's measured results, where the spec names a file: angles in the order of the run.
pub(crate) fn read_circular(spec: &CircularSpec) -> Result<Option<Measured>, StandardsError> {
    let sense = sense_of(spec)?;
    spec.csv
        .as_deref()
        .map(|p| {
            let m = Measured::read(p, &[("angle", Unit::Angle), ("deviation", Unit::Length)])?;
            m.require_monotonic(0, "angle", sense > 0.0)?;
            Ok(m)
        })
        .transpose()
}

/// [`circular`] with the measured results already read (a fit runs the test many times).
pub(crate) fn circular_with(
    setup: &Setup,
    spec: &CircularSpec,
    measured: Option<&Measured>,
) -> Result<TestResult, StandardsError> {
    let (u, v) = plane_axes(&spec.plane)?;
    let plane = spec.plane.trim().to_ascii_uppercase();
    let (lo, hi) = setup.travel_box()?;
    let centre = spec.centre_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let radius = spec
        .radius_mm
        .unwrap_or_else(|| 100f64.min(0.4 * (hi[u] - lo[u]).min(hi[v] - lo[v])));
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(parameter(format!(
            "radius {} mm: it must be a positive number",
            crate::error::shown(radius)
        )));
    }
    if !spec.start_deg.is_finite() {
        return Err(parameter(format!(
            "start {}°: it must be a finite angle",
            spec.start_deg
        )));
    }
    let sense = sense_of(spec)?;
    let angles: Vec<f64> = match measured {
        Some(m) => m.columns[0].clone(),
        None => {
            if spec.points < 3 {
                return Err(parameter("a circle needs at least 3 points"));
            }
            let points = check_count("points", "points", spec.points as f64, MAX_TEST_POINTS)?;
            (0..points)
                .map(|i| spec.start_deg + sense * 360.0 * i as f64 / points as f64)
                .collect()
        }
    };
    let (mut e1, mut e2) = (Vector3::zeros(), Vector3::zeros());
    e1[u] = 1.0;
    e2[v] = 1.0;
    let letters = [AxisLetter::X, AxisLetter::Y, AxisLetter::Z];
    // The centre ball sits where the machine put the tool tip when the set-up was made: the
    // ideal tip at the commanded centre plus VE there, every axis approaching as the inputs say.
    let centre_command = setup.command(centre);
    let centre_ball =
        setup.ideal_tip(&centre_command) + setup.twin().deviation(&centre_command).volumetric_mm;
    let mut predicted = Vec::with_capacity(angles.len());
    for &t in &angles {
        let (s, c) = t.to_radians().sin_cos();
        let p = centre + radius * (c * e1 + s * e2);
        let command = setup.command(p);
        setup.check_travel(&command, &format!("circle in {plane} at {t}°"))?;
        let (du, dv) = circle_directions(t, sense);
        let mut directions = [None; 6];
        directions[letters[u].index()] = Some(du);
        directions[letters[v].index()] = Some(dv);
        let ve = setup.deviation(&command, &directions).volumetric_mm;
        // The tool ball: the ideal tip in the workpiece frame plus VE.
        let tool_ball = setup.ideal_tip(&command) + ve;
        predicted.push((tool_ball - centre_ball).norm() - radius);
    }
    let figures_of = |radial: &[f64]| -> Result<[f64; 3], StandardsError> {
        let (_, residuals) = geometric_circle(&angles, radial, radius)?;
        let max = radial.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = radial.iter().copied().fold(f64::INFINITY, f64::min);
        Ok([range_of(&residuals), max, min])
    };
    // With measurements the angles are the file's: what they cannot do names it.
    let in_file = |e: StandardsError| match measured {
        Some(m) => parameter(format!("{}: {e}", m.path)),
        None => e,
    };
    let p = figures_of(&predicted).map_err(in_file)?;
    let m = measured
        .map(|m| figures_of(&m.columns[1]))
        .transpose()
        .map_err(in_file)?;
    if let Some(pitch) = spec.pitch_mm {
        // A micrometre to a kilometre: a lead a screw can have, and one whose phase `x / pitch`
        // stays a number over any travel.
        if !(1e-3..=1e6).contains(&pitch) {
            return Err(parameter(format!(
                "pitch {} mm: a screw's lead is between 0.001 and 1e6 mm",
                crate::error::shown(pitch)
            )));
        }
    }
    let circle = Circle {
        axes: [['X', 'Y', 'Z'][u], ['X', 'Y', 'Z'][v]],
        radius_mm: radius,
        centre_mm: [centre[u], centre[v]],
        sense,
        pitch_mm: spec.pitch_mm,
    };
    let ballbar = diagnose(&angles, &predicted, &circle).map(|predicted| BallbarReport {
        axes: circle.axes,
        radius_mm: radius,
        pitch_mm: spec.pitch_mm,
        predicted,
        measured: measured.and_then(|m| diagnose(&angles, &m.columns[1], &circle)),
    });
    Ok(TestResult {
        unit: super::ErrorUnit::Mm,
        title: format!(
            "ISO 230-4 circular test in {plane}, {}: centre ({}, {}, {}) mm, radius {}",
            if sense > 0.0 { "counter-clockwise" } else { "clockwise" },
            length(centre.x), length(centre.y), length(centre.z),
            length_mm(radius)
        ),
        position_label: "angle (deg)".into(),
        positions: angles,
        curve_names: vec!["radial deviation".into()],
        predicted: vec![predicted],
        measured: measured.map(|m| vec![m.columns[1].clone()]),
        predicted_u: None,
        measured_2s: None,
        figures: vec![
            figure(
                "G",
                "circular deviation: range of the radial deviation from the geometric least-squares circle",
                p[0],
                m.map(|m| m[0]),
            ),
            figure(
                "F max",
                "largest radial deviation from the nominal radius, about the centre ball",
                p[1],
                m.map(|m| m[1]),
            ),
            figure(
                "F min",
                "smallest radial deviation from the nominal radius, about the centre ball",
                p[2],
                m.map(|m| m[2]),
            ),
        ],
        polar: Some([['X', 'Y', 'Z'][u], ['X', 'Y', 'Z'][v]]),
        inputs: setup.describe_inputs(&[letters[u], letters[v]], "from the path"),
        moving_axes: vec![letters[u].as_char(), letters[v].as_char()],
        ballbar,
    })
}
