//! The tables of a `siemens` export as the SINUMERIK holds them once loaded and applies them,
//! and what the programs' writer and reader share: the files' and programs' names, the machine
//! axis names, the points of a table and how a number is written.

use crate::export::fitting::LINEAR;
use crate::export::format::{self, Control, TableInfo};
use crate::export::nodes::{equidistant, Pwl};
use crate::model::inputs::Approach;
use crate::model::Command;

pub const MSEC_FILE: &str = "AX_EEC.INI";
pub const CEC_FILE: &str = "NC_CEC.INI";
pub const MSEC_PROGRAM: &str = "%_N_AX_EEC_INI";
pub const CEC_PROGRAM: &str = "%_N_NC_CEC_INI";
/// The machine axis names of X, Y, Z.
pub const MACHINE_AXES: [&str; 3] = ["X1", "Y1", "Z1"];
/// Decimals of values and positions, mm: 1 nm.
const DECIMALS: i32 = 6;

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
    pub fn new(lo: f64, hi: f64, points: usize, spacing_mm: Option<f64>) -> Grid {
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
pub fn reread(v: f64) -> f64 {
    value(v).parse().expect("a formatted number parses")
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
                    corrects: format::component(t.output),
                }
            })
            .collect()
    }
}
