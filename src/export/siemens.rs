//! `siemens`: SINUMERIK 840D sl / 828D interpolatory compensation (Siemens, *Extended
//! Functions* function manual, K3 "Compensations"), written as the initialisation programs the
//! control runs to load it:
//!
//! - `AX_EEC.INI` (`%_N_AX_EEC_INI`): the measuring-system error compensation (MSEC, which
//!   includes leadscrew error compensation), one table per axis, input and output that axis:
//!   `$AA_ENC_COMP[0,N,X1]` with `$AA_ENC_COMP_STEP/_MIN/_MAX/_IS_MODULO[0,X1]`;
//! - `NC_CEC.INI` (`%_N_NC_CEC_INI`, only where there is something to hold): the sag/cross
//!   compensation (CEC), one table per (basic axis → compensated axis) pair the correction
//!   needs: `$AN_CEC[t,N]` with `$AN_CEC_INPUT_AXIS/_OUTPUT_AXIS/_STEP/_MIN/_MAX/_DIRECTION/
//!   _MULT_BY_TABLE/_IS_MODULO[t]`; and, for an axis with reversal terms, tables read only
//!   while that axis moves in the negative direction (`_DIRECTION = -1`) holding what the
//!   correction gains then.
//!
//! Every table is equidistant: point `N` at `MIN + N·STEP`, `(MAX − MIN)/STEP + 1` points;
//! linear between points; the first and last values hold outside `[MIN, MAX]`. The tables of
//! all axes sum. A CEC table reads the setpoint of its basic axis; an MSEC table the actual
//! position of its axis (the encoder's), so its values are the error as a function of where
//! the axis is, as a laser measures it. **Sign**: a table holds the error, actual − commanded position ("A positive
//! compensation value causes the corresponding machine axis to move in the negative
//! direction."), so the value written is the negated command correction, `−d`.
//!
//! Machine axis names: `X1`, `Y1`, `Z1` for X, Y, Z, the names of Siemens' examples.

use super::axis_tables::{self, AxisCurves};
use super::fitting::{Fitting, LINEAR};
use super::format::{
    Control, Format, Layout, Limits, Nodes, Structure, TableInfo, Term, WrittenFile,
};
use super::nodes::{equidistant, Pwl};
use super::ExportError;
use crate::model::inputs::Approach;
use crate::model::Command;

mod read;

pub struct Siemens;

pub const MSEC_FILE: &str = "AX_EEC.INI";
pub const CEC_FILE: &str = "NC_CEC.INI";
pub const MSEC_PROGRAM: &str = "%_N_AX_EEC_INI";
pub const CEC_PROGRAM: &str = "%_N_NC_CEC_INI";
/// The machine axis names of X, Y, Z.
pub const MACHINE_AXES: [&str; 3] = ["X1", "Y1", "Z1"];
/// Decimals of values and positions, mm: 1 nm.
const DECIMALS: i32 = 6;
/// The most points volmap writes to one table (see [`Siemens::limits`]).
pub const MAX_POINTS: usize = 2000;

impl Format for Siemens {
    fn name(&self) -> &'static str {
        "siemens"
    }

    fn title(&self) -> &'static str {
        "SINUMERIK 840D sl / 828D (measuring-system error and sag/cross compensation tables)"
    }

    fn layout(&self) -> Layout {
        Layout::Folder
    }

    fn limits(&self) -> Limits {
        Limits {
            nodes: Nodes::Equidistant,
            min_points: 2,
            // MD38000 / MD18342 size the tables (their upper limits are to be checked in the
            // control's lists manual); an 828D holds 200 points per CEC table, fixed.
            max_points: MAX_POINTS,
            // Ten increments of the default 1 µm position resolution.
            min_spacing_mm: 0.01,
            default_points: 200,
            source:
                "SINUMERIK MD38000/MD18342 table sizes as volmap bounds them; an 828D holds 200",
        }
    }

    fn structure(&self) -> Structure {
        Structure::Additive([[Term::Curve; 3]; 3])
    }

    fn holds(&self) -> &'static str {
        "per-axis tables (MSEC) hold each axis's error along itself, sag/cross tables (CEC) the error of one axis as a function of another (straightness, squareness, sag), summed, and reversal as negative-direction tables; no table holds an error that varies with two axes at once (the Abbe offset of an angular error, a sag that grows as the ram extends) or an orientation error"
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
        let grids: [Grid; 3] = std::array::from_fn(|d| {
            let [lo, hi] = fitting.ranges[d];
            Grid::new(lo, hi, points[d], spacing_mm)
        });
        let positions = grids.each_ref().map(Grid::positions);
        let curves = axis_tables::fit(fitting, positions.clone())?;
        // MSEC reads the axis's actual position, `q = t + f_kk(t)`: its value at point `q` is
        // −f_kk at the target `t` that puts the axis there (to first order `t = q − f_kk(q)`;
        // what is left is the curve's slope squared times the correction).
        let targets: [Vec<f64>; 3] = std::array::from_fn(|k| {
            positions[k]
                .iter()
                .zip(&curves.plus[k][k])
                .map(|(q, f)| q - f)
                .collect()
        });
        let own = axis_tables::own_curves_at(fitting, &curves, targets)?;
        let tables = tables(&grids, &curves, &own);
        let mut files = vec![WrittenFile {
            name: MSEC_FILE.into(),
            text: msec_program(fitting, &tables),
        }];
        if tables.iter().any(|t| t.kind != Kind::Msec) {
            files.push(WrittenFile {
                name: CEC_FILE.into(),
                text: cec_program(fitting, &tables),
            });
        }
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

/// The equidistant points of the tables along one axis, as written: `MIN`, `STEP`, count.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub min: f64,
    pub step: f64,
    pub points: usize,
}

impl Grid {
    /// `points` from `lo` over the travel to `hi` (at the spacing asked, else spread over it),
    /// `MIN` and `STEP` at the written decimals, the step rounded up so the points cover the
    /// travel.
    fn new(lo: f64, hi: f64, points: usize, spacing_mm: Option<f64>) -> Grid {
        let step = spacing_mm.unwrap_or((hi - lo) / (points - 1) as f64);
        let unit = 10f64.powi(DECIMALS);
        Grid {
            min: reread(lo),
            step: reread(((step * unit) - 1e-6).ceil() / unit),
            points,
        }
    }

    /// `MAX`: the last point.
    pub fn max(&self) -> f64 {
        reread(self.min + (self.points - 1) as f64 * self.step)
    }

    pub fn positions(&self) -> Vec<f64> {
        equidistant(self.min, self.step, self.points)
    }
}

/// A number as a position is written: [`DECIMALS`] decimals, trailing zeros dropped but one.
pub fn position(v: f64) -> String {
    let text = value(v);
    let trimmed = text.trim_end_matches('0');
    if trimmed.ends_with('.') {
        format!("{trimmed}0")
    } else {
        trimmed.to_string()
    }
}

/// A number as a compensation value is written: [`DECIMALS`] decimals, no negative zero.
pub fn value(v: f64) -> String {
    let text = format!("{v:.*}", DECIMALS as usize);
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        format!("{:.*}", DECIMALS as usize, 0.0)
    } else {
        text
    }
}

/// `v` as the control reads it back from its written text.
fn reread(v: f64) -> f64 {
    value(v).parse().expect("a formatted number parses")
}

/// Which kind of table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Measuring-system error compensation of its output axis.
    Msec,
    /// Sag/cross compensation table `t`.
    Cec(usize),
}

/// One table as written: the error (actual − commanded) of axis `output` at the points of
/// `grid` along axis `input`, read while `input` moves in `direction` (`0`: both).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub kind: Kind,
    pub input: usize,
    pub output: usize,
    pub direction: i8,
    pub grid: Grid,
    pub values: Vec<f64>,
}

impl Table {
    /// Whether a value of it is not zero as written.
    fn holds_something(&self) -> bool {
        self.values.iter().any(|&v| reread(v) != 0.0)
    }
}

/// The tables of `curves`: an MSEC table per axis from `own` (the own-axis curves at the targets
/// that put each axis on the points; always, so a reload overwrites what an earlier one left),
/// then the CEC tables that hold something: the cross tables by basic axis X, Y, Z and
/// compensated axis, then the negative-direction tables of reversing axes.
fn tables(grids: &[Grid; 3], curves: &AxisCurves, own: &[Vec<f64>; 3]) -> Vec<Table> {
    // The table holds the error: the negated command correction.
    let error = |d: &[f64]| d.iter().map(|v| -v).collect::<Vec<f64>>();
    let mut out: Vec<Table> = (0..3)
        .map(|k| Table {
            kind: Kind::Msec,
            input: k,
            output: k,
            direction: 0,
            grid: grids[k],
            values: error(&own[k]),
        })
        .collect();
    let mut cec = Vec::new();
    for i in 0..3 {
        for k in (0..3).filter(|&k| k != i) {
            cec.push((i, k, 0, error(&curves.plus[k][i])));
        }
    }
    for (j, minus) in curves.minus.iter().enumerate() {
        if let Some(minus) = minus {
            for (k, gain) in minus.iter().enumerate() {
                cec.push((j, k, -1, error(gain)));
            }
        }
    }
    for (input, output, direction, values) in cec {
        let table = Table {
            kind: Kind::Cec(0),
            input,
            output,
            direction,
            grid: grids[input],
            values,
        };
        if table.holds_something() {
            let t = out.len() - 3;
            out.push(Table {
                kind: Kind::Cec(t),
                ..table
            });
        }
    }
    out
}

/// `line` with what is not printable ASCII replaced: NC programs are ASCII.
fn ascii(line: &str) -> String {
    line.replace('°', "deg")
        .replace('µ', "u")
        .chars()
        .map(|c| {
            if c.is_ascii() && !c.is_ascii_control() {
                c
            } else {
                '?'
            }
        })
        .collect()
}

/// The comment lines every program starts with.
fn header(fitting: &Fitting, what: &[&str]) -> String {
    let mut text = String::new();
    for line in fitting
        .header
        .iter()
        .map(String::as_str)
        .chain(what.iter().copied())
    {
        text += &format!("; {}\n", ascii(line));
    }
    text
}

const SIGN: &str = "sign: each value is the ERROR, actual minus commanded position, mm (a positive value moves the axis in the negative direction): the negated command correction";
const AXES: &str = "machine axes: X1, Y1, Z1 are the machine's X, Y and Z (rename to your machine axis names, or AX1.. in a multi-channel system)";
const UNITS: &str = "positions and values in mm (MD10240 SCALING_SYSTEM_IS_METRIC = 1); points MIN + N*STEP; linear between them, the end values beyond";

fn msec_program(fitting: &Fitting, tables: &[Table]) -> String {
    let mut text = format!("{MSEC_PROGRAM}\n");
    text += &header(
        fitting,
        &[
            "SINUMERIK measuring-system error compensation (MSEC), measuring system 1: each axis's error along itself",
            SIGN,
            UNITS,
            AXES,
            "load with MD32700 ENC_COMP_ENABLE = 0, MD38000 MM_ENC_COMP_MAX_POINTS >= the points of each table; then MD32700 = 1 and reference the axes",
        ],
    );
    text += "CHANDATA(1)\n";
    for t in tables.iter().filter(|t| t.kind == Kind::Msec) {
        let axis = MACHINE_AXES[t.output];
        let g = &t.grid;
        text += &format!(
            "; {axis}: {} points from {} to {} mm, step {} mm\n",
            g.points,
            position(g.min),
            position(g.max()),
            position(g.step)
        );
        for (n, v) in t.values.iter().enumerate() {
            text += &format!("$AA_ENC_COMP[0,{n},{axis}]={}\n", value(*v));
        }
        text += &format!("$AA_ENC_COMP_STEP[0,{axis}]={}\n", position(g.step));
        text += &format!("$AA_ENC_COMP_MIN[0,{axis}]={}\n", position(g.min));
        text += &format!("$AA_ENC_COMP_MAX[0,{axis}]={}\n", position(g.max()));
        text += &format!("$AA_ENC_COMP_IS_MODULO[0,{axis}]=0\n");
    }
    text += "M17\n";
    text
}

fn cec_program(fitting: &Fitting, tables: &[Table]) -> String {
    let cec: Vec<&Table> = tables
        .iter()
        .filter(|t| matches!(t.kind, Kind::Cec(_)))
        .collect();
    let mut text = format!("{CEC_PROGRAM}\n");
    let count = format!(
        "{} tables, t = 0 to {} (an 828D has 8 of 200 points)",
        cec.len(),
        cec.len() - 1
    );
    text += &header(
        fitting,
        &[
            "SINUMERIK sag/cross compensation (CEC): the error of the OUTPUT axis as a function of the INPUT axis's setpoint; the tables of an axis sum",
            &count,
            SIGN,
            UNITS,
            AXES,
            "DIRECTION -1: read only while the input axis moves in the negative direction (what the error gains then)",
            "load with MD32710 CEC_ENABLE = 0, MD18342 MM_CEC_MAX_POINTS[t] >= the points of table t; then MD32710 = 1 for each output axis and SD41300 CEC_TABLE_ENABLE[t] = 1",
        ],
    );
    text += "CHANDATA(1)\n";
    for t in cec {
        let Kind::Cec(index) = t.kind else {
            continue;
        };
        let (input, output) = (MACHINE_AXES[t.input], MACHINE_AXES[t.output]);
        let g = &t.grid;
        let direction = match t.direction {
            0 => "both directions",
            1 => "positive direction only",
            _ => "negative direction only",
        };
        text += &format!(
            "; table {index}: {output} as a function of {input}, {direction}; {} points from {} to {} mm, step {} mm\n",
            g.points,
            position(g.min),
            position(g.max()),
            position(g.step)
        );
        for (n, v) in t.values.iter().enumerate() {
            text += &format!("$AN_CEC[{index},{n}]={}\n", value(*v));
        }
        text += &format!("$AN_CEC_INPUT_AXIS[{index}]=({input})\n");
        text += &format!("$AN_CEC_OUTPUT_AXIS[{index}]=({output})\n");
        text += &format!("$AN_CEC_STEP[{index}]={}\n", position(g.step));
        text += &format!("$AN_CEC_MIN[{index}]={}\n", position(g.min));
        text += &format!("$AN_CEC_MAX[{index}]={}\n", position(g.max()));
        text += &format!("$AN_CEC_DIRECTION[{index}]={}\n", t.direction);
        text += &format!("$AN_CEC_MULT_BY_TABLE[{index}]=0\n");
        text += &format!("$AN_CEC_IS_MODULO[{index}]=0\n");
    }
    text += "M17\n";
    text
}

/// A table as the control holds it after loading.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    /// "MSEC X1", "CEC 0".
    pub name: String,
    pub input: usize,
    pub output: usize,
    pub direction: i8,
    /// Whether the control looks it up at the axis's actual position (MSEC) rather than at
    /// the setpoint (CEC).
    pub at_actual: bool,
    pub grid: Grid,
    /// The error at the points, linear between them, end values beyond.
    pub error: Pwl,
}

/// The SINUMERIK with the tables loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct Sinumerik {
    pub tables: Vec<Loaded>,
}

impl Sinumerik {
    /// The command for `target`, each axis moving in `approach`. The CEC tables read the
    /// setpoints (the target) and move their compensated axes by minus their sum; then each
    /// axis's MSEC table reads its actual position `c` and moves it by minus its value there:
    /// `c = s − v(c)`, `s` the setpoint after CEC, solved by fixed-point steps (the tables'
    /// slopes are far below one).
    pub fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        for t in self.tables.iter().filter(|t| !t.at_actual) {
            let read = match t.direction {
                0 => true,
                1 => approach[t.input] == Approach::Positive,
                _ => approach[t.input] == Approach::Negative,
            };
            if read {
                c[t.output] -= t.error.eval(target[t.input]);
            }
        }
        for t in self.tables.iter().filter(|t| t.at_actual) {
            let setpoint = c[t.output];
            let mut actual = setpoint;
            for _ in 0..50 {
                let next = setpoint - t.error.eval(actual);
                let done = (next - actual).abs() < 1e-13;
                actual = next;
                if done {
                    break;
                }
            }
            c[t.output] = actual;
        }
        c
    }
}

impl Control for Sinumerik {
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        Sinumerik::command(self, target, approach)
    }

    fn tables(&self) -> Vec<TableInfo> {
        self.tables
            .iter()
            .map(|t| {
                let direction = match t.direction {
                    0 => String::new(),
                    1 => ", positive direction".into(),
                    _ => ", negative direction".into(),
                };
                TableInfo {
                    name: t.name.clone(),
                    size: format!(
                        "{} of {}{direction}: {} points, {} to {} mm, step {} mm",
                        LINEAR[t.output],
                        LINEAR[t.input],
                        t.grid.points,
                        position(t.grid.min),
                        position(t.grid.max()),
                        position(t.grid.step)
                    ),
                    points: t.grid.points,
                }
            })
            .collect()
    }
}
