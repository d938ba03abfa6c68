//! `volmap build`: a machine file from component errors measured at sparse positions along each
//! axis (Dobariya et al., seed 004: 1-D elements between the measured nodes, linear or
//! quadratic per axis; natural cubic splines as a third choice).
//!
//! Per axis one CSV, the way interferometer software exports a run: a header row naming the
//! axis position (`position_mm`, or `position_deg` for a rotary axis) and any of the axis's six
//! component errors with their unit, `EXX_um EYX_mm ECX_urad EAX_arcsec EBX_rad`; one row per
//! measured position, rising. Each component becomes a table with the interpolation chosen for
//! it: the one that predicts each interior node best from the others (leave-one-out: linear from
//! the two neighbours, quadratic through the three nearest nodes, the natural cubic spline
//! through all the others), ties (within 10%) going to the simpler. Quadratic tables need an odd
//! node count (three-node elements); with fewer than four nodes nothing can be compared and the
//! table is linear. `--interp` overrides the choice per component.

use std::path::Path;

use crate::model::{AxisLetter, Interp, Machine, Table, COMPONENT_NAMES};
use crate::standards::measured::{csv_fields, csv_lines, csv_number, read_text};
use crate::standards::StandardsError;

/// One measured component of one axis, with the interpolation chosen for it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BuiltComponent {
    /// `EXX`, `ECX`, …
    pub name: String,
    pub axis: char,
    pub index: usize,
    /// `(position, value)` in mm or degrees, and mm or rad.
    pub nodes: Vec<(f64, f64)>,
    pub interp: String,
    /// Leave-one-out RMS error of each candidate (`linear`, `quadratic`, `cubic`) that applies.
    pub leave_one_out: Vec<(String, f64)>,
    /// Why this interpolation: `best at leave-one-out`, `asked for`, `too few nodes to compare`.
    pub reason: String,
}

fn csv_error(path: &str, line: usize, message: String) -> StandardsError {
    StandardsError::Csv {
        path: path.to_string(),
        line,
        message,
    }
}

/// A measured component: its index among the six and its `(position, value)` nodes.
pub type MeasuredComponent = (usize, Vec<(f64, f64)>);

/// Reads one axis's CSV: its components as node lists.
pub fn read_axis_csv(
    path: &Path,
    axis: AxisLetter,
) -> Result<Vec<MeasuredComponent>, StandardsError> {
    let (name, text) = read_text(path)?;
    let mut rows = csv_lines(&text);
    let (header_line, header) = rows
        .next()
        .ok_or_else(|| csv_error(&name, 1, "empty file; expected a header row".into()))?;
    let position_unit = if axis.is_linear() { "mm" } else { "deg" };
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    if columns.first() != Some(&format!("position_{position_unit}").as_str()) {
        return Err(csv_error(
            &name,
            header_line,
            format!("the first column must be `position_{position_unit}` (the {axis} position)"),
        ));
    }
    // (component index, factor to mm or rad)
    let mut components: Vec<(usize, f64)> = Vec::new();
    for column in &columns[1..] {
        let (key, unit) = column.split_once('_').unwrap_or((column, ""));
        let chars: Vec<char> = key.chars().collect();
        let index = match chars.as_slice() {
            ['E', c, a] if *a == axis.as_char() => COMPONENT_NAMES.iter().position(|n| n == c),
            _ => None,
        }
        .ok_or_else(|| {
            csv_error(
                &name,
                header_line,
                format!(
                    "column `{column}`: expected a component error of {axis} with its unit, such as E{}{axis}_um or EA{axis}_urad",
                    'X'
                ),
            )
        })?;
        let factor = match (index < 3, unit) {
            (true, "mm") => 1.0,
            (true, "um") => 1e-3,
            (false, "rad") => 1.0,
            (false, "urad") => 1e-6,
            (false, "arcsec") => std::f64::consts::PI / (180.0 * 3600.0),
            _ => {
                return Err(csv_error(
                    &name,
                    header_line,
                    format!(
                        "column `{column}`: unit `{unit}` — {} errors are in {}",
                        if index < 3 {
                            "translational"
                        } else {
                            "angular"
                        },
                        if index < 3 {
                            "mm or um"
                        } else {
                            "rad, urad or arcsec"
                        }
                    ),
                ))
            }
        };
        if components.iter().any(|&(i, _)| i == index) {
            return Err(csv_error(
                &name,
                header_line,
                format!("{key} appears twice"),
            ));
        }
        components.push((index, factor));
    }
    if components.is_empty() {
        return Err(csv_error(
            &name,
            header_line,
            "no error column after the position".into(),
        ));
    }
    let mut nodes: Vec<Vec<(f64, f64)>> = vec![Vec::new(); components.len()];
    let mut previous: Option<f64> = None;
    for (line, row) in rows {
        let fields = csv_fields(row, columns.len()).map_err(|m| csv_error(&name, line, m))?;
        let number =
            |n: usize| csv_number(fields[n], columns[n]).map_err(|m| csv_error(&name, line, m));
        let q = number(0)?;
        if let Some(p) = previous {
            if q <= p {
                return Err(csv_error(
                    &name,
                    line,
                    format!("position {q} after {p}: rows must be sorted by position, rising"),
                ));
            }
        }
        previous = Some(q);
        for (c, &(_, factor)) in components.iter().enumerate() {
            nodes[c].push((q, number(c + 1)? * factor));
        }
    }
    if nodes[0].len() < 2 {
        return Err(csv_error(
            &name,
            header_line,
            format!(
                "{} measured position(s): a table needs at least 2",
                nodes[0].len()
            ),
        ));
    }
    Ok(components.iter().map(|&(i, _)| i).zip(nodes).collect())
}

/// Linear interpolation or extrapolation through two nodes.
fn line_through(a: (f64, f64), b: (f64, f64), q: f64) -> f64 {
    a.1 + (b.1 - a.1) * (q - a.0) / (b.0 - a.0)
}

/// Leave-one-out RMS error of `interp` over the interior nodes; `None` where it does not apply.
fn leave_one_out(nodes: &[(f64, f64)], interp: Interp) -> Option<f64> {
    let n = nodes.len();
    if n < 4 {
        return None;
    }
    let mut sum = 0.0;
    for i in 1..n - 1 {
        let (q, v) = nodes[i];
        let others: Vec<(f64, f64)> = nodes
            .iter()
            .enumerate()
            .filter(|&(k, _)| k != i)
            .map(|(_, p)| *p)
            .collect();
        let predicted = match interp {
            Interp::Linear => line_through(nodes[i - 1], nodes[i + 1], q),
            Interp::Quadratic => {
                // The Lagrange quadratic through the three remaining nodes nearest to q.
                let mut near = others.clone();
                near.sort_by(|a, b| (a.0 - q).abs().total_cmp(&(b.0 - q).abs()));
                let p = &near[..3];
                (0..3)
                    .map(|a| {
                        let basis: f64 = (0..3)
                            .filter(|&b| b != a)
                            .map(|b| (q - p[b].0) / (p[a].0 - p[b].0))
                            .product();
                        basis * p[a].1
                    })
                    .sum()
            }
            Interp::Cubic => Table::new(others, Interp::Cubic, false).ok()?.eval(q),
        };
        sum += (predicted - v).powi(2);
    }
    Some((sum / (n - 2) as f64).sqrt())
}

/// Chooses the interpolation of one component (see the module's documentation).
pub fn choose_interp(
    nodes: &[(f64, f64)],
    asked: Option<Interp>,
) -> (Interp, Vec<(String, f64)>, String) {
    let mut scores: Vec<(Interp, f64)> = Vec::new();
    for interp in [Interp::Linear, Interp::Quadratic, Interp::Cubic] {
        if interp == Interp::Quadratic && nodes.len() % 2 == 0 {
            continue;
        }
        if let Some(score) = leave_one_out(nodes, interp) {
            scores.push((interp, score));
        }
    }
    let listed = scores
        .iter()
        .map(|(i, s)| (i.name().to_string(), *s))
        .collect();
    if let Some(interp) = asked {
        return (interp, listed, "asked for".into());
    }
    if scores.is_empty() {
        return (
            Interp::Linear,
            listed,
            "too few nodes to compare (fewer than 4)".into(),
        );
    }
    let best = scores.iter().map(|&(_, s)| s).fold(f64::INFINITY, f64::min);
    let chosen = scores
        .iter()
        .find(|&&(_, s)| s <= best * 1.1 + 1e-15)
        .map(|&(i, _)| i)
        .unwrap_or(Interp::Linear);
    (chosen, listed, "best at leave-one-out".into())
}

/// `--interp EXX=linear,EZZ=quadratic`.
pub fn parse_interp_choices(text: &str) -> Result<Vec<(String, Interp)>, StandardsError> {
    text.split(',')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .map(|pair| {
            let (key, value) = pair.split_once('=').ok_or_else(|| {
                StandardsError::Parameter(format!(
                    "`{pair}`: expected COMPONENT=linear|quadratic|cubic"
                ))
            })?;
            let interp = Interp::parse(value.trim()).ok_or_else(|| {
                StandardsError::Parameter(format!("`{value}`: linear, quadratic or cubic"))
            })?;
            Ok((key.trim().to_string(), interp))
        })
        .collect()
}

/// Builds the components of each measured axis and writes them into the base machine's file:
/// returns the new file's text (a comment-free rewrite of the base TOML) and what was chosen.
pub fn build(
    base: &Machine,
    axes: &[(AxisLetter, &Path)],
    asked: &[(String, Interp)],
) -> Result<(String, Vec<BuiltComponent>), StandardsError> {
    let mut table: toml::Table = toml::from_str(&base.source.toml).map_err(|e| {
        StandardsError::Parameter(format!("the base machine's file does not parse again: {e}"))
    })?;
    let mut built = Vec::new();
    for (key, _) in asked {
        let known = axes
            .iter()
            .any(|(a, _)| (0..6).any(|i| format!("E{}{}", COMPONENT_NAMES[i], a) == *key));
        if !known {
            return Err(StandardsError::Parameter(format!(
                "--interp {key}: not a component of a measured axis"
            )));
        }
    }
    for &(axis, path) in axes {
        if base.axis(axis).is_none() {
            return Err(StandardsError::Parameter(format!(
                "{}: the base machine (chain {}) has no {axis} axis",
                path.display(),
                base.chain.hwang_notation()
            )));
        }
        let section = table
            .get_mut("axes")
            .and_then(|v| v.as_table_mut())
            .and_then(|t| t.get_mut(&axis.to_string()))
            .and_then(|v| v.as_table_mut())
            .ok_or_else(|| {
                StandardsError::Parameter(format!(
                    "the base machine file has no [axes.{axis}] section"
                ))
            })?;
        for (index, nodes) in read_axis_csv(path, axis)? {
            let name = format!("E{}{}", COMPONENT_NAMES[index], axis);
            let wanted = asked.iter().find(|(k, _)| *k == name).map(|&(_, i)| i);
            let (interp, scores, reason) = choose_interp(&nodes, wanted);
            // Validates the table (an even node count for quadratic, …) the way the file will.
            Table::new(nodes.clone(), interp, false).map_err(|e| {
                StandardsError::Parameter(format!("{}: {name}: {e}", path.display()))
            })?;
            let mut entry = toml::Table::new();
            entry.insert(
                "table".into(),
                toml::Value::Array(
                    nodes
                        .iter()
                        .map(|&(q, v)| toml::Value::Array(vec![q.into(), v.into()]))
                        .collect(),
                ),
            );
            entry.insert("interp".into(), interp.name().into());
            section.insert(name.clone(), toml::Value::Table(entry));
            built.push(BuiltComponent {
                name,
                axis: axis.as_char(),
                index,
                nodes,
                interp: interp.name().into(),
                leave_one_out: scores,
                reason,
            });
        }
    }
    let text = toml::to_string(&table).map_err(|e| StandardsError::Parameter(e.to_string()))?;
    Ok((text, built))
}
