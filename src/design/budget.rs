//! The error budget (docs/model.md): each toleranced term alone at its limit (`+h` for uniform,
//! `+2σ` for normal) on the ideal machine (every other error value zero, nominal offsets kept), and
//! the statistics of that term's own field over the grid (and every pose of a sweep). The budget's
//! total is the root sum of squares of the terms' `max |VE|`; a term's share is its `max |VE|²`
//! over the sum of them all.

use crate::engine::variants::Variants;
use crate::engine::Engine;
use crate::model::grid::Grid;
use crate::model::perturbation::{Perturbation, Tolerance};
use crate::model::statistics::FieldStats;
use crate::model::{Command, Machine};

use super::DesignError;

/// One term of the budget.
#[derive(Debug, Clone)]
pub struct BudgetRow {
    pub tolerance: Tolerance,
    /// The amplitude the term is taken at: `h` or `2σ` (mm or rad).
    pub limit: f64,
    pub stats: FieldStats,
    /// `max |VE|²` over the sum of every term's.
    pub share: f64,
    /// The commanded position of the largest |VE|.
    pub worst_at: Command,
}

/// The budget, its rows sorted by `max |VE|`, largest first.
#[derive(Debug, Clone)]
pub struct Budget {
    pub rows: Vec<BudgetRow>,
    pub total_rss_mm: f64,
}

/// The budget of `tolerances` on `machine` over `grids` (one grid per pose of a sweep).
/// `on_progress(terms done)` is called as terms finish.
pub fn budget(
    engine: &Engine,
    machine: &Machine,
    tolerances: &[Tolerance],
    grids: &[Grid],
    on_progress: impl Fn(usize) + Sync,
) -> Result<Budget, DesignError> {
    let ideal = machine.without_errors();
    let perturbations: Vec<Perturbation> = tolerances.iter().map(|t| t.perturbation).collect();
    // Row t: term t at its limit, every other term zero; each row is one sampled machine.
    let rows: Vec<Vec<f64>> = (0..tolerances.len())
        .map(|t| {
            let mut row = vec![0.0; tolerances.len()];
            row[t] = tolerances[t].distribution.limit();
            row
        })
        .collect();
    let variants = Variants {
        base: &ideal,
        perturbations: &perturbations,
    };
    let stats = engine.variant_stats(&variants, &rows, grids, on_progress)?;
    let sum_sq: f64 = stats.iter().map(|s| s.max_ve_mm * s.max_ve_mm).sum();
    let mut budget_rows: Vec<BudgetRow> = tolerances
        .iter()
        .zip(stats)
        .map(|(tolerance, stats)| BudgetRow {
            tolerance: *tolerance,
            limit: tolerance.distribution.limit(),
            share: if sum_sq > 0.0 {
                stats.max_ve_mm * stats.max_ve_mm / sum_sq
            } else {
                0.0
            },
            worst_at: worst_at(&stats, grids),
            stats,
        })
        .collect();
    // Stable: equal terms keep the file's order.
    budget_rows.sort_by(|a, b| b.stats.max_ve_mm.total_cmp(&a.stats.max_ve_mm));
    Ok(Budget {
        rows: budget_rows,
        total_rss_mm: sum_sq.sqrt(),
    })
}

/// The commanded position of a field's largest |VE|.
pub fn worst_at(stats: &FieldStats, grids: &[Grid]) -> Command {
    match grids.get(stats.max_ve_pose) {
        Some(grid) => grid.command(grid.indices(stats.max_ve_point)),
        None => [0.0; 6],
    }
}
