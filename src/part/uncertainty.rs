//! The uncertainty of each feature's error from the standard uncertainties of the machine's
//! error values (docs/model.md, "Uncertainty of the error values"), and the decision by
//! ISO 14253-1 it leaves.
//!
//! First order (GUM): the machine is perturbed along each direction of its quantities'
//! covariance, `±u_i` alone for an independent quantity and `±` each column of the Cholesky
//! factor of a correlated group (`F·Fᵀ = C`), every feature evaluated on each perturbed machine
//! exactly as on the machine itself (the f64 reference at the same cutter positions), and
//! `u²(F) = Σ_d ((F(+d) − F(−d))/2)²`: the central difference over `±d` is the derivative along
//! `d` times its length, and the directions' outer products sum to `C`.

use rayon::prelude::*;
use serde::Serialize;

use super::{cutter_positions, evaluate_at, FeatureError, PartFile};
use crate::model::channels::Sample;
use crate::model::{Machine, MachineSource};
use crate::reference::Twin;

/// The coverage factor of the expanded uncertainty: about 95 % for a normal distribution.
pub const COVERAGE_FACTOR: f64 = 2.0;

/// The decision on a feature's error against its tolerance by ISO 14253-1: its conformance zone
/// is the tolerance shrunk by the expanded uncertainty `U`, its non-conformance zone beyond the
/// tolerance widened by `U`, and between them nothing can be decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Conformance {
    /// `error + U ≤ tolerance`.
    Conforms,
    /// `error − U > tolerance`.
    DoesNotConform,
    /// Neither: the measurements behind the machine's error values cannot decide it.
    Undecided,
}

impl Conformance {
    /// The decision for an error (a width, never negative) with its expanded uncertainty.
    pub fn of(error_mm: f64, u_expanded_mm: f64, tolerance_mm: f64) -> Conformance {
        if error_mm + u_expanded_mm <= tolerance_mm {
            Conformance::Conforms
        } else if error_mm - u_expanded_mm > tolerance_mm {
            Conformance::DoesNotConform
        } else {
            Conformance::Undecided
        }
    }

    /// In words, as the table prints it.
    pub fn words(self) -> &'static str {
        match self {
            Conformance::Conforms => "conforms",
            Conformance::DoesNotConform => "does not conform",
            Conformance::Undecided => "undecided",
        }
    }
}

/// The expanded uncertainty (`k = 2`, mm) of every feature's error, in the order of the part's
/// features, from the machine's uncertain quantities; all zero where it has none. A form or zone
/// value (flatness, cylindricity, a position's zone) gets its uncertainty from the same
/// differences of that value: first order where the worst points stay the same over `±u`.
pub fn expanded_uncertainties(
    part: &PartFile,
    machine: &Machine,
    file: &str,
) -> Result<Vec<f64>, FeatureError> {
    let count = part.features.len();
    if machine.uncertainty.is_empty() {
        return Ok(vec![0.0; count]);
    }
    let directions =
        machine.uncertainty.directions().map_err(|e| FeatureError::Feature {
            file: file.to_string(),
            feature: "(machine)".into(),
            message: format!(
                "the machine's covariance matrix is not positive semi-definite ({} entries at fault)",
                e.pairs.len()
            ),
        })?;
    let tips = cutter_positions(part, file)?;
    let pose = part.pose();
    let commands = tips.commands_at(pose);
    // Each perturbed copy would only carry the files the machine came from along.
    let mut base = machine.clone();
    base.source = MachineSource::default();
    let errors_on = |e: &[f64]| -> Result<Vec<f64>, FeatureError> {
        let twin = Twin::new(base.with_deviations(e));
        let values: Vec<Sample> = commands
            .par_iter()
            .map(|c| {
                let d = twin.deviation(c);
                let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
                [ve.x, ve.y, ve.z, oe.x, oe.y, oe.z]
            })
            .collect();
        let rows = evaluate_at(part, file, &tips, &values)?;
        Ok(rows.into_iter().map(|r| r.error_mm).collect())
    };
    let mut variance = vec![0.0; count];
    for d in &directions {
        let minus: Vec<f64> = d.iter().map(|x| -x).collect();
        let (plus, minus) = (errors_on(d)?, errors_on(&minus)?);
        for (v, (p, m)) in variance.iter_mut().zip(plus.iter().zip(&minus)) {
            *v += (0.5 * (p - m)).powi(2);
        }
    }
    Ok(variance
        .into_iter()
        .map(|v| COVERAGE_FACTOR * v.sqrt())
        .collect())
}
