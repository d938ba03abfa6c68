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
use super::map::print_summary;
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
        outln!("  stored      {}", file.storage(0));
        outln!("  field       {}", args.file.display());
        if let Some(path) = &args.json.json {
            let info = reader.info();
            let mut result = file_json(&args.file, info, file.storage(0));
            result["stats"] = stats_json(info, &stats);
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

/// The statistics of one field, read in chunks.
fn field_stats(reader: &mut FieldReader) -> Result<FieldStats, Failure> {
    let nx = reader.info().dims[0];
    let mut stats = FieldStats::default();
    reader.for_each_chunk((1u64 << 20) / nx as u64, |first, lines, data| {
        stats.add_chunk(first, lines, nx, data)
    })?;
    Ok(stats)
}
