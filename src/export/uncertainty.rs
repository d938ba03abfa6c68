//! The uncertainty of the tables' nodes: what the standard uncertainties of the machine's error
//! values (docs/model.md, "Uncertainty of the error values") make of the correction a node
//! holds, and whether the residual an export leaves is below what the measurements can know.
//!
//! A node's correction is, to first order, `d = −J⁻¹·VE` at the node's command (`J` the ideal
//! Jacobian of the tip by X, Y, Z at the pose), so its standard uncertainty is that of a row of
//! `J⁻¹` times VE, propagated from the machine at the inputs, pose and tool of the tables
//! ([`Propagation::first_order_of`], GUM first order, the covariances counted). On a machine
//! whose linear axes move the tip along X, Y, Z it is the u of VE's component.
//!
//! Per table: the largest u of the components it holds over its nodes, where the control
//! gives them ([`Control::nodes`], a 3-D grid: each node's own command), else over a lattice of
//! [`LATTICE_POINTS`] per axis over the travels (a node of a table of one axis applies wherever
//! the other axes are, so its u is the largest over them; the lattice holds the travels' ends,
//! where a u that grows with the distance from an axis's zero is largest).

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::fitting::{Fitting, LINEAR};
use super::format::{Control, TableInfo};
use crate::reference::Propagation;

/// Points per axis of the lattice the u of a table without node commands is taken over.
pub const LATTICE_POINTS: usize = 11;

/// The coverage factor of the expanded uncertainties (ISO 14253-1's, as `features` and
/// `compensate` give them).
pub const COVERAGE: f64 = 2.0;

/// The uncertainty of one table's nodes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TableUncertainty {
    /// The table's name, as in the report's tables.
    pub table: String,
    /// The components of the correction it holds: `X Y Z`, `Z`.
    pub corrects: String,
    /// The largest standard uncertainty of a node's correction value, mm.
    pub u_mm: f64,
    /// The same expanded (`k = 2`), mm.
    pub u_expanded_mm: f64,
}

/// The uncertainty of an export's tables, and the residual against it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ExportUncertainty {
    pub tables: Vec<TableUncertainty>,
    /// The largest node U (`k = 2`) of all the tables, mm.
    pub u_expanded_mm: f64,
    /// Whether the largest residual is at most that U: the residual is below what the
    /// measurements can know.
    pub within_u: bool,
}

/// The standard uncertainty of the correction (X, Y, Z, mm) at each of `targets` (X, Y, Z at
/// the pose) for the machine of `fitting` at its inputs, pose and tool; `None` where the machine
/// gives no uncertainties.
pub fn correction_u(fitting: &Fitting, targets: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
    if fitting.machine.uncertainty.is_empty() {
        return None;
    }
    let propagation = Propagation::new(&fitting.machine.at(fitting.inputs));
    let rows = correction_rows(&fitting.field().inverse_jacobian());
    Some(
        targets
            .par_iter()
            .map(|&xyz| {
                let u = propagation.first_order_of(&fitting.field().command(xyz), &rows);
                [u[0], u[1], u[2]]
            })
            .collect(),
    )
}

/// The rows of `−J⁻¹` over [VE, OE]: the correction's components as combinations of the
/// channels (the sign does not change a standard uncertainty).
fn correction_rows(inverse: &Matrix3<f64>) -> [[f64; 6]; 3] {
    std::array::from_fn(|k| std::array::from_fn(|c| if c < 3 { -inverse[(k, c)] } else { 0.0 }))
}

/// The uncertainty of the nodes of `tables` (read back by `control`) and the residual
/// `residual_mm` against it; `None` where the machine gives no uncertainties.
///
/// The rule (docs/export.md): the residual is below what the measurements can know when the
/// largest residual is at most the largest node U of the tables. The residual is a distance
/// (all three components), a node's U that of one component: the comparison says "below"
/// only where even one component's uncertainty covers the whole residual.
pub fn of_tables(
    fitting: &Fitting,
    control: &dyn Control,
    tables: &[TableInfo],
    residual_mm: f64,
) -> Option<ExportUncertainty> {
    let targets = control.nodes().unwrap_or_else(|| lattice(fitting));
    let u = correction_u(fitting, &targets)?;
    let tables: Vec<TableUncertainty> = tables
        .iter()
        .map(|t| {
            let largest = u
                .iter()
                .flat_map(|v| (0..3).filter(|&k| t.corrects[k]).map(move |k| v[k]))
                .fold(0.0, f64::max);
            let corrects: Vec<String> = (0..3)
                .filter(|&k| t.corrects[k])
                .map(|k| LINEAR[k].to_string())
                .collect();
            TableUncertainty {
                table: t.name.clone(),
                corrects: corrects.join(" "),
                u_mm: largest,
                u_expanded_mm: COVERAGE * largest,
            }
        })
        .collect();
    let u_expanded_mm = tables.iter().map(|t| t.u_expanded_mm).fold(0.0, f64::max);
    Some(ExportUncertainty {
        within_u: residual_mm <= u_expanded_mm,
        u_expanded_mm,
        tables,
    })
}

/// [`LATTICE_POINTS`] per axis over the travels, X fastest.
fn lattice(fitting: &Fitting) -> Vec<[f64; 3]> {
    let axes: [Vec<f64>; 3] = std::array::from_fn(|d| fitting.travel(d, LATTICE_POINTS));
    let mut targets = Vec::with_capacity(LATTICE_POINTS.pow(3));
    for &z in &axes[2] {
        for &y in &axes[1] {
            for &x in &axes[0] {
                targets.push([x, y, z]);
            }
        }
    }
    targets
}

/// The comment line of one table's uncertainty (ASCII, for every control's files).
pub fn comment_line(t: &TableUncertainty) -> String {
    format!(
        "uncertainty of table {}, correcting {}: largest node u {:.4} um, U = {:.4} um (k = 2)",
        t.table,
        t.corrects,
        t.u_mm * 1e3,
        t.u_expanded_mm * 1e3
    )
}
