//! SplitMix64 (Steele, Lea and Flood 2014, as in Vigna's `splitmix64.c`): the one generator of
//! every choice that must come out the same on every run and every machine: the check points of
//! a map, the Monte Carlo draws of sampled machines, the tests' data and the fuzzing harness's
//! seeds. Not for anything that must be unpredictable.

/// The state's increment, 2⁶⁴ divided by the golden ratio (odd, so every state is visited).
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// A 64-bit state advanced by a fixed increment, each output the [`mix`](SplitMix64::mix) of the
/// state: the same seed gives the same numbers everywhere.
#[derive(Debug, Clone)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub const fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GAMMA);
        SplitMix64::mix(self.state)
    }

    /// Uniform in [0, 1): the top 53 bits of [`next_u64`](SplitMix64::next_u64), as an f64 holds
    /// them exactly.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The finaliser: a bijection of u64 that mixes every input bit into every output bit (the
    /// draws of sampled machines hash their counters with it).
    pub const fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests {
    use super::SplitMix64;

    /// The first outputs of the reference `splitmix64.c` for two seeds: a change of the stream
    /// would change every map's check points and every Monte Carlo result.
    #[test]
    fn the_stream_is_the_reference_algorithms() {
        let mut rng = SplitMix64::new(1_477_776_061_723_855_037);
        let first: Vec<u64> = (0..5).map(|_| rng.next_u64()).collect();
        assert_eq!(
            first,
            [
                1_985_237_415_132_408_290,
                2_979_275_885_539_914_483,
                13_511_426_838_097_143_398,
                8_488_337_342_461_049_707,
                15_141_737_807_933_549_159,
            ]
        );
        let mut zero = SplitMix64::new(0);
        assert_eq!(zero.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(zero.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        // The finaliser alone is the output of the state after one step.
        assert_eq!(
            SplitMix64::mix(0x9E37_79B9_7F4A_7C15),
            0xE220_A839_7B1D_CDAF
        );
    }

    #[test]
    fn uniform_numbers_take_the_top_53_bits() {
        let mut a = SplitMix64::new(9);
        let mut b = SplitMix64::new(9);
        for _ in 0..1000 {
            let u = a.next_f64();
            assert!((0.0..1.0).contains(&u));
            assert_eq!(u, (b.next_u64() >> 11) as f64 * 2f64.powi(-53));
        }
    }
}
