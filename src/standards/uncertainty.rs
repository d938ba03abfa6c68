//! The standard uncertainty of a test's predicted curves and figures from the standard
//! uncertainties of the machine's error values (docs/model.md, "Uncertainty of the error values").
//!
//! First order (GUM), as for features ([`crate::part::uncertainty`]): the test is run again on
//! the machine perturbed by `±d` along each direction `d` of the covariance
//! ([`Uncertainty::directions`](crate::model::uncertainty::Uncertainty::directions): `±u_i` for an independent quantity, `±` a column of the Cholesky
//! factor of a correlated group), the step of the reference's [`crate::reference::Propagation`],
//! and `u²(Y) = Σ_d ((Y(+d) − Y(−d))/2)²` for every point of every curve and every figure. The
//! same positions and the same measured results serve every run. A figure that is an extreme or a
//! range (ISO 230-2's A, E, M, R; a circle's G, F max, F min) gets the derivative of its value
//! where the extreme points stay the same over `±u`: first order there, not where two points tie.

use rayon::prelude::*;

use super::{parameter, Setup, StandardsError, TestResult};

/// `run` on `setup`, with every predicted curve's and figure's standard uncertainty where the
/// machine has any `u` (and `setup` is not itself a perturbed copy); without, `run`'s result as
/// it is.
pub(crate) fn with_uncertainty(
    setup: &Setup,
    run: impl Fn(&Setup) -> Result<TestResult, StandardsError> + Sync,
) -> Result<TestResult, StandardsError> {
    let mut result = run(setup)?;
    let uncertainty = &setup.machine().uncertainty;
    if uncertainty.is_empty() || setup.is_perturbed() {
        return Ok(result);
    }
    let directions = uncertainty.directions().map_err(|e| {
        parameter(format!(
            "the machine's covariance matrix is not positive semi-definite ({} entries at fault)",
            e.pairs.len()
        ))
    })?;
    // One direction's half differences: its contribution, `(Y(+d) − Y(−d))/2`, to every value.
    let halves = directions
        .par_iter()
        .map(|d| {
            let minus: Vec<f64> = d.iter().map(|x| -x).collect();
            let plus = run(&setup.perturbed(d))?;
            let minus = run(&setup.perturbed(&minus))?;
            Ok(half_differences(&result, &plus, &minus))
        })
        .collect::<Result<Vec<_>, StandardsError>>()?;
    let mut curves: Vec<Vec<f64>> = result
        .predicted
        .iter()
        .map(|c| vec![0.0; c.len()])
        .collect();
    let mut figures = vec![0.0; result.figures.len()];
    for half in &halves {
        let (half_curves, half_figures) = half.as_ref().map_err(|what| {
            parameter(format!(
                "{}: {what} on the machine moved by its uncertainty, so no uncertainty follows",
                result.title
            ))
        })?;
        for (sum, half) in curves.iter_mut().zip(half_curves) {
            for (s, h) in sum.iter_mut().zip(half) {
                *s += h * h;
            }
        }
        for (s, h) in figures.iter_mut().zip(half_figures) {
            *s += h * h;
        }
    }
    result.predicted_u = Some(
        curves
            .into_iter()
            .map(|c| c.into_iter().map(f64::sqrt).collect())
            .collect(),
    );
    for (figure, variance) in result.figures.iter_mut().zip(figures) {
        figure.predicted_u = Some(variance.sqrt());
    }
    Ok(result)
}

/// `(Y(+d) − Y(−d))/2` of every point of every curve and every figure; where the perturbed runs
/// do not have the nominal's shape (a count of points or figures that changed), what differs.
#[allow(clippy::type_complexity)]
fn half_differences(
    nominal: &TestResult,
    plus: &TestResult,
    minus: &TestResult,
) -> Result<(Vec<Vec<f64>>, Vec<f64>), String> {
    for run in [plus, minus] {
        let same_curves = run.predicted.len() == nominal.predicted.len()
            && run
                .predicted
                .iter()
                .zip(&nominal.predicted)
                .all(|(a, b)| a.len() == b.len());
        if !same_curves {
            return Err("the curves have other points".into());
        }
        let same_figures = run.figures.len() == nominal.figures.len()
            && run
                .figures
                .iter()
                .zip(&nominal.figures)
                .all(|(a, b)| a.name == b.name);
        if !same_figures {
            return Err("the figures differ".into());
        }
    }
    let curves = plus
        .predicted
        .iter()
        .zip(&minus.predicted)
        .map(|(p, m)| p.iter().zip(m).map(|(p, m)| 0.5 * (p - m)).collect())
        .collect();
    let figures = plus
        .figures
        .iter()
        .zip(&minus.figures)
        .map(|(p, m)| 0.5 * (p.predicted - m.predicted))
        .collect();
    Ok((curves, figures))
}
