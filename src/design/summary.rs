//! Statistics over the samples: mean, standard deviation, percentiles, and the fraction within a
//! specification with its confidence interval.

use serde::Serialize;

/// The two-sided 95% normal quantile.
const Z95: f64 = 1.959_963_984_540_054;

/// The distribution of one statistic over the samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    pub mean: f64,
    /// The sample standard deviation (divisor N − 1; 0 for one sample).
    pub std: f64,
    pub p5: f64,
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
}

impl Summary {
    pub fn of(values: &[f64]) -> Summary {
        let n = values.len();
        // Shifted by the first value: exact when every value is the same, and without the
        // cancellation of a large common part.
        let shift = values.first().copied().unwrap_or(0.0);
        let mean = shift + values.iter().map(|v| v - shift).sum::<f64>() / n.max(1) as f64;
        let std = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        Summary {
            mean,
            std,
            p5: percentile(&sorted, 5.0),
            p50: percentile(&sorted, 50.0),
            p95: percentile(&sorted, 95.0),
            p99: percentile(&sorted, 99.0),
        }
    }
}

/// Percentile `p` (0–100) of sorted values, interpolated linearly between order statistics: the
/// value at rank `(N − 1)·p/100` (Hyndman and Fan's definition 7, numpy's default).
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    let Some(&last) = sorted.last() else {
        return f64::NAN;
    };
    let rank = (sorted.len() - 1) as f64 * p / 100.0;
    let below = rank.floor() as usize;
    match sorted.get(below + 1) {
        Some(&above) => sorted[below] + (rank - below as f64) * (above - sorted[below]),
        None => last,
    }
}

/// The fraction of samples that meet a criterion, with its 95% confidence interval (Wilson's
/// score interval, which stays inside [0, 1] and is sound at fractions near 0 and 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fraction {
    pub fraction: f64,
    pub ci95: [f64; 2],
}

impl Fraction {
    pub fn of(hits: usize, samples: usize) -> Fraction {
        let n = samples.max(1) as f64;
        let p = hits as f64 / n;
        let z2 = Z95 * Z95;
        let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
        let half = Z95 / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
        Fraction {
            fraction: p,
            ci95: [(centre - half).max(0.0), (centre + half).min(1.0)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_interpolate_between_order_statistics() {
        let v = [4.0, 1.0, 3.0, 2.0, 5.0];
        let s = Summary::of(&v);
        assert_eq!(s.mean, 3.0);
        assert!((s.std - 2.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.p50, 3.0);
        assert!((s.p5 - 1.2).abs() < 1e-12);
        assert!((s.p95 - 4.8).abs() < 1e-12);
        assert!((s.p99 - 4.96).abs() < 1e-12);
        assert_eq!(Summary::of(&[2.0]).p99, 2.0);
    }

    #[test]
    fn wilson_interval_matches_hand_computed_values() {
        // 8 of 10: centre (0.8 + 1.92/10)/(1 + 3.84/10), half-width from the formula.
        let f = Fraction::of(8, 10);
        assert!((f.ci95[0] - 0.4901624).abs() < 1e-6, "{:?}", f.ci95);
        assert!((f.ci95[1] - 0.9433178).abs() < 1e-6, "{:?}", f.ci95);
        let all = Fraction::of(100, 100);
        assert_eq!(all.fraction, 1.0);
        assert_eq!(all.ci95[1], 1.0);
        assert!((all.ci95[0] - 0.963005).abs() < 1e-5, "{:?}", all.ci95);
    }
}
