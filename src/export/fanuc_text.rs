//! The text of a `fanuc` export and its reading back: the parameter record (`N<no>Q1A<axis>P<v>`
//! blocks between `%` lines), the pitch error compensation data (`N1<point>P<increment>` blocks,
//! point number + 10000), and the notes a user reads before loading them.

use std::collections::BTreeMap;

use super::{
    PitchTable, ReverseTable, DETECTION_UNIT_MM, INCREMENT_RANGE, MAX_MAGNIFICATION,
    NUMBERS_PER_TABLE,
};
use crate::export::fitting::Fitting;
use crate::export::format::{read_error, WrittenFile};
use crate::export::ExportError;

pub const AXES: [&str; 3] = ["X", "Y", "Z"];
pub const PARAMETERS: &str = "PITCHPRM.TXT";
pub const DATA: &str = "PITCH.TXT";
pub const NOTES: &str = "NOTES.TXT";
/// Pitch error compensation data blocks are numbered from 10000 (point 0).
const DATA_NUMBER_BASE: i64 = 10000;
/// Point numbers of the pool, 0…1023.
const POOL: i64 = 1024;
const REFERENCE_LINE: &str = "reference position (machine coordinate, parameter 1240):";

/// A length with 3 decimals (the least input increment of IS-B), `-0` written `0`.
pub fn real(v: f64) -> String {
    let text = format!("{v:.3}");
    if text == "-0.000" {
        "0.000".into()
    } else {
        text
    }
}

/// The three files of an export of `tables`.
/// `at_reference_mm`: per table, the correction at the reference position the table leaves.
pub fn write_files(
    fitting: &Fitting,
    tables: &[PitchTable],
    at_reference_mm: &[f64],
) -> Vec<WrittenFile> {
    vec![
        WrittenFile {
            name: PARAMETERS.into(),
            text: parameters_text(tables),
        },
        WrittenFile {
            name: DATA.into(),
            text: data_text(tables),
        },
        WrittenFile {
            name: NOTES.into(),
            text: notes_text(fitting, tables, at_reference_mm),
        },
    ]
}

/// An axis-type parameter block: `N0<no>Q1A<axis>P<value>…` over `values` (axis, value).
fn block(number: u32, values: &[(usize, String)]) -> String {
    let mut line = format!("N{number:05}Q1");
    for (axis, value) in values {
        line += &format!("A{}P{value}", axis + 1);
    }
    line + "\n"
}

fn parameters_text(tables: &[PitchTable]) -> String {
    let each = |f: &dyn Fn(&PitchTable) -> String| -> Vec<(usize, String)> {
        tables.iter().map(|t| (t.axis, f(t))).collect()
    };
    let mut text = String::from("%\n");
    text += &block(3620, &each(&|t| t.reference_number.to_string()));
    text += &block(3621, &each(&|t| t.first_number.to_string()));
    text += &block(3622, &each(&|t| t.last_number.to_string()));
    text += &block(3623, &each(&|t| t.magnification.to_string()));
    text += &block(
        3624,
        &each(&|t| real(t.interval_units as f64 * DETECTION_UNIT_MM)),
    );
    let reverse: Vec<(usize, &ReverseTable)> = tables
        .iter()
        .filter_map(|t| t.reverse.as_ref().map(|r| (t.axis, r)))
        .collect();
    if !reverse.is_empty() {
        let values = |f: &dyn Fn(&ReverseTable) -> i64| -> Vec<(usize, String)> {
            reverse
                .iter()
                .map(|(a, r)| (*a, f(r).to_string()))
                .collect()
        };
        text += &block(3626, &values(&|r| r.first_number));
        text += &block(3627, &values(&|r| r.at_reference));
    }
    text + "%\n"
}

fn data_text(tables: &[PitchTable]) -> String {
    let mut points: BTreeMap<i64, i64> = BTreeMap::new();
    for t in tables {
        for (i, v) in t.increments.iter().enumerate() {
            points.insert(t.first_number + i as i64, *v);
        }
        if let Some(r) = &t.reverse {
            for (i, v) in r.increments.iter().enumerate() {
                points.insert(r.first_number + i as i64, *v);
            }
        }
    }
    let mut text = String::from("%\n");
    for (n, v) in points {
        text += &format!("N{}P{v}\n", DATA_NUMBER_BASE + n);
    }
    text + "%\n"
}

fn notes_text(fitting: &Fitting, tables: &[PitchTable], at_reference_mm: &[f64]) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("{line}\n");
    }
    text += "format: volmap fanuc, FANUC pitch error compensation\n\n";
    text += &format!(
        "{REFERENCE_LINE} {} mm\n",
        tables
            .iter()
            .map(|t| format!(
                "{}={}",
                AXES[t.axis],
                real(t.reference_units as f64 * DETECTION_UNIT_MM)
            ))
            .collect::<Vec<_>>()
            .join(" ")
    );
    text += "  (the tables are anchored there: the control's reference position of each axis must be at this\n";
    text += "  machine coordinate, and volmap's commanded positions must be the control's machine coordinates)\n\n";
    text += "files:\n";
    text += &format!("  {PARAMETERS}  parameters 3620-3624 (3626, 3627 for bidirectional tables), axis 1 = X, 2 = Y, 3 = Z\n");
    text += &format!(
        "  {DATA}     pitch error compensation data, N(10000 + point number) P(increment)\n\n"
    );
    text += "values: the CORRECTION (added to the command, minus the error to first order) at the compensation\n";
    text += "  points less the correction at the reference position, as increments from point to point in\n";
    text += "  detection units (1 um, IS-B) x the magnification 3623; zero at the reference position travelling +\n";
    text += "  (3627 gives it travelling - on a bidirectional table). Between points the control applies a\n";
    text += "  staircase (the value of the point at or below the position); the residual volmap reports is for\n";
    text += "  that staircase.\n\n";
    for (t, offset) in tables.iter().zip(at_reference_mm) {
        let [from, to] = t.point_positions_mm();
        let interval = t.interval_units as f64 * DETECTION_UNIT_MM;
        text += &format!(
            "{} (axis {}): 3620 = {}, 3621 = {}, 3622 = {}, 3623 = {}, 3624 = {} mm: points at {} to {} mm\n",
            AXES[t.axis],
            t.axis + 1,
            t.reference_number,
            t.first_number,
            t.last_number,
            t.magnification,
            real(interval),
            real(from),
            real(to),
        );
        text += &format!(
            "  interval {} mm: the control takes it where the rapid traverse rate is at most {:.0} mm/min (interval >= rate / 7500)\n",
            real(interval),
            interval * 7500.0
        );
        text += &format!(
            "  the correction at the reference position, {:.1} um, is a shift of the whole axis the table\n  cannot hold (zero there by construction): it stays in the residual (a work offset takes it)\n",
            offset / DETECTION_UNIT_MM
        );
        if let Some(r) = &t.reverse {
            text += &format!(
                "  bidirectional: set 3605#0 = 1; 3626 = {}, 3627 = {} (the compensation at the reference position travelling -)\n",
                r.first_number, r.at_reference
            );
        }
    }
    text += "\nloading (check every step against the control's parameter manual first):\n";
    text += "  1. Compare PITCHPRM.TXT with a parameter backup of this control: the axis numbers, the point\n";
    text += "     numbers (volmap uses 0-383 travelling +, 384-767 travelling -; they must not clash with a\n";
    text += "     rotary axis's table), and the data form of 3624 (a real number in mm on the Series 30i\n";
    text += "     family; an integer in the least input increment on the Series 16i/18i/21i and 0i-A/B/C,\n";
    text += "     whose records carry no Q1).\n";
    text += "  2. With parameter write enabled, read PITCHPRM.TXT in (EDIT mode, memory card) or key in the\n";
    text += "     values; for bidirectional tables set 3605#0 = 1 by hand (a bit parameter: volmap does not\n";
    text += "     write its other bits). Turn the power off and on.\n";
    text += "  3. Read PITCH.TXT in on the pitch error compensation screen (or key in the increments).\n";
    text +=
        "  4. Return every axis to its reference position: the compensation acts from then on.\n";
    text += "  5. Check one point with a laser before use: a positive value moves the axis further in +.\n";
    text
}

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
        if !(0..POOL).contains(&point) {
            return Err(read_error(
                name,
                line,
                format!("N{number}: point {point} is outside 0-{}", POOL - 1),
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
        if !(first <= reference && reference < last && first >= 0 && last < POOL) {
            return Err(read_error(
                pname,
                line,
                format!(
                    "axis {}: 3621 <= 3620 < 3622 within 0-{} fails: {first}, {reference}, {last}",
                    axis + 1,
                    POOL - 1
                ),
            ));
        }
        if last - first + 1 > NUMBERS_PER_TABLE {
            return Err(read_error(
                pname,
                line,
                format!("axis {}: more than {NUMBERS_PER_TABLE} points", axis + 1),
            ));
        }
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
                if from < 0 || from + last - first >= POOL {
                    return Err(read_error(pname, l, format!("3626 = {from}")));
                }
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
