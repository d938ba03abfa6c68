//! What `volmap map` prints at the end (and `info`, which reads the same summary back): the
//! field's summary, the time and storage, the spot checks with their exit code, the part of
//! uncertainties; and its JSON.

use std::process::ExitCode;

use volmap::engine::map::{self, CheckResult, FieldStats};
use volmap::engine::map_uncertainty::UncertaintySummary;
use volmap::engine::uncertainty::UncertaintyMethod;
use volmap::io::field::{FieldInfo, Storage};

use super::field_report::{check_json, stats_json};
use super::numbers;

/// The worse of two exit codes of a map's checks.
pub fn worse(a: ExitCode, b: ExitCode) -> ExitCode {
    if a == ExitCode::SUCCESS {
        b
    } else {
        a
    }
}

/// The closing lines of a map's uncertainties: the method, the largest |u(VE)| and where, the
/// machines summed, and their spot check (exit code 4 when it failed).
pub fn print_uncertainty(
    info: &FieldInfo,
    summary: &UncertaintySummary,
    pose_names: &[String],
) -> ExitCode {
    let stats = &summary.stats;
    let grid = info.grid();
    let ijk = grid.indices(stats.max_ve_point);
    let command = grid.command(ijk);
    let at: Vec<String> = (0..3)
        .map(|d| format!("{}={}", ["X", "Y", "Z"][d], numbers::length(command[d])))
        .collect();
    outln!("  uncertainty {}", summary.method.describe());
    let run = &summary.run;
    let machines = match summary.method {
        UncertaintyMethod::FirstOrder => format!("{} directions, two maps each", run.terms_max),
        _ if run.terms_min == run.terms_max => format!("{} draws", run.terms_max),
        _ => format!("{} to {} draws per chunk", run.terms_min, run.terms_max),
    };
    outln!(
        "  max |u(VE)| {} at point ({}, {}, {}){}: {} mm ({machines}, {} s)",
        numbers::error_um(stats.max_ve_mm),
        ijk[0],
        ijk[1],
        ijk[2],
        pose_names
            .get(stats.max_ve_pose)
            .map_or(String::new(), |n| format!(" of pose {n}")),
        at.join(" "),
        numbers::quantity(summary.seconds)
    );
    outln!("  max |u(OE)| {}", numbers::angle_urad(stats.max_oe_rad));
    if run.unstable_chunks > 0 {
        errln!(
            "volmap: the adaptive rule stopped at its bound of {} batches in {} chunks before their uncertainties were stable to 2 significant digits",
            volmap::engine::uncertainty::MAX_ADAPTIVE_BATCHES,
            run.unstable_chunks
        );
    }
    match &summary.check {
        Some(check) => {
            outln!("  check of u  against the f64 reference's propagation by the same method:");
            print_check(Some(check), pose_names)
        }
        None => ExitCode::SUCCESS,
    }
}

/// The uncertainties of a map in its JSON report (`null` where none were asked for).
pub fn uncertainty_json(
    info: &FieldInfo,
    summary: Option<&UncertaintySummary>,
) -> serde_json::Value {
    summary.map_or(serde_json::Value::Null, |u| {
        serde_json::json!({
            "method": u.method.describe(),
            "terms_min": u.run.terms_min,
            "terms_max": u.run.terms_max,
            "unstable_chunks": u.run.unstable_chunks,
            "stats": stats_json(info, &u.stats),
            "check": check_json(u.check.as_ref()),
            "seconds": u.seconds,
        })
    })
}

pub fn print_time(seconds: f64, points: u64) {
    outln!(
        "  time        {} s, {} Mpts/s",
        numbers::quantity(seconds),
        numbers::quantity(points as f64 / seconds.max(1e-9) / 1e6)
    );
}

/// How the field file stores its values, and its size.
pub fn print_stored(storage: &Storage, bytes: u64) {
    outln!(
        "  stored      {}, {} MB",
        storage.describe(),
        numbers::quantity(bytes as f64 / 1e6)
    );
}

/// Prints the spot check, if there was one: exit code 4 when it failed, naming the point it
/// failed worst at (and its pose's name, from `pose_names`, in a sweep).
pub fn print_check(check: Option<&CheckResult>, pose_names: &[String]) -> ExitCode {
    if let Some(check) = check {
        outln!(
            "  check       {} points against the f64 reference: max ΔVE {}, max ΔOE {} (tolerance {}, {}, or {} f32 units in the last place of the value): {}",
            check.points,
            // Numerical agreement, far below the 0.001 of an error: 4 significant digits.
            format!("{} µm", numbers::quantity(check.max_ve_diff_mm * 1e3)),
            format!("{} µrad", numbers::quantity(check.max_oe_diff_rad * 1e6)),
            format!("{} µm", numbers::quantity(map::VE_TOLERANCE_MM * 1e3)),
            format!("{} µrad", numbers::quantity(map::OE_TOLERANCE_RAD * 1e6)),
            map::ULPS,
            if check.passed() { "ok" } else { "FAILED" }
        );
        if !check.passed() {
            if let Some(w) = &check.worst {
                let at: Vec<String> = (0..3)
                    .map(|d| format!("{}={}", ["X", "Y", "Z"][d], numbers::length(w.at_mm[d])))
                    .collect();
                let pose = pose_names
                    .get(w.pose)
                    .map_or(String::new(), |name| format!(" of pose {name}"));
                errln!(
                    "volmap: the spot check failed at point ({}, {}, {}){pose}, {} mm: ΔVE {}, ΔOE {} from the f64 reference",
                    w.indices[0],
                    w.indices[1],
                    w.indices[2],
                    at.join(" "),
                    format!("{} µm", numbers::quantity(w.ve_diff_mm * 1e3)),
                    format!("{} µrad", numbers::quantity(w.oe_diff_rad * 1e6)),
                );
            }
            return ExitCode::from(4);
        }
    }
    ExitCode::SUCCESS
}

/// The closing summary of a map or a field file: the machine, the grid, where the largest error
/// is, the RMS and the largest orientation error.
pub fn print_summary(info: &FieldInfo, stats: &FieldStats) {
    let grid = info.grid();
    let ijk = grid.indices(stats.max_ve_point);
    let command = grid.command(ijk);
    let at: Vec<String> = (0..3)
        .map(|d| format!("{}={}", ["X", "Y", "Z"][d], numbers::length(command[d])))
        .collect();
    let pose: Vec<String> = info
        .pose_axes
        .chars()
        .map(|a| {
            let index = "ABC".find(a).unwrap_or(0);
            format!("{a}={}", numbers::degrees(info.pose_deg[index]))
        })
        .collect();
    outln!(
        "volmap: {} ({}), grid {}x{}x{} = {} points{}",
        info.machine_name,
        info.chain,
        info.dims[0],
        info.dims[1],
        info.dims[2],
        stats.points,
        if pose.is_empty() {
            String::new()
        } else {
            format!(", pose {}", pose.join(" "))
        }
    );
    outln!("  device      {}", info.device);
    outln!("  inputs      {}", info.inputs.describe());
    outln!(
        "  max |VE|    {} at point ({}, {}, {}): {} mm",
        numbers::error_um(stats.max_ve_mm),
        ijk[0],
        ijk[1],
        ijk[2],
        at.join(" ")
    );
    outln!("  RMS |VE|    {}", numbers::error_um(stats.rms_ve_mm()));
    outln!("  max |OE|    {}", numbers::angle_urad(stats.max_oe_rad));
}
