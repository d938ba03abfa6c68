//! The documented limits on what an input may ask for (docs/inputs-and-limits.md). Every count an input
//! implies (the points a feature is sampled at, the points of a test, its runs, the machines
//! drawn, the decimals written, the points of a drawing) is checked against one of these before
//! anything is allocated or looped: a value far beyond any use is bad input naming its key or
//! flag, never an exhausted memory, an endless loop or a panic.
//!
//! Counts are computed in f64 from the inputs (`size / spacing`, products of counts), so no
//! integer overflows before the check; a count that is not a number is over every limit.

/// Machined points sampled on one feature of a part: a floor's grid, a wall's positions times
/// heights, a hole's angles times heights, a meshed surface's samples (about a minute of work).
pub const MAX_FEATURE_POINTS: u64 = 1_000_000;

/// Machined points sampled on all the features of a part together.
pub const MAX_PART_POINTS: u64 = 4_000_000;

/// Points of one standard test: positioning targets, points along a diagonal or around a
/// circle, angles of an R-test.
pub const MAX_TEST_POINTS: u64 = 100_000;

/// Runs per approach direction of a positioning test (ISO 230-2 asks for 5).
pub const MAX_RUNS: u64 = 100;

/// Machines drawn by Monte Carlo (`budget --samples`, `features --samples`).
pub const MAX_SAMPLES: u64 = 1_000_000;

/// Decimals of the coordinates an NC program is written with: beyond what an f64 holds of any
/// coordinate above 0.1 mm.
pub const MAX_DECIMALS: usize = 15;

/// Samples of a traced program (`trace --step`), every move together.
pub const MAX_TRACE_SAMPLES: u64 = 4_000_000;

/// Blocks (lines) of an NC program that `trace` and `compensate` read, the program they write
/// included: each move is traced at 4 samples at least, and [`MAX_TRACE_SAMPLES`] are the most,
/// so a million moves are the most a program can be traced or its compensation checked at.
/// Counted before the program is parsed.
pub const MAX_PROGRAM_BLOCKS: u64 = 1_000_000;

/// Words of an NC program's own blocks (16 a block on average at [`MAX_PROGRAM_BLOCKS`]): each
/// word read takes 40 bytes, so the program's words stay within about 640 MB however its 256 MiB
/// are laid out (two characters make a word: `X1`).
pub const MAX_PROGRAM_WORDS: u64 = 16_000_000;

/// Blocks one move of a compensated program becomes (`--chord-tolerance`,
/// `--angular-tolerance`).
pub const MAX_PIECES_PER_MOVE: u64 = 100_000;

/// Blocks of a compensated program (`compensate --out`, `trace --compensate`): what volmap reads
/// back as a program, [`MAX_PROGRAM_BLOCKS`].
pub const MAX_COMPENSATED_BLOCKS: u64 = MAX_PROGRAM_BLOCKS;

/// Bytes of a compensated program: what volmap reads back as a program (256 MiB, the limit on
/// NC programs), held in memory until it is checked and written.
pub const MAX_COMPENSATED_BYTES: u64 = crate::io::source::PROGRAM_LIMIT_BYTES;

/// Points along the lines of a deformed-grid drawing (`plot grid`: about 34 lines each way).
pub const MAX_DRAWN_POINTS: u64 = 1_000_000;

/// Machine-points of one Monte Carlo run (`budget`: (terms + `--samples`) × grid points ×
/// poses): about a day of work on a fast GPU (58 billion machine-points per second measured on an
/// NVIDIA H200, docs/performance.md, times 86,400 s), years on a CPU.
pub const MAX_MACHINE_POINTS: u64 = 5_000_000_000_000_000;

/// The largest magnitude of a measured value (`volmap test --measured`, fit files' tests: mm,
/// degrees, arc-seconds): a thousand kilometres, beyond any machine tool's travel or error, so
/// that every figure computed from measurements stays a finite number.
pub const MAX_MEASURED_MAGNITUDE: f64 = 1e9;

/// A count beyond its limit.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{} is more than the limit of {limit}", count_words(*.count))]
pub struct TooMany {
    /// The count the input implies (may be far beyond any integer, or not a number).
    pub count: f64,
    pub limit: u64,
}

/// `count` (computed in f64 from the inputs) as an integer, where it is within `limit`.
pub fn within(count: f64, limit: u64) -> Result<u64, TooMany> {
    if count >= 0.0 && count <= limit as f64 {
        Ok(count as u64)
    } else {
        Err(TooMany { count, limit })
    }
}

/// A count in words: an integer where it is one that reads well, else in scientific notation.
pub fn count_words(count: f64) -> String {
    if count.is_nan() {
        "NaN".to_string()
    } else if count.is_infinite() {
        "over 1e308".to_string()
    } else if count.abs() < 1e15 {
        format!("{}", count.ceil())
    } else {
        format!("{count:.3e}")
    }
}

/// A number as a message quotes it: as written where that is short, else in scientific notation
/// (`1e-300`, not three hundred zeros).
pub fn number_words(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-4..1e15).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

/// The points of `steps(lo, hi, spacing)`-style sampling of a length: `ceil(length / spacing) +
/// 1` (at least 2), in f64.
pub fn sampled_points(length: f64, spacing: f64) -> f64 {
    (length / spacing).ceil().max(1.0) + 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_beyond_the_limit_or_not_numbers_are_refused() {
        assert_eq!(within(10.0, 10), Ok(10));
        assert!(within(11.0, 10).is_err());
        assert!(within(f64::NAN, 10).is_err());
        assert!(within(f64::INFINITY, 10).is_err());
        assert!(within(-1.0, 10).is_err());
        assert_eq!(
            TooMany {
                count: 1e300,
                limit: 5
            }
            .to_string(),
            "1.000e300 is more than the limit of 5"
        );
        assert_eq!(
            TooMany {
                count: 12.0,
                limit: 5
            }
            .to_string(),
            "12 is more than the limit of 5"
        );
        assert_eq!(number_words(1e-300), "1e-300");
        assert_eq!(number_words(-2.5e20), "-2.5e20");
        assert_eq!(number_words(0.05), "0.05");
        assert_eq!(number_words(f64::NAN), "NaN");
        assert_eq!(sampled_points(1e300, 1e-300), f64::INFINITY);
        assert_eq!(sampled_points(10.0, 5.0), 3.0);
        assert_eq!(sampled_points(1e-300, 5.0), 2.0);
    }
}
