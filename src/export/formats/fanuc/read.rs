//! Reading a `fanuc` export back as the control loads it: the parameter record and the pitch
//! error compensation data (blocks between `%` lines), with the reference positions from the
//! notes.

use std::collections::BTreeMap;

use super::tables::{
    PitchTable, ReverseTable, AXES, DATA, DATA_NUMBER_BASE, DETECTION_UNIT_MM, INCREMENT_RANGE,
    LAST_NUMBER, MAX_MAGNIFICATION, NOTES, PARAMETERS, REFERENCE_LINE,
};
use crate::export::error::{read_error, ExportError};
use crate::export::format::WrittenFile;

/// One `N…` block of a record: its number and the text after it; or the `%` lines.
fn blocks(file: &WrittenFile) -> Result<Vec<(usize, u32, &str)>, ExportError> {
    let name = &file.name;
    let mut lines = file
        .text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()));
    match lines.next() {
        Some((_, "%")) => {}
        Some((n, _)) => return Err(read_error(name, n, "a record begins with `%`")),
        None => return Err(read_error(name, 1, "the file is empty")),
    }
    let mut out = Vec::new();
    let mut closed = false;
    for (n, line) in lines {
        if closed {
            if line.is_empty() {
                continue;
            }
            return Err(read_error(name, n, "text after the closing `%`"));
        }
        if line == "%" {
            closed = true;
            continue;
        }
        let rest = line
            .strip_prefix('N')
            .ok_or_else(|| read_error(name, n, format!("`{line}`: a block begins with N")))?;
        let digits = rest.chars().take_while(char::is_ascii_digit).count();
        let number: u32 = rest[..digits]
            .parse()
            .map_err(|_| read_error(name, n, format!("`{line}`: no number after N")))?;
        out.push((n, number, &rest[digits..]));
    }
    if !closed {
        return Err(read_error(
            name,
            file.text.lines().count(),
            "no closing `%`",
        ));
    }
    Ok(out)
}

/// An integer word value.
fn integer(name: &str, line: usize, text: &str) -> Result<i64, ExportError> {
    text.parse()
        .map_err(|_| read_error(name, line, format!("`{text}` is not an integer")))
}

fn find<'a>(files: &'a [WrittenFile], name: &str) -> Result<&'a WrittenFile, ExportError> {
    files
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| read_error(name, 0, "the file is missing"))
}

/// Reads the parameter record, the pitch data and the reference positions back into tables,
/// as the control holds them.
pub fn read_tables(files: &[WrittenFile]) -> Result<Vec<PitchTable>, ExportError> {
    let parameters = find(files, PARAMETERS)?;
    let data = find(files, DATA)?;
    let notes = find(files, NOTES)?;
    // parameter number → (axis → (line, value text))
    let mut values: BTreeMap<u32, BTreeMap<usize, (usize, String)>> = BTreeMap::new();
    for (line, number, rest) in blocks(parameters)? {
        let name = &parameters.name;
        let mut words = rest
            .strip_prefix("Q1")
            .ok_or_else(|| read_error(name, line, "a parameter block reads N<number>Q1…"))?;
        if !(3620..=3627).contains(&number) || number == 3625 {
            return Err(read_error(
                name,
                line,
                format!("parameter {number} is not one volmap writes"),
            ));
        }
        while !words.is_empty() {
            let after_a = words
                .strip_prefix('A')
                .ok_or_else(|| read_error(name, line, format!("`{words}`: expected A<axis>")))?;
            let p = after_a
                .find('P')
                .ok_or_else(|| read_error(name, line, "an axis without P<value>"))?;
            let axis: usize = after_a[..p]
                .parse()
                .ok()
                .filter(|a| (1..=3).contains(a))
                .ok_or_else(|| read_error(name, line, format!("axis `{}`", &after_a[..p])))?;
            let value_end = after_a[p + 1..]
                .find('A')
                .map_or(after_a.len(), |i| p + 1 + i);
            let value = after_a[p + 1..value_end].to_string();
            values
                .entry(number)
                .or_default()
                .insert(axis - 1, (line, value));
            words = &after_a[value_end..];
        }
    }
    let mut increments: BTreeMap<i64, i64> = BTreeMap::new();
    for (line, number, rest) in blocks(data)? {
        let name = &data.name;
        let point = number as i64 - DATA_NUMBER_BASE;
        if !(0..=LAST_NUMBER).contains(&point) {
            return Err(read_error(
                name,
                line,
                format!("N{number}: point {point} is outside 0-{LAST_NUMBER}"),
            ));
        }
        let value = rest
            .strip_prefix('P')
            .ok_or_else(|| read_error(name, line, "a data block reads N<10000 + point>P<value>"))?;
        let v = integer(name, line, value)?;
        if !(INCREMENT_RANGE[0]..=INCREMENT_RANGE[1]).contains(&v) {
            return Err(read_error(
                name,
                line,
                format!(
                    "{v} is outside {}…{}",
                    INCREMENT_RANGE[0], INCREMENT_RANGE[1]
                ),
            ));
        }
        if increments.insert(point, v).is_some() {
            return Err(read_error(name, line, format!("point {point} given twice")));
        }
    }
    let references = reference_positions(notes)?;
    let pname = parameters.name.as_str();
    let mut tables = Vec::new();
    // Each table's point numbers (first, last), axis and the line that places them.
    let mut spans: Vec<(i64, i64, usize, usize)> = Vec::new();
    for (&axis, &(line, _)) in values.get(&3620).into_iter().flatten() {
        let get = |number: u32| -> Result<Option<(usize, &str)>, ExportError> {
            Ok(values
                .get(&number)
                .and_then(|m| m.get(&axis))
                .map(|(l, v)| (*l, v.as_str())))
        };
        let need = |number: u32| -> Result<(usize, &str), ExportError> {
            get(number)?.ok_or_else(|| {
                read_error(
                    pname,
                    line,
                    format!("axis {} has no parameter {number}", axis + 1),
                )
            })
        };
        let int = |number: u32| -> Result<i64, ExportError> {
            let (l, v) = need(number)?;
            integer(pname, l, v)
        };
        let (reference, first, last) = (int(3620)?, int(3621)?, int(3622)?);
        if !(first <= reference && reference < last && first >= 0 && last <= LAST_NUMBER) {
            return Err(read_error(
                pname,
                line,
                format!(
                    "axis {}: 3621 <= 3620 < 3622 within 0-{LAST_NUMBER} fails: {first}, {reference}, {last}",
                    axis + 1,
                ),
            ));
        }
        spans.push((first, last, axis, need(3621)?.0));
        let magnification = match int(3623)? {
            0 => 1,
            m if (1..=MAX_MAGNIFICATION).contains(&m) => m,
            m => {
                return Err(read_error(
                    pname,
                    need(3623)?.0,
                    format!("magnification {m}"),
                ))
            }
        };
        let (l, interval_text) = need(3624)?;
        let interval_mm: f64 = interval_text
            .parse()
            .map_err(|_| read_error(pname, l, format!("interval `{interval_text}`")))?;
        let interval_units = (interval_mm / DETECTION_UNIT_MM).round() as i64;
        if interval_units <= 0 {
            return Err(read_error(pname, l, "the interval 3624 must be positive"));
        }
        let take = |from: i64| -> Result<Vec<i64>, ExportError> {
            (from..=from + last - first)
                .map(|n| {
                    increments.get(&n).copied().ok_or_else(|| {
                        read_error(
                            &data.name,
                            0,
                            format!("no data for point {n} of axis {}", axis + 1),
                        )
                    })
                })
                .collect()
        };
        let reverse = match get(3626)? {
            Some((l, v)) => {
                let from = integer(pname, l, v)?;
                if from < 0 || from + last - first > LAST_NUMBER {
                    return Err(read_error(pname, l, format!("3626 = {from}")));
                }
                spans.push((from, from + last - first, axis, l));
                Some(ReverseTable {
                    first_number: from,
                    at_reference: int(3627)?,
                    increments: take(from)?,
                })
            }
            None => None,
        };
        let reference_units = (references[axis].ok_or_else(|| {
            read_error(
                &notes.name,
                0,
                format!("no reference position for {}", AXES[axis]),
            )
        })? / DETECTION_UNIT_MM)
            .round() as i64;
        tables.push(PitchTable {
            axis,
            reference_units,
            reference_number: reference,
            first_number: first,
            last_number: last,
            magnification,
            interval_units,
            increments: take(first)?,
            reverse,
        });
    }
    // The control keeps one value per point number: two tables over one number would share it.
    spans.sort();
    for pair in spans.windows(2) {
        let ((a0, a1, a, _), (b0, b1, b, line)) = (pair[0], pair[1]);
        if b0 <= a1 {
            return Err(read_error(
                pname,
                line,
                format!(
                    "the tables of axes {} ({a0}-{a1}) and {} ({b0}-{b1}) share point numbers",
                    a + 1,
                    b + 1
                ),
            ));
        }
    }
    Ok(tables)
}

/// The reference positions the notes state, mm, per axis.
fn reference_positions(notes: &WrittenFile) -> Result<[Option<f64>; 3], ExportError> {
    let (n, line) = notes
        .text
        .lines()
        .enumerate()
        .find(|(_, l)| l.starts_with(REFERENCE_LINE))
        .ok_or_else(|| read_error(&notes.name, 0, "no reference position line"))?;
    let mut out = [None; 3];
    let words = line[REFERENCE_LINE.len()..].trim().trim_end_matches("mm");
    for word in words.split_whitespace() {
        let (axis, value) = word
            .split_once('=')
            .ok_or_else(|| read_error(&notes.name, n + 1, format!("`{word}`")))?;
        let d = AXES
            .iter()
            .position(|a| *a == axis)
            .ok_or_else(|| read_error(&notes.name, n + 1, format!("axis `{axis}`")))?;
        out[d] = Some(
            value
                .parse()
                .map_err(|_| read_error(&notes.name, n + 1, format!("`{value}`")))?,
        );
    }
    Ok(out)
}
