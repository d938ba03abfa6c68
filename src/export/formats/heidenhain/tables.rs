//! The tables of a `heidenhain` export as the TNC holds them once loaded and applies them, and
//! what the files' writer and reader share: the files' names, the axis keys, the decimals.

use crate::export::fitting::LINEAR;
use crate::export::format::{Control, TableInfo};
use crate::export::nodes::Pwl;
use crate::model::inputs::Approach;
use crate::model::Command;

/// The tables' file names, by input axis.
pub const TABLE_FILES: [&str; 3] = ["x.com", "y.com", "z.com"];
/// The assignment table, by the name the manual gives as the standard one.
pub const ASSIGNMENT_FILE: &str = "config.cma";
/// What was written, for people.
pub const NOTES_FILE: &str = "volmap.txt";
/// The axis keys (CfgAxes/axisList) of X, Y, Z, and the tables' column names.
pub const AXIS_KEYS: [&str; 3] = ["X", "Y", "Z"];
/// Decimals of positions and values, mm: 0.1 µm.
pub const DECIMALS: usize = 4;
/// The smallest distance between points, mm (the format's limit).
pub const MIN_SPACING_MM: f64 = 0.1;

/// A position in words: at most 4 decimals, trailing zeros dropped.
pub fn short(v: f64) -> String {
    let text = format!("{v:.DECIMALS$}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
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
                    corrects: std::array::from_fn(|k| t.columns[k].is_some()),
                }
            })
            .collect()
    }
}
