//! `volmap build`: a machine file from component errors measured at sparse positions along each
//! axis (Dobariya, Patel and Jani 2015: 1-D elements between the measured nodes, linear or
//! quadratic per axis; natural cubic splines as a third choice).
//!
//! Per axis one CSV, the way interferometer software exports a run: a header row naming the
//! axis position (`position_mm`, or `position_deg` for a rotary axis) and any of the axis's six
//! component errors with their unit, `EXX_um EYX_mm ECX_urad EAX_arcsec EBX_rad`, and optionally
//! each row's standard uncertainty (`u_um`, `u_urad`: see [`read_axis_csv`]), written beside the
//! table as `u = [ … ]`; one row per measured position, rising. Each component becomes a table with the interpolation chosen for
//! it: the one that predicts each interior node best from the others (leave-one-out: linear from
//! the two neighbours, quadratic through the three nearest nodes, the natural cubic spline
//! through all the others), ties (within 10%) going to the simpler. Quadratic tables need an odd
//! node count (three-node elements); with fewer than four nodes nothing can be compared and the
//! table is linear. An interpolation asked for overrides the choice per component.

use std::path::Path;

use toml_edit::{Array, DocumentMut, InlineTable, Item, TableLike, Value};

pub use super::axis_csv::{read_axis_csv, MeasuredComponent};
use super::{toml_number, CalibrateError};
use crate::error::excerpt;
use crate::io::source::Reach;
use crate::model::{AxisLetter, Interp, Machine, Table, COMPONENT_NAMES};

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
    /// The standard uncertainty of each node (mm or rad) and the CSV column it came from
    /// (`u_um`), where the measurements give one.
    pub u: Option<(String, Vec<f64>)>,
}

/// Linear interpolation or extrapolation through two nodes.
fn line_through(a: (f64, f64), b: (f64, f64), q: f64) -> f64 {
    a.1 + (b.1 - a.1) * (q - a.0) / (b.0 - a.0)
}

/// Leave-one-out RMS error of `interp` over the interior nodes; `None` where it does not apply.
/// Each interior node is predicted from the others in constant time (the spline through the
/// others from sweeps over the whole table), so a table of a million nodes takes a moment.
fn leave_one_out(nodes: &[(f64, f64)], interp: Interp) -> Option<f64> {
    let n = nodes.len();
    if n < 4 {
        return None;
    }
    let sweeps = (interp == Interp::Cubic).then(|| SplineSweeps::of(nodes));
    let mut sum = 0.0;
    for i in 1..n - 1 {
        let (q, v) = nodes[i];
        let predicted = match &sweeps {
            None if interp == Interp::Linear => line_through(nodes[i - 1], nodes[i + 1], q),
            None => quadratic_without(nodes, i),
            Some(sweeps) => sweeps.spline_without(nodes, i),
        };
        sum += (predicted - v).powi(2);
    }
    Some((sum / (n - 2) as f64).sqrt())
}

/// The Lagrange quadratic through the three nodes nearest to node `i` (`i` left out), at node
/// `i`. The nodes rise, so the nearest are found walking outwards from `i`; of two as near, the
/// lower first.
fn quadratic_without(nodes: &[(f64, f64)], i: usize) -> f64 {
    let q = nodes[i].0;
    let (mut below, mut above) = (i.checked_sub(1), i + 1);
    let mut p = [(0.0, 0.0); 3];
    for slot in &mut p {
        let take_below = match (below, nodes.get(above)) {
            (Some(b), Some(a)) => (nodes[b].0 - q).abs() <= (a.0 - q).abs(),
            (Some(_), None) => true,
            (None, _) => false,
        };
        if take_below {
            let b = below.expect("a node below");
            *slot = nodes[b];
            below = b.checked_sub(1);
        } else {
            *slot = nodes[above];
            above += 1;
        }
    }
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

/// The natural cubic spline's tridiagonal system
/// `h_{k-1} M_{k-1} + 2 (h_{k-1} + h_k) M_k + h_k M_{k+1} = 6 (s_k − s_{k-1})` (`M_0 = M_{n-1} = 0`)
/// eliminated from both ends: rows `1 ..= k` give `M_k = P_k − Q_k M_{k+1}`, rows `k ..= n-2`
/// give `M_k = U_k − V_k M_{k-1}`. Leaving node `i` out changes only the rows of its two
/// neighbours, so the spline through the others follows from these and a 2×2 system.
struct SplineSweeps {
    p: Vec<f64>,
    q: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
}

impl SplineSweeps {
    fn of(nodes: &[(f64, f64)]) -> SplineSweeps {
        let n = nodes.len();
        let h = |k: usize| nodes[k + 1].0 - nodes[k].0;
        let slope = |k: usize| (nodes[k + 1].1 - nodes[k].1) / h(k);
        let rhs = |k: usize| 6.0 * (slope(k) - slope(k - 1));
        let (mut p, mut q) = (vec![0.0; n], vec![0.0; n]);
        for k in 1..n - 1 {
            let d = 2.0 * (h(k - 1) + h(k)) - h(k - 1) * q[k - 1];
            p[k] = (rhs(k) - h(k - 1) * p[k - 1]) / d;
            q[k] = h(k) / d;
        }
        let (mut u, mut v) = (vec![0.0; n], vec![0.0; n]);
        for k in (1..n - 1).rev() {
            let e = 2.0 * (h(k - 1) + h(k)) - h(k) * v[k + 1];
            u[k] = (rhs(k) - h(k) * u[k + 1]) / e;
            v[k] = h(k - 1) / e;
        }
        SplineSweeps { p, q, u, v }
    }

    /// The natural cubic spline through every node but `i` (interior), at node `i`.
    fn spline_without(&self, nodes: &[(f64, f64)], i: usize) -> f64 {
        let n = nodes.len();
        let (a, b) = (i - 1, i + 1);
        let (xa, ya) = nodes[a];
        let (xb, yb) = nodes[b];
        let span = xb - xa;
        let joined = (yb - ya) / span;
        // Row a: α1 M_a + β1 M_b = γ1 (M_a = 0 at the first node).
        let (a1, b1, c1) = if a == 0 {
            (1.0, 0.0, 0.0)
        } else {
            let h = xa - nodes[a - 1].0;
            let s = (ya - nodes[a - 1].1) / h;
            (
                2.0 * (h + span) - h * self.q[a - 1],
                span,
                6.0 * (joined - s) - h * self.p[a - 1],
            )
        };
        // Row b: α2 M_a + β2 M_b = γ2 (M_b = 0 at the last node).
        let (a2, b2, c2) = if b == n - 1 {
            (0.0, 1.0, 0.0)
        } else {
            let h = nodes[b + 1].0 - xb;
            let s = (nodes[b + 1].1 - yb) / h;
            (
                span,
                2.0 * (span + h) - h * self.v[b + 1],
                6.0 * (s - joined) - h * self.u[b + 1],
            )
        };
        let det = a1 * b2 - b1 * a2;
        let ma = (c1 * b2 - b1 * c2) / det;
        let mb = (a1 * c2 - c1 * a2) / det;
        let (t, w) = (nodes[i].0 - xa, xb - nodes[i].0);
        ma * w.powi(3) / (6.0 * span)
            + mb * t.powi(3) / (6.0 * span)
            + (ya / span - ma * span / 6.0) * w
            + (yb / span - mb * span / 6.0) * t
    }
}

/// Chooses the interpolation of one component (see the module's documentation).
pub fn choose_interp(
    nodes: &[(f64, f64)],
    asked: Option<Interp>,
) -> (Interp, Vec<(String, f64)>, String) {
    let mut scores: Vec<(Interp, f64)> = Vec::new();
    for interp in [Interp::Linear, Interp::Quadratic, Interp::Cubic] {
        if interp == Interp::Quadratic && nodes.len().is_multiple_of(2) {
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

/// Interpolations asked for per component: `EXX=linear,EZZ=quadratic`.
pub fn parse_interp_choices(text: &str) -> Result<Vec<(String, Interp)>, CalibrateError> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    let mut choices: Vec<(String, Interp)> = Vec::new();
    for pair in text.split(',').map(str::trim) {
        let (key, value) = pair.split_once('=').ok_or_else(|| {
            CalibrateError::Parameter(format!(
                "`{}`: expected COMPONENT=linear|quadratic|cubic",
                excerpt(pair)
            ))
        })?;
        let interp = Interp::parse(value.trim()).ok_or_else(|| {
            CalibrateError::Parameter(format!("`{}`: linear, quadratic or cubic", excerpt(value)))
        })?;
        let key = key.trim().to_string();
        if choices.iter().any(|(k, _)| *k == key) {
            return Err(CalibrateError::Parameter(format!(
                "{} is given twice",
                excerpt(&key)
            )));
        }
        choices.push((key, interp));
    }
    Ok(choices)
}

/// A measured component as the machine file holds it: `{ interp = "…", table = [ [q, v], … ] }`,
/// one node a line, and `u = [ … ]` beside it, one per node, where the measurements give it; each
/// number rounded to [`super::SIGNIFICANT_DIGITS`] significant digits.
fn component_entry(nodes: &[(f64, f64)], interp: Interp, u: Option<&[f64]>) -> InlineTable {
    let mut table = Array::new();
    for &(q, v) in nodes {
        let mut pair = Array::new();
        pair.push(toml_number(q));
        pair.push(toml_number(v));
        let mut pair = Value::Array(pair);
        pair.decor_mut().set_prefix("\n    ");
        table.push_formatted(pair);
    }
    table.set_trailing_comma(true);
    table.set_trailing("\n");
    let mut entry = InlineTable::new();
    entry.insert("interp", interp.name().into());
    entry.insert("table", Value::Array(table));
    if let Some(u) = u {
        let mut column = Array::new();
        for &value in u {
            let mut value = toml_number(value);
            value.decor_mut().set_prefix("\n    ");
            column.push_formatted(value);
        }
        column.set_trailing_comma(true);
        column.set_trailing("\n");
        entry.insert("u", Value::Array(column));
    }
    entry
}

/// Sets component `name` of an axis's section to `entry`: in place of the old one, keeping its
/// comments (a `[axes.X.EXX]` section keeps its header and takes the entry's keys), or at the
/// end of the section.
fn set_component(section: &mut dyn TableLike, name: &str, entry: InlineTable) {
    match section.get_mut(name) {
        Some(Item::Table(table)) => {
            table.clear();
            for (key, value) in entry.iter() {
                table.insert(key, Item::Value(value.clone()));
            }
        }
        Some(Item::Value(old)) => {
            let decor = old.decor().clone();
            *old = Value::InlineTable(entry);
            *old.decor_mut() = decor;
        }
        _ => {
            section.insert(name, Item::Value(Value::InlineTable(entry)));
        }
    }
}

/// Checks that the measured axes are axes of `base`, each once (`axes`: each with the file of
/// its measurements).
fn check_measured_axes(base: &Machine, axes: &[(AxisLetter, &Path)]) -> Result<(), CalibrateError> {
    for (n, &(axis, path)) in axes.iter().enumerate() {
        if base.axis(axis).is_none() {
            return Err(CalibrateError::Parameter(format!(
                "{}: the base machine (chain {}) has no {axis} axis",
                path.display(),
                base.chain.hwang_notation()
            )));
        }
        if axes[..n].iter().any(|&(a, _)| a == axis) {
            return Err(CalibrateError::Parameter(format!(
                "{}: {axis} is given twice: one file holds an axis's measurements",
                path.display()
            )));
        }
    }
    Ok(())
}

/// Checks that every interpolation asked for names a component of a measured axis.
fn check_interp_choices(
    axes: &[(AxisLetter, &Path)],
    asked: &[(String, Interp)],
) -> Result<(), CalibrateError> {
    for (key, _) in asked {
        let known = axes
            .iter()
            .any(|(a, _)| (0..6).any(|i| format!("E{}{}", COMPONENT_NAMES[i], a) == *key));
        if !known {
            return Err(CalibrateError::InterpChoice(format!(
                "interpolation asked for {}: not a component of a measured axis",
                excerpt(key)
            )));
        }
    }
    Ok(())
}

/// Builds the components of each measured axis and writes them into the base machine's file:
/// returns the new file's text (the base file with its comments and order, each measured
/// component set) and what was chosen.
pub fn build(
    base: &Machine,
    axes: &[(AxisLetter, &Path)],
    asked: &[(String, Interp)],
) -> Result<(String, Vec<BuiltComponent>), CalibrateError> {
    let mut document: DocumentMut = base.source.toml.parse().map_err(|e| {
        CalibrateError::Parameter(format!("the base machine's file does not parse again: {e}"))
    })?;
    let mut built = Vec::new();
    check_measured_axes(base, axes)?;
    check_interp_choices(axes, asked)?;
    for &(axis, path) in axes {
        let section = document
            .get_mut("axes")
            .and_then(|a| a.get_mut(axis.to_string().as_str()))
            .and_then(Item::as_table_like_mut)
            .ok_or_else(|| {
                CalibrateError::Parameter(format!(
                    "the base machine file has no [axes.{axis}] section"
                ))
            })?;
        for MeasuredComponent { index, nodes, u } in read_axis_csv(path, axis)? {
            let name = format!("E{}{}", COMPONENT_NAMES[index], axis);
            let wanted = asked.iter().find(|(k, _)| *k == name).map(|&(_, i)| i);
            let (interp, scores, reason) = choose_interp(&nodes, wanted);
            // Validates the table (an even node count for quadratic, …) the way the file will.
            Table::new(nodes.clone(), interp, false).map_err(|e| {
                CalibrateError::Parameter(format!("{}: {name}: {e}", path.display()))
            })?;
            let u_nodes = u.as_ref().map(|(_, values)| values.as_slice());
            set_component(section, &name, component_entry(&nodes, interp, u_nodes));
            built.push(BuiltComponent {
                name,
                axis: axis.as_char(),
                index,
                nodes,
                interp: interp.name().into(),
                leave_one_out: scores,
                reason,
                u,
            });
        }
    }
    let text = document.to_string();
    // What is built must read back as a machine: a measured angle no machine tool has (µrad
    // written as rad), or a table that swings beyond one between its nodes, is refused here,
    // naming the measurements, rather than written into a file no command reads.
    let measured: Vec<String> = axes.iter().map(|(_, p)| p.display().to_string()).collect();
    Machine::from_toml_reaching(
        &text,
        &measured.join(", "),
        base.source.folder.as_deref(),
        Reach::Anywhere,
    )
    .map_err(|e| CalibrateError::Parameter(e.to_string()))?;
    Ok((text, built))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leave-one-out as written first: the spline or quadratic through a copy of the others.
    fn leave_one_out_by_copies(nodes: &[(f64, f64)], interp: Interp) -> Option<f64> {
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

    proptest::proptest! {
        #[test]
        fn leave_one_out_in_constant_time_per_node_agrees_with_copies(
            steps in proptest::collection::vec((0.05f64..20.0, -1.0f64..1.0), 4..40)
        ) {
            let mut x = -3.0;
            let nodes: Vec<(f64, f64)> = steps
                .iter()
                .map(|&(step, value)| {
                    x += step;
                    (x, value * 1e-2)
                })
                .collect();
            for interp in [Interp::Linear, Interp::Quadratic, Interp::Cubic] {
                let fast = leave_one_out(&nodes, interp).unwrap();
                let slow = leave_one_out_by_copies(&nodes, interp).unwrap();
                proptest::prop_assert!(
                    (fast - slow).abs() <= 1e-9 * slow.abs().max(1e-6),
                    "{:?}: {} vs {}", interp, fast, slow
                );
            }
        }
    }

    #[test]
    fn ties_in_nearness_take_the_lower_node_as_sorting_did() {
        // Evenly spaced: node i's neighbours at i±1 and i±2 tie; the lower is taken.
        let nodes: Vec<(f64, f64)> = (0..9).map(|k| (k as f64, (k * k % 7) as f64)).collect();
        for interp in [Interp::Quadratic, Interp::Cubic] {
            let fast = leave_one_out(&nodes, interp).unwrap();
            let slow = leave_one_out_by_copies(&nodes, interp).unwrap();
            assert!(
                (fast - slow).abs() <= 1e-12 * slow.max(1.0),
                "{fast} vs {slow}"
            );
        }
    }
}
