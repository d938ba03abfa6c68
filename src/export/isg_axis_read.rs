//! The text of an `isg-axis` export and its reading back as the ISG kernel reads a compensation
//! value list: `name value` lines, whole-line comments `# `, end-of-line comments after a blank
//! (`#`, `/*`, `(`), the list closed by `End`.

use std::collections::BTreeMap;

use super::{list_name, AxisLists, LSEC_MAX_POINTS, PLANE_MAX_POINTS, STARTUP, UNIT_MM};
use crate::export::fitting::{Fitting, LINEAR};
use crate::export::format::{read_error, Control, TableInfo, WrittenFile};
use crate::export::nodes::Pwl;
use crate::export::ExportError;
use crate::model::inputs::Approach;
use crate::model::Command;

/// Where the start-up lines say the lists lie on the control.
const FOLDER: &str = r"C:\axiscomp\";

fn line(key: &str, value: impl std::fmt::Display) -> String {
    format!("{key:<40} {value}\n")
}

/// One axis's compensation value list.
pub fn list_text(fitting: &Fitting, l: &AxisLists) -> String {
    let letter = LINEAR[l.axis];
    let mut text = String::new();
    for h in &fitting.header {
        text += &format!("# {h}\n");
    }
    text += &format!(
        "# volmap isg-axis: compensation value list of axis {letter} (logical axis {}), positions and values in 0.1 um\n",
        l.axis + 1
    );
    text += &line("kopf.achs_nr", l.axis + 1);
    text += &line("kopf.log_achs_name", letter);
    text += &format!("# leadscrew error compensation: the ERROR of {letter} at its set point (actual - nominal); the control subtracts it\n");
    text += &line("kw.ssfk.unit", 1);
    text += &line("kw.ssfk.max_points", LSEC_MAX_POINTS);
    text += &line("kw.ssfk.interval", 0);
    text += &line("kw.ssfk.kw_nr_max", l.setpoints.len());
    text += &line("kw.ssfk.bilateral", u8::from(l.neg.is_some()));
    text += &line("kw.ssfk.modulo", 0);
    for (i, s) in l.setpoints.iter().enumerate() {
        text += &line(&format!("kw.ssfk.table[{i}].setpoint"), s);
        text += &line(&format!("kw.ssfk.table[{i}].pos"), l.pos[i]);
        if let Some(neg) = &l.neg {
            text += &line(&format!("kw.ssfk.table[{i}].neg"), neg[i]);
        }
    }
    let [m1, m2] = l.masters;
    text += &format!(
        "# plane compensation: the CORRECTION added to the set point of {letter} over {} (master 1) and {} (master 2)\n",
        LINEAR[m1], LINEAR[m2]
    );
    text += &line("kw.crosscomp2.unit", 1);
    text += &line("kw.crosscomp2.grid", "RECTANGULAR");
    text += &line("kw.crosscomp2.interval1", l.interval[0]);
    text += &line("kw.crosscomp2.interval2", l.interval[1]);
    text += &line("kw.crosscomp2.start_position_master1", l.start[0]);
    text += &line("kw.crosscomp2.start_position_master2", l.start[1]);
    text += &line(
        "kw.crosscomp2.last_index_master1",
        l.correction[0].len() - 1,
    );
    text += &line("kw.crosscomp2.last_index_master2", l.correction.len() - 1);
    text += &line("kw.crosscomp2.master1_ax_nr", m1 + 1);
    text += &line("kw.crosscomp2.master2_ax_nr", m2 + 1);
    text += &line("kw.crosscomp2.n_cycles", 0);
    text += &line("kw.crosscomp2.max_points", PLANE_MAX_POINTS);
    for (j, row) in l.correction.iter().enumerate() {
        for (i, v) in row.iter().enumerate() {
            text += &line(&format!("kw.crosscomp2.table[{j}][{i}].correction"), v);
        }
    }
    text + "End\n"
}

/// The lines of the start-up list that name the lists.
pub fn startup_text(fitting: &Fitting) -> String {
    let mut text = String::new();
    for h in &fitting.header {
        text += &format!("# {h}\n");
    }
    text +=
        "# volmap isg-axis: the compensation value lists in the start-up list (hochlauf.lis);\n";
    text += "# activate them in each axis's parameters: lr_param.ssfk 1 (P-AXIS-00175), lr_param.crosscomp2 1 (P-AXIS-00174)\n";
    text += &line("zahl_kw", 3);
    for axis in 0..3 {
        text += &line(
            &format!("achs_kw[{axis}]"),
            format!("{FOLDER}{}", list_name(axis)),
        );
        text += &line(&format!("achs_kw_log_ax_nr[{axis}]"), axis + 1);
    }
    text
}

/// A list's `name value` entries: name → (line, value).
fn entries(file: &WrittenFile) -> Result<BTreeMap<String, (usize, String)>, ExportError> {
    let mut out = BTreeMap::new();
    let mut ended = false;
    for (i, raw) in file.text.lines().enumerate() {
        let text = raw.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        if ended {
            return Err(read_error(&file.name, i + 1, "a line after End"));
        }
        if text == "End" {
            ended = true;
            continue;
        }
        let words: Vec<&str> = text
            .split_whitespace()
            .take_while(|w| !(w.starts_with('#') || w.starts_with("/*") || w.starts_with('(')))
            .collect();
        let [name, value] = words[..] else {
            return Err(read_error(
                &file.name,
                i + 1,
                format!("`{text}`: expected a name and a value"),
            ));
        };
        if out
            .insert(name.to_string(), (i + 1, value.to_string()))
            .is_some()
        {
            return Err(read_error(
                &file.name,
                i + 1,
                format!("`{name}` given twice"),
            ));
        }
    }
    if !ended {
        return Err(read_error(
            &file.name,
            file.text.lines().count(),
            "no End line",
        ));
    }
    Ok(out)
}

/// Reads every axis's list back.
pub fn read_lists(files: &[WrittenFile]) -> Result<Vec<AxisLists>, ExportError> {
    let mut out = Vec::new();
    for file in files.iter().filter(|f| f.name != STARTUP) {
        let e = entries(file)?;
        let name = file.name.as_str();
        let int = |key: &str| -> Result<i64, ExportError> {
            let (l, v) = e
                .get(key)
                .ok_or_else(|| read_error(name, 0, format!("no `{key}`")))?;
            v.parse()
                .map_err(|_| read_error(name, *l, format!("{key} `{v}` is not an integer")))
        };
        let axis = int("kopf.achs_nr")?;
        if !(1..=3).contains(&axis) {
            return Err(read_error(
                name,
                e["kopf.achs_nr"].0,
                format!("logical axis {axis}: volmap writes 1, 2, 3"),
            ));
        }
        for key in ["kw.ssfk.unit", "kw.crosscomp2.unit"] {
            if int(key)? != 1 {
                return Err(read_error(
                    name,
                    e[key].0,
                    format!("{key}: volmap reads 1 (0.1 um)"),
                ));
            }
        }
        if int("kw.ssfk.interval")? != 0 {
            return Err(read_error(
                name,
                e["kw.ssfk.interval"].0,
                "volmap reads free positions (interval 0)",
            ));
        }
        let n = int("kw.ssfk.kw_nr_max")?;
        if n < 2 || n as usize >= LSEC_MAX_POINTS {
            return Err(read_error(
                name,
                e["kw.ssfk.kw_nr_max"].0,
                format!("kw_nr_max {n}"),
            ));
        }
        let bilateral = int("kw.ssfk.bilateral")? == 1;
        let column = |what: &str| -> Result<Vec<i64>, ExportError> {
            (0..n)
                .map(|i| int(&format!("kw.ssfk.table[{i}].{what}")))
                .collect()
        };
        let setpoints = column("setpoint")?;
        if let Some(i) = (1..setpoints.len()).find(|&i| setpoints[i] <= setpoints[i - 1]) {
            let key = format!("kw.ssfk.table[{i}].setpoint");
            return Err(read_error(
                name,
                e[&key].0,
                "the set points must increase strictly",
            ));
        }
        let grid = e.get("kw.crosscomp2.grid").map(|(_, v)| v.as_str());
        let interval = match grid {
            Some("QUADRATIC") => [int("kw.crosscomp2.interval")?; 2],
            Some("RECTANGULAR") => [
                int("kw.crosscomp2.interval1")?,
                int("kw.crosscomp2.interval2")?,
            ],
            other => return Err(read_error(name, 0, format!("kw.crosscomp2.grid {other:?}"))),
        };
        let masters = [
            int("kw.crosscomp2.master1_ax_nr")?,
            int("kw.crosscomp2.master2_ax_nr")?,
        ];
        if masters.iter().any(|m| !(1..=3).contains(m)) || interval.iter().any(|&d| d <= 0) {
            return Err(read_error(
                name,
                0,
                "plane compensation: masters 1-3 and positive intervals",
            ));
        }
        let last = [
            int("kw.crosscomp2.last_index_master1")?,
            int("kw.crosscomp2.last_index_master2")?,
        ];
        if ((last[0] + 1) * (last[1] + 1)) as usize > PLANE_MAX_POINTS {
            return Err(read_error(name, 0, "more plane points than max_points"));
        }
        let correction = (0..=last[1])
            .map(|j| {
                (0..=last[0])
                    .map(|i| int(&format!("kw.crosscomp2.table[{j}][{i}].correction")))
                    .collect()
            })
            .collect::<Result<Vec<Vec<i64>>, _>>()?;
        out.push(AxisLists {
            axis: axis as usize - 1,
            setpoints,
            pos: column("pos")?,
            neg: if bilateral {
                Some(column("neg")?)
            } else {
                None
            },
            masters: masters.map(|m| m as usize - 1),
            start: [
                int("kw.crosscomp2.start_position_master1")?,
                int("kw.crosscomp2.start_position_master2")?,
            ],
            interval,
            correction,
        });
    }
    Ok(out)
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
            });
        }
        out
    }
}
