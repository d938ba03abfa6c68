//! The probability that a part conforms: every feature of the part evaluated on every sampled
//! machine. The cutter positions of a part do not depend on the machine, so they are found once
//! (an evaluation that records where it asks for the error); the engine then gives VE and OE at
//! all of them for a batch of samples at once (the GPU's positions pass), and each sample's
//! features are evaluated from its values, replayed in the order they were asked for.

use rayon::prelude::*;

use super::draws::amplitude_rows;
use super::monte_carlo::Study;
use super::summary::{percentile, Fraction};
use super::DesignError;
use crate::engine::variants::Variants;
use crate::engine::Engine;
use crate::part::{self, FeatureResult, PartFile};

/// Values held at once per batch of samples (samples × cutter positions): bounds memory.
const VALUES_PER_BATCH: usize = 1 << 22;

/// One feature over the samples.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FeatureConformance {
    pub name: String,
    pub kind: String,
    pub tolerance_mm: f64,
    /// The error on the nominal machine (the machine file as it is), its safety (tolerance over
    /// error) and the cutter position of its worst point.
    pub error_mm: f64,
    pub safety: Option<f64>,
    pub worst_point: [f64; 3],
    pub error_p50_mm: f64,
    pub error_p95_mm: f64,
    /// The fraction of sampled machines on which the feature is within its tolerance.
    pub conforming_fraction: f64,
    pub conforming_ci95: [f64; 2],
    pub samples: usize,
    /// `fit` where the fraction reaches the confidence, `unfit` where it does not.
    pub verdict: part::Verdict,
}

/// Evaluates `part` on `samples` machines of `study` (its grids are not used: the part says
/// where the cutter goes). `on_progress(samples done)` is called as batches finish.
pub fn conformance(
    engine: &Engine,
    study: &Study,
    part: &PartFile,
    file: &str,
    samples: usize,
    confidence: f64,
    on_progress: impl Fn(usize) + Sync,
) -> Result<Vec<FeatureConformance>, DesignError> {
    let (nominal, errors) = feature_errors(engine, study, part, file, 0..samples, on_progress)?;
    Ok(summarize(nominal, errors, confidence))
}

/// A feature on the nominal machine (the machine file as it is): what the summary over the
/// samples reports beside them.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NominalFeature {
    pub name: String,
    pub kind: String,
    pub tolerance_mm: f64,
    pub error_mm: f64,
    pub safety: Option<f64>,
    pub worst_point: [f64; 3],
}

/// Every feature's error on the samples of `range` (a shard's, or all): `errors[f][n]` is
/// feature `f`'s on sample `range.start + n`, the same as in a run of all of them.
pub fn feature_errors(
    engine: &Engine,
    study: &Study,
    part: &PartFile,
    file: &str,
    range: std::ops::Range<usize>,
    on_progress: impl Fn(usize) + Sync,
) -> Result<(Vec<NominalFeature>, Vec<Vec<f64>>), DesignError> {
    if range.is_empty() {
        return Err(DesignError::NoSamples);
    }
    let nominal = part::evaluate(part, part::ErrorSource::Exact(study.machine), file)?;
    let tips = part::cutter_positions(part, file)?;
    let pose = part.pose();
    let commands = tips.commands_at(pose);
    let perturbations = study.perturbations();
    let variants = Variants {
        base: study.machine,
        perturbations: &perturbations,
    };
    let scale = vec![1.0; study.tolerances.len()];
    let batch = (VALUES_PER_BATCH / commands.len().max(1)).clamp(1, 4096);
    let mut errors: Vec<Vec<f64>> = vec![Vec::with_capacity(range.len()); nominal.len()];
    for first in range.clone().step_by(batch) {
        let count = batch.min(range.end - first);
        let rows = amplitude_rows(study.tolerances, &scale, study.seed, first as u64, count);
        let values = engine.variant_values(&variants, &rows, &commands, |_| {})?;
        let results: Vec<Vec<FeatureResult>> = values
            .par_iter()
            .map(|v| part::evaluate_at(part, file, &tips, v))
            .collect::<Result<_, _>>()?;
        for rows in results {
            for (f, r) in rows.iter().enumerate() {
                errors[f].push(r.error_mm);
            }
        }
        on_progress(first + count - range.start);
    }
    let nominal = nominal
        .into_iter()
        .map(|n| NominalFeature {
            name: n.name,
            kind: n.kind,
            tolerance_mm: n.tolerance_mm,
            error_mm: n.error_mm,
            safety: n.safety,
            worst_point: n.worst_point,
        })
        .collect();
    Ok((nominal, errors))
}

/// Each feature over its errors on the samples: percentiles, the fraction within tolerance and
/// the verdict at `confidence`.
pub fn summarize(
    nominal: Vec<NominalFeature>,
    errors: Vec<Vec<f64>>,
    confidence: f64,
) -> Vec<FeatureConformance> {
    nominal
        .into_iter()
        .zip(errors)
        .map(|(n, mut e)| {
            let hits = e.iter().filter(|&&v| v <= n.tolerance_mm).count();
            let fraction = Fraction::of(hits, e.len());
            e.sort_by(f64::total_cmp);
            FeatureConformance {
                name: n.name,
                kind: n.kind,
                tolerance_mm: n.tolerance_mm,
                error_mm: n.error_mm,
                safety: n.safety,
                worst_point: n.worst_point,
                samples: e.len(),
                error_p50_mm: percentile(&e, 50.0),
                error_p95_mm: percentile(&e, 95.0),
                conforming_fraction: fraction.fraction,
                conforming_ci95: fraction.ci95,
                verdict: if fraction.fraction >= confidence {
                    part::Verdict::Fit
                } else {
                    part::Verdict::Unfit
                },
            }
        })
        .collect()
}
