//! The R-test of a rotary axis (Hwang et al. 2014, Figs. 14–15). The rotary axis turns `+`
//! (the angles rise); the linear axes following the sphere approach each point in the direction
//! they move there.

use std::path::PathBuf;

use nalgebra::Vector3;
use serde::Deserialize;

use super::measured::{Measured, Unit};
use super::uncertainty::with_uncertainty;
use super::{
    check_count, default_pose, direction_of, figure, parameter, range_of, read_profile, Setup,
    StandardsError, TestResult,
};
use crate::limits::MAX_TEST_POINTS;
use crate::model::inputs::Approach;
use crate::model::AxisLetter;

/// How far back along the sweep (degrees) a linear axis's direction is read.
const LOOK_BACK_DEG: f64 = 0.01;

/// The R-test of a rotary axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RTestSpec {
    /// The rotary axis under test: A, B or C.
    pub axis: String,
    /// The sphere's centre in the workpiece frame (commanded coordinates at the pose); default:
    /// where the tool tip is at the middle of the linear travels, if the linear axes can follow
    /// it over the sweep, else the nearest sphere they can follow (`default_sphere`).
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
    let measured = read_rtest(spec)?;
    with_uncertainty(setup, |s| rtest_with(s, spec, measured.as_ref()))?.finite()
}

/// An R-test's measured results, where the spec names a file.
pub(crate) fn read_rtest(spec: &RTestSpec) -> Result<Option<Measured>, StandardsError> {
    spec.csv
        .as_deref()
        .map(|p| read_profile(p, ("angle", Unit::Angle), &["dX", "dY", "dZ"]))
        .transpose()
}

/// [`rtest`] with the measured results already read (a fit runs the test many times).
pub(crate) fn rtest_with(
    setup: &Setup,
    spec: &RTestSpec,
    measured: Option<&Measured>,
) -> Result<TestResult, StandardsError> {
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
    let axis = setup.machine().axis(letter).ok_or_else(|| {
        parameter(format!(
            "the machine (chain {}) has no {letter} axis",
            setup.machine().chain.hwang_notation()
        ))
    })?;
    let angles: Vec<f64> = match measured {
        Some(m) => m.columns[0].clone(),
        None => {
            let from = spec.from_deg.unwrap_or(axis.range[0]);
            let to = spec.to_deg.unwrap_or(axis.range[1]);
            if !(spec.step_deg > 0.0 && from.is_finite() && to.is_finite() && to >= from) {
                return Err(parameter(format!(
                    "angles from {from}° to {to}° in steps of {}°: the step must be positive, the ends finite and the end not below the start",
                    spec.step_deg
                )));
            }
            // Halves: the span of two finite ends may overflow, its half does not.
            let steps = ((to / 2.0 - from / 2.0) / spec.step_deg * 2.0 + 1e-9).floor();
            let angles = check_count(
                "from_deg, to_deg and step_deg",
                "angles",
                steps + 1.0,
                MAX_TEST_POINTS,
            )?;
            (0..angles)
                .map(|i| from + i as f64 * spec.step_deg)
                .collect()
        }
    };
    let sphere = match spec.sphere_mm {
        Some(s) => Vector3::from(s),
        None => default_sphere(setup, letter, &angles)?,
    };
    let mut curves: Vec<Vec<f64>> = vec![Vec::new(); 3];
    let command_at = |angle: f64| {
        let mut command = setup.pose;
        command[letter.index()] = angle;
        setup.nominal_command_for_tip(sphere, &command)
    };
    let mut moving = vec![letter];
    for (row, &angle) in angles.iter().enumerate() {
        // With measurements the angles are the file's: an angle the test cannot take names
        // its line.
        let at_row = |e: StandardsError| match measured {
            Some(m) => m.error(row, e.to_string()),
            None => e,
        };
        let command = command_at(angle).map_err(at_row)?;
        setup
            .check_travel(
                &command,
                &format!("R-test of {letter} at {letter}={angle}°"),
            )
            .map_err(at_row)?;
        // The rotary axis turns `+` (angles rising); each linear axis moves the way its command
        // changed over the last LOOK_BACK_DEG of the sweep (at a turning point: the way it
        // arrived); one whose command does not change approaches as the inputs say.
        let before = command_at(angle - LOOK_BACK_DEG).map_err(at_row)?;
        let mut directions = [None; 6];
        directions[letter.index()] = Some(Approach::Positive);
        for linear in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
            let i = linear.index();
            let change = command[i] - before[i];
            if change.abs() > 1e-12 * (1.0 + command[i].abs()) {
                directions[i] = Some(direction_of(change, 0.0));
                if !moving.contains(&linear) {
                    moving.push(linear);
                }
            }
        }
        let ve = setup.deviation(&command, &directions).volumetric_mm;
        let reading = -(setup.twin().ideal_rotation(&command).transpose() * ve);
        for d in 0..3 {
            curves[d].push(reading[d]);
        }
    }
    moving.sort();
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
        ballbar: None,
        unit: super::ErrorUnit::Mm,
        title: format!(
            "R-test of {letter}: sphere at ({}, {}, {}) mm (workpiece frame)",
            crate::report::numbers::length(sphere.x),
            crate::report::numbers::length(sphere.y),
            crate::report::numbers::length(sphere.z)
        ),
        position_label: format!("{letter} (deg)"),
        positions: angles,
        curve_names: vec!["dX".into(), "dY".into(), "dZ".into()],
        predicted: curves,
        measured: measured_curves,
        predicted_u: None,
        measured_2s: None,
        figures,
        polar: None,
        inputs: setup.describe_inputs(&moving, "from the sweep"),
        moving_axes: moving.iter().map(|l| l.as_char()).collect(),
    })
}

/// Fractions of each linear travel the default sphere is looked for at, the middle first.
const SPHERE_FRACTIONS: [f64; 7] = [0.5, 0.375, 0.625, 0.25, 0.75, 0.125, 0.875];

/// The default sphere: the tool tip at mid-travel where the linear axes can follow it over every
/// angle of the sweep; else the tip at the nearest point of a grid over the travels (the
/// fractions above of each) that they can follow. None: the error of the mid-travel sphere,
/// with what to give instead.
fn default_sphere(
    setup: &Setup,
    letter: AxisLetter,
    angles: &[f64],
) -> Result<Vector3<f64>, StandardsError> {
    let (lo, hi) = setup.travel_box()?;
    let reachable = |sphere: Vector3<f64>| -> Result<(), StandardsError> {
        for &angle in angles {
            let mut command = setup.pose;
            command[letter.index()] = angle;
            let command = setup.nominal_command_for_tip(sphere, &command)?;
            setup.check_travel(
                &command,
                &format!("R-test of {letter} at {letter}={angle}°"),
            )?;
        }
        Ok(())
    };
    let mut candidates = Vec::new();
    for fx in SPHERE_FRACTIONS {
        for fy in SPHERE_FRACTIONS {
            for fz in SPHERE_FRACTIONS {
                let f = Vector3::new(fx, fy, fz);
                let at = lo + (hi - lo).component_mul(&f);
                let distance = (f - Vector3::repeat(0.5)).norm();
                candidates.push((distance, setup.twin().ideal_tip(&setup.command(at))));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mid = candidates[0].1;
    let first = reachable(mid);
    if first.is_ok() {
        return Ok(mid);
    }
    // A sphere on a table's axis stays put while the axis turns: its commands half a turn apart
    // average to the axis, so spheres between the mid-travel one and the axis follow circles
    // the travels may hold, the largest first.
    let mut toward_axis = Vec::new();
    let mut half_turn = setup.pose;
    half_turn[letter.index()] += 180.0;
    if let (Ok(here), Ok(there)) = (
        setup.nominal_command_for_tip(mid, &setup.pose),
        setup.nominal_command_for_tip(mid, &half_turn),
    ) {
        let mut centre = setup.pose;
        for d in 0..3 {
            centre[d] = (here[d] + there[d]) / 2.0;
        }
        let on_axis = setup.twin().ideal_tip(&centre);
        for s in [0.75, 0.5, 0.25, 0.125, 0.0] {
            toward_axis.push(on_axis + (mid - on_axis) * s);
        }
    }
    for sphere in toward_axis
        .into_iter()
        .chain(candidates[1..].iter().map(|c| c.1))
    {
        if reachable(sphere).is_ok() {
            return Ok(sphere);
        }
    }
    let why = first.err().map(|e| e.to_string()).unwrap_or_default();
    Err(parameter(format!(
        "no sphere at {} points over the travels can be followed over the whole sweep ({why}): give the sphere (sphere_mm) or fewer angles (from_deg, to_deg)",
        candidates.len()
    )))
}
