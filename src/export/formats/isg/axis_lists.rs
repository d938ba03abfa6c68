//! The lists of an `isg-axis` export as the ISG kernel holds them and applies them, and what
//! their writer and reader share: the unit, the memory bounds, the files' names.

use crate::export::fitting::LINEAR;
use crate::export::format::{self, Control, TableInfo};
use crate::export::nodes::Pwl;
use crate::model::inputs::Approach;
use crate::model::Command;

/// The unit of the lists' positions and values: 0.1 µm, mm.
pub const UNIT_MM: f64 = 1e-4;
/// P-COMP-00059, the LSEC memory volmap reserves (`kw_nr_max` must stay below it).
pub const LSEC_MAX_POINTS: usize = 1500;
/// P-COMP-00061, the plane compensation's memory (101 × 101 by default).
pub const PLANE_MAX_POINTS: usize = 10201;
pub const STARTUP: &str = "hochlauf_axis_comp.lis";

/// The list of linear axis `axis` (0, 1, 2).
pub fn list_name(axis: usize) -> String {
    format!(
        "achskw_{}.lis",
        LINEAR[axis].to_string().to_ascii_lowercase()
    )
}

/// One axis's lists as written: positions and values in 0.1 µm.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLists {
    pub axis: usize,
    /// LSEC set points and the errors there travelling + and (bilateral) −.
    pub setpoints: Vec<i64>,
    pub pos: Vec<i64>,
    pub neg: Option<Vec<i64>>,
    /// The plane: its masters (axes), start positions, intervals, and
    /// `correction[j][i]` (j along master 2, i along master 1).
    pub masters: [usize; 2],
    pub start: [i64; 2],
    pub interval: [i64; 2],
    pub correction: Vec<Vec<i64>>,
}

impl AxisLists {
    /// The LSEC error at set point `x` mm travelling `approach`, mm.
    pub fn error_mm(&self, x: f64, approach: Approach) -> f64 {
        let values = match (&self.neg, approach) {
            (Some(neg), Approach::Negative) => neg,
            _ => &self.pos,
        };
        Pwl {
            q: self.setpoints.iter().map(|&s| s as f64 * UNIT_MM).collect(),
            v: values.iter().map(|&v| v as f64 * UNIT_MM).collect(),
        }
        .eval(x)
    }

    /// The plane correction at the masters' command positions `a`, `b` mm: bilinear, the
    /// margin's values outside.
    pub fn plane_mm(&self, a: f64, b: f64) -> f64 {
        let locate = |k: usize, x: f64| -> (usize, f64) {
            let n = if k == 0 {
                self.correction[0].len()
            } else {
                self.correction.len()
            };
            let u = (x / UNIT_MM - self.start[k] as f64) / self.interval[k] as f64;
            let u = u.clamp(0.0, (n - 1) as f64);
            let i = (u.floor() as usize).min(n.saturating_sub(2));
            (i, u - i as f64)
        };
        let ((i, u), (j, w)) = (locate(0, a), locate(1, b));
        let at = |j: usize, i: usize| {
            let row = &self.correction[j.min(self.correction.len() - 1)];
            row[i.min(row.len() - 1)] as f64
        };
        let v = (1.0 - w) * ((1.0 - u) * at(j, i) + u * at(j, i + 1))
            + w * ((1.0 - u) * at(j + 1, i) + u * at(j + 1, i + 1));
        v * UNIT_MM
    }
}

/// The lists as the control applies them: each axis's set point less its LSEC error plus its
/// plane correction.
pub struct AxisControl {
    pub lists: Vec<AxisLists>,
}

impl Control for AxisControl {
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        for l in &self.lists {
            let k = l.axis;
            c[k] += -l.error_mm(target[k], approach[k])
                + l.plane_mm(target[l.masters[0]], target[l.masters[1]]);
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        let mut out = Vec::new();
        for l in &self.lists {
            let letter = LINEAR[l.axis];
            let mm = |u: i64| u as f64 * UNIT_MM;
            out.push(TableInfo {
                name: format!("{letter} leadscrew"),
                size: format!(
                    "{} points at {} to {} mm{}",
                    l.setpoints.len(),
                    mm(l.setpoints[0]),
                    mm(l.setpoints[l.setpoints.len() - 1]),
                    if l.neg.is_some() { ", bilateral" } else { "" }
                ),
                points: l.setpoints.len(),
                corrects: format::component(l.axis),
            });
            out.push(TableInfo {
                name: format!("{letter} plane"),
                size: format!(
                    "{} x {} points over {}, {} at {} x {} mm",
                    l.correction[0].len(),
                    l.correction.len(),
                    LINEAR[l.masters[0]],
                    LINEAR[l.masters[1]],
                    mm(l.interval[0]),
                    mm(l.interval[1])
                ),
                points: l.correction[0].len().max(l.correction.len()),
                corrects: format::component(l.axis),
            });
        }
        out
    }
}
