//! The programs of a `siemens` export: the tables fitted at the points of each axis, as the MSEC
//! program `AX_EEC.INI` and, where a cross or direction table holds something, the CEC program
//! `NC_CEC.INI`.

use super::tables::{
    position, reread, value, Grid, CEC_FILE, CEC_PROGRAM, MACHINE_AXES, MSEC_FILE, MSEC_PROGRAM,
};
use crate::export::error::ExportError;
use crate::export::fitting::Fitting;
use crate::export::format::WrittenFile;
use crate::export::formats::axis_tables::{self, AxisCurves};

/// The files of tables of `points` per axis (at `spacing_mm` where asked).
pub fn write_files(
    fitting: &Fitting,
    points: [usize; 3],
    spacing_mm: Option<f64>,
) -> Result<Vec<WrittenFile>, ExportError> {
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
