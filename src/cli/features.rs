//! `volmap features`: the GD&T error each feature of a part gets from the machine, against its
//! tolerance: the machine's capability (exit code 3 when any feature is unfit).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use volmap::io::field::{FieldError, FieldFile, LoadedField};
use volmap::model::{poses, AxisLetter};
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
    /// Take the machine's error from this field file (trilinear interpolation); of a five-axis
    /// map (`map --poses`), from the part at the part's pose.
    #[arg(long)]
    field: Option<PathBuf>,
    #[command(flatten)]
    machine: OptionalMachineArg,
    #[command(flatten)]
    json: JsonArg,
}

/// The field the part is evaluated in: a single-pose field file whole, or the part of a
/// five-axis map (`map --poses`) at the part's pose (`placement.pose_deg`, axes not named at 0),
/// found as `sample` finds a point's (within 1e-9°).
fn open_field(path: &Path, part: &PartFile) -> Result<LoadedField, FieldError> {
    let file = FieldFile::open(path)?;
    if !file.is_multipart() {
        return LoadedField::open_part(&file, 0);
    }
    let pose = part.pose();
    let degrees = [pose[3], pose[4], pose[5]];
    // The file's rotary axes, and any other the part turns.
    let axes = file.info(0).pose_axes;
    let letters: Vec<AxisLetter> = AxisLetter::ALL[3..]
        .iter()
        .copied()
        .filter(|l| axes.contains(l.as_char()) || degrees[l.index() - 3] != 0.0)
        .collect();
    let words = format!(
        "{} (the part's placement.pose_deg)",
        poses::name_of(degrees, &letters)
    );
    LoadedField::open_part(&file, file.part_at(degrees, &words)?)
}

pub fn run(args: FeaturesArgs) -> Result<ExitCode, Failure> {
    let part_name = args.part.display().to_string();
    let part = PartFile::read(&args.part).flag("--part")?;
    let field;
    let machine;
    let source = match (&args.field, &args.machine.machine) {
        (Some(path), _) => {
            field = open_field(path, &part).flag("--field")?;
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
