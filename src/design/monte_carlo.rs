//! Monte Carlo over machines built to the tolerances: each sample draws every tolerance's
//! amplitude ([`super::draws`]), and its field over the grid (and every pose of a sweep) is
//! reduced to its statistics on the engine; the GPU reduces on the device, so only a few numbers
//! per machine are read back. Over the samples: mean, standard deviation and percentiles of each
//! statistic, and the fraction of machines whose `max |VE|` stays at or below a specification.

use crate::engine::variants::Variants;
use crate::engine::Engine;
use crate::limits::MAX_SAMPLES;
use crate::model::grid::Grid;
use crate::model::perturbation::{Perturbation, Tolerance};
use crate::model::statistics::FieldStats;
use crate::model::Machine;

use super::draws::amplitude_rows;
use super::summary::{Fraction, Summary};
use super::DesignError;

/// Samples drawn and evaluated at once on the host: bounds the memory of the amplitude rows,
/// whatever the number of samples (the engine batches again for the device).
const HOST_BATCH: usize = 4096;

/// Machines built to `tolerances` from `machine` (the nominal), mapped over `grids` (one per pose),
/// drawn from `seed`.
#[derive(Debug, Clone, Copy)]
pub struct Study<'a> {
    pub machine: &'a Machine,
    pub tolerances: &'a [Tolerance],
    pub grids: &'a [Grid],
    pub seed: u64,
}

impl Study<'_> {
    pub fn perturbations(&self) -> Vec<Perturbation> {
        self.tolerances.iter().map(|t| t.perturbation).collect()
    }

    /// The statistics of samples `0 .. samples`, each tolerance's width times `scale[t]`.
    /// `on_progress(samples done)` is called as samples finish.
    pub fn sample_stats(
        &self,
        engine: &Engine,
        samples: usize,
        scale: &[f64],
        on_progress: impl Fn(usize) + Sync,
    ) -> Result<Vec<FieldStats>, DesignError> {
        self.range_stats(engine, 0..samples, scale, on_progress)
    }

    /// The statistics of the samples of `range` (a shard's): each sample's the same as in a run
    /// of all of them, its draws being counter-based.
    pub fn range_stats(
        &self,
        engine: &Engine,
        range: std::ops::Range<usize>,
        scale: &[f64],
        on_progress: impl Fn(usize) + Sync,
    ) -> Result<Vec<FieldStats>, DesignError> {
        if range.is_empty() {
            return Err(DesignError::NoSamples);
        }
        let perturbations = self.perturbations();
        let variants = Variants {
            base: self.machine,
            perturbations: &perturbations,
        };
        let mut stats = Vec::with_capacity(range.len());
        for first in range.clone().step_by(HOST_BATCH) {
            let count = HOST_BATCH.min(range.end - first);
            let rows = amplitude_rows(self.tolerances, scale, self.seed, first as u64, count);
            let done = stats.len();
            stats.extend(
                engine.variant_stats(&variants, &rows, self.grids, |n| on_progress(done + n))?,
            );
        }
        Ok(stats)
    }

    /// Every sample's amplitudes (for a per-sample report), each width times `scale[t]`.
    pub fn amplitudes(&self, first: usize, count: usize, scale: &[f64]) -> Vec<Vec<f64>> {
        amplitude_rows(self.tolerances, scale, self.seed, first as u64, count)
    }
}

/// The statistics of a Monte Carlo run over its samples.
#[derive(Debug, Clone)]
pub struct MonteCarlo {
    pub samples: usize,
    pub seed: u64,
    pub max_ve_mm: Summary,
    pub rms_ve_mm: Summary,
    pub max_oe_rad: Summary,
    /// `max |VE·x̂|`, `max |VE·ŷ|`, `max |VE·ẑ|`.
    pub max_ve_axis_mm: [Summary; 3],
    pub within_spec: Option<WithinSpec>,
}

/// The machines whose `max |VE|` stays at or below a specification.
#[derive(Debug, Clone, Copy)]
pub struct WithinSpec {
    pub spec_mm: f64,
    pub fraction: Fraction,
}

/// The fraction of `stats` whose `max |VE|` is at or below `spec_mm`.
pub fn within_spec(stats: &[FieldStats], spec_mm: f64) -> WithinSpec {
    let hits = stats.iter().filter(|s| s.max_ve_mm <= spec_mm).count();
    WithinSpec {
        spec_mm,
        fraction: Fraction::of(hits, stats.len()),
    }
}

impl MonteCarlo {
    pub fn of(stats: &[FieldStats], seed: u64, spec_mm: Option<f64>) -> MonteCarlo {
        let summary =
            |f: &dyn Fn(&FieldStats) -> f64| Summary::of(&stats.iter().map(f).collect::<Vec<_>>());
        MonteCarlo {
            samples: stats.len(),
            seed,
            max_ve_mm: summary(&|s| s.max_ve_mm),
            rms_ve_mm: summary(&|s| s.rms_ve_mm()),
            max_oe_rad: summary(&|s| s.max_oe_rad),
            max_ve_axis_mm: std::array::from_fn(|d| summary(&|s| s.max_axis_mm[d])),
            within_spec: spec_mm.map(|spec| within_spec(stats, spec)),
        }
    }
}

/// Checks a specification: a finite length above zero.
pub fn check_spec(spec_mm: f64) -> Result<f64, DesignError> {
    if spec_mm.is_finite() && spec_mm > 0.0 {
        Ok(spec_mm)
    } else {
        Err(DesignError::Spec(spec_mm))
    }
}

/// Checks a number of machines to draw: at least one, at most [`MAX_SAMPLES`].
pub fn check_samples(samples: u64) -> Result<usize, DesignError> {
    match samples {
        0 => Err(DesignError::NoSamples),
        n if n > MAX_SAMPLES => Err(DesignError::TooManySamples(n)),
        n => Ok(n as usize),
    }
}

/// Checks a confidence: strictly between 0 and 1, or 1.
pub fn check_confidence(confidence: f64) -> Result<f64, DesignError> {
    if confidence > 0.0 && confidence <= 1.0 {
        Ok(confidence)
    } else {
        Err(DesignError::Confidence(confidence))
    }
}
