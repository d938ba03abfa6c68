//! The workspace grid displaced by its magnified volumetric error (Hwang et al., Fig. 9).

use super::QueryError;
use crate::limits::{self, MAX_DRAWN_POINTS};
use crate::model::grid::{dims_text, Grid};
use crate::model::Machine;
use crate::reference::Twin;

/// Each grid cell's lines are cut into this many pieces, so the lines show their bends.
const CUTS: usize = 8;

/// The points drawn along the lines of `grid` (in f64: a count of any grid).
pub fn drawn_points(grid: &Grid) -> f64 {
    (0..3)
        .filter(|&along| grid.dims[along] >= 2)
        .map(|along| {
            let [a, b] = [(along + 1) % 3, (along + 2) % 3].map(|d| grid.dims[d] as f64);
            a * b * ((grid.dims[along] - 1) as f64 * CUTS as f64 + 1.0)
        })
        .sum()
}

/// The grid lines of a workspace, nominal and with the magnified error added.
#[derive(Debug, Clone, PartialEq)]
pub struct DeformedGrid {
    pub nominal: Vec<Vec<[f64; 3]>>,
    pub deformed: Vec<Vec<[f64; 3]>>,
    /// The magnification of the error.
    pub scale: f64,
    /// The largest |VE| on the lines, mm.
    pub largest_mm: f64,
}

/// The lines of `grid` along X, Y and Z (each cell cut into 8 so the lines show their bends),
/// and the tool tip's actual positions `p + scale·VE(p)`. `scale` defaults to drawing the
/// largest error as 8% of the workspace's diagonal. The points drawn are within
/// [`MAX_DRAWN_POINTS`]; a scale must be a finite number above zero, and every point drawn a
/// finite number.
pub fn deformed_grid(
    machine: &Machine,
    grid: &Grid,
    scale: Option<f64>,
) -> Result<DeformedGrid, QueryError> {
    limits::within(drawn_points(grid), MAX_DRAWN_POINTS).map_err(|points| {
        QueryError::DrawnPoints {
            grid: dims_text(grid.dims),
            points,
        }
    })?;
    if grid.dims.iter().all(|&n| n < 2) {
        return Err(QueryError::NoGridLine(dims_text(grid.dims)));
    }
    if let Some(s) = scale.filter(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(QueryError::Scale(s));
    }
    let twin = Twin::of(machine);
    let position = |d: usize, t: f64| grid.origin_mm[d] + t * grid.spacing_mm[d];
    let mut nominal = Vec::new();
    for along in 0..3 {
        let (a, b) = ((along + 1) % 3, (along + 2) % 3);
        let n = grid.dims[along];
        if n < 2 {
            continue;
        }
        for ia in 0..grid.dims[a] {
            for ib in 0..grid.dims[b] {
                let line = (0..=(n - 1) * CUTS)
                    .map(|s| {
                        let mut p = [0.0; 3];
                        p[along] = position(along, s as f64 / CUTS as f64);
                        p[a] = position(a, ia as f64);
                        p[b] = position(b, ib as f64);
                        p
                    })
                    .collect();
                nominal.push(line);
            }
        }
    }
    let errors: Vec<Vec<[f64; 3]>> = nominal
        .iter()
        .map(|line: &Vec<[f64; 3]>| {
            line.iter()
                .map(|p| {
                    let mut command = grid.pose;
                    command[..3].copy_from_slice(p);
                    let ve = twin.deviation(&command).volumetric_mm;
                    if ve.iter().all(|v| v.is_finite()) {
                        Ok([ve.x, ve.y, ve.z])
                    } else {
                        Err(QueryError::NotFinite(format!(
                            "the volumetric error at X={} Y={} Z={} mm",
                            p[0], p[1], p[2]
                        )))
                    }
                })
                .collect()
        })
        .collect::<Result<_, _>>()?;
    let largest = errors
        .iter()
        .flatten()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .fold(0.0, f64::max);
    let diagonal = (0..3)
        .map(|d| ((grid.dims[d].max(1) - 1) as f64 * grid.spacing_mm[d]).powi(2))
        .sum::<f64>()
        .sqrt();
    let scale = scale.unwrap_or(if largest > 0.0 {
        0.08 * diagonal / largest
    } else {
        1.0
    });
    let deformed: Vec<Vec<[f64; 3]>> = nominal
        .iter()
        .zip(&errors)
        .map(|(line, e)| {
            line.iter()
                .zip(e)
                .map(|(p, e)| std::array::from_fn(|d| p[d] + scale * e[d]))
                .collect()
        })
        .collect();
    if deformed.iter().flatten().flatten().any(|v| !v.is_finite()) || !largest.is_finite() {
        return Err(QueryError::Scale(scale));
    }
    Ok(DeformedGrid {
        nominal,
        deformed,
        scale,
        largest_mm: largest,
    })
}
