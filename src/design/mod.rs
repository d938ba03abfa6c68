//! Machine design (docs/model.md, "Tolerances and sampled machines"): what a designer's tolerances
//! mean before any machine exists. The error budget (each toleranced term alone at its limit on
//! the ideal machine), Monte Carlo over machines built to the tolerances (each sample's field
//! reduced to its statistics on the engine), tolerance allocation (the common factor on the
//! tolerances for which enough machines hold a specification), and the probability that a part
//! conforms.
//!
//! Every sample is drawn from counters (seed, sample, term), so a seed gives the same machines on
//! every engine and in any batching, and a later run over the same samples reuses their draws.

pub mod allocate;
pub mod budget;
pub mod conformance;
pub mod draws;
pub mod monte_carlo;
pub mod plausible;
pub mod shards;
pub mod summary;

use crate::engine::EngineError;
use crate::error::{Classify, ErrorKind};
use crate::limits::number_words;
use crate::part::FeatureError;

/// What went wrong in a design computation.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error(transparent)]
    Engine(#[from] EngineError),
    #[error(transparent)]
    Feature(#[from] FeatureError),
    #[error("a specification of {} mm: it must be a finite length above zero", number_words(*.0))]
    Spec(f64),
    #[error(transparent)]
    Angles(#[from] plausible::TooMuchAngle),
    #[error("a confidence of {}: it must lie between 0 and 1", number_words(*.0))]
    Confidence(f64),
    #[error("no samples: Monte Carlo needs at least one")]
    NoSamples,
    #[error("{0} machines are more than the limit of {max} drawn", max = crate::limits::MAX_SAMPLES)]
    TooManySamples(u64),
    #[error(
        "no factor reaches the confidence {}: with the allocated tolerances at zero, {} {} mm; \
         the other tolerances or the machine's own errors take too much of it",
        number_words(*confidence), machines_hold(*fraction), number_words(*spec_mm)
    )]
    Unreachable {
        confidence: f64,
        spec_mm: f64,
        fraction: f64,
    },
    #[error(
        "the allocated tolerances could grow without limit (at {} times their widths, {} {} \
         mm): they do not move the tool tip",
        number_words(*factor), machines_hold(*fraction), number_words(*spec_mm)
    )]
    Unbounded {
        factor: f64,
        spec_mm: f64,
        fraction: f64,
    },
}

/// The machines that hold a specification, in words with their verb: `every machine holds`,
/// `no machine holds`, `97.5% of the machines hold`; never a share that rounds to 100% or 0%
/// where it is not all or none.
pub fn machines_hold(fraction: f64) -> String {
    let percent = 100.0 * fraction;
    if fraction >= 1.0 {
        "every machine holds".to_string()
    } else if fraction <= 0.0 {
        "no machine holds".to_string()
    } else if percent >= 99.95 {
        "more than 99.9% of the machines hold".to_string()
    } else if percent < 0.05 {
        "fewer than 0.1% of the machines hold".to_string()
    } else {
        format!(
            "{} of the machines hold",
            crate::report::numbers::percent(percent)
        )
    }
}

impl Classify for DesignError {
    fn kind(&self) -> ErrorKind {
        match self {
            DesignError::Engine(e) => e.kind(),
            DesignError::Feature(e) => e.kind(),
            _ => ErrorKind::Input,
        }
    }
}
