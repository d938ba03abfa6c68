//! `volmap info`: the summary of a field file.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::engine::map::FieldStats;
use volmap::io::field::FieldReader;

use super::failure::Failure;
use super::map::print_summary;

#[derive(clap::Args)]
pub struct InfoArgs {
    /// The field file (.exr).
    file: PathBuf,
}

pub fn run(args: InfoArgs) -> Result<ExitCode, Failure> {
    let mut reader = FieldReader::open(&args.file)?;
    let info = reader.info().clone();
    let mut stats = FieldStats::default();
    let nx = info.dims[0];
    let lines_per_chunk = (1u64 << 20) / nx as u64;
    reader.for_each_chunk(lines_per_chunk, |first, lines, data| {
        stats.add_chunk(first, lines, nx, data)
    })?;
    print_summary(&info, &stats);
    println!("  field       {}", args.file.display());
    Ok(ExitCode::SUCCESS)
}
