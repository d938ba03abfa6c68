//! The numbers along a chart's axis, for any finite input: a range wide enough to draw (never
//! empty, never wider than f64 holds), round ticks across it (never more than a few per tick
//! asked for), their labels (never longer than a number needs), and where a value falls on it.
//! Spans are taken in halves (`hi/2 − lo/2`), which no pair of finite values overflows; ranges
//! narrower than f64 resolves about their values (subnormal, or a few ulps) are widened.

/// The smallest and largest of the finite `values`; `None` where there is none.
pub(super) fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Whether `(lo, hi)` is wide enough to draw: more than a millionth of a millionth of its
/// values' magnitude, and not subnormal.
pub(super) fn is_wide((lo, hi): (f64, f64)) -> bool {
    let half = hi / 2.0 - lo / 2.0;
    half > (lo.abs().max(hi.abs()) * 1e-12).max(1e-300)
}

/// A value within the finite numbers.
fn clamped(v: f64) -> f64 {
    v.clamp(-f64::MAX, f64::MAX)
}

/// `(lo, hi)` as a range a chart can draw: as it is where it is wide enough, else widened about
/// its middle by half the middle's magnitude (at least 1e-6 each way).
pub(super) fn drawable((lo, hi): (f64, f64)) -> (f64, f64) {
    if is_wide((lo, hi)) {
        return (lo, hi);
    }
    let mid = lo / 2.0 + hi / 2.0;
    let pad = mid.abs().max(1e-6) * 0.5;
    (clamped(mid - pad), clamped(mid + pad))
}

/// `(lo, hi)` with 5% of its span added at either end; a range too narrow to draw is widened as
/// [`drawable`] does.
pub(super) fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    if !is_wide((lo, hi)) {
        return drawable((lo, hi));
    }
    let pad = 0.1 * (hi / 2.0 - lo / 2.0);
    (clamped(lo - pad), clamped(hi + pad))
}

/// Where `v` falls across `(lo, hi)`: 0 at `lo`, 1 at `hi`.
pub(super) fn fraction(v: f64, (lo, hi): (f64, f64)) -> f64 {
    (v / 2.0 - lo / 2.0) / (hi / 2.0 - lo / 2.0)
}

/// The smallest step of 1, 2 or 5 × 10ⁿ at least `raw` (0 or infinite where no such step is a
/// normal number).
pub(super) fn round_step(raw: f64) -> f64 {
    let power = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power)
}

/// Round steps of 1, 2 or 5 × 10ⁿ covering `[lo, hi]` with about `count` ticks; the two ends
/// where no round step can be told apart from its neighbours (a range below f64's resolution)
/// or would give more than `4·count + 4` ticks; `[lo]` for an empty or non-finite range.
pub fn ticks(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater)
        || !lo.is_finite()
        || !hi.is_finite()
    {
        return vec![lo];
    }
    let count = count.max(1) as f64;
    let raw = match hi - lo {
        span if span.is_finite() => span / count,
        _ => hi / count - lo / count,
    };
    let step = round_step(raw);
    let (first, last) = ((lo / step).ceil(), (hi / step).floor());
    let resolved = raw.is_normal() && step.is_normal() && first.abs().max(last.abs()) < 2e15;
    if !resolved || last - first > 4.0 * count + 4.0 {
        return vec![lo, hi];
    }
    (first as i64..=last as i64)
        .map(|k| k as f64 * step)
        .collect()
}

/// A tick's label: with the decimals its step needs (a step of 1 or more: none), or in
/// scientific notation with the significant digits the step needs where that would be long
/// (magnitudes from 1e7, steps below 1e-6): at most about 12 characters, which the margins hold.
pub(super) fn tick_label(value: f64, step: f64) -> String {
    let step = step.abs();
    if !value.is_finite() {
        return format!("{value}");
    }
    let decimals = if step >= 1.0 {
        Some(0)
    } else if step >= 1e-6 {
        Some((-step.log10().floor()) as usize)
    } else {
        None
    };
    let text = match decimals {
        Some(decimals) if value.abs() < 1e7 => format!("{value:.decimals$}"),
        _ if value == 0.0 => "0".to_string(),
        _ => {
            let digits = if step > 0.0 {
                value.abs().log10().floor() - step.log10().floor()
            } else {
                16.0
            };
            let digits = digits.clamp(1.0, 6.0) as usize;
            format!("{value:.digits$e}")
        }
    };
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".into()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_of_any_finite_range_are_few_and_finite() {
        assert_eq!(
            ticks(0.0, 1.0, 5),
            vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]
        );
        for (lo, hi) in [
            (0.0, 1e-323),
            (0.0, 5e-324),
            (-f64::MAX, f64::MAX),
            (1e300, 1e300 * (1.0 + 1e-15)),
            (-1e308, 1e308),
            (1.0, 1.0 + f64::EPSILON),
        ] {
            let t = ticks(lo, hi, 8);
            assert!(!t.is_empty() && t.len() <= 36, "{lo} {hi}: {t:?}");
            assert!(t.iter().all(|v| v.is_finite()), "{lo} {hi}: {t:?}");
            let step = if t.len() > 1 { t[1] - t[0] } else { 1.0 };
            for v in &t {
                assert!(tick_label(*v, step).len() <= 12, "{v} {step}");
            }
        }
    }

    #[test]
    fn labels_are_short_at_any_magnitude() {
        assert_eq!(tick_label(0.25, 0.05), "0.25");
        assert_eq!(tick_label(-0.0001, 0.1), "0");
        assert_eq!(tick_label(1e300, 1e299), "1.0e300");
        assert_eq!(tick_label(5e-324, 5e-324), "4.9e-324");
        assert_eq!(tick_label(2e-7, 1e-7), "2.0e-7");
        assert_eq!(tick_label(1234.5, 0.5), "1234.5");
        assert_eq!(tick_label(0.0, 0.0), "0");
        assert_eq!(tick_label(3.0, f64::INFINITY), "3");
    }

    #[test]
    fn ranges_are_drawable_and_fractions_finite() {
        for r in [(0.0, 1e-323), (5.0, 5.0), (-f64::MAX, f64::MAX), (0.0, 0.0)] {
            let (lo, hi) = padded(r);
            assert!(lo.is_finite() && hi.is_finite() && hi > lo, "{r:?}");
            let f = fraction(r.1, (lo, hi));
            assert!((0.0..=1.0).contains(&f), "{r:?}: {f}");
        }
        assert_eq!(padded((0.0, 10.0)), (-0.5, 10.5));
        assert_eq!(drawable((2.0, 2.0)), (1.0, 3.0));
    }
}
