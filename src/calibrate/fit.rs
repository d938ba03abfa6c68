//! `volmap fit`: location errors of a machine estimated from standard-test measurements by
//! least squares.
//!
//! The unknowns are location errors `E?0k` (the squareness errors `EC0Y EB0Z EA0Z` of a 3-axis
//! machine; `EX0C EY0C EA0C EB0C` of a rotary axis from R-tests, …); everything else in the
//! machine file stays as it is. The residuals are measured minus predicted, point by point, over
//! every curve of every test, with what the instruments cannot know taken out: each curve's mean
//! (a laser's or a probe's zero) and, for circular tests, the least-squares circle (the ballbar's
//! length and its centring). Gauss-Newton with central-difference derivatives of the f64
//! reference; the uncertainty of each estimate is the square root of the diagonal of
//! `σ²·(JᵀJ)⁻¹`, with `σ²` the residual sum of squares over the degrees of freedom (points
//! minus unknowns minus the removed zeros and circles).

use std::path::{Path, PathBuf};

use nalgebra::{DMatrix, DVector};
use serde::Deserialize;

use super::CalibrateError;
use crate::io::read_text;
use crate::model::{AxisLetter, Machine, COMPONENT_NAMES};
use crate::standards::iso230_2::{positioning_with, PositioningData};
use crate::standards::iso230_4::{circular_with, read_circular};
use crate::standards::iso230_6::{diagonal_with, read_diagonal};
use crate::standards::measured::Measured;
use crate::standards::rtest::{read_rtest, rtest_with};
use crate::standards::{
    least_squares_circle, read_positioning, CircularSpec, DiagonalSpec, PositioningSpec, RTestSpec,
    Setup, StandardsError, TestResult,
};

/// The measurements file (TOML): what to estimate and the tests with their measured results.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitFile {
    /// Location errors to estimate, e.g. `["EC0Y", "EB0Z", "EA0Z"]`.
    pub estimate: Vec<String>,
    #[serde(default)]
    pub positioning: Vec<PositioningSpec>,
    #[serde(default)]
    pub diagonal: Vec<DiagonalSpec>,
    #[serde(default)]
    pub circular: Vec<CircularSpec>,
    #[serde(default)]
    pub rtest: Vec<RTestSpec>,
}

impl FitFile {
    /// Reads the file; CSV paths are relative to its folder.
    pub fn read(path: &Path) -> Result<FitFile, CalibrateError> {
        let name = path.display().to_string();
        let text = read_text(path)?;
        let mut file: FitFile =
            toml::from_str(&text).map_err(|e| CalibrateError::Parameter(format!("{name}: {e}")))?;
        let folder = path.parent().unwrap_or(Path::new(""));
        let resolve = |csv: &mut Option<PathBuf>| {
            if let Some(p) = csv {
                *p = folder.join(&*p);
            }
        };
        file.positioning
            .iter_mut()
            .for_each(|s| resolve(&mut s.csv));
        file.diagonal.iter_mut().for_each(|s| resolve(&mut s.csv));
        file.circular.iter_mut().for_each(|s| resolve(&mut s.csv));
        file.rtest.iter_mut().for_each(|s| resolve(&mut s.csv));
        Ok(file)
    }
}

/// A location error: its axis and its index among `EX0k EY0k EZ0k EA0k EB0k EC0k`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LocationError {
    pub axis: AxisLetter,
    pub index: usize,
}

impl LocationError {
    pub fn parse(name: &str, machine: &Machine) -> Result<LocationError, CalibrateError> {
        let c: Vec<char> = name.trim().chars().collect();
        let parsed = match c.as_slice() {
            ['E', component, '0', axis] => COMPONENT_NAMES
                .iter()
                .position(|n| n == component)
                .zip(AxisLetter::from_char(*axis)),
            _ => None,
        };
        let (index, axis) = parsed.ok_or_else(|| {
            CalibrateError::Parameter(format!(
                "`{name}` is not a location error (E, then X Y Z A B C, then 0, then the axis: EC0Y, EX0C)"
            ))
        })?;
        if machine.axis(axis).is_none() {
            return Err(CalibrateError::Parameter(format!(
                "`{name}`: the machine (chain {}) has no {axis} axis",
                machine.chain.hwang_notation()
            )));
        }
        Ok(LocationError { axis, index })
    }

    pub fn name(&self) -> String {
        format!("E{}0{}", COMPONENT_NAMES[self.index], self.axis)
    }

    /// mm for positions, rad for orientations.
    pub fn unit(&self) -> &'static str {
        if self.index < 3 {
            "mm"
        } else {
            "rad"
        }
    }

    fn get(&self, machine: &Machine) -> f64 {
        machine
            .axis(self.axis)
            .map_or(0.0, |a| a.location[self.index])
    }

    fn set(&self, machine: &mut Machine, value: f64) {
        if let Some(a) = machine.axis_mut(self.axis) {
            a.location[self.index] = value;
        }
    }

    /// The step of the central differences.
    fn step(&self) -> f64 {
        if self.index < 3 {
            1e-4
        } else {
            1e-7
        }
    }
}

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
    #[serde(skip)]
    pub machine: Machine,
}

/// One test of the file with its measured results, read once, ready to run on any version of
/// the machine.
enum Test<'a> {
    Positioning(&'a PositioningSpec, PositioningData),
    Diagonal(&'a DiagonalSpec, Measured),
    Circular(&'a CircularSpec, Measured),
    Rotary(&'a RTestSpec, Measured),
}

impl Test<'_> {
    fn run(&self, machine: &Machine) -> Result<TestResult, StandardsError> {
        let pose = match self {
            Test::Positioning(s, _) => &s.pose,
            Test::Diagonal(s, _) => &s.pose,
            Test::Circular(s, _) => &s.pose,
            Test::Rotary(s, _) => &s.pose,
        };
        let setup = Setup::new(machine, pose)?;
        match self {
            Test::Positioning(s, m) => positioning_with(&setup, s, Some(m)),
            Test::Diagonal(s, m) => diagonal_with(&setup, s, Some(m)),
            Test::Circular(s, m) => circular_with(&setup, s, Some(m)),
            Test::Rotary(s, m) => rtest_with(&setup, s, Some(m)),
        }
    }

    /// The nuisance parameters taken out of each curve: 3 for a circle, else 1.
    fn nuisance_per_curve(&self) -> usize {
        match self {
            Test::Circular(..) => 3,
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
        let result = test.run(machine)?;
        let measured = result
            .measured
            .as_ref()
            .expect("fit tests carry measurements");
        for (m, p) in measured.iter().zip(&result.predicted) {
            nuisance += test.nuisance_per_curve();
            let difference: Vec<f64> = m.iter().zip(p).map(|(a, b)| a - b).collect();
            if test.nuisance_per_curve() == 3 {
                all.extend(least_squares_circle(&result.positions, &difference)?.1);
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

pub fn fit(machine: &Machine, file: &FitFile) -> Result<FitReport, CalibrateError> {
    let unknowns: Vec<LocationError> = file
        .estimate
        .iter()
        .map(|n| LocationError::parse(n, machine))
        .collect::<Result<_, _>>()?;
    if unknowns.is_empty() {
        return Err(CalibrateError::Parameter(
            "`estimate` names no location error".into(),
        ));
    }
    let tests = read_tests(file)?;
    let (before, nuisance) = residuals(&tests, machine)?;
    let points = before.len();
    let k = unknowns.len();
    let dof = points.checked_sub(k + nuisance).filter(|&d| d > 0).ok_or_else(|| {
        CalibrateError::Parameter(format!(
            "{points} measured points cannot determine {k} unknowns besides {nuisance} zeros and circles"
        ))
    })?;
    let (current, r, j) = gauss_newton(machine, &tests, &unknowns, before.clone())?;
    let sigma2 = r.norm_squared() / dof as f64;
    let normal = j.transpose() * &j;
    let covariance = normal
        .try_inverse()
        .ok_or_else(|| CalibrateError::Parameter("the normal equations are singular".into()))?
        * sigma2;
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
        machine: current,
    })
}

/// Every test of the file with its measured results, read once.
fn read_tests(file: &FitFile) -> Result<Vec<Test<'_>>, CalibrateError> {
    let missing = |kind: &str, n: usize| {
        CalibrateError::Parameter(format!(
            "[[{kind}]] number {}: give the measured results (`csv = \"...\"`)",
            n + 1
        ))
    };
    let mut tests: Vec<Test> = Vec::new();
    for (n, s) in file.positioning.iter().enumerate() {
        let csv = s.csv.as_deref().ok_or_else(|| missing("positioning", n))?;
        tests.push(Test::Positioning(s, read_positioning(csv)?));
    }
    for (n, s) in file.diagonal.iter().enumerate() {
        let m = read_diagonal(s)?.ok_or_else(|| missing("diagonal", n))?;
        tests.push(Test::Diagonal(s, m));
    }
    for (n, s) in file.circular.iter().enumerate() {
        let m = read_circular(s)?.ok_or_else(|| missing("circular", n))?;
        tests.push(Test::Circular(s, m));
    }
    for (n, s) in file.rtest.iter().enumerate() {
        let m = read_rtest(s)?.ok_or_else(|| missing("rtest", n))?;
        tests.push(Test::Rotary(s, m));
    }
    if tests.is_empty() {
        return Err(CalibrateError::Parameter(
            "no measurements: add [[diagonal]], [[circular]], [[rtest]] or [[positioning]] tables"
                .into(),
        ));
    }
    Ok(tests)
}

/// Gauss-Newton from the machine as given, with central-difference derivatives: the machine
/// with the estimates, the residuals there and their Jacobian in the unknowns.
fn gauss_newton(
    machine: &Machine,
    tests: &[Test],
    unknowns: &[LocationError],
    before: Vec<f64>,
) -> Result<(Machine, DVector<f64>, DMatrix<f64>), CalibrateError> {
    let points = before.len();
    let jacobian_at = |m: &Machine| -> Result<DMatrix<f64>, CalibrateError> {
        let mut j = DMatrix::zeros(points, unknowns.len());
        for (c, u) in unknowns.iter().enumerate() {
            let (value, h) = (u.get(m), u.step());
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
        check_observable(&j, unknowns)?;
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
            .all(|(c, u)| step[c].abs() <= 1e-6 * u.step());
        if small {
            break;
        }
    }
    Ok((current, r, j))
}

/// Every unknown must move the measurements, and no two the same way.
fn check_observable(j: &DMatrix<f64>, unknowns: &[LocationError]) -> Result<(), CalibrateError> {
    let norms: Vec<f64> = (0..j.ncols()).map(|c| j.column(c).norm()).collect();
    let largest = norms.iter().copied().fold(0.0, f64::max);
    for (c, u) in unknowns.iter().enumerate() {
        if norms[c] <= 1e-12 * largest.max(1e-300) || norms[c] == 0.0 {
            return Err(CalibrateError::Parameter(format!(
                "{} does not change any of the given measurements: measure a test that sees it, or leave it out",
                u.name()
            )));
        }
    }
    let mut scaled = j.clone();
    for (c, n) in norms.iter().enumerate() {
        scaled.column_mut(c).scale_mut(1.0 / n);
    }
    let singular = scaled.clone().svd(false, true);
    let values = &singular.singular_values;
    let (max, min) = (values.max(), values.min());
    if min < 1e-6 * max {
        let v_t = singular.v_t.as_ref().expect("asked for V");
        let row = values.imin();
        let involved: Vec<String> = unknowns
            .iter()
            .enumerate()
            .filter(|(c, _)| v_t[(row, *c)].abs() > 0.1)
            .map(|(_, u)| u.name())
            .collect();
        return Err(CalibrateError::Parameter(format!(
            "{} cannot be told apart from these measurements (they move them alike): add a test that separates them",
            involved.join(" and ")
        )));
    }
    Ok(())
}

/// The machine file with the estimates written in: the original file's keys with each
/// estimated location error set (a comment-free rewrite of the TOML).
pub fn fitted_machine_toml(
    machine: &Machine,
    estimates: &[Estimate],
) -> Result<String, CalibrateError> {
    let mut table: toml::Table = toml::from_str(&machine.source.toml).map_err(|e| {
        CalibrateError::Parameter(format!("the machine's own file does not parse again: {e}"))
    })?;
    for e in estimates {
        let axis = e.name.chars().last().expect("four letters").to_string();
        let axes = table
            .entry("axes")
            .or_insert_with(|| toml::Value::Table(Default::default()));
        let section = axes
            .as_table_mut()
            .and_then(|t| t.get_mut(&axis))
            .and_then(|v| v.as_table_mut())
            .ok_or_else(|| {
                CalibrateError::Parameter(format!("the machine file has no [axes.{axis}] section"))
            })?;
        section.insert(e.name.clone(), toml::Value::Float(e.value));
    }
    toml::to_string(&table).map_err(|e| CalibrateError::Parameter(e.to_string()))
}
