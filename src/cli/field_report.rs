//! The JSON of a field's summary, as `map --json` and `info --json` write it: the file, its grid
//! and storage, the statistics (of each pose, for a sweep), and the spot check.

use std::path::Path;

use serde_json::{json, Value};
use volmap::engine::map::{self, CheckResult, FieldStats};
use volmap::io::field::FieldInfo;

use super::envelope::field_pose;

/// The statistics of one field (or of a sweep, over every pose): where the largest |VE| is as
/// grid indices and as the commanded linear positions (mm).
pub fn stats_json(info: &FieldInfo, stats: &FieldStats) -> Value {
    let grid = info.grid();
    let ijk = grid.indices(stats.max_ve_point);
    let command = grid.command(ijk);
    json!({
        "points": stats.points,
        "max_ve_mm": stats.max_ve_mm,
        "max_ve_at": {
            "index": ijk,
            "position_mm": { "X": command[0], "Y": command[1], "Z": command[2] },
        },
        "rms_ve_mm": stats.rms_ve_mm(),
        "max_oe_rad": stats.max_oe_rad,
        "max_abs_ve_component_mm": { "x": stats.max_axis_mm[0], "y": stats.max_axis_mm[1], "z": stats.max_axis_mm[2] },
    })
}

/// The file, its grid, the device that computed it and how it is stored.
pub fn file_json(path: &Path, info: &FieldInfo, stored: String) -> Value {
    json!({
        "file": path.display().to_string(),
        "grid": {
            "dims": info.dims,
            "origin_mm": info.origin_mm,
            "spacing_mm": info.spacing_mm,
        },
        "device": info.device,
        "stored": stored,
    })
}

/// The poses of a sweep, each with its statistics: `infos[k]` the header of pose `k`.
fn poses_json(infos: &[FieldInfo], names: &[String], stats: &[FieldStats]) -> Value {
    infos
        .iter()
        .zip(names)
        .zip(stats)
        .map(|((info, name), stats)| {
            json!({ "name": name, "pose_deg": field_pose(info), "stats": stats_json(info, stats) })
        })
        .collect()
}

/// A sweep's summary (map --poses, or a multi-part field): the worst pose's file and grid, the
/// statistics over every pose (`total`), the worst pose's name and each pose's statistics;
/// `infos[k]` is the header of pose `k`.
pub fn sweep_json(
    path: &Path,
    infos: &[FieldInfo],
    names: &[String],
    stats: &[FieldStats],
    total: &FieldStats,
    stored: String,
) -> Value {
    let worst = &infos[total.max_ve_pose];
    let mut result = file_json(path, worst, stored);
    result["stats"] = stats_json(worst, total);
    result["worst_pose"] = names[total.max_ve_pose].clone().into();
    result["poses"] = poses_json(infos, names, stats);
    result
}

/// The spot check against the f64 reference, with its tolerances; null where none was asked.
pub fn check_json(check: Option<&CheckResult>) -> Value {
    check.map_or(Value::Null, |c| {
        json!({
            "points": c.points,
            "max_ve_diff_mm": c.max_ve_diff_mm,
            "max_oe_diff_rad": c.max_oe_diff_rad,
            "tolerance_mm": map::VE_TOLERANCE_MM,
            "tolerance_rad": map::OE_TOLERANCE_RAD,
            "passed": c.passed(),
        })
    })
}
