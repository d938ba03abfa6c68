//! The random draws of sampled machines, from counters: the amplitude of term `t` of sample `b`
//! under seed `seed` is a pure function of `(seed, b, t)`. The same seed gives the same machines
//! on every engine, in any batching and in any order, and runs that scale the tolerances (an
//! allocation) reuse the same draws.

use crate::model::perturbation::{Distribution, Tolerance};
use crate::model::random::SplitMix64;

/// A uniform number in (0, 1) for counter `(seed, sample, term, k)`, hashed by SplitMix64's
/// finaliser (a bijection of u64).
fn open_unit(seed: u64, sample: u64, term: u64, k: u64) -> f64 {
    let mix = SplitMix64::mix;
    let z = mix(mix(mix(seed ^ 0x6A09_E667_F3BC_C909) ^ sample) ^ (term << 1 | k));
    ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// The standardised draw of term `term` of sample `sample`: `u ~ U(−1, 1)` for a uniform
/// tolerance, `z ~ N(0, 1)` for a normal one (Box–Muller).
pub fn standard_draw(seed: u64, sample: u64, term: u64, distribution: Distribution) -> f64 {
    match distribution {
        Distribution::Uniform { .. } => 2.0 * open_unit(seed, sample, term, 0) - 1.0,
        Distribution::Normal { .. } => {
            let u1 = open_unit(seed, sample, term, 0);
            let u2 = open_unit(seed, sample, term, 1);
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }
}

/// The amplitudes of samples `first .. first + count`, one row per sample and one column per
/// tolerance, each tolerance's width times `scale[t]`.
pub fn amplitude_rows(
    tolerances: &[Tolerance],
    scale: &[f64],
    seed: u64,
    first: u64,
    count: usize,
) -> Vec<Vec<f64>> {
    (first..first + count as u64)
        .map(|b| {
            tolerances
                .iter()
                .zip(scale)
                .enumerate()
                .map(|(t, (tolerance, k))| {
                    let d = tolerance.distribution;
                    k * d.width() * standard_draw(seed, b, t as u64, d)
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_have_the_moments_of_their_distributions() {
        let n = 200_000;
        for (d, var) in [
            (Distribution::Uniform { half_width: 1.0 }, 1.0 / 3.0),
            (Distribution::Normal { sigma: 1.0 }, 1.0),
        ] {
            let v: Vec<f64> = (0..n).map(|b| standard_draw(7, b, 3, d)).collect();
            let mean = v.iter().sum::<f64>() / n as f64;
            let variance = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
            assert!(mean.abs() < 0.01, "{d:?}: mean {mean}");
            assert!((variance - var).abs() < 0.01, "{d:?}: variance {variance}");
        }
        let inside = (0..n)
            .map(|b| standard_draw(1, b, 0, Distribution::Normal { sigma: 1.0 }))
            .filter(|z| z.abs() <= 1.959964)
            .count() as f64
            / n as f64;
        assert!((inside - 0.95).abs() < 0.003, "{inside}");
    }

    #[test]
    fn a_draw_depends_on_its_counter_only() {
        let d = Distribution::Uniform { half_width: 1.0 };
        assert_eq!(standard_draw(5, 10, 2, d), standard_draw(5, 10, 2, d));
        assert_ne!(standard_draw(5, 10, 2, d), standard_draw(5, 11, 2, d));
        assert_ne!(standard_draw(5, 10, 2, d), standard_draw(6, 10, 2, d));
        assert_ne!(standard_draw(5, 10, 2, d), standard_draw(5, 10, 3, d));
    }
}
