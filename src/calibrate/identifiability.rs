//! What the measurements of a fit can see: for every unknown, how strongly the readings move
//! with it and how much of that no other unknown (nor an instrument's zero or a ballbar's
//! centring, already taken out of the residuals) can imitate. All figures come from the
//! Jacobian `J` of the readings in the unknowns, so they depend on the machine model, the tests'
//! positions and their number, never on the measured deviations (like the valuation numbers of
//! Heidenhain's KinematicsOpt, TNC 640 cycle programming manual, cycle 451, "Notes on log data").
//!
//! - sensitivity `s_c = ‖J_c‖ / √n`: the RMS change of the `n` readings per unit of unknown `c`
//!   (mm per mm, mm per rad, mm per unit per kelvin);
//! - independence `ι_c = 1 / √((Ĵᵀ Ĵ)⁻¹_cc)`, with `Ĵ` the columns of `J` scaled to unit norm:
//!   1 where no combination of the other unknowns moves the readings alike, 0 where one does
//!   (`1 − ι_c²` is the `R²` of unknown `c`'s column on the others);
//! - correlation `ρ_ij = (JᵀJ)⁻¹_ij / √((JᵀJ)⁻¹_ii (JᵀJ)⁻¹_jj)` of the estimates;
//! - condition number of `Ĵ`: its largest over its smallest singular value;
//! - valuation `v_c = Δ_c / u_c(1 µm)`: a typical size `Δ_c` of the unknown ([`typical_size`]) in
//!   standard uncertainties, if the instruments scattered 1 µm, `u_c(σ) = σ / (‖J_c‖ ι_c)`;
//!   below [`VALUATION_WEAK`] the tests barely resolve a change of that size.
//!
//! A fit is refused for an unknown a typical change of which moves the readings by less than
//! [`INVISIBLE_MM`] (it cannot be told from zero), and for two unknowns whose estimates correlate
//! beyond [`CORRELATED`] (they cannot be told from each other).

use nalgebra::DMatrix;

use super::unknowns::Unknown;
use super::CalibrateError;
use crate::model::perturbation::ErrorTarget;
use crate::model::Machine;

/// A typical change of an unknown that moves the readings by less than this (mm, RMS: 1 nm, the
/// resolution of a laser interferometer) is not seen. A location error of a linear axis still
/// moves the readings of a machine with angular errors a little (it changes their lever arms by
/// 1 µm in hundreds of mm): a fit on that alone would return estimates of tenths of a mm.
pub const INVISIBLE_MM: f64 = 1e-6;
/// Estimates correlated beyond this cannot be told apart.
pub const CORRELATED: f64 = 0.999;
/// Valuations below this are reported as weak (Heidenhain asks for 2 at least, 4 desirable).
pub const VALUATION_WEAK: f64 = 2.0;

/// The identifiability figures of a fit's unknowns.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Identifiability {
    /// Per unknown, in the order of the estimates.
    pub sensitivity: Vec<f64>,
    pub independence: Vec<f64>,
    pub valuation: Vec<f64>,
    /// The typical size each valuation is computed for, in the unknown's unit.
    pub typical_size: Vec<f64>,
    /// `[i][j]`, symmetric, unit diagonal.
    pub correlation: Vec<Vec<f64>>,
    pub condition_number: f64,
}

/// A typical size of an unknown, in its unit: 1 µm for a length, 10 µrad (1 µm over 100 mm) for
/// an angle, and the same per kelvin for a thermal coefficient.
pub fn typical_size(unknown: &Unknown) -> f64 {
    if unknown.target.is_angular() {
        1e-5
    } else {
        1e-3
    }
}

/// The figures of `j` (readings × unknowns), or the reason the unknowns cannot be estimated.
pub fn identifiability(
    j: &DMatrix<f64>,
    unknowns: &[Unknown],
    machine: &Machine,
) -> Result<Identifiability, CalibrateError> {
    let n = j.nrows().max(1) as f64;
    let norms: Vec<f64> = (0..j.ncols()).map(|c| j.column(c).norm()).collect();
    let sizes: Vec<f64> = unknowns.iter().map(typical_size).collect();
    for (c, u) in unknowns.iter().enumerate() {
        let moved = norms[c] / n.sqrt() * sizes[c];
        if moved.is_nan() || moved < INVISIBLE_MM {
            return Err(CalibrateError::Parameter(format!(
                "{} cannot be told from zero: a change of {} {} moves the given measurements by {} RMS; {}",
                u.name(),
                sizes[c],
                u.unit(),
                crate::report::numbers::error_um(moved),
                what_sees(u, machine)
            )));
        }
    }
    let mut scaled = j.clone();
    for (c, norm) in norms.iter().enumerate() {
        scaled.column_mut(c).scale_mut(1.0 / norm);
    }
    let singular = scaled.clone().svd(false, false).singular_values;
    let condition_number = singular.max() / singular.min();
    let inverse = (scaled.transpose() * &scaled).try_inverse();
    let Some(inverse) =
        inverse.filter(|m| m.iter().all(|v| v.is_finite()) && condition_number < 1e12)
    else {
        return Err(alike(unknowns, machine, &scaled));
    };
    let k = unknowns.len();
    let correlation: Vec<Vec<f64>> = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| inverse[(a, b)] / (inverse[(a, a)] * inverse[(b, b)]).sqrt())
                .collect()
        })
        .collect();
    for a in 0..k {
        for b in a + 1..k {
            if correlation[a][b].abs() > CORRELATED {
                return Err(CalibrateError::Parameter(format!(
                    "{} and {} cannot be told apart from these measurements (their estimates correlate {:+.4}): {}; {}",
                    unknowns[a].name(),
                    unknowns[b].name(),
                    correlation[a][b],
                    what_sees(&unknowns[a], machine),
                    what_sees(&unknowns[b], machine)
                )));
            }
        }
    }
    let independence: Vec<f64> = (0..k).map(|c| 1.0 / inverse[(c, c)].sqrt()).collect();
    let valuation = (0..k)
        .map(|c| sizes[c] * norms[c] * independence[c] / 1e-3)
        .collect();
    Ok(Identifiability {
        sensitivity: norms.iter().map(|m| m / n.sqrt()).collect(),
        independence,
        valuation,
        typical_size: sizes,
        correlation,
        condition_number,
    })
}

/// The unknowns a (near) null direction of `scaled` involves, refused together.
fn alike(unknowns: &[Unknown], machine: &Machine, scaled: &DMatrix<f64>) -> CalibrateError {
    let svd = scaled.clone().svd(false, true);
    let row = svd.singular_values.imin();
    let v_t = svd.v_t.as_ref().expect("asked for V");
    let involved: Vec<&Unknown> = unknowns
        .iter()
        .enumerate()
        .filter(|(c, _)| v_t[(row, *c)].abs() > 0.1)
        .map(|(_, u)| u)
        .collect();
    let names: Vec<String> = involved.iter().map(|u| u.name()).collect();
    let hints: Vec<String> = involved.iter().map(|u| what_sees(u, machine)).collect();
    let mut hints_unique = hints.clone();
    hints_unique.dedup();
    CalibrateError::Parameter(format!(
        "{} cannot be told apart from these measurements (together they move them alike): {}",
        names.join(" and "),
        hints_unique.join("; ")
    ))
}

/// Which measurement sees an unknown, in words.
pub fn what_sees(unknown: &Unknown, machine: &Machine) -> String {
    let name = unknown.name();
    if let Some((_, input)) = &unknown.per_kelvin {
        return format!(
            "{name} needs the tests that see its error measured at two or more temperatures of {input}"
        );
    }
    let has_rotary = machine.axes.iter().any(|a| a.letter.index() >= 3);
    match unknown.target {
        ErrorTarget::Location { axis, index } if axis.index() < 3 && index < 3 => {
            if has_rotary {
                format!("{name} offsets the tool tip by a constant, which every laser's zero and ballbar's centring take out: R-tests (or tests) at several positions of a rotary axis see it")
            } else {
                format!("{name} offsets the tool tip by a constant, which every laser's zero and ballbar's centring take out: no test of a machine without rotary axes sees it; leave it out")
            }
        }
        ErrorTarget::Location { axis, index } if axis.index() < 3 => {
            let plane = ["YZ", "ZX", "XY"][index - 3];
            format!(
                "{name} (a squareness or tilt of {axis}) is seen by a diagonal or a circle in the {plane} plane"
            )
        }
        ErrorTarget::Location { axis, .. } => format!(
            "{name} (where rotary axis {axis} lies) is seen by R-tests over a range of {axis} angles at two or more sphere positions"
        ),
        ErrorTarget::Spindle { .. } => format!(
            "{name} (a spindle error) is seen by R-tests or circles at poses that turn the spindle, or with two tool lengths"
        ),
        _ => format!("measure a test that sees {name}"),
    }
}
