//! A five-axis map over the rotary axes: the linear grid mapped at every pose of a sweep, into one
//! multi-part field file, one part per pose named by the pose (`B=-90,C=0`), each part the field
//! a map at that pose alone writes.
//!
//! The poses are computed one after the other, each streamed chunk by chunk into its part (the
//! headers and offset tables of every part are written first, see
//! [`PartsWriter`](crate::io::field::PartsWriter)): memory holds one chunk, whatever the sweep.

use std::path::Path;
use std::time::Instant;

use super::map::{
    capture, check_against_reference, check_finite, corrupted_for_tests, field_info, sample_points,
};
use super::map::{CheckResult, MapOptions, MapTimes};
use super::map_uncertainty::{map_uncertainty, uncertainty_part, UncertaintySummary};
use super::{Engine, EngineError};
use crate::io::field::PartsWriter;
use crate::model::grid::Grid;
use crate::model::poses::pose_name;
use crate::model::statistics::FieldStats;
use crate::model::Machine;

/// One pose of a sweep and its field's statistics.
#[derive(Debug, Clone)]
pub struct PoseSummary {
    /// The pose's name, which is its part's (`B=-90,C=0`).
    pub name: String,
    pub stats: FieldStats,
}

/// What a sweep reports at the end.
#[derive(Debug, Clone)]
pub struct SweepSummary {
    /// Every pose, in the order of the sweep (and of the parts).
    pub poses: Vec<PoseSummary>,
    /// Over every pose: `max_ve_pose` is the index of the worst pose (the largest max |VE|).
    pub stats: FieldStats,
    pub seconds: f64,
    pub device: String,
    /// The spot check: `check_points` points of every pose, the largest differences over all.
    pub check: Option<CheckResult>,
    /// Where the time went, over every pose.
    pub times: MapTimes,
    /// The parts of uncertainties over every pose, where asked for.
    pub uncertainty: Option<UncertaintySummary>,
}

/// Maps `machine` over every grid of `grids` (one per pose, the same linear grid) into the
/// multi-part field file `out`. `on_progress(points_done)` is called after each chunk, counting
/// the points of every pose so far.
pub fn map_sweep_to_file(
    machine: &Machine,
    grids: &[Grid],
    engine: &Engine,
    out: &Path,
    options: &MapOptions,
    mut on_progress: impl FnMut(u64),
) -> Result<SweepSummary, EngineError> {
    let device = engine.name();
    // With uncertainties, each pose's part of values is followed by its part of uncertainties.
    let per_pose = if options.uncertainty.is_some() { 2 } else { 1 };
    let mut writer = PartsWriter::create_stored(
        out,
        per_pose * grids.len(),
        |p| {
            let grid = &grids[p / per_pose];
            let info = field_info(machine, grid, &device);
            match options.uncertainty {
                Some(method) if p % per_pose == 1 => {
                    uncertainty_part(machine, grid, &info, method, false)
                }
                _ => (pose_name(&grid.pose, machine), info),
            }
        },
        options.storage,
    )?;
    let mut uncertainty: Option<UncertaintySummary> = None;
    let start = Instant::now();
    let mut poses = Vec::with_capacity(grids.len());
    let mut total = FieldStats::default();
    let mut check: Option<CheckResult> = None;
    let mut points_before = 0u64;
    let mut check_seconds = 0.0;
    let mut handoff_s = 0.0;
    for (p, grid) in grids.iter().enumerate() {
        let nx = grid.dims[0];
        let mut stats = FieldStats::default();
        let checked = sample_points(grid.points(), options.check_points);
        let mut captured: Vec<[f32; 6]> = Vec::with_capacity(checked.len());
        engine.run(
            machine,
            grid,
            options.chunk_points,
            |first_line, lines, data| -> Result<(), EngineError> {
                let handing = Instant::now();
                let corrupted = corrupted_for_tests(
                    options.corrupt_point_for_tests,
                    first_line,
                    lines,
                    nx,
                    data,
                );
                let data = corrupted.as_deref().unwrap_or(data);
                check_finite(machine, grid, first_line, lines, data)?;
                writer.write_lines(per_pose * p, first_line, lines, data)?;
                stats.add_chunk(first_line, lines, nx, data);
                let end_point = capture(&checked, &mut captured, first_line, lines, nx, data);
                on_progress(points_before + end_point);
                handoff_s += handing.elapsed().as_secs_f64();
                Ok(())
            },
        )?;
        points_before += grid.points();
        if !checked.is_empty() {
            let checking = Instant::now();
            let mut pose_check = check_against_reference(machine, grid, &checked, &captured);
            if let Some(worst) = &mut pose_check.worst {
                worst.pose = p;
            }
            match &mut check {
                Some(merged) => merged.merge(&pose_check),
                None => check = Some(pose_check),
            }
            // The time of the map, as for one pose, leaves the spot check out.
            check_seconds += checking.elapsed().as_secs_f64();
        }
        if let Some(method) = options.uncertainty {
            let part = map_uncertainty(
                machine,
                grid,
                engine,
                method,
                (options.chunk_points, options.check_points, p),
                |first_line, lines, data| {
                    Ok(writer.write_lines(per_pose * p + 1, first_line, lines, data)?)
                },
            )?;
            match &mut uncertainty {
                Some(all) => all.merge(&part, p),
                None => uncertainty = Some(part),
            }
        }
        total.merge(&stats, p);
        poses.push(PoseSummary {
            name: pose_name(&grid.pose, machine),
            stats,
        });
    }
    let engine_s = start.elapsed().as_secs_f64() - check_seconds - handoff_s;
    let write = writer.finish()?;
    Ok(SweepSummary {
        poses,
        stats: total,
        seconds: start.elapsed().as_secs_f64() - check_seconds,
        device,
        check,
        times: MapTimes {
            engine_s,
            handoff_s,
            write,
        },
        uncertainty,
    })
}
