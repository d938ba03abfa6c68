//! The size of a Monte Carlo run, bounded before any work (`volmap::limits::MAX_MACHINE_POINTS`),
//! and the time of a long one, said on standard error once it is measured: from the machines done
//! when the first progress report comes after [`MEASURE_S`], extrapolated to the run's machines.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use volmap::limits::{count_words, MAX_MACHINE_POINTS};
use volmap::model::grid::Grid;

use super::failure::Failure;
use super::numbers;

/// Seconds of work measured before the time of the run is estimated.
const MEASURE_S: f64 = 2.0;

/// Runs estimated to take at least this long, s, are announced.
const LONG_RUN_S: f64 = 60.0;

/// The machine-points of one Monte Carlo run: `machines` (the budget's terms and the machines
/// drawn, `machines_words` in words) over every point of every grid; refused beyond the limit,
/// naming `flags`.
pub fn check_machine_points(
    machines: u64,
    machines_words: &str,
    grids: &[Grid],
    flags: &str,
) -> Result<f64, Failure> {
    let points: f64 = grids
        .first()
        .map_or(0.0, |g| g.dims.iter().map(|&d| d as f64).product());
    let count = machines as f64 * points * grids.len() as f64;
    if count <= MAX_MACHINE_POINTS as f64 {
        return Ok(count);
    }
    Err(Failure::input(format!(
        "{flags}: {machines_words} × {} grid points × {} poses = {} machine-points is more than the limit of {} for one run (about a day on a fast GPU)",
        count_words(points),
        grids.len(),
        count_words(count),
        count_words(MAX_MACHINE_POINTS as f64),
    )))
}

/// Announces, once, the time a run of `total` machines of `points_each` machine-points will
/// take, from the rate measured on its first machines.
pub struct Estimate {
    start: Instant,
    total: usize,
    points_each: f64,
    what: String,
    said: AtomicBool,
}

impl Estimate {
    pub fn new(total: usize, points_each: f64, what: impl Into<String>) -> Estimate {
        Estimate {
            start: Instant::now(),
            total,
            points_each,
            what: what.into(),
            said: AtomicBool::new(false),
        }
    }

    /// Called with the machines done; says the estimate once, where the run is long, through
    /// `say` (which suspends a progress bar).
    pub fn progress(&self, done: usize, say: impl FnOnce(&str)) {
        if done == 0 || done >= self.total || self.said.load(Ordering::Relaxed) {
            return;
        }
        let elapsed = self.start.elapsed().as_secs_f64();
        if elapsed < MEASURE_S {
            return;
        }
        if self.said.swap(true, Ordering::Relaxed) {
            return;
        }
        let per_machine = elapsed / done as f64;
        let total_s = per_machine * self.total as f64;
        if total_s >= LONG_RUN_S {
            say(&format!(
                "volmap: {} will take about {} (measured on its first {done} machines: {} machine-points/s)",
                self.what,
                duration_words(total_s),
                numbers::quantity(self.points_each / per_machine)
            ));
        }
    }
}

/// A duration in words, to two units: `3 h 20 min`, `5 min 10 s`, `12 days 4 h`.
pub fn duration_words(seconds: f64) -> String {
    if !seconds.is_finite() {
        return "longer than any run".to_string();
    }
    let s = seconds.round() as u64;
    let (days, hours, minutes, secs) = (s / 86_400, s / 3600 % 24, s / 60 % 60, s % 60);
    if days > 0 {
        format!("{days} days {hours} h")
    } else if hours > 0 {
        format!("{hours} h {minutes} min")
    } else if minutes > 0 {
        format!("{minutes} min {secs} s")
    } else {
        format!("{secs} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_read_in_two_units() {
        assert_eq!(duration_words(59.4), "59 s");
        assert_eq!(duration_words(610.0), "10 min 10 s");
        assert_eq!(duration_words(3.0 * 3600.0 + 20.0 * 60.0), "3 h 20 min");
        assert_eq!(
            duration_words(86_400.0 * 12.0 + 4.0 * 3600.0),
            "12 days 4 h"
        );
    }
}
