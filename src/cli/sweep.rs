//! Five-axis maps over the rotary axes: `volmap map --poses` maps every pose of a sweep into one
//! multi-part field, and its summary (printed by `map` and by `volmap info`) gives the worst pose
//! and the largest |VE| of each.

use std::path::Path;

use volmap::engine::map::{FieldStats, MapOptions};
use volmap::engine::sweep::{self, SweepSummary};
use volmap::engine::Engine;
use volmap::io::field::FieldInfo;
use volmap::model::grid::Grid;
use volmap::model::Machine;

use super::numbers;
use super::output::progress;

/// Maps `machine` at every pose of the sweep (`grids`, one per pose) into `out`, with a progress
/// bar over the whole sweep.
pub fn map_sweep(
    machine: &Machine,
    grids: &[Grid],
    engine: &Engine,
    out: &Path,
    options: &MapOptions,
) -> Result<SweepSummary, volmap::engine::EngineError> {
    let points: u64 = grids.iter().map(Grid::points).sum();
    let bar = progress(Some(points), "mapping", "points");
    let summary = sweep::map_sweep_to_file(machine, grids, engine, out, options, |done| {
        bar.set_position(done)
    });
    bar.finish_and_clear();
    summary
}

/// The closing summary of a sweep, from a map or a multi-part field file: the machine, the grid
/// and the number of poses, the worst pose (the largest max |VE|) and where its largest error is,
/// the RMS and the largest orientation error over every pose, then one row per pose.
/// `worst` is the header of the worst pose's field (`total.max_ve_pose`).
pub fn print_sweep_summary(
    worst: &FieldInfo,
    names: &[String],
    stats: &[FieldStats],
    total: &FieldStats,
) {
    let grid = worst.grid();
    let ijk = grid.indices(total.max_ve_point);
    let command = grid.command(ijk);
    let at: Vec<String> = (0..3)
        .map(|d| format!("{}={}", ["X", "Y", "Z"][d], numbers::length(command[d])))
        .collect();
    let worst_name = names.get(total.max_ve_pose).map_or("", String::as_str);
    let per_pose = stats.first().map_or(0, |s| s.points);
    outln!(
        "volmap: {} ({}), grid {}x{}x{} = {} points at each of {} poses, {} points",
        worst.machine_name,
        worst.chain,
        worst.dims[0],
        worst.dims[1],
        worst.dims[2],
        per_pose,
        names.len(),
        total.points
    );
    outln!("  device      {}", worst.device);
    outln!("  inputs      {}", worst.inputs.describe());
    outln!(
        "  max |VE|    {} at pose {worst_name}, point ({}, {}, {}): {} mm",
        numbers::error_um(total.max_ve_mm),
        ijk[0],
        ijk[1],
        ijk[2],
        at.join(" ")
    );
    outln!("  worst pose  {worst_name}");
    outln!(
        "  RMS |VE|    {} over every pose",
        numbers::error_um(total.rms_ve_mm())
    );
    outln!("  max |OE|    {}", numbers::angle_urad(total.max_oe_rad));
    let width = names.iter().map(|n| n.len()).max().unwrap_or(0).max(4);
    outln!(
        "  {:<width$}  {:>12}  {:>12}  {:>13}",
        "pose",
        "max |VE| µm",
        "RMS |VE| µm",
        "max |OE| µrad"
    );
    for (name, s) in names.iter().zip(stats) {
        outln!(
            "  {name:<width$}  {:>12}  {:>12}  {:>13}",
            numbers::error(s.max_ve_mm),
            numbers::error(s.rms_ve_mm()),
            numbers::angle(s.max_oe_rad)
        );
    }
}

/// Prints a sweep's summary after `map --poses`.
pub fn print_map_summary(machine: &Machine, grids: &[Grid], summary: &SweepSummary) {
    let worst = summary.stats.max_ve_pose;
    let info = volmap::engine::map::field_info(machine, &grids[worst], &summary.device);
    let names: Vec<String> = summary.poses.iter().map(|p| p.name.clone()).collect();
    let stats: Vec<FieldStats> = summary.poses.iter().map(|p| p.stats.clone()).collect();
    print_sweep_summary(&info, &names, &stats, &summary.stats);
}
