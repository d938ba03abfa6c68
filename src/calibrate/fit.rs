//! `volmap fit`: location and spindle errors of a machine, and their thermal coefficients,
//! estimated from standard-test measurements by least squares.
//!
//! The unknowns are location errors `E?0k` (the squareness errors `EC0Y EB0Z EA0Z` of a 3-axis
//! machine; `EX0C EY0C EA0C EB0C` of a rotary axis from R-tests, …), spindle errors `E?S`, and
//! the coefficient per kelvin of either for one declared thermal input (`EC0Y.per_kelvin.hall`,
//! see [`Unknown`]); everything else in the machine file stays as it is. Each test of the fit file
//! may give the temperatures it was measured at (`temperatures = { hall = 26.0 }`) and is
//! predicted at them. The residuals are measured minus predicted, point by point, over every
//! curve of every test, with what the instruments cannot know taken out: each curve's mean (a
//! laser's or a probe's zero) and, for circular tests, the least-squares circle (the ballbar's
//! length and its centring). Gauss-Newton with central-difference derivatives of the f64
//! reference; the uncertainty of each estimate is the square root of the diagonal of
//! `σ²·(JᵀJ)⁻¹`, with `σ²` the residual sum of squares over the degrees of freedom (points
//! minus unknowns minus the removed zeros and circles).

use nalgebra::{DMatrix, DVector};

use super::ballbar_figures::BallbarFigures;
pub use super::fit_file::{Entry, FitFile};
use super::identifiability::identifiability;
pub use super::identifiability::Identifiability;
pub use super::unknowns::Unknown;
use super::CalibrateError;
use crate::io::machine_file::{
    MAX_PLAUSIBLE_ANGLE_RAD, MAX_PLAUSIBLE_LENGTH_MM, PLAUSIBLE_TEMPERATURE_CHANGE_K,
};
use crate::model::inputs::Inputs;
use crate::model::Machine;
use crate::standards::iso230_2::PositioningData;
use crate::standards::iso230_4::{circular_with, read_circular};
use crate::standards::iso230_6::{diagonal_with, read_diagonal};
use crate::standards::measured::Measured;
use crate::standards::positioning::positioning_with;
use crate::standards::rtest::{read_rtest, rtest_with};
use crate::standards::{
    least_squares_circle, read_positioning_of, CircularSpec, DiagonalSpec, PositioningSpec,
    RTestSpec, Setup, StandardsError, TestResult,
};

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub name: String,
    pub unit: String,
    pub initial: f64,
    pub value: f64,
    /// One standard uncertainty.
    pub uncertainty: f64,
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct FitReport {
    pub estimates: Vec<Estimate>,
    /// Measured points used.
    pub points: usize,
    /// Points minus unknowns minus removed zeros and circles.
    pub degrees_of_freedom: usize,
    /// RMS of the residuals with the machine as given, and with the estimates, mm.
    pub rms_before_mm: f64,
    pub rms_after_mm: f64,
    /// What the measurements can see of each estimate (figures in the order of `estimates`).
    pub identifiability: Identifiability,
    /// The covariance of the estimates, `σ²(JᵀJ)⁻¹`, in the order of `estimates` (the products of
    /// their units): its diagonal is the square of each `uncertainty`.
    pub covariance: Vec<Vec<f64>>,
    #[serde(skip)]
    pub machine: Machine,
}

/// One test of the file with its measured results, read once, ready to run on any version of
/// the machine at the inputs it was measured at.
struct Test<'a> {
    kind: Kind<'a>,
    inputs: Inputs,
    /// The fit file and where the test is in it (`[[circular]] number 2`), for errors.
    file: &'a str,
    key: &'a str,
}

enum Kind<'a> {
    Positioning(&'a PositioningSpec, PositioningData),
    Diagonal(&'a DiagonalSpec, Measured),
    Circular(&'a CircularSpec, Measured),
    Rotary(&'a RTestSpec, Measured),
    Ballbar(&'a BallbarFigures),
}

/// An error of the test at `key` of the fit file `file`, naming both.
fn in_entry<E: Into<CalibrateError>>(file: &str, key: &str) -> impl FnOnce(E) -> CalibrateError {
    let (file, key) = (file.to_string(), key.to_string());
    move |e| CalibrateError::Entry {
        file,
        key,
        source: Box::new(e.into()),
    }
}

impl Test<'_> {
    /// The test's result on `machine`; an error names the test.
    fn result(&self, machine: &Machine) -> Result<TestResult, CalibrateError> {
        self.run(machine).map_err(in_entry(self.file, self.key))
    }

    fn run(&self, machine: &Machine) -> Result<TestResult, StandardsError> {
        let pose = match &self.kind {
            Kind::Positioning(s, _) => &s.pose,
            Kind::Diagonal(s, _) => &s.pose,
            Kind::Circular(s, _) => &s.pose,
            Kind::Rotary(s, _) => &s.pose,
            Kind::Ballbar(s) => &s.pose,
        };
        let setup = Setup::with_inputs(machine, pose, &self.inputs)?;
        match &self.kind {
            Kind::Positioning(s, m) => positioning_with(&setup, s, Some(m)),
            Kind::Diagonal(s, m) => diagonal_with(&setup, s, Some(m)),
            Kind::Circular(s, m) => circular_with(&setup, s, Some(m)),
            Kind::Rotary(s, m) => rtest_with(&setup, s, Some(m)),
            Kind::Ballbar(s) => s.run(&setup),
        }
    }

    /// The nuisance parameters taken out of each curve: 3 for a circle, none for ballbar
    /// figures (the diagnostics took the ballbar's length and centring out already), else 1.
    fn nuisance_per_curve(&self) -> usize {
        match self.kind {
            Kind::Circular(..) => 3,
            Kind::Ballbar(..) => 0,
            _ => 1,
        }
    }
}

/// Measured minus predicted, with each curve's zero (or circle) taken out, and the number of
/// parameters so taken out.
fn residuals(tests: &[Test], machine: &Machine) -> Result<(Vec<f64>, usize), CalibrateError> {
    let mut all = Vec::new();
    let mut nuisance = 0;
    for test in tests {
        let result = test.result(machine)?;
        let measured = result
            .measured
            .as_ref()
            .expect("fit tests carry measurements");
        for (m, p) in measured.iter().zip(&result.predicted) {
            nuisance += test.nuisance_per_curve();
            let difference: Vec<f64> = m.iter().zip(p).map(|(a, b)| a - b).collect();
            if test.nuisance_per_curve() == 3 {
                let circle = least_squares_circle(&result.positions, &difference)
                    .map_err(in_entry(test.file, test.key))?;
                all.extend(circle.1);
            } else if test.nuisance_per_curve() == 0 {
                all.extend(difference);
            } else {
                let mean = difference.iter().sum::<f64>() / difference.len() as f64;
                all.extend(difference.iter().map(|d| d - mean));
            }
        }
    }
    Ok((all, nuisance))
}

fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

/// Fits the unknowns the file names to its tests. An error of the estimation itself (unknowns
/// the tests cannot tell apart, too few points, estimates no machine can have) names the file
/// and its `estimate`.
pub fn fit(machine: &Machine, file: &FitFile) -> Result<FitReport, CalibrateError> {
    let unknowns = file.unknowns(machine)?;
    let tests = read_tests(file, machine)?;
    estimate(machine, &unknowns, &tests).map_err(|e| match e {
        CalibrateError::Parameter(message) => file.key_error("estimate", message),
        other => other,
    })
}

fn estimate(
    machine: &Machine,
    unknowns: &[Unknown],
    tests: &[Test],
) -> Result<FitReport, CalibrateError> {
    let (before, nuisance) = residuals(tests, machine)?;
    let points = before.len();
    let k = unknowns.len();
    let dof = points.checked_sub(k + nuisance).filter(|&d| d > 0).ok_or_else(|| {
        CalibrateError::Parameter(format!(
            "{points} measured points cannot determine {k} unknowns besides {nuisance} zeros and circles"
        ))
    })?;
    // Each coefficient's step is scaled to the widest temperature difference of its input.
    let steps: Vec<f64> = unknowns
        .iter()
        .map(|u| u.step(temperature_span(u, tests, machine)))
        .collect();
    let (current, r, j) = gauss_newton(machine, tests, unknowns, &steps, before.clone())?;
    let identifiability = identifiability(&j, unknowns, machine)?;
    let sigma2 = r.norm_squared() / dof as f64;
    let normal = j.transpose() * &j;
    let covariance = normal
        .try_inverse()
        .ok_or_else(|| CalibrateError::Parameter("the normal equations are singular".into()))?
        * sigma2;
    for u in unknowns {
        check_plausible(u, u.get(&current))?;
    }
    let estimates = unknowns
        .iter()
        .enumerate()
        .map(|(c, u)| Estimate {
            name: u.name(),
            unit: u.unit().into(),
            initial: u.get(machine),
            value: u.get(&current),
            uncertainty: covariance[(c, c)].max(0.0).sqrt(),
        })
        .collect();
    Ok(FitReport {
        estimates,
        points,
        degrees_of_freedom: dof,
        rms_before_mm: rms(&before),
        rms_after_mm: rms(r.as_slice()),
        identifiability,
        covariance: (0..k)
            .map(|a| (0..k).map(|b| covariance[(a, b)]).collect())
            .collect(),
        machine: current,
    })
}

/// Refuses an estimate no machine file may hold: the measurements do not fit the machine (a unit
/// mistake, a test of another machine, a file of another test).
fn check_plausible(unknown: &Unknown, value: f64) -> Result<(), CalibrateError> {
    let largest = if unknown.target.is_angular() {
        MAX_PLAUSIBLE_ANGLE_RAD
    } else {
        MAX_PLAUSIBLE_LENGTH_MM
    };
    let largest = match unknown.per_kelvin {
        None => largest,
        Some(_) => largest / PLAUSIBLE_TEMPERATURE_CHANGE_K,
    };
    if value.is_finite() && value.abs() <= largest {
        return Ok(());
    }
    Err(CalibrateError::Parameter(format!(
        "the estimate of {} is {} {unit}, more than any machine tool has (at most {largest:e} {unit}): the measurements do not fit this machine (their units? another machine's tests?)",
        unknown.name(),
        crate::error::shown(value),
        unit = unknown.unit()
    )))
}

/// The largest `|T − reference_C|` of a coefficient's input over the tests, K (0 for a value).
fn temperature_span(unknown: &Unknown, tests: &[Test], machine: &Machine) -> f64 {
    let (Some((_, input)), Some(thermal)) = (&unknown.per_kelvin, &machine.thermal) else {
        return 0.0;
    };
    tests
        .iter()
        .map(|t| (t.inputs.temperature_c(input, thermal.reference_c) - thermal.reference_c).abs())
        .fold(0.0, f64::max)
}

/// Every test of the file with its measured results, read once, and its inputs on `machine`.
fn read_tests<'a>(file: &'a FitFile, machine: &Machine) -> Result<Vec<Test<'a>>, CalibrateError> {
    let missing = |key: &str| file.key_error(key, "give the measured results (`csv = \"...\"`)");
    let mut tests: Vec<Test> = Vec::new();
    let mut push = |kind: Kind<'a>, key: &'a str, inputs: Inputs| {
        tests.push(Test {
            kind,
            inputs,
            file: &file.file,
            key,
        })
    };
    for e in &file.positioning {
        let data = read_positioning_of(&e.spec).map_err(in_entry(&file.file, &e.key))?;
        let data = data.ok_or_else(|| missing(&e.key))?;
        push(
            Kind::Positioning(&e.spec, data),
            &e.key,
            file.inputs_of(e, machine)?,
        );
    }
    for e in &file.diagonal {
        let m = read_diagonal(&e.spec).map_err(in_entry(&file.file, &e.key))?;
        let m = m.ok_or_else(|| missing(&e.key))?;
        push(
            Kind::Diagonal(&e.spec, m),
            &e.key,
            file.inputs_of(e, machine)?,
        );
    }
    for e in &file.circular {
        let m = read_circular(&e.spec).map_err(in_entry(&file.file, &e.key))?;
        let m = m.ok_or_else(|| missing(&e.key))?;
        push(
            Kind::Circular(&e.spec, m),
            &e.key,
            file.inputs_of(e, machine)?,
        );
    }
    for e in &file.rtest {
        let m = read_rtest(&e.spec).map_err(in_entry(&file.file, &e.key))?;
        let m = m.ok_or_else(|| missing(&e.key))?;
        push(
            Kind::Rotary(&e.spec, m),
            &e.key,
            file.inputs_of(e, machine)?,
        );
    }
    for e in &file.ballbar {
        if e.spec.is_empty() {
            return Err(file.key_error(
                &e.key,
                "give a figure to fit: squareness_urad, scale_mismatch_ppm or backlash_um",
            ));
        }
        push(Kind::Ballbar(&e.spec), &e.key, file.inputs_of(e, machine)?);
    }
    if tests.is_empty() {
        return Err(CalibrateError::Parameter(format!(
            "{}: no measurements: add [[diagonal]], [[circular]], [[ballbar]], [[rtest]] or [[positioning]] tables",
            file.file
        )));
    }
    Ok(tests)
}

/// Gauss-Newton from the machine as given, with central-difference derivatives: the machine
/// with the estimates, the residuals there and their Jacobian in the unknowns.
fn gauss_newton(
    machine: &Machine,
    tests: &[Test],
    unknowns: &[Unknown],
    steps: &[f64],
    before: Vec<f64>,
) -> Result<(Machine, DVector<f64>, DMatrix<f64>), CalibrateError> {
    let points = before.len();
    let jacobian_at = |m: &Machine| -> Result<DMatrix<f64>, CalibrateError> {
        let mut j = DMatrix::zeros(points, unknowns.len());
        for (c, u) in unknowns.iter().enumerate() {
            let (value, h) = (u.get(m), steps[c]);
            let mut plus = m.clone();
            u.set(&mut plus, value + h);
            let mut minus = m.clone();
            u.set(&mut minus, value - h);
            let (rp, rm) = (residuals(tests, &plus)?.0, residuals(tests, &minus)?.0);
            for r in 0..points {
                // r = measured − predicted, so ∂predicted/∂p = −∂r/∂p.
                j[(r, c)] = -(rp[r] - rm[r]) / (2.0 * h);
            }
        }
        Ok(j)
    };
    let mut current = machine.clone();
    let mut r = DVector::from_vec(before);
    let mut j = jacobian_at(&current)?;
    for _ in 0..10 {
        identifiability(&j, unknowns, machine)?;
        let step = j
            .clone()
            .svd(true, true)
            .solve(&r, 1e-14)
            .map_err(|e| CalibrateError::Parameter(e.to_string()))?;
        for (c, u) in unknowns.iter().enumerate() {
            let value = u.get(&current);
            u.set(&mut current, value + step[c]);
        }
        r = DVector::from_vec(residuals(tests, &current)?.0);
        j = jacobian_at(&current)?;
        let small = unknowns
            .iter()
            .enumerate()
            .all(|(c, _)| step[c].abs() <= 1e-6 * steps[c]);
        if small {
            break;
        }
    }
    Ok((current, r, j))
}

/// The machine file with the estimates written in: the original file, comments, order and all,
/// with each estimated error set with its standard uncertainty, `{ value = …, u = … }` (a thermal
/// coefficient the same inside `per_kelvin`), and the covariance of every pair of estimates in
/// `[covariance]` (pairs the file gave that name an estimate are dropped: the fit replaces what
/// was known of it). Each estimate is written to the decimal place of a thousandth of its standard
/// uncertainty (rounding moves it by less than 0.05 % of the uncertainty; digits below carry
/// nothing the measurements know), and every number to at most [`super::SIGNIFICANT_DIGITS`]
/// significant digits.
pub fn fitted_machine_toml(
    machine: &Machine,
    report: &FitReport,
) -> Result<String, CalibrateError> {
    let mut document: toml_edit::DocumentMut = machine.source.toml.parse().map_err(|e| {
        CalibrateError::Parameter(format!("the machine's own file does not parse again: {e}"))
    })?;
    let estimates = &report.estimates;
    let values = estimates
        .iter()
        .map(|e| {
            Unknown::parse(&e.name, machine)
                .map(|u| {
                    let value = super::rounded(e.value, e.uncertainty * 1e-3);
                    (u, value, super::rounded(e.uncertainty, 0.0))
                })
                .map_err(CalibrateError::Parameter)
        })
        .collect::<Result<Vec<_>, _>>()?;
    super::unknowns::write_into(&mut document, &values).map_err(CalibrateError::Parameter)?;
    let names: Vec<String> = values.iter().map(|(u, ..)| u.quantity()).collect();
    let mut pairs = Vec::new();
    for a in 0..names.len() {
        for b in a + 1..names.len() {
            let c = report.covariance.get(a).and_then(|row| row.get(b)).copied();
            // An estimate with no uncertainty (a perfect fit) is exact: it has no covariance.
            if let Some(c) = c.filter(|_| values[a].2 > 0.0 && values[b].2 > 0.0) {
                pairs.push((format!("{} {}", names[a], names[b]), c));
            }
        }
    }
    super::unknowns::write_covariance(&mut document, &names, &pairs)
        .map_err(CalibrateError::Parameter)?;
    Ok(document.to_string())
}
