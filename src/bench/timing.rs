//! Repeated timings and their spread: every figure of `volmap bench` is the median of its runs,
//! with the fastest, the slowest and the quartiles beside it.

use std::time::Instant;

use serde::Serialize;

/// Runs `f` and says how long it took, seconds.
pub(super) fn timed<R>(f: impl FnOnce() -> R) -> (R, f64) {
    let start = Instant::now();
    let r = f();
    (r, start.elapsed().as_secs_f64())
}

/// The spread of repeated timings, seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    pub runs: usize,
    pub median: f64,
    pub min: f64,
    pub max: f64,
    /// The first and third quartiles (linear interpolation between runs).
    pub q1: f64,
    pub q3: f64,
}

impl Spread {
    /// The spread of `seconds` (at least one run).
    pub fn of(seconds: &[f64]) -> Spread {
        let mut sorted: Vec<f64> = seconds.to_vec();
        sorted.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            if sorted.is_empty() {
                return f64::NAN;
            }
            let at = q * (sorted.len() - 1) as f64;
            let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
            sorted[lo] + (sorted[hi] - sorted[lo]) * (at - lo as f64)
        };
        Spread {
            runs: sorted.len(),
            median: quantile(0.5),
            min: sorted.first().copied().unwrap_or(f64::NAN),
            max: sorted.last().copied().unwrap_or(f64::NAN),
            q1: quantile(0.25),
            q3: quantile(0.75),
        }
    }

    /// The index in `seconds` of the run nearest the median (whose details a report shows).
    pub fn median_run(seconds: &[f64]) -> usize {
        let median = Spread::of(seconds).median;
        (0..seconds.len())
            .min_by(|&a, &b| {
                (seconds[a] - median)
                    .abs()
                    .total_cmp(&(seconds[b] - median).abs())
            })
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::Spread;

    #[test]
    fn median_quartiles_and_range() {
        let s = Spread::of(&[5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!(
            (s.median, s.min, s.max, s.q1, s.q3),
            (3.0, 1.0, 5.0, 2.0, 4.0)
        );
        let s = Spread::of(&[2.0, 1.0]);
        assert_eq!((s.median, s.q1, s.q3), (1.5, 1.25, 1.75));
        assert_eq!(Spread::median_run(&[9.0, 1.0, 5.0]), 2);
    }
}
