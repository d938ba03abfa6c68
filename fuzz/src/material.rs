//! What mutations work on: the kind of file a target reads, the corpus and dictionary they draw
//! from, and the pieces of a text they change (its lines, numbers and words) with the numbers
//! that break parsers. Used by the byte and text mutations (`mutate`) and each format's own
//! (`grammar`).

use super::rng::Rng;

/// What kind of file a target reads, which chooses the mutations that fit it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Grammar {
    Toml,
    Csv,
    Gcode,
    /// STL: binary, or ASCII text.
    Stl,
    /// OpenEXR: a binary header of attributes, an offset table, blocks.
    Exr,
}

/// What mutations draw on: the target's corpus and its dictionary (the words of its corpus and
/// of its format).
pub struct Material<'a> {
    pub corpus: &'a [Vec<u8>],
    pub dictionary: &'a [Vec<u8>],
    pub grammar: Grammar,
}

/// Numbers that parsers and what follows them get wrong: zeros of both signs, the extremes and
/// the subnormals of f64, values that are not numbers, the edges of i32, u32 and u64, counts that
/// allocate, a number of 400 digits, forms some parsers take and others do not.
pub const INTERESTING_NUMBERS: &[&str] = &[
    "0", "-0", "0.0", "-0.0", "1", "-1", "2", "3", "7", "0.5", "1e300", "-1e300", "1e308",
    "-1e308", "1.7976931348623157e308", "1e309", "-1e309", "5e-324", "-5e-324", "1e-323",
    "2.2250738585072014e-308", "1e-300", "1e-9", "1e-12", "nan", "NaN", "-nan", "inf", "-inf",
    "+inf", "Infinity", "2147483647", "2147483648", "-2147483648", "-2147483649", "4294967295",
    "4294967296", "9223372036854775807", "9223372036854775808", "18446744073709551615",
    "18446744073709551616", "65535", "65536", "46340", "1000000", "1e6", "1e7", "1e9", "1e12",
    "1e15", "1e18", "3.4028235e38", "3.5e38", "1e-45", "360", "-360", "720", "359.999999",
    "1e-7", "0.001", "+1", ".5", "5.", "1e", "1e+", "-", "+", "00", "007", "0x10", "1_000",
    "1__0", "1.2.3", "--1",
    "9999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999",
    "0.00000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000001",
];

/// Whether `data` reads as text (ASCII STL, not binary): valid UTF-8 with no NUL in its start.
pub fn looks_like_text(data: &[u8]) -> bool {
    let head = &data[..data.len().min(512)];
    !head.contains(&0)
        && std::str::from_utf8(head).map_or_else(|e| e.error_len().is_none(), |_| true)
}

/// A random range of `data`, mostly short.
pub fn range(data: &[u8], rng: &mut Rng) -> (usize, usize) {
    if data.is_empty() {
        return (0, 0);
    }
    let start = rng.below(data.len());
    let most = data.len() - start;
    let len = match rng.below(4) {
        0 => rng.between(1, most.min(4)),
        1 => rng.between(1, most.min(32)),
        2 => rng.between(1, most.min(512)),
        _ => rng.between(1, most),
    };
    (start, start + len)
}

/// The lines of `data`: `(start, end)` with the line end included.
pub fn lines(data: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (n, &b) in data.iter().enumerate() {
        if b == b'\n' {
            out.push((start, n + 1));
            start = n + 1;
        }
    }
    if start < data.len() {
        out.push((start, data.len()));
    }
    out
}

/// The numbers written in `data`: `(start, end)` of each run of a sign, digits, a point and an
/// exponent.
pub fn numbers(data: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut n = 0;
    while n < data.len() {
        let starts = data[n].is_ascii_digit()
            && (n == 0 || !(data[n - 1].is_ascii_alphanumeric() || data[n - 1] == b'_'));
        if !starts {
            n += 1;
            continue;
        }
        let mut start = n;
        if start > 0 && (data[start - 1] == b'-' || data[start - 1] == b'+') {
            start -= 1;
        }
        let mut end = n;
        while end < data.len()
            && (data[end].is_ascii_digit()
                || data[end] == b'.'
                || ((data[end] == b'e' || data[end] == b'E') && end > n)
                || ((data[end] == b'-' || data[end] == b'+')
                    && matches!(data[end - 1], b'e' | b'E')))
        {
            end += 1;
        }
        out.push((start, end));
        n = end;
    }
    out
}

/// The words of `data` (letters, digits and `_`, starting with a letter or `_`).
pub fn words(data: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut n = 0;
    while n < data.len() {
        if data[n].is_ascii_alphabetic() || data[n] == b'_' {
            let start = n;
            while n < data.len() && (data[n].is_ascii_alphanumeric() || data[n] == b'_') {
                n += 1;
            }
            out.push((start, n));
        } else {
            n += 1;
        }
    }
    out
}

/// A number that breaks parsers, or one near `old`.
pub fn interesting_number(old: &[u8], rng: &mut Rng) -> Vec<u8> {
    let value = std::str::from_utf8(old)
        .ok()
        .and_then(|s| s.parse::<f64>().ok());
    match (rng.below(3), value) {
        (0, Some(v)) => {
            let changed = match rng.below(8) {
                0 => v + 1.0,
                1 => v - 1.0,
                2 => -v,
                3 => v * 10.0,
                4 => v / 10.0,
                5 => v * 1e6,
                6 => v + v.abs() * 1e-15,
                _ => (v as i64).wrapping_add(1) as f64,
            };
            changed.to_string().into_bytes()
        }
        (1, _) if !old.is_empty() => {
            // The same number with digits repeated or appended.
            let mut out = old.to_vec();
            let at = rng.below(out.len() + 1);
            let digits: Vec<u8> = (0..rng.few(40) * 4)
                .map(|_| b'0' + rng.below(10) as u8)
                .collect();
            out.splice(at..at, digits);
            out
        }
        _ => rng.pick(INTERESTING_NUMBERS).as_bytes().to_vec(),
    }
}

/// `line` ending in a line feed.
pub fn with_line_end(line: &[u8]) -> Vec<u8> {
    let mut out = line.to_vec();
    if !out.ends_with(b"\n") {
        out.push(b'\n');
    }
    out
}
