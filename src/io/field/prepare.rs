//! The bytes of a compressed block before they are deflated, as OpenEXR lays them out (its
//! `ImfZip.cpp` and `ImfPxr24Compressor.cpp`), so that the deflate level is volmap's choice: the
//! `exr` crate's encoders deflate at level 4, which measured 2 to 3 times slower a core than
//! level 1 for files 10 to 20% smaller (docs/performance.md). Every reader decodes them as any
//! ZIP or PXR24 block (the `exr` crate decodes volmap's own).
//!
//! A block's values arrive per line, per channel, `nx` values each: the layout of the block.

use std::io::Write;

/// The deflate level volmap compresses at.
const LEVEL: u32 = 1;

/// The zlib stream of `bytes`.
pub(super) fn deflate(bytes: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut encoder = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(bytes.len() / 2),
        flate2::Compression::new(LEVEL),
    );
    encoder.write_all(bytes)?;
    encoder.finish()
}

/// OpenEXR's ZIP predictor over the block's little-endian bytes: the even bytes, then the odd
/// ones, each byte replaced by its difference to the one before plus 128.
pub(super) fn zip_bytes(little_endian: &[u8]) -> Vec<u8> {
    let half = little_endian.len().div_ceil(2);
    let mut out = vec![0u8; little_endian.len()];
    let (even, odd) = out.split_at_mut(half);
    for (n, pair) in little_endian.chunks(2).enumerate() {
        even[n] = pair[0];
        if let Some(&b) = pair.get(1) {
            odd[n] = b;
        }
    }
    let mut previous = out.first().copied().unwrap_or(0);
    for byte in out.iter_mut().skip(1) {
        let value = *byte;
        *byte = value.wrapping_sub(previous).wrapping_add(128);
        previous = value;
    }
    out
}

/// A FLOAT rounded to 24 bits (sign, 8-bit exponent, 15-bit mantissa, rounded to nearest), as
/// OpenEXR's `floatToFloat24`: within 2^-16 of the value.
pub(super) fn float_to_f24(value: f32) -> u32 {
    let bits = value.to_bits();
    let sign = bits & 0x8000_0000;
    let exponent = bits & 0x7f80_0000;
    let mantissa = bits & 0x007f_ffff;
    let rounded = if exponent == 0x7f80_0000 {
        if mantissa != 0 {
            // A NaN keeps a non-zero significand.
            let m = mantissa >> 8;
            (exponent >> 8) | m | u32::from(m == 0)
        } else {
            exponent >> 8
        }
    } else {
        let r = ((exponent | mantissa) + (mantissa & 0x80)) >> 8;
        // Rounding up past the largest finite value truncates instead.
        if r >= 0x7f_8000 {
            (exponent | mantissa) >> 8
        } else {
            r
        }
    };
    (sign >> 8) | rounded
}

/// PXR24's layout of a block of FLOAT values: per line and channel, each value as 24 bits
/// minus the one before it (from 0), the differences' high, middle and low bytes in three runs.
pub(super) fn pxr24_float_bytes(values: &[f32], nx: usize) -> Vec<u8> {
    let mut out = vec![0u8; values.len() * 3];
    for (run, out) in values.chunks_exact(nx).zip(out.chunks_exact_mut(3 * nx)) {
        let (high, rest) = out.split_at_mut(nx);
        let (middle, low) = rest.split_at_mut(nx);
        let mut previous = 0u32;
        for (i, &v) in run.iter().enumerate() {
            let f24 = float_to_f24(v);
            let d = f24.wrapping_sub(previous);
            previous = f24;
            high[i] = (d >> 16) as u8;
            middle[i] = (d >> 8) as u8;
            low[i] = d as u8;
        }
    }
    out
}

/// PXR24's layout of a block of HALF values (their bits): per line and channel, each value
/// minus the one before it, the differences' high and low bytes in two runs. Lossless.
pub(super) fn pxr24_half_bytes(bits: &[u16], nx: usize) -> Vec<u8> {
    let mut out = vec![0u8; bits.len() * 2];
    for (run, out) in bits.chunks_exact(nx).zip(out.chunks_exact_mut(2 * nx)) {
        let (high, low) = out.split_at_mut(nx);
        let mut previous = 0u16;
        for (i, &h) in run.iter().enumerate() {
            let d = h.wrapping_sub(previous);
            previous = h;
            high[i] = (d >> 8) as u8;
            low[i] = d as u8;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f24_keeps_15_mantissa_bits_rounded_to_nearest() {
        assert_eq!(float_to_f24(1.0), 0x3f_8000);
        assert_eq!(float_to_f24(-2.0), 0xc0_0000);
        // 1 + 2^-16 rounds up to 1 + 2^-15; just below it rounds down to 1.
        assert_eq!(float_to_f24(1.0 + 2f32.powi(-16)), 0x3f_8001);
        assert_eq!(float_to_f24(1.0 + 2f32.powi(-17)), 0x3f_8000);
        assert_eq!(float_to_f24(f32::INFINITY), 0x7f_8000);
        // A NaN stays a NaN: every exponent bit and a significand bit set.
        let nan = float_to_f24(f32::NAN);
        assert_eq!(nan & 0x7f_8000, 0x7f_8000);
        assert_ne!(nan & 0x7fff, 0);
    }

    #[test]
    fn the_zip_predictor_splits_and_differences() {
        assert_eq!(zip_bytes(&[1, 10, 3, 20, 6]), vec![1, 130, 131, 132, 138]);
    }
}
