//! `volmap merge-maps`: the shards of a five-axis map (`map --poses … --shard K/M`) put into one
//! multi-part field, the file one run over every pose writes.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::io::field::{merge_parts, FieldFile};

use super::args::JsonArg;
use super::envelope::{field_pose, Envelope};
use super::failure::Failure;
use super::output::{check_distinct_outputs, progress};

#[derive(clap::Args)]
pub struct MergeMapsArgs {
    /// The field files of the shards (`map --poses … --shard K/M`), in the order of K: their
    /// parts are written in this order.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// The multi-part field file to write (.exr).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: MergeMapsArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[
        ("--out", Some(args.out.as_path())),
        ("--json", args.json.json.as_deref()),
    ])?;
    if args
        .out
        .extension()
        .is_none_or(|e| !e.eq_ignore_ascii_case("exr"))
    {
        return Err(Failure::input(format!(
            "--out {}: a field file ends in .exr",
            args.out.display()
        )));
    }
    if let Some(same) = args.files.iter().find(|f| **f == args.out) {
        return Err(Failure::input(format!(
            "--out {} is also a file to merge",
            same.display()
        )));
    }
    let files = args
        .files
        .iter()
        .map(|f| FieldFile::open(f))
        .collect::<Result<Vec<_>, _>>()?;
    let lines: u64 = files
        .iter()
        .flat_map(|f| (0..f.parts()).map(|p| f.info(p)))
        .map(|i| (i.dims[1] * i.dims[2]) as u64)
        .sum();
    let bar = progress(Some(lines), "merging", "lines");
    let result = merge_parts(&files, &args.out, |n| bar.set_position(n));
    bar.finish_and_clear();
    result?;
    let parts: usize = files.iter().map(FieldFile::parts).sum();
    outln!(
        "Merged {} field files: {parts} poses of {} into {}",
        files.len(),
        files[0].info(0).machine_name,
        args.out.display()
    );
    if let Some(path) = &args.json.json {
        let infos: Vec<_> = files
            .iter()
            .flat_map(|f| (0..f.parts()).map(|p| f.info(p)))
            .collect();
        let poses = infos.iter().map(field_pose).collect();
        let result = serde_json::json!({
            "file": args.out.display().to_string(),
            "parts": parts,
            "merged": args.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        });
        Envelope::new("merge-maps")
            .field(&infos[0])
            .pose(serde_json::Value::Array(poses))
            .write(path, "--json", &result)?;
    }
    Ok(ExitCode::SUCCESS)
}
