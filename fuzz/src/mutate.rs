//! Inputs made from the seed corpus: an entry chosen at random, then one to sixteen mutations
//! stacked on it. Byte mutations (flips, inserted, deleted, duplicated and copied ranges,
//! truncation, splices with another entry) serve every format; the text formats get mutations
//! that keep to their tokens and lines (numbers replaced by the numbers that break parsers,
//! words from the format's dictionary, lines repeated, dropped, swapped or taken from another
//! entry, a line of 70 KB, a byte-order mark, NULs, CR line ends, bad UTF-8), and each format
//! its own (`grammar`): nesting and values of other types in TOML, columns in CSV, subprogram
//! calls in G-code, counts and floats in binary STL, attributes and offsets in OpenEXR.

use super::grammar;
use super::material::{
    interesting_number, lines, looks_like_text, numbers, range, with_line_end, words, Grammar,
    Material,
};
use super::rng::Rng;

/// The largest input a campaign makes.
pub const MAX_INPUT_BYTES: usize = 512 << 10;

/// Bytes that change what a text means: separators, quotes, brackets, line ends, a NUL, bytes
/// that are not UTF-8.
const INTERESTING_BYTES: &[u8] = &[
    0, b'\n', b'\r', b'\t', b' ', b'"', b'\'', b'[', b']', b'{', b'}', b'(', b')', b'=', b',',
    b';', b'#', b'.', b'-', b'+', b'e', b'E', b'\\', b'%', b'/', 0x7f, 0x80, 0xc0, 0xef, 0xff,
];

/// Text that is hard to read: a byte-order mark (anywhere but first it is a character), bad
/// UTF-8, characters of 2, 3 and 4 bytes, a line separator, an escape.
const INTERESTING_TEXT: &[&[u8]] = &[
    b"\xEF\xBB\xBF",
    b"\xEF\xBB",
    b"\xC3\x28",
    b"\xF0\x28\x8C\x28",
    b"\xED\xA0\x80",
    "é".as_bytes(),
    "∞".as_bytes(),
    "😀".as_bytes(),
    "\u{2028}".as_bytes(),
    "\u{FFFD}".as_bytes(),
    b"\x00",
    b"\r",
    b"\r\n",
    b"\\u0000",
    b"\x1b[31m",
];

/// A new input for execution `rng`: a corpus entry with mutations stacked on it.
pub fn input(material: &Material, rng: &mut Rng) -> Vec<u8> {
    let mut data = rng.pick(material.corpus).clone();
    let count = rng.few(16);
    for _ in 0..count {
        mutate(&mut data, material, rng);
        if data.len() > MAX_INPUT_BYTES {
            data.truncate(MAX_INPUT_BYTES);
        }
    }
    data
}

/// One mutation, chosen by the grammar's weights.
pub fn mutate(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    let binary = matches!(material.grammar, Grammar::Exr)
        || (material.grammar == Grammar::Stl && !looks_like_text(data));
    // Byte mutations, text mutations, the grammar's own.
    let weights: [u32; 3] = if binary { [10, 1, 10] } else { [4, 10, 5] };
    match rng.weighted(&weights) {
        0 => byte_mutation(data, material, rng),
        1 => text_mutation(data, material, rng),
        _ => grammar::mutation(data, material, rng),
    }
}

/// A random position in `0..=len`.
fn position(data: &[u8], rng: &mut Rng) -> usize {
    rng.below(data.len() + 1)
}

fn byte_mutation(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    match rng.below(9) {
        0 if !data.is_empty() => {
            let at = rng.below(data.len());
            data[at] ^= 1 << rng.below(8);
        }
        1 if !data.is_empty() => {
            let at = rng.below(data.len());
            data[at] = if rng.one_in(2) {
                *rng.pick(INTERESTING_BYTES)
            } else {
                rng.next_u64() as u8
            };
        }
        2 => {
            let at = position(data, rng);
            let n = rng.few(8);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            data.splice(at..at, bytes);
        }
        3 => {
            let (start, end) = range(data, rng);
            data.drain(start..end);
        }
        4 => {
            let (start, end) = range(data, rng);
            let copy = data[start..end].to_vec();
            let at = if rng.one_in(2) {
                end
            } else {
                position(data, rng)
            };
            data.splice(at..at, copy);
        }
        5 if !data.is_empty() => {
            let (start, end) = range(data, rng);
            let copy = data[start..end].to_vec();
            let at = rng.below(data.len());
            let end = (at + copy.len()).min(data.len());
            data.splice(at..end, copy);
        }
        6 => {
            let at = position(data, rng);
            data.truncate(at);
        }
        7 => crossover(data, material, rng),
        _ => {
            let at = position(data, rng);
            data.splice(at..at, rng.pick(INTERESTING_TEXT).iter().copied());
        }
    }
}

/// This input's start with another entry's end, cut at random bytes or at line starts.
fn crossover(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    let other = rng.pick(material.corpus);
    let (here, there) = if rng.one_in(2) {
        (position(data, rng), rng.below(other.len() + 1))
    } else {
        (pick_line_start(data, rng), pick_line_start(other, rng))
    };
    data.truncate(here);
    data.extend_from_slice(&other[there..]);
}

/// The start of a random line of `data`.
fn pick_line_start(data: &[u8], rng: &mut Rng) -> usize {
    let lines = lines(data);
    lines.get(rng.below(lines.len().max(1))).map_or(0, |l| l.0)
}

fn text_mutation(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    match rng.below(13) {
        0 | 1 => {
            let spans = numbers(data);
            if spans.is_empty() {
                let at = position(data, rng);
                data.splice(at..at, interesting_number(b"", rng));
            } else {
                let (start, end) = *rng.pick(&spans);
                let new = interesting_number(&data[start..end], rng);
                data.splice(start..end, new);
            }
        }
        2 => {
            let spans = words(data);
            if !spans.is_empty() && !material.dictionary.is_empty() {
                let (start, end) = *rng.pick(&spans);
                let new = rng.pick(material.dictionary).clone();
                data.splice(start..end, new);
            }
        }
        3 if !material.dictionary.is_empty() => {
            let at = position(data, rng);
            let new = rng.pick(material.dictionary).clone();
            data.splice(at..at, new);
        }
        4 => {
            // A line repeated: twice, or many times.
            let spans = lines(data);
            if !spans.is_empty() {
                let (start, end) = *rng.pick(&spans);
                let times = rng.size(&[1, 1, 2, 3, 10, 100], &[1000, 10000]);
                let line = with_line_end(&data[start..end]);
                let most = (MAX_INPUT_BYTES / line.len().max(1)).max(1);
                let copies = line.repeat(times.min(most));
                data.splice(end..end, copies);
            }
        }
        5 => {
            let spans = lines(data);
            if !spans.is_empty() {
                let (start, end) = *rng.pick(&spans);
                data.drain(start..end);
            }
        }
        6 => {
            let spans = lines(data);
            if spans.len() >= 2 {
                let a = rng.below(spans.len());
                let b = rng.below(spans.len());
                let (a, b) = (spans[a.min(b)], spans[a.max(b)]);
                if a != b {
                    let first = with_line_end(&data[a.0..a.1]);
                    let second = with_line_end(&data[b.0..b.1]);
                    data.splice(b.0..b.1, first);
                    data.splice(a.0..a.1, second);
                }
            }
        }
        7 => {
            // A line from another entry.
            let other = rng.pick(material.corpus);
            let spans = lines(other);
            if !spans.is_empty() {
                let (start, end) = *rng.pick(&spans);
                let line = with_line_end(&other[start..end]);
                let at = pick_line_start(data, rng);
                data.splice(at..at, line);
            }
        }
        8 => {
            // A long line: now and then past the 64 KiB a streamed line may hold, or just short of it.
            let len = rng.size(&[100, 1000, 4096], &[65535, 65536, 65537, 70000]);
            let unit: &[u8] = match rng.below(4) {
                0 => b"9",
                1 => b"a",
                2 => b"0,",
                _ => b" ",
            };
            let mut line = unit.repeat(len / unit.len());
            line.push(b'\n');
            let at = pick_line_start(data, rng);
            data.splice(at..at, line);
        }
        9 => {
            // Line ends changed throughout: CR LF, CR only, none.
            let to: &[u8] = rng.pick::<&[u8]>(&[&b"\r\n"[..], b"\r", b"\n\n", b""]);
            let mut out = Vec::with_capacity(data.len() * 2);
            for &b in data.iter() {
                if b == b'\n' {
                    out.extend_from_slice(to);
                } else {
                    out.push(b);
                }
            }
            *data = out;
        }
        10 => {
            // A byte-order mark first, or two.
            let n = rng.few(2);
            data.splice(0..0, b"\xEF\xBB\xBF".repeat(n));
        }
        11 => {
            let at = position(data, rng);
            data.splice(at..at, rng.pick(INTERESTING_TEXT).iter().copied());
        }
        _ => {
            // An empty line, or a line of blanks, or a comment.
            let at = pick_line_start(data, rng);
            let line: &[u8] = rng.pick::<&[u8]>(&[&b"\n"[..], b"   \n", b"#\n", b"; x\n", b"//\n"]);
            data.splice(at..at, line.iter().copied());
        }
    }
}

/// The dictionary of a corpus: its distinct words and other tokens, with `extra` words of the
/// format.
pub fn dictionary(corpus: &[Vec<u8>], extra: &[&str]) -> Vec<Vec<u8>> {
    let mut out: Vec<Vec<u8>> = extra.iter().map(|w| w.as_bytes().to_vec()).collect();
    for entry in corpus {
        if !looks_like_text(entry) {
            continue;
        }
        for (start, end) in words(entry) {
            if end - start <= 40 {
                out.push(entry[start..end].to_vec());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}
