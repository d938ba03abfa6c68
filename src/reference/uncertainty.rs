//! The uncertainty of VE and OE from the standard uncertainties of the error values
//! (docs/model.md, "Uncertainty of the error values"), in f64 on the CPU, at the evaluation inputs
//! the machine is at ([`Machine::at`]):
//! - first order (GUM, JCGM 100): `u²(Y_k) = Σ_i Σ_j J_ki J_kj cov(e_i, e_j)`, `J_ki = ∂Y_k/∂e_i`
//!   at the nominal values by central differences of the reference;
//! - Monte Carlo (JCGM 101): `e ~ N(0, cov)` drawn through a Cholesky factor of the covariance,
//!   each draw a machine evaluated at every point; per point the mean and standard deviation.

use rayon::prelude::*;

use super::deviation_against;
use crate::design::draws::standard_draw;
use crate::model::channels::Sample;
use crate::model::perturbation::{Distribution, ErrorTarget};
use crate::model::uncertainty::{NotPositiveSemidefinite, UncertainValue, Uncertainty};
use crate::model::{Command, Machine, MachineSource};

/// A machine prepared for uncertainty evaluations: itself (at its inputs, without the files it
/// came from, which each perturbed copy would only carry along) and its ideal twin.
#[derive(Debug, Clone)]
pub struct Propagation {
    base: Machine,
    ideal: Machine,
}

/// What a Monte Carlo run gives at each point, [`Sample`] order (VE mm, then OE rad).
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    pub draws: usize,
    pub seed: u64,
    /// The mean over the draws, per point.
    pub mean: Vec<Sample>,
    /// The standard deviation over the draws (divisor `N − 1`), per point.
    pub std: Vec<Sample>,
}

impl MonteCarlo {
    /// The standard error of [`MonteCarlo::std`] at point `p`: `s / sqrt(2(N − 1))`, that of a
    /// normal sample's standard deviation.
    pub fn std_error(&self, p: usize) -> Sample {
        let k = (2.0 * (self.draws as f64 - 1.0)).sqrt();
        self.std[p].map(|s| s / k)
    }

    /// The standard error of [`MonteCarlo::mean`] at point `p`: `s / sqrt(N)`.
    pub fn mean_error(&self, p: usize) -> Sample {
        let k = (self.draws as f64).sqrt();
        self.std[p].map(|s| s / k)
    }
}

/// VE and OE of a machine at a command, [`Sample`] order.
fn values(machine: &Machine, ideal: &Machine, command: &Command) -> Sample {
    let d = deviation_against(machine, ideal, command);
    let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
    [ve.x, ve.y, ve.z, oe.x, oe.y, oe.z]
}

impl Propagation {
    pub fn new(machine: &Machine) -> Propagation {
        let mut base = machine.clone();
        base.source = MachineSource::default();
        let ideal = base.without_errors();
        Propagation { base, ideal }
    }

    /// The first-order standard uncertainty of VE and OE at `command`.
    pub fn first_order(&self, command: &Command) -> Sample {
        let rows: [Sample; 6] = std::array::from_fn(|r| std::array::from_fn(|c| f64::from(r == c)));
        let u = self.first_order_of(command, &rows);
        std::array::from_fn(|c| u[c])
    }

    /// The first-order standard uncertainty at `command` of each linear combination `rows[r] ·
    /// [VE, OE]` ([`Sample`] order): `u² = Σ_i Σ_j (r·J_i)(r·J_j) cov(e_i, e_j)`, the covariances
    /// between the channels counted (the correction a table holds, `−J⁻¹·VE`, is one).
    pub fn first_order_of(&self, command: &Command, rows: &[Sample]) -> Vec<f64> {
        let uncertainty = &self.base.uncertainty;
        let sigmas = uncertainty.sigmas();
        let mut jacobian = vec![[0.0; 6]; sigmas.len()];
        let mut work = self.base.clone();
        let mut first = 0;
        for value in &uncertainty.values {
            let count = value.kind.count();
            let factor = value.factor(&self.base.inputs, self.base.thermal.as_ref());
            for k in 0..count {
                let u = sigmas[first + k];
                // A quantity without spread adds nothing (nor do its covariances: they are
                // zero in a positive semi-definite matrix), nor one whose shape is zero here.
                if u == 0.0 || factor == 0.0 || shape_at(value, k, command) == 0.0 {
                    continue;
                }
                // Central differences with the step h = u_i: the model is smooth in e and
                // nearly linear over ±u, so the difference quotient is the derivative at the
                // nominal values to well within the first order the GUM asks for.
                let mut e = vec![0.0; count];
                e[k] = u;
                let plus = self.perturbed(&mut work, value, &e, command);
                e[k] = -u;
                let minus = self.perturbed(&mut work, value, &e, command);
                jacobian[first + k] = std::array::from_fn(|c| (plus[c] - minus[c]) / (2.0 * u));
            }
            first += count;
        }
        rows.iter()
            .map(|row| {
                let along: Vec<f64> = jacobian
                    .iter()
                    .map(|j| row.iter().zip(j).map(|(r, j)| r * j).sum())
                    .collect();
                let independent: f64 = along
                    .iter()
                    .zip(&sigmas)
                    .map(|(j, s)| (j * s).powi(2))
                    .sum();
                let correlated: f64 = uncertainty
                    .covariance
                    .iter()
                    .map(|&(i, j, cov)| 2.0 * along[i] * along[j] * cov)
                    .sum();
                // Rounding may leave a perfectly cancelled variance a hair below zero.
                (independent + correlated).max(0.0).sqrt()
            })
            .collect()
    }

    /// VE and OE at `command` of `work` with the deviation of `value` for `e` added, `work`
    /// restored after.
    fn perturbed(
        &self,
        work: &mut Machine,
        value: &UncertainValue,
        e: &[f64],
        command: &Command,
    ) -> Sample {
        let saved = saved_value(work, value.target);
        work.add_deviation(value, e);
        let out = values(work, &self.ideal, command);
        restore_value(work, value.target, saved);
        out
    }

    /// Monte Carlo over `draws` machines (at least 2) with `e ~ N(0, cov)`, the same for the
    /// same `seed` on every run: each draw's numbers are a function of `(seed, draw, quantity)`.
    pub fn monte_carlo(
        &self,
        commands: &[Command],
        draws: usize,
        seed: u64,
    ) -> Result<MonteCarlo, NotPositiveSemidefinite> {
        let drawn = Draws::new(&self.base.uncertainty, seed)?;
        let n = commands.len();
        // Welford's running mean and sum of squared deviations, per point and channel.
        let mut mean = vec![[0.0; 6]; n];
        let mut m2 = vec![[0.0; 6]; n];
        for draw in 0..draws {
            let e = drawn.deviations(draw as u64);
            let machine = self.base.with_deviations(&e);
            let samples: Vec<Sample> = commands
                .par_iter()
                .map(|c| values(&machine, &self.ideal, c))
                .collect();
            let count = (draw + 1) as f64;
            mean.par_iter_mut()
                .zip(m2.par_iter_mut())
                .zip(samples.par_iter())
                .for_each(|((mean, m2), x)| {
                    for c in 0..6 {
                        let delta = x[c] - mean[c];
                        mean[c] += delta / count;
                        m2[c] += delta * (x[c] - mean[c]);
                    }
                });
        }
        let divisor = draws.saturating_sub(1).max(1) as f64;
        Ok(MonteCarlo {
            draws,
            seed,
            mean,
            std: m2
                .iter()
                .map(|m| m.map(|x| (x / divisor).max(0.0).sqrt()))
                .collect(),
        })
    }
}

/// The draws of a Monte Carlo run: `e ~ N(0, cov)`, each draw's numbers a function of `(seed,
/// draw, quantity)` alone, so a draw is the same whoever makes it (the map's engines, the
/// reference, chunk after chunk).
#[derive(Debug, Clone)]
pub struct Draws {
    sigmas: Vec<f64>,
    members: Vec<usize>,
    factor: Vec<Vec<f64>>,
    seed: u64,
}

impl Draws {
    pub fn new(uncertainty: &Uncertainty, seed: u64) -> Result<Draws, NotPositiveSemidefinite> {
        let (members, factor) = uncertainty.correlated_factor()?;
        Ok(Draws {
            sigmas: uncertainty.sigmas(),
            members,
            factor,
            seed,
        })
    }

    /// The perturbations of draw `draw`, one per quantity: independent quantities `z_i·u_i`,
    /// correlated ones `F·z` over their members.
    pub fn deviations(&self, draw: u64) -> Vec<f64> {
        let normal = Distribution::Normal { sigma: 1.0 };
        let z: Vec<f64> = (0..self.sigmas.len())
            .map(|i| standard_draw(self.seed, draw, i as u64, normal))
            .collect();
        let mut e: Vec<f64> = z.iter().zip(&self.sigmas).map(|(z, s)| z * s).collect();
        for (a, row) in self.factor.iter().enumerate() {
            e[self.members[a]] = row.iter().zip(&self.members).map(|(f, &m)| f * z[m]).sum();
        }
        e
    }
}

/// `δ_k` of `value` at `command`: its shape for a unit perturbation of quantity `k`.
fn shape_at(value: &UncertainValue, k: usize, command: &Command) -> f64 {
    let mut e = vec![0.0; value.kind.count()];
    e[k] = 1.0;
    let delta = value.delta(&e);
    match value.target {
        ErrorTarget::Component { axis, .. } => delta.eval_at(command[axis.index()], command),
        _ => delta.eval(0.0),
    }
}

/// What a deviation of `target` changes in a machine, to be put back.
enum Saved {
    Component(Option<crate::model::ErrorFunction>),
    Constant(f64),
}

fn saved_value(machine: &Machine, target: ErrorTarget) -> Saved {
    match target {
        ErrorTarget::Component { axis, index } => {
            Saved::Component(machine.axis(axis).and_then(|a| a.components[index].clone()))
        }
        ErrorTarget::Location { axis, index } => {
            Saved::Constant(machine.axis(axis).map_or(0.0, |a| a.location[index]))
        }
        ErrorTarget::Spindle { index } => Saved::Constant(machine.spindle[index]),
    }
}

fn restore_value(machine: &mut Machine, target: ErrorTarget, saved: Saved) {
    match (target, saved) {
        (ErrorTarget::Component { axis, index }, Saved::Component(f)) => {
            if let Some(a) = machine.axis_mut(axis) {
                a.components[index] = f;
            }
        }
        (ErrorTarget::Location { axis, index }, Saved::Constant(v)) => {
            if let Some(a) = machine.axis_mut(axis) {
                a.location[index] = v;
            }
        }
        (ErrorTarget::Spindle { index }, Saved::Constant(v)) => machine.spindle[index] = v,
        _ => {}
    }
}
