//! ISO 230-2 positioning of any axis: the linear test ([`super::iso230_2`]) or the rotary one
//! ([`super::iso230_2_rotary`]), chosen by the axis the spec names.

use super::iso230_2::{
    linear_positioning_with, parse_axis, read_positioning, PositioningData, PositioningSpec,
};
use super::iso230_2_rotary::{read_rotary_positioning, rotary_positioning_with};
use super::uncertainty::with_uncertainty;
use super::{Setup, StandardsError, TestResult};

/// The measured runs a spec names, read in the units of its axis: [`read_positioning`] for a
/// linear axis, `target_deg, direction, run, deviation_arcsec` for a rotary one.
pub fn read_positioning_of(
    spec: &PositioningSpec,
) -> Result<Option<PositioningData>, StandardsError> {
    let Some(path) = spec.csv.as_deref() else {
        return Ok(None);
    };
    if !parse_axis(&spec.axis)?.is_linear() {
        read_rotary_positioning(path).map(Some)
    } else {
        read_positioning(path).map(Some)
    }
}

pub fn positioning(setup: &Setup, spec: &PositioningSpec) -> Result<TestResult, StandardsError> {
    let measured = read_positioning_of(spec)?;
    with_uncertainty(setup, |s| positioning_with(s, spec, measured.as_ref()))?.finite()
}

/// [`positioning`] with the measured runs already read (a fit runs the test many times).
pub(crate) fn positioning_with(
    setup: &Setup,
    spec: &PositioningSpec,
    measured: Option<&PositioningData>,
) -> Result<TestResult, StandardsError> {
    let letter = parse_axis(&spec.axis)?;
    if letter.is_linear() {
        linear_positioning_with(setup, spec, letter, measured)
    } else {
        rotary_positioning_with(setup, spec, letter, measured)
    }
}
