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
pub mod shards;
pub mod summary;

use crate::engine::EngineError;
use crate::error::{Classify, ErrorKind};
use crate::part::FeatureError;

/// What went wrong in a design computation.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error(transparent)]
    Engine(#[from] EngineError),
    #[error(transparent)]
    Feature(#[from] FeatureError),
    #[error("a specification of {0} mm: it must be a finite length above zero")]
    Spec(f64),
    #[error("a confidence of {0}: it must lie between 0 and 1")]
    Confidence(f64),
    #[error("no samples: Monte Carlo needs at least one")]
    NoSamples,
    #[error("{0} machines are more than the limit of {max} drawn", max = crate::limits::MAX_SAMPLES)]
    TooManySamples(u64),
    #[error(
        "no factor reaches the confidence {confidence}: with the allocated tolerances at zero, \
         {fraction} of the machines hold {spec_mm} mm; the other tolerances or the machine's own \
         errors take too much of it"
    )]
    Unreachable {
        confidence: f64,
        spec_mm: f64,
        fraction: f64,
    },
    #[error(
        "the allocated tolerances could grow without limit (at {factor} times their widths, \
         {fraction} of the machines still hold {spec_mm} mm): they do not move the tool tip"
    )]
    Unbounded {
        factor: f64,
        spec_mm: f64,
        fraction: f64,
    },
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
