//! Reading the `heidenhain` tables back as the TNC loads them: `config.cma`'s active row names
//! the `*.COM` table read along each axis; a table is a `BEGIN <name> <unit>` line, a line of
//! column names, fixed-width rows (each field under its column's name, up to the next name),
//! `[END]`. Positions must increase; values are linear between them and, beyond the ends, the
//! end values hold.

use super::tables::{LoadedCom, Tnc, ASSIGNMENT_FILE, AXIS_KEYS};
use crate::export::error::{read_error, ExportError};
use crate::export::format::WrittenFile;
use crate::export::nodes::Pwl;

/// A table file: its column names and, per row, the line and each column's field (trimmed).
struct Fields {
    names: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

/// Splits a TNC table of type `ext` (`.COM`, `.CMA`) into its fields.
fn fields(file: &WrittenFile, ext: &str) -> Result<Fields, ExportError> {
    let name = file.name.as_str();
    if !file.text.is_ascii() {
        return Err(read_error(name, 1, "the table is not ASCII"));
    }
    let lines: Vec<&str> = file.text.lines().collect();
    let words: Vec<&str> = lines
        .first()
        .map_or(Vec::new(), |l| l.split_whitespace().collect());
    if words.len() < 3 || words[0] != "BEGIN" {
        return Err(read_error(
            name,
            1,
            "the table does not start with BEGIN <name> <unit>",
        ));
    }
    let unit = words[words.len() - 1];
    if unit != "MM" {
        return Err(read_error(
            name,
            1,
            format!("the unit is `{unit}`: volmap writes MM"),
        ));
    }
    let title = words[1..words.len() - 1].concat();
    if !title.to_uppercase().ends_with(ext) {
        return Err(read_error(
            name,
            1,
            format!("`{title}` is not a {ext} table"),
        ));
    }
    let header = lines
        .get(1)
        .ok_or_else(|| read_error(name, 2, "no line of column names"))?;
    // Each column starts where its name starts.
    let mut starts = Vec::new();
    let mut names = Vec::new();
    let bytes = header.as_bytes();
    for (at, &b) in bytes.iter().enumerate() {
        if b != b' ' && (at == 0 || bytes[at - 1] == b' ') {
            starts.push(at);
            let end = header[at..].find(' ').map_or(header.len(), |e| at + e);
            names.push(header[at..end].to_string());
        }
    }
    let mut rows = Vec::new();
    let mut ended = false;
    for (n, line) in lines.iter().enumerate().skip(2) {
        if line.trim().is_empty() {
            continue;
        }
        if ended {
            return Err(read_error(name, n + 1, "a line after [END]"));
        }
        if line.trim() == "[END]" {
            ended = true;
            continue;
        }
        let field = |c: usize| {
            let from = starts[c].min(line.len());
            let to = starts.get(c + 1).map_or(line.len(), |&s| s.min(line.len()));
            line[from..to].trim().to_string()
        };
        rows.push((n + 1, (0..starts.len()).map(field).collect()));
    }
    if !ended {
        return Err(read_error(
            name,
            lines.len(),
            "the table does not end with [END]",
        ));
    }
    Ok(Fields { names, rows })
}

fn column(fields: &Fields, file: &str, name: &str) -> Result<usize, ExportError> {
    fields
        .names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| read_error(file, 2, format!("no {name} column")))
}

fn number(file: &str, line: usize, what: &str, text: &str) -> Result<f64, ExportError> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| read_error(file, line, format!("{what}: `{text}` is not a number")))
}

/// Reads the `*.COM` table `file` as the table of input axis `input`.
fn com(file: &WrittenFile, input: usize) -> Result<LoadedCom, ExportError> {
    let f = file.name.as_str();
    let fields = fields(file, ".COM")?;
    for (c, n) in fields.names.iter().enumerate() {
        let known =
            ["NR", "AXISPOS", "BACKLASH"].contains(&n.as_str()) || AXIS_KEYS.contains(&n.as_str());
        if !known || fields.names[..c].contains(n) {
            return Err(read_error(
                f,
                2,
                format!("`{n}` is not a column volmap reads once"),
            ));
        }
    }
    let nr = column(&fields, f, "NR")?;
    let axispos = column(&fields, f, "AXISPOS")?;
    let axes: Vec<(usize, usize)> = AXIS_KEYS
        .iter()
        .enumerate()
        .filter_map(|(k, key)| fields.names.iter().position(|n| n == key).map(|c| (k, c)))
        .collect();
    let backlash = fields.names.iter().position(|n| n == "BACKLASH");
    if fields.rows.is_empty() {
        return Err(read_error(f, 3, "no rows"));
    }
    let mut q: Vec<f64> = Vec::new();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); axes.len()];
    let mut negative: Vec<f64> = Vec::new();
    for (row, (line, cells)) in fields.rows.iter().enumerate() {
        let line = *line;
        if cells[nr] != row.to_string() {
            return Err(read_error(
                f,
                line,
                format!("NR `{}` where row {row} is expected", cells[nr]),
            ));
        }
        let p = number(f, line, "AXISPOS", &cells[axispos])?;
        if q.last().is_some_and(|&last| p <= last) {
            return Err(read_error(
                f,
                line,
                format!("AXISPOS {p} does not increase"),
            ));
        }
        q.push(p);
        for (v, &(k, c)) in values.iter_mut().zip(&axes) {
            v.push(number(f, line, AXIS_KEYS[k], &cells[c])?);
        }
        if let Some(c) = backlash {
            // All rows or none: a table with holes in it reads nothing the control documents.
            let given = !cells[c].is_empty();
            let expected = if row == 0 {
                given
            } else {
                !negative.is_empty()
            };
            if given != expected {
                return Err(read_error(
                    f,
                    line,
                    "BACKLASH is given in some rows and not in others",
                ));
            }
            if given {
                negative.push(number(f, line, "BACKLASH", &cells[c])?);
            }
        }
    }
    let mut columns: [Option<Pwl>; 3] = Default::default();
    for (v, &(k, _)) in values.into_iter().zip(&axes) {
        columns[k] = Some(Pwl { q: q.clone(), v });
    }
    let backlash = if negative.is_empty() {
        None
    } else if columns[input].is_none() {
        return Err(read_error(
            f,
            2,
            format!(
                "BACKLASH without the {} column it is the negative direction of",
                AXIS_KEYS[input]
            ),
        ));
    } else {
        Some(Pwl { q, v: negative })
    };
    Ok(LoadedCom {
        file: file.name.clone(),
        input,
        columns,
        backlash,
    })
}

/// Reads the files of a `heidenhain` export: the active row of `config.cma` and its tables.
pub fn read(files: &[WrittenFile]) -> Result<Tnc, ExportError> {
    let cma = files
        .iter()
        .find(|f| f.name == ASSIGNMENT_FILE)
        .ok_or_else(|| read_error(ASSIGNMENT_FILE, 1, "the assignment table is missing"))?;
    let f = cma.name.as_str();
    let fields = fields(cma, ".CMA")?;
    let active = column(&fields, f, "ACTIVE")?;
    let rows: Vec<&(usize, Vec<String>)> = fields
        .rows
        .iter()
        .filter(|(_, cells)| cells[active] == "*")
        .collect();
    let (line, cells) = match rows[..] {
        [row] => row,
        [] => {
            return Err(read_error(
                f,
                3,
                "no row is active (*): the control compensates nothing",
            ))
        }
        _ => return Err(read_error(f, rows[1].0, "more than one row is active (*)")),
    };
    let mut tables = Vec::new();
    for (c, name) in fields.names.iter().enumerate() {
        let Some(input) = AXIS_KEYS.iter().position(|k| k == name) else {
            continue;
        };
        let table = &cells[c];
        if table.is_empty() {
            continue;
        }
        let file = files
            .iter()
            .find(|w| w.name.eq_ignore_ascii_case(table))
            .ok_or_else(|| read_error(f, *line, format!("the table {table} is missing")))?;
        tables.push(com(file, input)?);
    }
    Ok(Tnc { tables })
}
