//! Reading an `isg-axis` export back as the ISG kernel reads a compensation value list: `name
//! value` lines, whole-line comments `# `, end-of-line comments after a blank (`#`, `/*`, `(`),
//! the list closed by `End`.

use std::collections::BTreeMap;

use super::axis_lists::{AxisLists, LSEC_MAX_POINTS, PLANE_MAX_POINTS, STARTUP};
use crate::export::error::{read_error, ExportError};
use crate::export::format::WrittenFile;

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
