//! Tolerance allocation: the largest common factor on the chosen tolerances for which the
//! fraction of machines within the specification reaches the confidence. Bisection over Monte
//! Carlo runs that reuse the same draws (the samples' counters are fixed, only the widths scale),
//! so the fraction moves with the factor alone and not with fresh randomness.

use super::monte_carlo::{within_spec, Study, WithinSpec};
use super::plausible::Ceiling;
use super::DesignError;
use crate::engine::Engine;

/// The bisection stops when the factor is known to this relative width.
const RELATIVE_WIDTH: f64 = 1e-3;
/// The most the factor may grow before the tolerances are said not to matter.
const LARGEST_FACTOR: f64 = 1e6;
/// The most halvings: a factor the bisection cannot tell from zero ends it.
const MOST_HALVINGS: usize = 60;

/// What an allocation found.
#[derive(Debug, Clone)]
pub struct Allocation {
    /// The largest factor found for which the fraction reaches the confidence.
    pub factor: f64,
    /// Each tolerance's scale at that factor: the factor, where a chosen term stopped at the
    /// widest the tolerance file may give less; 1 for the terms not chosen.
    pub scale: Vec<f64>,
    /// The chosen terms that stopped at the widest the tolerance file may give.
    pub stopped: Vec<usize>,
    /// Whether the factor stopped where the machines drawn would reach the kernels' limit on
    /// angles ([`super::plausible`]) rather than where the fraction falls below the confidence.
    pub at_angle_limit: bool,
    /// The fraction within the specification at that factor, with its interval.
    pub within: WithinSpec,
    /// Every factor tried and the fraction it gave, in the order tried.
    pub tried: Vec<(f64, f64)>,
}

/// Which tolerances scale (`chosen[t]`), the specification and the confidence of an allocation.
#[derive(Debug, Clone)]
pub struct Target<'a> {
    pub chosen: &'a [bool],
    pub samples: usize,
    pub spec_mm: f64,
    pub confidence: f64,
}

/// Finds the factor. `on_run(factor, fraction)` is called after each Monte Carlo run and
/// `on_progress(samples done)` within each.
pub fn allocate(
    engine: &Engine,
    study: &Study,
    target: &Target,
    mut on_run: impl FnMut(f64, f64),
    on_progress: impl Fn(usize) + Sync,
) -> Result<Allocation, DesignError> {
    let ceiling = Ceiling::of(study, target.chosen);
    let top = ceiling.factor();
    let mut tried = Vec::new();
    let mut run = |factor: f64| -> Result<WithinSpec, DesignError> {
        let scale = ceiling.scale(target.chosen, factor);
        let stats = study.sample_stats(engine, target.samples, &scale, &on_progress)?;
        let within = within_spec(&stats, target.spec_mm);
        tried.push((factor, within.fraction.fraction));
        on_run(factor, within.fraction.fraction);
        Ok(within)
    };
    let holds = |w: &WithinSpec| w.fraction.fraction >= target.confidence;
    let at_zero = run(0.0)?;
    if !holds(&at_zero) {
        return Err(DesignError::Unreachable {
            confidence: target.confidence,
            spec_mm: target.spec_mm,
            fraction: at_zero.fraction.fraction,
        });
    }
    // Bracket: `low` holds, `high` does not.
    let (mut low, mut low_within) = (0.0, at_zero);
    let mut high: f64 = 1.0_f64.min(top);
    loop {
        let w = run(high)?;
        if !holds(&w) {
            break;
        }
        (low, low_within) = (high, w);
        if high >= top {
            // Nothing grows further: every chosen term is at its widest, or the angles at their
            // limit. The allocation stops there and says so.
            return Ok(finish(&ceiling, target.chosen, high, low_within, tried));
        }
        if high >= LARGEST_FACTOR {
            return Err(DesignError::Unbounded {
                factor: high,
                spec_mm: target.spec_mm,
                fraction: w.fraction.fraction,
            });
        }
        high = (high * 2.0).min(top);
    }
    for _ in 0..MOST_HALVINGS {
        if high - low <= RELATIVE_WIDTH * high {
            break;
        }
        let middle = 0.5 * (low + high);
        let w = run(middle)?;
        if holds(&w) {
            (low, low_within) = (middle, w);
        } else {
            high = middle;
        }
    }
    Ok(finish(&ceiling, target.chosen, low, low_within, tried))
}

fn finish(
    ceiling: &Ceiling,
    chosen: &[bool],
    factor: f64,
    within: WithinSpec,
    tried: Vec<(f64, f64)>,
) -> Allocation {
    Allocation {
        factor,
        scale: ceiling.scale(chosen, factor),
        stopped: ceiling.stopped(chosen, factor),
        at_angle_limit: factor >= ceiling.angle_factor,
        within,
        tried,
    }
}
