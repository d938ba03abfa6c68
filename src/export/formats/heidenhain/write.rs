//! The files of a `heidenhain` export: the `*.COM` tables fitted at their points (free, or
//! equidistant where a spacing is asked), the assignment table `config.cma` and the notes.

use super::tables::{
    ASSIGNMENT_FILE, AXIS_KEYS, DECIMALS, MIN_SPACING_MM, NOTES_FILE, TABLE_FILES,
};
use crate::export::error::ExportError;
use crate::export::fitting::{self, Fitting, LINEAR};
use crate::export::format::WrittenFile;
use crate::export::formats::axis_tables::{self, AxisCurves};
use crate::export::nodes::{self as node_choice, equidistant};

/// A table takes the fewest points whose largest chord error is within this of the best `n`
/// points give, mm: a tenth of the rounding of the 0.1 µm the values are written to.
const FEWER_POINTS_TOLERANCE_MM: f64 = 5e-6;

/// The files of tables of at most `points` per axis (at `spacing_mm` where asked).
pub fn write_files(
    fitting: &Fitting,
    points: [usize; 3],
    spacing_mm: Option<f64>,
) -> Result<Vec<WrittenFile>, ExportError> {
    let tables = match spacing_mm {
        Some(step) => equidistant_tables(fitting, points, step)?,
        None => free_tables(fitting, points)?,
    };
    let mut files: Vec<WrittenFile> = tables
        .iter()
        .enumerate()
        .map(|(i, t)| WrittenFile {
            name: TABLE_FILES[i].into(),
            text: com_table(i, t),
        })
        .collect();
    files.push(WrittenFile {
        name: ASSIGNMENT_FILE.into(),
        text: cma_table(),
    });
    files.push(WrittenFile {
        name: NOTES_FILE.into(),
        text: notes(fitting, &tables),
    });
    Ok(files)
}

/// One `*.COM` table as written: the error (actual − commanded) of X, Y, Z at `axispos` along
/// its input axis, and the own column's values for the negative direction where it reverses.
#[derive(Debug, Clone, PartialEq)]
pub struct ComTable {
    pub axispos: Vec<f64>,
    pub columns: [Vec<f64>; 3],
    pub backlash: Option<Vec<f64>>,
}

/// `v` rounded to the written decimals.
fn reread(v: f64) -> f64 {
    number(v).parse().expect("a formatted number parses")
}

/// A position or a value as written: signed, [`DECIMALS`] decimals, `+0.0000` for zero.
fn number(v: f64) -> String {
    let text = format!("{v:+.DECIMALS$}");
    if text[1..].chars().all(|c| c == '0' || c == '.') {
        format!("{:+.DECIMALS$}", 0.0)
    } else {
        text
    }
}

/// The table of input axis `i` from the curves, at the indices `at` of their positions.
fn com(curves: &AxisCurves, i: usize, at: &[usize]) -> ComTable {
    let pick = |f: &[f64]| at.iter().map(|&n| -f[n]).collect::<Vec<f64>>();
    ComTable {
        axispos: at.iter().map(|&n| curves.positions[i][n]).collect(),
        columns: std::array::from_fn(|k| pick(&curves.plus[k][i])),
        backlash: curves.minus[i].as_ref().map(|gain| {
            let negative: Vec<f64> = curves.plus[i][i]
                .iter()
                .zip(&gain[i])
                .map(|(p, g)| p + g)
                .collect();
            pick(&negative)
        }),
    }
}

/// Tables at `step` from the start of each travel, `points[i]` points (covering the travel).
fn equidistant_tables(
    fitting: &Fitting,
    points: [usize; 3],
    step: f64,
) -> Result<[ComTable; 3], ExportError> {
    let step = reread(step);
    let positions: [Vec<f64>; 3] = std::array::from_fn(|i| {
        equidistant(reread(fitting.ranges[i][0]), step, points[i])
            .into_iter()
            .map(reread)
            .collect()
    });
    let curves = axis_tables::fit(fitting, positions)?;
    Ok(std::array::from_fn(|i| {
        com(&curves, i, &(0..points[i]).collect::<Vec<_>>())
    }))
}

/// Candidates per axis for `n` free points: four between points, 101 to 801 over the travel.
fn candidate_count(n: usize) -> usize {
    (4 * n.saturating_sub(1) + 1).clamp(101, 801)
}

/// Tables of at most `points[i]` free points each, chosen among candidates over the travel
/// (evenly spread, with the positions where the machine's error values change form) so that
/// the largest chord error of the table's columns is the smallest.
fn free_tables(fitting: &Fitting, points: [usize; 3]) -> Result<[ComTable; 3], ExportError> {
    let positions: [Vec<f64>; 3] = std::array::from_fn(|i| {
        let [lo, hi] = fitting.ranges[i];
        let breaks = fitting::breakpoints(fitting.machine, LINEAR[i]);
        let mut q: Vec<f64> = node_choice::candidates(lo, hi, candidate_count(points[i]), &breaks)
            .into_iter()
            .map(reread)
            .collect();
        q.dedup_by(|b, a| *b - *a < MIN_SPACING_MM * 1e-3);
        q
    });
    let curves = axis_tables::fit(fitting, positions)?;
    Ok(std::array::from_fn(|i| {
        let mut held: Vec<Vec<f64>> = (0..3).map(|k| curves.plus[k][i].clone()).collect();
        if let Some(gain) = &curves.minus[i] {
            held.push(
                curves.plus[i][i]
                    .iter()
                    .zip(&gain[i])
                    .map(|(p, g)| p + g)
                    .collect(),
            );
        }
        let refs: Vec<&[f64]> = held.iter().map(Vec::as_slice).collect();
        let at = node_choice::free_nodes(
            &curves.positions[i],
            &refs,
            points[i],
            MIN_SPACING_MM,
            FEWER_POINTS_TOLERANCE_MM,
        );
        com(&curves, i, &at)
    }))
}

/// Column layout: `(name, width)`; the last column runs to the end of the line.
const COM_COLUMNS: [(&str, usize); 6] = [
    ("NR", 6),
    ("AXISPOS", 14),
    ("X", 13),
    ("Y", 13),
    ("Z", 13),
    ("BACKLASH", 13),
];
const CMA_COLUMNS: [(&str, usize); 5] = [("NR", 6), ("ACTIVE", 8), ("X", 9), ("Y", 9), ("Z", 9)];

/// The `BEGIN` line of a table file `stem.ext`: name and type in fixed fields, the unit last.
fn begin(stem: &str, ext: &str) -> String {
    format!("BEGIN {:<8}{:<9}MM\n", stem.to_uppercase(), ext)
}

/// One row of fixed-width fields, trailing blanks trimmed.
fn row(fields: &[String], widths: &[(&str, usize)]) -> String {
    let mut line = String::new();
    for (f, (_, w)) in fields.iter().zip(widths) {
        line += &format!("{f:<w$}");
    }
    format!("{}\n", line.trim_end())
}

fn com_table(i: usize, t: &ComTable) -> String {
    let mut text = begin(AXIS_KEYS[i], ".COM");
    // The BACKLASH column only where its rows carry it: the header names what the rows hold.
    let columns = if t.backlash.is_some() {
        &COM_COLUMNS[..]
    } else {
        &COM_COLUMNS[..COM_COLUMNS.len() - 1]
    };
    let names: Vec<String> = columns.iter().map(|(n, _)| n.to_string()).collect();
    text += &row(&names, columns);
    for (n, q) in t.axispos.iter().enumerate() {
        let mut fields = vec![n.to_string(), number(*q)];
        fields.extend(t.columns.iter().map(|c| number(c[n])));
        if let Some(b) = &t.backlash {
            fields.push(number(b[n]));
        }
        text += &row(&fields, columns);
    }
    text += "[END]\n";
    text
}

fn cma_table() -> String {
    let mut text = begin("CONFIG", ".CMA");
    let names: Vec<String> = CMA_COLUMNS.iter().map(|(n, _)| n.to_string()).collect();
    text += &row(&names, &CMA_COLUMNS);
    let mut fields = vec!["0".to_string(), "*".to_string()];
    fields.extend(TABLE_FILES.iter().map(|f| f.to_string()));
    text += &row(&fields, &CMA_COLUMNS);
    text += "[END]\n";
    text
}

fn notes(fitting: &Fitting, tables: &[ComTable; 3]) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("{line}\n");
    }
    text += "format: volmap heidenhain, HEIDENHAIN nonlinear axis error compensation\n";
    for (i, t) in tables.iter().enumerate() {
        text += &format!(
            "{}: X, Y, Z = F({}), {} points from {} to {} mm{}\n",
            TABLE_FILES[i],
            AXIS_KEYS[i],
            t.axispos.len(),
            number(t.axispos[0]),
            number(t.axispos[t.axispos.len() - 1]),
            if t.backlash.is_some() {
                format!(", BACKLASH: {} for the negative direction", AXIS_KEYS[i])
            } else {
                String::new()
            }
        );
    }
    text += &format!(
        "{ASSIGNMENT_FILE}: row 0 active, {} in columns X, Y, Z\n",
        TABLE_FILES.join(", ")
    );
    text += "sign: each value is the ERROR, actual minus commanded position, mm (positive where the axis travels too far): the negated command correction\n";
    text += "positions AXISPOS from the machine datum, mm; linear between points; the points cover the travel\n";
    text += "load: copy the four tables to the control (machine-builder access), open config.cma in the table editor and check that row 0 is active (*), enable nonlinear axis error compensation for X, Y, Z in the machine configuration, reference the axes\n";
    text += "the file frame (BEGIN line, column widths) is volmap's reading of the TNC's tables: open and save each table in the TNC's table editor once, and check the sign with a single test value\n";
    text
}
