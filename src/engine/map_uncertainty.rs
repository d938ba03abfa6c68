//! The uncertainty part of a map: the standard uncertainties of the channels computed after the
//! values ([`Engine::run_uncertainty`]), streamed into the part that follows the values', with
//! their statistics and the spot check against the f64 reference's own propagation.

use std::time::Instant;

use super::map::{capture, check_finite, sample_points, CheckResult, CheckedPoint};
use super::uncertainty::{UncertaintyMethod, UncertaintyRun};
use super::{Engine, EngineError};
use crate::io::field::FieldInfo;
use crate::model::channels::Sample;
use crate::model::grid::Grid;
use crate::model::poses::pose_name;
use crate::model::statistics::FieldStats;
use crate::model::Machine;
use crate::reference::uncertainty::Propagation;

/// What the uncertainty part of a map reports: its statistics are those of the field of
/// uncertainties (`max_ve_mm` the largest `|u(VE)|`, the norm of its three components).
#[derive(Debug, Clone)]
pub struct UncertaintySummary {
    pub method: UncertaintyMethod,
    pub run: UncertaintyRun,
    pub stats: FieldStats,
    /// The spot check against the reference's propagation at the map's checked points
    /// (first order and Monte Carlo with a fixed number of draws; an adaptive run's draws
    /// differ per chunk, so it has none).
    pub check: Option<CheckResult>,
    pub seconds: f64,
}

impl UncertaintySummary {
    /// Adds the part of another pose of a sweep.
    pub fn merge(&mut self, other: &UncertaintySummary, pose: usize) {
        self.run.terms_min = self.run.terms_min.min(other.run.terms_min);
        self.run.terms_max = self.run.terms_max.max(other.run.terms_max);
        self.run.unstable_chunks += other.run.unstable_chunks;
        self.stats.merge(&other.stats, pose);
        match (&mut self.check, &other.check) {
            (Some(mine), Some(theirs)) => mine.merge(theirs),
            (None, Some(theirs)) => self.check = Some(theirs.clone()),
            _ => {}
        }
        self.seconds += other.seconds;
    }
}

/// The name and header of the part of uncertainties that follows the part `info` describes.
pub fn uncertainty_part(
    machine: &Machine,
    grid: &Grid,
    info: &FieldInfo,
    method: UncertaintyMethod,
    single: bool,
) -> (String, FieldInfo) {
    // In a sweep, `POSE u`; beside the one part of a map of one pose, `u`.
    let name = if single {
        "u".to_string()
    } else {
        format!("{} u", pose_name(&grid.pose, machine))
    };
    let mut info = info.clone();
    info.uncertainty = Some(method.describe());
    (name, info)
}

/// Computes the uncertainties of `machine` over `grid` by `method` on `engine`, handing each
/// chunk to `write`, with their statistics and the check of `check_points` points (pose `pose`
/// of a sweep).
pub fn map_uncertainty(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    method: UncertaintyMethod,
    (chunk_points, check_points, pose): (Option<u64>, usize, usize),
    mut write: impl FnMut(u64, u64, &[f32]) -> Result<(), EngineError>,
) -> Result<UncertaintySummary, EngineError> {
    let start = Instant::now();
    let nx = grid.dims[0];
    let mut stats = FieldStats::default();
    let checked = sample_points(grid.points(), check_points);
    let mut captured: Vec<[f32; 6]> = Vec::with_capacity(checked.len());
    let run = engine.run_uncertainty(
        machine,
        grid,
        method,
        chunk_points,
        |first_line, lines, data| -> Result<(), EngineError> {
            check_finite(machine, grid, first_line, lines, data)?;
            write(first_line, lines, data)?;
            stats.add_chunk(first_line, lines, nx, data);
            capture(&checked, &mut captured, first_line, lines, nx, data);
            Ok(())
        },
    )?;
    let seconds = start.elapsed().as_secs_f64();
    let check = (!checked.is_empty())
        .then(|| check_uncertainty(machine, grid, method, &checked, &captured))
        .flatten()
        .map(|mut c| {
            if let Some(w) = &mut c.worst {
                w.pose = pose;
            }
            c
        });
    Ok(UncertaintySummary {
        method,
        run,
        stats,
        check,
        seconds,
    })
}

/// Compares the uncertainties `values` (channel order) at `points` with the reference's
/// propagation by the same method; `None` for an adaptive run.
pub fn check_uncertainty(
    machine: &Machine,
    grid: &Grid,
    method: UncertaintyMethod,
    points: &[u64],
    values: &[[f32; 6]],
) -> Option<CheckResult> {
    assert_eq!(points.len(), values.len(), "a value per checked point");
    let propagation = Propagation::new(machine);
    let commands: Vec<_> = points
        .iter()
        .map(|&p| grid.command(grid.indices(p)))
        .collect();
    let want: Vec<Sample> = match method {
        UncertaintyMethod::FirstOrder => commands
            .iter()
            .map(|c| propagation.first_order(c))
            .collect(),
        UncertaintyMethod::MonteCarlo { draws, seed } => {
            propagation.monte_carlo(&commands, draws, seed).ok()?.std
        }
        UncertaintyMethod::Adaptive { .. } => return None,
    };
    // The values the uncertainties are of, whose f32 rounding bounds the differences of fields.
    let twin = crate::reference::Twin::of(machine);
    let mut result = CheckResult {
        points: points.len(),
        max_ve_diff_mm: 0.0,
        max_oe_diff_rad: 0.0,
        worst: None,
    };
    assert_eq!(want.len(), points.len(), "a reference per checked point");
    for ((&p, got), want) in points.iter().zip(values).zip(&want) {
        let value = super::reference::point_values(&twin, grid, grid.indices(p));
        // The reference's sample order (VE, then OE) into channel order (OE, then VE).
        let want = [want[3], want[4], want[5], want[0], want[1], want[2]];
        result.add(CheckedPoint::of(grid, p, got, &want, &value));
    }
    Some(result)
}
