//! `heidenhain`: HEIDENHAIN TNC 640 / 620 / iTNC 530 nonlinear axis error compensation
//! (HEIDENHAIN technical manuals, "Nonlinear axis error compensation"): compensation-value
//! tables `*.COM` and the assignment table `*.CMA` that says which `*.COM` is read along which
//! axis.
//!
//! - `x.com`, `y.com`, `z.com`: one table per input axis (the axis of its `config.cma` column),
//!   `AXISPOS` the positions of its points (machine datum, mm) and a column per compensated axis
//!   (`X`, `Y`, `Z`): `[column axis] = F(input axis)`, so `y.com` holds the pitch error of Y
//!   along Y, the straightness of Y in X and Z, the squareness of Y to X and Z;
//!   `BACKLASH`, where the input axis has reversal terms, the own column's values for the
//!   negative direction of traverse (empty otherwise);
//! - `config.cma`: one row, active (`*`), naming the three tables in the columns X, Y, Z;
//! - `volmap.txt`: what was written from what, the sign and the loading steps (for people; the
//!   control reads only the tables).
//!
//! The control interpolates linearly between points; the points are free (volmap chooses them,
//! [`free_nodes`](node_choice::free_nodes), shared by the columns of a table) and cover the
//! travel, so nothing is read beyond the ends (where the end values are taken to hold).
//! **Sign**: the tables hold the error, actual − commanded position ("The error is positive if
//! the table travel is too long"), so the values are the negated command correction, `−d`.
//! The frame of the file (`BEGIN` line, fixed-width columns, `[END]`) is the general form of the
//! TNC's tables; the column widths are volmap's.

use super::axis_tables::{self, AxisCurves};
use super::fitting::{self, Fitting, LINEAR};
use super::format::{
    Control, Format, Layout, Limits, Nodes, Structure, TableInfo, Term, WrittenFile,
};
use super::nodes::{self as node_choice, equidistant, Pwl};
use super::ExportError;
use crate::model::inputs::Approach;
use crate::model::Command;

mod read;

pub struct Heidenhain;

/// The tables' file names, by input axis.
pub const TABLE_FILES: [&str; 3] = ["x.com", "y.com", "z.com"];
/// The assignment table, by the name the manual gives as the standard one.
pub const ASSIGNMENT_FILE: &str = "config.cma";
/// What was written, for people.
pub const NOTES_FILE: &str = "volmap.txt";
/// The axis keys (CfgAxes/axisList) of X, Y, Z, and the tables' column names.
pub const AXIS_KEYS: [&str; 3] = ["X", "Y", "Z"];
/// Decimals of positions and values, mm: 0.1 µm.
const DECIMALS: usize = 4;
/// The smallest distance between points, mm (see [`Heidenhain::limits`]).
pub const MIN_SPACING_MM: f64 = 0.1;
/// A table takes the fewest points whose largest chord error is within this of the best `n`
/// points give, mm: a tenth of the rounding of the 0.1 µm the values are written to.
const FEWER_POINTS_TOLERANCE_MM: f64 = 5e-6;

impl Format for Heidenhain {
    fn name(&self) -> &'static str {
        "heidenhain"
    }

    fn title(&self) -> &'static str {
        "HEIDENHAIN TNC (nonlinear axis error compensation, *.COM and *.CMA)"
    }

    fn layout(&self) -> Layout {
        Layout::Folder
    }

    fn limits(&self) -> Limits {
        Limits {
            nodes: Nodes::Free,
            min_points: 2,
            max_points: 256,
            min_spacing_mm: MIN_SPACING_MM,
            default_points: 64,
            source:
                "HEIDENHAIN: 256 entries per .COM table (TNC 407 technical manual, PLC module 9095)",
        }
    }

    fn structure(&self) -> Structure {
        Structure::Additive([[Term::Curve; 3]; 3])
    }

    fn holds(&self) -> &'static str {
        "one table per axis holds the error of X, Y and Z as a function of that axis (pitch, straightness, squareness, sag), summed over the axes, and the reversal of each axis along itself (BACKLASH); no table holds an error that varies with two axes at once (the Abbe offset of an angular error, a sag that grows as the ram extends) or an orientation error"
    }

    fn uses_direction(&self) -> bool {
        true
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([self.limits().default_points; 3]);
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

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(read::read(files)?))
    }
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
pub fn number(v: f64) -> String {
    let text = format!("{v:+.DECIMALS$}");
    if text[1..].chars().all(|c| c == '0' || c == '.') {
        format!("{:+.DECIMALS$}", 0.0)
    } else {
        text
    }
}

/// A position in words: at most 4 decimals, trailing zeros dropped.
fn short(v: f64) -> String {
    let text = format!("{v:.DECIMALS$}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
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
    let names: Vec<String> = COM_COLUMNS.iter().map(|(n, _)| n.to_string()).collect();
    text += &row(&names, &COM_COLUMNS);
    for (n, q) in t.axispos.iter().enumerate() {
        let mut fields = vec![n.to_string(), number(*q)];
        fields.extend(t.columns.iter().map(|c| number(c[n])));
        fields.push(t.backlash.as_ref().map_or(String::new(), |b| number(b[n])));
        text += &row(&fields, &COM_COLUMNS);
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

/// A `*.COM` table as the control holds it: its input axis and, per column axis present, the
/// error as a function of the input axis's position.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedCom {
    pub file: String,
    pub input: usize,
    pub columns: [Option<Pwl>; 3],
    /// The input axis's own column for the negative direction.
    pub backlash: Option<Pwl>,
}

/// The TNC with the active row of `config.cma` and its tables loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct Tnc {
    pub tables: Vec<LoadedCom>,
}

impl Tnc {
    /// The error the tables hold at `target`, each axis moving in `approach`.
    pub fn error(&self, target: &Command, approach: &[Approach; 6]) -> [f64; 3] {
        let mut e = [0.0; 3];
        for t in &self.tables {
            let at = target[t.input];
            for (k, column) in t.columns.iter().enumerate() {
                let negative = k == t.input && approach[t.input] == Approach::Negative;
                let table = match (&t.backlash, negative) {
                    (Some(b), true) => Some(b),
                    _ => column.as_ref(),
                };
                if let Some(table) = table {
                    e[k] += table.eval(at);
                }
            }
        }
        e
    }
}

impl Control for Tnc {
    /// The tables are looked up at the commanded positions; each axis moves by the negated
    /// error.
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        let e = self.error(target, approach);
        let mut c = *target;
        for k in 0..3 {
            c[k] -= e[k];
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        self.tables
            .iter()
            .map(|t| {
                let q = &t
                    .columns
                    .iter()
                    .flatten()
                    .next()
                    .map_or(&[][..], |p| &p.q[..]);
                let (lo, hi) = (q.first().copied(), q.last().copied());
                TableInfo {
                    name: t.file.clone(),
                    size: format!(
                        "X, Y, Z of {}{}: {} points, {} to {} mm",
                        LINEAR[t.input],
                        if t.backlash.is_some() {
                            " and BACKLASH"
                        } else {
                            ""
                        },
                        q.len(),
                        lo.map_or("-".into(), short),
                        hi.map_or("-".into(), short),
                    ),
                    points: q.len(),
                }
            })
            .collect()
    }
}
