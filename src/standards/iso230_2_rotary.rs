//! ISO 230-2 positioning of a rotary axis, in arc-seconds, measured against an angle reference
//! (an angular interferometer or an autocollimator with a polygon, or a reference indexing table)
//! set up between the tool side and the workpiece side.
//!
//! The reference reads the error of the relative rotation of tool and workpiece about the axis:
//! at target `θ` of axis `k`, with the linear axes at `at` and the other rotary axes at the pose,
//! `x(θ) = OE(θ)·ω̂(θ) − OE(θ0)·ω̂(θ0)` (zeroed at the first target of the ↑ run), where `OE` is
//! the orientation error of the tool relative to the workpiece (docs/model.md, workpiece frame)
//! and `ω̂` the unit direction about which the ideal tool turns relative to the workpiece when
//! `k` turns `+` (from `R_ideal(θ + 1°) R_ideal(θ)ᵀ`, exact for the ideal machine). Since every
//! axis's transform is the motion of the tool relative to the workpiece (docs/model.md,
//! "Meaning"), a positive error of the axis's own angular component (`ECC` for C) is a positive
//! reading, on the table and on the head alike: the axis turned beyond its target. The ↑ runs
//! approach every target with `k` turning `+`, the ↓ runs `−`; the figures are ISO 230-2's (see
//! [`super::iso230_2`]) in arc-seconds.

use std::path::Path;

use nalgebra::Vector3;

use super::iso230_2::{positioning_from, positioning_result, PositioningData, PositioningSpec};
use super::measured::{Measured, Unit};
use super::{check_count, parameter, ErrorUnit, Setup, StandardsError, TestResult, ARCSEC_PER_RAD};
use crate::limits::{MAX_RUNS, MAX_TEST_POINTS};
use crate::model::inputs::Approach;
use crate::model::AxisLetter;
use crate::reference::rotation_vector;

/// Reads a rotary positioning test's measured runs: columns `target_deg, direction, run,
/// deviation_arcsec` (or `deviation_urad`), rows of a run in the order of approach.
pub fn read_rotary_positioning(path: &Path) -> Result<PositioningData, StandardsError> {
    let m = Measured::read(
        path,
        &[
            ("target", Unit::Angle),
            ("direction", Unit::None),
            ("run", Unit::None),
            ("deviation", Unit::SmallAngle),
        ],
    )?;
    positioning_from(&m)
}

/// The default targets over a rotary axis's range `[a, b]` (degrees): every 30° at most, at
/// least 5, ends included (a full turn: 0°, 30°, …, 360°).
fn default_targets(a: f64, b: f64) -> f64 {
    (((b - a) / 30.0).ceil() + 1.0).max(5.0)
}

pub(super) fn rotary_positioning_with(
    setup: &Setup,
    spec: &PositioningSpec,
    letter: AxisLetter,
    measured: Option<&PositioningData>,
) -> Result<TestResult, StandardsError> {
    let axis = setup.machine().axis(letter).ok_or_else(|| {
        parameter(format!(
            "the machine (chain {}) has no {letter} axis",
            setup.machine().chain.hwang_notation()
        ))
    })?;
    let [a, b] = axis.range;
    let targets: Vec<f64> = match measured {
        Some(data) => data
            .targets_mm
            .iter()
            .map(|&t| super::clamp_to_ends(t, a, b).unwrap_or(t))
            .collect(),
        None => {
            let count = spec
                .targets
                .map_or_else(|| default_targets(a, b), |n| n as f64);
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
    let (lo, hi) = setup.travel_box()?;
    let at = spec.at_mm.map_or((lo + hi) / 2.0, Vector3::from);
    let mut up_directions = [None; 6];
    up_directions[letter.index()] = Some(Approach::Positive);
    let mut down_directions = [None; 6];
    down_directions[letter.index()] = Some(Approach::Negative);
    let ideal = setup.twin();
    let mut up = Vec::with_capacity(targets.len());
    let mut down = Vec::with_capacity(targets.len());
    for (i, &t) in targets.iter().enumerate() {
        let mut command = setup.command(at);
        command[letter.index()] = t;
        setup
            .check_travel(&command, &format!("positioning of {letter}, target {t}°"))
            .map_err(|e| match measured {
                Some(data) => data.at_target(i, e),
                None => e,
            })?;
        let mut turned = command;
        turned[letter.index()] += 1.0;
        let turn = ideal.ideal_rotation(&turned) * ideal.ideal_rotation(&command).transpose();
        let about = rotation_vector(&turn).normalize();
        let reading = |directions| {
            setup
                .deviation(&command, directions)
                .orientation_rad
                .dot(&about)
                * ARCSEC_PER_RAD
        };
        up.push(reading(&up_directions));
        down.push(reading(&down_directions));
    }
    Ok(positioning_result(
        setup,
        spec,
        letter,
        (targets, up, down),
        measured,
        (
            format!("ISO 230-2 positioning of rotary axis {letter}, against an angle reference"),
            format!("target {letter} (deg)"),
        ),
        ErrorUnit::Arcsec,
    ))
}
