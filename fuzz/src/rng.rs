//! The campaign's random numbers: xoshiro256** seeded by the library's SplitMix64 from the campaign's seed and
//! the execution's number, so that execution `n` of seed `s` is the same input whatever ran
//! before it (`--seed s --at n` makes it again without running the others).

use volmap::model::random::SplitMix64;

/// A small, fast generator; not for anything but choosing mutations.
#[derive(Debug, Clone)]
pub struct Rng {
    state: [u64; 4],
}

impl Rng {
    /// The generator of execution `execution` of the campaign with `seed`.
    pub fn for_execution(seed: u64, execution: u64) -> Rng {
        let first =
            SplitMix64::new(seed ^ execution.wrapping_mul(0xD605_0B43_FA61_0F71)).next_u64();
        let mut seeds = SplitMix64::new(first ^ execution);
        Rng {
            state: [
                seeds.next_u64(),
                seeds.next_u64(),
                seeds.next_u64(),
                seeds.next_u64(),
            ],
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        let [s0, s1, s2, s3] = &mut self.state;
        let result = s1.wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = *s1 << 17;
        *s2 ^= *s0;
        *s3 ^= *s1;
        *s1 ^= *s2;
        *s0 ^= *s3;
        *s2 ^= t;
        *s3 = s3.rotate_left(45);
        result
    }

    /// A number in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        debug_assert!(n > 0);
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// A number in `lo..=hi`.
    pub fn between(&mut self, lo: usize, hi: usize) -> usize {
        lo + self.below(hi - lo + 1)
    }

    /// True with probability `1 / n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }

    /// A small count, most often 1: `1 + ` the number of further heads in a row, at most `most`.
    pub fn few(&mut self, most: usize) -> usize {
        let mut n = 1;
        while n < most && self.one_in(2) {
            n += 1;
        }
        n
    }

    /// A size: one of `small` most of the time, one of `large` once in 32 (inputs that large are
    /// slow to read, and their point, that a reader's time and memory stay in proportion, is
    /// made in a few thousand executions).
    pub fn size(&mut self, small: &[usize], large: &[usize]) -> usize {
        if self.one_in(32) {
            *self.pick(large)
        } else {
            *self.pick(small)
        }
    }

    /// Index into `weights` chosen with probability proportional to each weight.
    pub fn weighted(&mut self, weights: &[u32]) -> usize {
        let total: u64 = weights.iter().map(|&w| w as u64).sum();
        let mut at = self.next_u64() % total.max(1);
        for (n, &w) in weights.iter().enumerate() {
            if at < w as u64 {
                return n;
            }
            at -= w as u64;
        }
        weights.len() - 1
    }
}
