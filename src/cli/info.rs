//! `volmap info`: the summary of a field file; of a five-axis map, the summary of the sweep with
//! the largest |VE| of each pose.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::engine::map::FieldStats;
use volmap::io::field::{FieldFile, FieldReader};

use super::args::JsonArg;
use super::envelope::{field_pose, Envelope};
use super::failure::Failure;
use super::field_report::{file_json, stats_json, sweep_json};
use super::map_report::print_summary;
use super::numbers;
use super::sweep::print_sweep_summary;

#[derive(clap::Args)]
pub struct InfoArgs {
    /// The field file (.exr).
    file: PathBuf,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: InfoArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[("--json", args.json.json.as_deref())])?;
    let file = FieldFile::open(&args.file)?;
    if !file.is_multipart() {
        let mut reader = file.reader(0)?;
        let stats = field_stats(&mut reader)?;
        print_summary(reader.info(), &stats);
        let uncertainty = uncertainty_stats(&file, 0)?;
        if let Some((method, u)) = &uncertainty {
            print_uncertainty(reader.info(), method, u);
        }
        outln!("  stored      {}", file.storage(0));
        outln!("  field       {}", args.file.display());
        if let Some(path) = &args.json.json {
            let info = reader.info();
            let mut result = file_json(&args.file, info, file.storage(0));
            result["stats"] = stats_json(info, &stats);
            result["uncertainty"] = uncertainty.as_ref().map_or(
                serde_json::Value::Null,
                |(method, u)| serde_json::json!({ "method": method, "stats": stats_json(info, u) }),
            );
            Envelope::new("info")
                .field(info)
                .write(path, "--json", &result)?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    let mut names = Vec::with_capacity(file.parts());
    let mut stats = Vec::with_capacity(file.parts());
    let mut total = FieldStats::default();
    for part in 0..file.parts() {
        let part_stats = field_stats(&mut file.reader(part)?)?;
        total.merge(&part_stats, part);
        stats.push(part_stats);
        names.push(file.name(part));
    }
    print_sweep_summary(&file.info(total.max_ve_pose), &names, &stats, &total);
    let mut u_total: Option<(String, FieldStats)> = None;
    for part in 0..file.parts() {
        if let Some((method, u)) = uncertainty_stats(&file, part)? {
            match &mut u_total {
                Some((_, all)) => all.merge(&u, part),
                None => u_total = Some((method, u)),
            }
        }
    }
    if let Some((method, u)) = &u_total {
        print_uncertainty(&file.info(u.max_ve_pose), method, u);
    }
    outln!("  stored      {}", file.storage(0));
    outln!(
        "  field       {} ({} parts, one per pose)",
        args.file.display(),
        file.parts()
    );
    if let Some(path) = &args.json.json {
        // Without the machine's text, which a copy per part would multiply by the parts.
        let infos: Vec<_> = (0..file.parts())
            .map(|p| file.info_without_machine(p))
            .collect();
        let result = sweep_json(&args.file, &infos, &names, &stats, &total, file.storage(0));
        let poses = infos.iter().map(field_pose).collect();
        Envelope::new("info")
            .field(&file.info(total.max_ve_pose))
            .pose(serde_json::Value::Array(poses))
            .write(path, "--json", &result)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The method and statistics of the uncertainties of part `part`, where the file holds them.
fn uncertainty_stats(
    file: &FieldFile,
    part: usize,
) -> Result<Option<(String, FieldStats)>, Failure> {
    let (Some(method), Some(reader)) = (file.uncertainty(part), file.uncertainty_reader(part))
    else {
        return Ok(None);
    };
    Ok(Some((method.to_string(), field_stats(&mut reader?)?)))
}

/// The lines of a field's uncertainties: the method, the largest |u(VE)| and where.
fn print_uncertainty(info: &volmap::io::field::FieldInfo, method: &str, u: &FieldStats) {
    let grid = info.grid();
    let ijk = grid.indices(u.max_ve_point);
    outln!("  uncertainty {method}");
    outln!(
        "  max |u(VE)| {} at point ({}, {}, {}){}",
        numbers::error_um(u.max_ve_mm),
        ijk[0],
        ijk[1],
        ijk[2],
        if info.pose_axes.is_empty() {
            String::new()
        } else {
            format!(" of pose {}", info.pose_name())
        }
    );
    outln!("  max |u(OE)| {}", numbers::angle_urad(u.max_oe_rad));
}

/// The statistics of one field, read in chunks.
fn field_stats(reader: &mut FieldReader) -> Result<FieldStats, Failure> {
    let nx = reader.info().dims[0];
    let mut stats = FieldStats::default();
    reader.for_each_chunk((1u64 << 20) / nx as u64, |first, lines, data| {
        stats.add_chunk(first, lines, nx, data)
    })?;
    Ok(stats)
}
