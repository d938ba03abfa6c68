//! `volmap features`: the GD&T error each feature of a part gets from the machine, against its
//! tolerance: the machine's capability (exit code 3 when any feature is unfit).

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::io::field::LoadedField;
use volmap::part::{self, ErrorSource, PartFile, Verdict};

use super::args::{load_machine, JsonArg, OptionalMachineArg};
use super::failure::{Failure, FlagContext};
use super::output::write_json;

#[derive(clap::Args)]
#[command(mut_arg("machine", |a| a.conflicts_with("field")))]
pub struct FeaturesArgs {
    /// The part file (TOML): placement, cutter and features with their tolerances.
    #[arg(long)]
    part: PathBuf,
    /// Take the machine's error from this field file (trilinear interpolation).
    #[arg(long)]
    field: Option<PathBuf>,
    #[command(flatten)]
    machine: OptionalMachineArg,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: FeaturesArgs) -> Result<ExitCode, Failure> {
    let part_name = args.part.display().to_string();
    let part = PartFile::read(&args.part).flag("--part")?;
    let field;
    let machine;
    let source = match (&args.field, &args.machine.machine) {
        (Some(path), _) => {
            field = LoadedField::open(path).flag("--field")?;
            ErrorSource::Field(&field)
        }
        (None, Some(name)) => {
            machine = load_machine(name)?;
            ErrorSource::Exact(&machine)
        }
        (None, None) => {
            return Err(Failure::input(
                "say where the machine's error comes from: --field FILE.exr or --machine M",
            ))
        }
    };
    let rows = part::evaluate(&part, source, &part_name)?;
    println!("{} ({} features)", part.name, rows.len());
    println!(
        "  {:<24} {:<18} {:>12} {:>12} {:>8}  {:<8} worst point (commanded X Y Z, mm)",
        "feature", "kind", "error mm", "tolerance mm", "safety", "verdict"
    );
    for r in &rows {
        let safety = r.safety.map_or("-".to_string(), |s| format!("{s:.2}"));
        let verdict = match r.verdict {
            Verdict::Unfit => "unfit",
            Verdict::Inspect => "inspect",
            Verdict::Fit => "fit",
        };
        let area = r.area_outside.map_or(String::new(), |a| {
            format!("  ({:.1}% of the area outside the zone)", 100.0 * a)
        });
        println!(
            "  {:<24} {:<18} {:>12.6} {:>12.6} {:>8}  {:<8} {:.3} {:.3} {:.3}{area}",
            r.name,
            r.kind,
            r.error_mm,
            r.tolerance_mm,
            safety,
            verdict,
            r.worst_point[0],
            r.worst_point[1],
            r.worst_point[2]
        );
    }
    if let Some(path) = &args.json.json {
        write_json(path, &rows)?;
    }
    if rows.iter().any(|r| r.verdict == Verdict::Unfit) {
        return Ok(ExitCode::from(3));
    }
    Ok(ExitCode::SUCCESS)
}
