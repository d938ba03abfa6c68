//! Numbers in what volmap prints for people: one rule, here, for every command's summaries,
//! tables and the library's report text they print. Files (CSV, JSON, G-code, tables, field
//! headers) keep their own units and full precision and do not use these.
//!
//! - Positions, travels, sizes, distances, tool lengths: mm, 3 decimals ([`length_mm`]);
//!   rotary axis positions: degrees, 3 decimals ([`degrees`]).
//! - Linear errors and deviations: µm, 3 decimals ([`error_um`], given mm).
//! - Angular errors: µrad, 3 decimals ([`angle_urad`], given rad).
//! - Every other quantity (coefficients, ratios, rates, times, factors): 4 significant digits
//!   ([`quantity`]); temperatures °C with 2 decimals ([`celsius`]); percentages 1 decimal
//!   ([`percent`]).
//!
//! The bare forms ([`length`], [`error`], [`angle`], [`rotary`]) are for table cells whose
//! column heading names the unit.

/// µm in a mm.
const UM_PER_MM: f64 = 1e3;

/// µrad in a rad.
const URAD_PER_RAD: f64 = 1e6;

/// `value` with `decimals` decimals; a value that rounds to zero prints without a sign
/// (`0.000`, never `-0.000`), and one that is not a number as `NaN`, `inf` or `-inf`.
pub fn fixed(value: f64, decimals: usize) -> String {
    if !value.is_finite() {
        return not_finite(value);
    }
    let text = format!("{value:.decimals$}");
    match text.strip_prefix('-') {
        Some(unsigned) if unsigned.bytes().all(|b| b == b'0' || b == b'.') => unsigned.to_string(),
        _ => text,
    }
}

fn not_finite(value: f64) -> String {
    if value.is_nan() {
        "NaN".into()
    } else if value > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

/// A position, travel, size or distance in mm, without its unit: `565.217`.
pub fn length(mm: f64) -> String {
    fixed(mm, 3)
}

/// A position, travel, size or distance: `565.217 mm`.
pub fn length_mm(mm: f64) -> String {
    format!("{} mm", length(mm))
}

/// A linear error given in mm, in µm without its unit: `130.146`.
pub fn error(mm: f64) -> String {
    fixed(mm * UM_PER_MM, 3)
}

/// A linear error given in mm: `130.146 µm`.
pub fn error_um(mm: f64) -> String {
    format!("{} µm", error(mm))
}

/// An angular error given in rad, in µrad without its unit: `172.400`.
pub fn angle(rad: f64) -> String {
    fixed(rad * URAD_PER_RAD, 3)
}

/// An angular error given in rad: `172.400 µrad`.
pub fn angle_urad(rad: f64) -> String {
    format!("{} µrad", angle(rad))
}

/// A rotary axis position in degrees, without its unit: `30.000`.
pub fn rotary(deg: f64) -> String {
    fixed(deg, 3)
}

/// A rotary axis position: `30.000°`.
pub fn degrees(deg: f64) -> String {
    format!("{}°", rotary(deg))
}

/// A temperature: `20.00 °C`.
pub fn celsius(c: f64) -> String {
    format!("{} °C", fixed(c, 2))
}

/// A percentage, given in percent: `95.0%`.
pub fn percent(p: f64) -> String {
    format!("{}%", fixed(p, 1))
}

/// Any other quantity (a coefficient, ratio, rate, time, factor) with 4 significant digits:
/// fixed where 1e-3 ≤ |x| < 1e6 after rounding (`43.20`, `0.001234`, `123500`), else the
/// mantissa's 4 digits and a signed exponent (`1.234e-7`, `1.000e+6`); zero is `0`.
pub fn quantity(x: f64) -> String {
    if !x.is_finite() {
        return not_finite(x);
    }
    if x == 0.0 {
        return "0".into();
    }
    // Rust's `{:.3e}` rounds once to 4 significant digits; its digits and exponent place the point.
    let scientific = format!("{x:.3e}");
    let (mantissa, exponent) = scientific.split_once('e').expect("`{:e}` has an exponent");
    let exponent: i32 = exponent.parse().expect("`{:e}` has an integer exponent");
    let (sign, mantissa) = match mantissa.strip_prefix('-') {
        Some(m) => ("-", m),
        None => ("", mantissa),
    };
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    if !(-3..6).contains(&exponent) {
        let exponent_sign = if exponent < 0 { '-' } else { '+' };
        return format!("{sign}{mantissa}e{exponent_sign}{}", exponent.abs());
    }
    let text = if exponent >= 3 {
        format!("{digits}{}", "0".repeat(exponent as usize - 3))
    } else if exponent >= 0 {
        let point = exponent as usize + 1;
        format!("{}.{}", &digits[..point], &digits[point..])
    } else {
        format!("0.{}{digits}", "0".repeat((-exponent - 1) as usize))
    };
    format!("{sign}{text}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_errors_and_angles_have_three_decimals_in_their_units() {
        assert_eq!(length_mm(565.21749), "565.217 mm");
        assert_eq!(error_um(0.1301456), "130.146 µm");
        assert_eq!(angle_urad(1.724e-4), "172.400 µrad");
        assert_eq!(degrees(30.0), "30.000°");
        assert_eq!(error(-0.0000123), "-0.012");
        assert_eq!(celsius(20.0), "20.00 °C");
        assert_eq!(percent(95.04), "95.0%");
    }

    #[test]
    fn negative_zero_and_what_rounds_to_zero_print_without_a_sign() {
        assert_eq!(length(-0.0), "0.000");
        assert_eq!(length(-0.0004), "0.000");
        assert_eq!(error(-1e-9), "0.000");
        assert_eq!(angle(-0.0), "0.000");
        assert_eq!(percent(-0.01), "0.0%");
        assert_eq!(quantity(-0.0), "0");
        assert_eq!(length(-0.0005), "-0.001");
    }

    #[test]
    fn not_a_number_and_infinities_print_as_words() {
        for f in [length, error, angle, rotary, quantity] {
            assert_eq!(f(f64::NAN), "NaN");
            assert_eq!(f(f64::INFINITY), "inf");
            assert_eq!(f(f64::NEG_INFINITY), "-inf");
        }
        assert_eq!(error_um(f64::NAN), "NaN µm");
    }

    #[test]
    fn quantities_have_four_significant_digits_fixed_in_the_middle_range() {
        assert_eq!(quantity(43.2), "43.20");
        assert_eq!(quantity(-43.2), "-43.20");
        assert_eq!(quantity(1.0), "1.000");
        assert_eq!(quantity(0.001), "0.001000");
        assert_eq!(quantity(0.0012345), "0.001234");
        assert_eq!(quantity(1234.0), "1234");
        assert_eq!(quantity(123456.0), "123500");
        assert_eq!(quantity(999_999.0), "1.000e+6");
        assert_eq!(quantity(9.9996), "10.00");
        assert_eq!(quantity(0.00099996), "0.001000");
    }

    #[test]
    fn quantities_outside_it_are_scientific_with_a_signed_exponent() {
        assert_eq!(quantity(1.234e-7), "1.234e-7");
        assert_eq!(quantity(-1.2344e-7), "-1.234e-7");
        assert_eq!(quantity(0.000999), "9.990e-4");
        assert_eq!(quantity(1e6), "1.000e+6");
        assert_eq!(quantity(2.5e300), "2.500e+300");
        assert_eq!(quantity(f64::MIN_POSITIVE), "2.225e-308");
        assert_eq!(quantity(5e-324), "4.941e-324");
    }

    #[test]
    fn every_quantity_has_four_digits_and_reads_back_near_its_value() {
        let mut x = 1.234_567e-12;
        while x < 1e12 {
            for v in [x, -x] {
                let text = quantity(v);
                let digits = text
                    .split('e')
                    .next()
                    .unwrap()
                    .trim_start_matches(['-', '0', '.'])
                    .chars()
                    .filter(char::is_ascii_digit)
                    .count();
                assert!(digits == 4 || text.ends_with('0'), "{v}: {text}");
                let back: f64 = text.parse().unwrap();
                assert!(((back - v) / v).abs() < 1e-3, "{v}: {text}");
            }
            x *= 3.7;
        }
    }
}
