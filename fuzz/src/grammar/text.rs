//! The mutations of the text formats: TOML, CSV, G-code.

use crate::material::{interesting_number, lines, with_line_end, Material};
use crate::rng::Rng;

/// Where the value of a random `key = value` line starts and ends (the line end excluded).
fn value_span(data: &[u8], rng: &mut Rng) -> Option<(usize, usize)> {
    let candidates: Vec<(usize, usize)> = lines(data)
        .into_iter()
        .filter_map(|(start, end)| {
            let line = &data[start..end];
            let eq = line.iter().position(|&b| b == b'=')?;
            let mut value_end = end;
            while value_end > start + eq + 1 && matches!(data[value_end - 1], b'\n' | b'\r') {
                value_end -= 1;
            }
            Some((start + eq + 1, value_end))
        })
        .collect();
    (!candidates.is_empty()).then(|| *rng.pick(&candidates))
}

/// Depths of nesting: shallow, past what a reader's recursion limit allows, far past it.
const DEPTHS: &[usize] = &[2, 3, 10, 100, 127, 128, 129];
const DEEP: &[usize] = &[1000, 10000];

/// Values of other types than the key expects, and sizes no file has.
const TOML_VALUES: &[&str] = &[
    "\"text\"",
    "''",
    "\"\"",
    "true",
    "false",
    "[]",
    "{}",
    "[[]]",
    "[{}]",
    "{ x = 1 }",
    "1979-05-27T07:32:00Z",
    "07:32:00",
    "1979-05-27",
    "inf",
    "-inf",
    "nan",
    "+nan",
    "-0.0",
    "0x7fffffff",
    "0o777",
    "0b1",
    "1_000.5",
    "\"\"\"a\nb\"\"\"",
    "[1, \"a\"]",
    "[[0, 0], [0]]",
    "[[0, 0], [0, 0], [0, 0]]",
    "[0.0, 0.0]",
    "[0.0, 0.0, 0.0, 0.0]",
    "\"\\u0000\"",
    "\"\\uD800\"",
    "\"../../x.csv\"",
    "\"/dev/zero\"",
    "\"x.csv\"",
    "\"a.stl\"",
];

pub(super) fn toml(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    match rng.below(7) {
        0 => {
            // A value nested deep in arrays or inline tables.
            let depth = rng.size(DEPTHS, DEEP);
            let (open, close): (&[u8], &[u8]) = if rng.one_in(2) {
                (b"[", b"]")
            } else {
                (b"{ a = ", b" }")
            };
            let (start, end) = value_span(data, rng).unwrap_or((data.len(), data.len()));
            let mut value = open.repeat(depth);
            value.extend_from_slice(&data[start..end]);
            value.extend_from_slice(&close.repeat(depth));
            data.splice(start..end, value);
        }
        1 => {
            if let Some((start, end)) = value_span(data, rng) {
                let new: Vec<u8> = match rng.below(4) {
                    0 => {
                        // A long array of numbers, or of pairs (a table of many nodes).
                        let n = rng.size(&[2, 10, 100], &[1000, 20000]);
                        let item: &[u8] = if rng.one_in(2) { b"0.0, " } else { b"[0, 0], " };
                        let mut v = b"[".to_vec();
                        v.extend(item.repeat(n));
                        v.push(b']');
                        v
                    }
                    1 => {
                        let mut v = b"[".to_vec();
                        v.extend(interesting_number(b"", rng));
                        v.extend_from_slice(b", ");
                        v.extend(interesting_number(b"", rng));
                        v.push(b']');
                        v
                    }
                    _ => rng.pick(TOML_VALUES).as_bytes().to_vec(),
                };
                let mut new_value = b" ".to_vec();
                new_value.extend(new);
                data.splice(start..end, new_value);
            }
        }
        2 => {
            // A table header of the format's words.
            let mut header = if rng.one_in(3) {
                b"[[".to_vec()
            } else {
                b"[".to_vec()
            };
            for n in 0..rng.few(3) {
                if n > 0 {
                    header.push(b'.');
                }
                header.extend(word(material, rng));
            }
            header.extend_from_slice(if header.starts_with(b"[[") {
                b"]]\n"
            } else {
                b"]\n"
            });
            let at = line_start(data, rng);
            data.splice(at..at, header);
        }
        3 => {
            // A key of the format's words with a value.
            let mut line = word(material, rng);
            line.extend_from_slice(b" = ");
            if rng.one_in(2) {
                line.extend(interesting_number(b"", rng));
            } else {
                line.extend_from_slice(rng.pick(TOML_VALUES).as_bytes());
            }
            line.push(b'\n');
            let at = line_start(data, rng);
            data.splice(at..at, line);
        }
        4 => {
            // A dotted key as deep as the nesting above.
            let depth = rng.size(DEPTHS, DEEP);
            let mut line = b"a".to_vec();
            line.extend(b".a".repeat(depth));
            line.extend_from_slice(b" = 1\n");
            let at = line_start(data, rng);
            data.splice(at..at, line);
        }
        5 => {
            // A table header or key twice.
            let candidates: Vec<(usize, usize)> = lines(data)
                .into_iter()
                .filter(|&(s, e)| data[s..e].starts_with(b"[") || data[s..e].contains(&b'='))
                .collect();
            if !candidates.is_empty() {
                let (start, end) = *rng.pick(&candidates);
                let line = with_line_end(&data[start..end]);
                let at = line_start(data, rng);
                data.splice(at..at, line);
            }
        }
        _ => {
            // An unclosed string, array or table.
            let at = rng.below(data.len() + 1);
            let cut: &[u8] =
                rng.pick::<&[u8]>(&[&b"\""[..], b"'", b"[", b"{", b"\"\"\"", b"'''", b"\\"]);
            data.splice(at..at, cut.iter().copied());
        }
    }
}

/// A word of the format's dictionary (or `x`).
pub(super) fn word(material: &Material, rng: &mut Rng) -> Vec<u8> {
    if material.dictionary.is_empty() {
        b"x".to_vec()
    } else {
        rng.pick(material.dictionary).clone()
    }
}

/// The start of a random line, or the end of the data.
pub(super) fn line_start(data: &[u8], rng: &mut Rng) -> usize {
    let spans = lines(data);
    if spans.is_empty() || rng.one_in(spans.len() + 1) {
        data.len()
    } else {
        rng.pick(&spans).0
    }
}

/// The data's lines split into comma-separated fields (line ends dropped).
fn fields(data: &[u8]) -> Vec<Vec<Vec<u8>>> {
    lines(data)
        .into_iter()
        .map(|(s, e)| {
            let line = data[s..e].strip_suffix(b"\n").unwrap_or(&data[s..e]);
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            line.split(|&b| b == b',').map(<[u8]>::to_vec).collect()
        })
        .collect()
}

fn join(rows: &[Vec<Vec<u8>>]) -> Vec<u8> {
    let mut out = Vec::new();
    for row in rows {
        out.extend(row.join(&b","[..]));
        out.push(b'\n');
    }
    out
}

pub(super) fn csv(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    let mut rows = fields(data);
    if rows.is_empty() {
        data.extend_from_slice(b"position_mm,deviation_mm\n0,0\n");
        return;
    }
    let columns = rows.iter().map(Vec::len).max().unwrap_or(1);
    let column = rng.below(columns);
    match rng.below(8) {
        0 => {
            // A column twice.
            for row in &mut rows {
                if let Some(f) = row.get(column).cloned() {
                    row.insert(column, f);
                }
            }
        }
        1 => {
            for row in &mut rows {
                if column < row.len() {
                    row.remove(column);
                }
            }
        }
        2 => {
            let other = rng.below(columns);
            for row in &mut rows {
                if column < row.len() && other < row.len() {
                    row.swap(column, other);
                }
            }
        }
        3 => {
            // A new column: a name of the format, a number in every row.
            let name = word(material, rng);
            let value = interesting_number(b"", rng);
            for (n, row) in rows.iter_mut().enumerate() {
                let at = column.min(row.len());
                row.insert(at, if n == 0 { name.clone() } else { value.clone() });
            }
        }
        4 => {
            // Many rows.
            let times = rng.size(&[2, 10, 100], &[1000, 20000]);
            if let Some(row) = rows.last().cloned() {
                for _ in 0..times {
                    rows.push(row.clone());
                }
            }
        }
        5 => {
            // A field quoted, emptied, or made a number that breaks parsers.
            let n = rng.below(rows.len());
            if let Some(f) = rows[n].get_mut(column) {
                *f = match rng.below(4) {
                    0 => [&b"\""[..], f, b"\""].concat(),
                    1 => Vec::new(),
                    2 => b"\"a,b\"".to_vec(),
                    _ => interesting_number(f, rng),
                };
            }
        }
        6 => {
            // Other separators on a line.
            let n = rng.below(rows.len());
            let sep: &[u8] = rng.pick::<&[u8]>(&[&b";"[..], b"\t", b" ", b",,", b", "]);
            let line = rows[n].join(sep);
            rows[n] = vec![line];
        }
        _ => {
            // Every row's field in this column made the same number.
            let value = interesting_number(b"", rng);
            for row in rows.iter_mut().skip(1) {
                if let Some(f) = row.get_mut(column) {
                    *f = value.clone();
                }
            }
        }
    }
    let joined = join(&rows);
    *data = joined;
}

/// Codes a program may hold, supported or not.
const GCODES: &[&str] = &[
    "G0", "G1", "G2", "G3", "G4", "G17", "G18", "G19", "G20", "G21", "G28", "G40", "G41", "G43",
    "G49", "G53", "G54", "G55", "G59", "G61", "G64", "G68", "G69", "G73", "G80", "G81", "G82",
    "G83", "G85", "G89", "G90", "G91", "G94", "G95", "G98", "G99", "G65", "M98", "M99", "M30",
    "M2", "M3", "M5", "M6", "T1", "H1", "G43 H1", "G54.1 P1", "G112", "G05.1",
];
const GWORDS: &[u8] = b"XYZABCIJKRFPLQHDTSNOUVW";

pub(super) fn gcode(data: &mut Vec<u8>, rng: &mut Rng) {
    match rng.below(6) {
        0 | 1 => {
            // Subprogram calls: repeated, nested, recursive, to a body that is missing.
            let n = rng.between(1, 9999);
            let repeats = *rng.pick(&[
                "",
                " L2",
                " L1000",
                " L9999",
                " L99999",
                " L4294967296",
                " L0",
                " L-1",
            ]);
            let spans = lines(data);
            let body: Vec<u8> = if spans.is_empty() {
                b"G1 X1\n".to_vec()
            } else {
                let (s, _) = *rng.pick(&spans);
                let (_, e) = spans[(spans.iter().position(|l| l.0 == s).unwrap_or(0)
                    + rng.below(4))
                .min(spans.len() - 1)];
                with_line_end(&data[s..e])
            };
            let call = if rng.one_in(4) { "G65" } else { "M98" };
            let mut text = format!("{call} P{n}{repeats}\n").into_bytes();
            let at = line_start(data, rng);
            data.splice(at..at, text.drain(..));
            let mut sub = format!("O{n}\n").into_bytes();
            match rng.below(3) {
                0 => sub.extend(format!("{call} P{n}\n").into_bytes()),
                1 => {
                    let inner = n + 1;
                    sub.extend(format!("M98 P{inner}{repeats}\nM99\nO{inner}\n").into_bytes());
                }
                _ => {}
            }
            sub.extend(body);
            sub.extend_from_slice(b"M99\n");
            if rng.one_in(5) {
                return; // the body missing
            }
            let end = data
                .windows(3)
                .position(|w| w == b"M30")
                .map_or(data.len(), |p| lines(&data[..p]).last().map_or(0, |l| l.1));
            let at = if rng.one_in(2) { data.len() } else { end };
            data.splice(at..at, sub);
        }
        2 => {
            // A block of a code and words.
            let mut line = rng.pick(GCODES).as_bytes().to_vec();
            for _ in 0..rng.few(4) {
                line.push(b' ');
                line.push(GWORDS[rng.below(GWORDS.len())]);
                line.extend(interesting_number(b"", rng));
            }
            line.push(b'\n');
            let at = line_start(data, rng);
            data.splice(at..at, line);
        }
        3 => {
            // A word added to a block.
            let spans = lines(data);
            if let Some(&(_, end)) = spans.get(rng.below(spans.len().max(1))) {
                let at = if data[..end].ends_with(b"\n") {
                    end - 1
                } else {
                    end
                };
                let mut word = vec![b' ', GWORDS[rng.below(GWORDS.len())]];
                word.extend(interesting_number(b"", rng));
                data.splice(at..at, word);
            }
        }
        4 => {
            // A comment or a program mark, closed or not.
            let text: &[u8] = rng.pick::<&[u8]>(&[
                &b"(comment)"[..],
                b"(open",
                b"; note",
                b"%",
                b"((nested))",
                b"/",
                b"N99999999999",
                b"O0001",
                b"#1=5",
                b"[1+2]",
            ]);
            let at = line_start(data, rng);
            data.splice(at..at, with_line_end(text));
        }
        _ => {
            // A block repeated many times.
            let spans = lines(data);
            if !spans.is_empty() {
                let (s, e) = *rng.pick(&spans);
                let line = with_line_end(&data[s..e]);
                let times = rng.size(&[2, 10, 100], &[5000]);
                data.splice(e..e, line.repeat(times));
            }
        }
    }
}
