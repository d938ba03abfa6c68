//! `volmap features`: the GD&T error each feature of a part gets from the machine, against its
//! tolerance: the machine's capability, and the decision by ISO 14253-1 with the expanded
//! uncertainty of each error (exit code 3 when any feature does not conform, 5 when none fails
//! but some cannot be decided).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use volmap::io::field::{FieldError, FieldFile, LoadedField};
use volmap::model::{poses, AxisLetter};
use volmap::part::{self, Conformance, ErrorSource, Evaluation, PartFile, Verdict};

use volmap::design::conformance::{feature_errors, summarize, FeatureConformance};
use volmap::design::monte_carlo::{check_confidence, check_samples, Study};
use volmap::design::shards::{tolerance_text, SampleFile, Shard, StudyKey};
use volmap::io::tolerance_file::ToleranceFile;

use super::args::{load_machine, DeviceArg, InputsArg, JsonArg, OptionalMachineArg};
use super::envelope::Envelope;
use super::estimate::Estimate;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, progress, write_file};
use volmap::io::digest;

#[derive(clap::Args)]
#[command(mut_arg("machine", |a| a.conflicts_with("field")))]
#[command(mut_arg("device", |a| a.requires("tolerances")))]
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
    /// The evaluation inputs: of the machine (and of the machines drawn around it with
    /// --tolerances); with --field, those the field must have been computed for (default: every
    /// axis `+`, every input at its reference).
    #[command(flatten)]
    inputs: InputsArg,
    /// The probability that the part conforms: draw machines built to these tolerances (a
    /// tolerance file) around --machine and evaluate every feature on each.
    #[arg(
        long,
        requires = "machine",
        requires = "samples",
        conflicts_with = "field"
    )]
    tolerances: Option<PathBuf>,
    /// The number of machines drawn (with --tolerances).
    #[arg(long, requires = "tolerances", value_parser = clap::value_parser!(u64).range(1..))]
    samples: Option<u64>,
    /// A feature is `fit` where at least this fraction of the machines make it conform.
    #[arg(
        long,
        default_value_t = 0.95,
        requires = "tolerances",
        allow_negative_numbers = true
    )]
    confidence: f64,
    /// The seed of the draws: the same seed gives the same machines on every device.
    #[arg(long, default_value_t = 0, requires = "tolerances")]
    seed: u64,
    /// Compute only the K-th (from 0) of M equal ranges of the samples (a job of a batch
    /// scheduler's array), written with --per-sample FILE.json for `merge-samples`.
    #[arg(long, value_name = "K/M", requires = "per_sample")]
    shard: Option<Shard>,
    /// Write every feature's error on every sampled machine here (JSON), for `merge-samples`.
    #[arg(long, requires = "tolerances")]
    per_sample: Option<PathBuf>,
    #[command(flatten)]
    device: DeviceArg,
    #[command(flatten)]
    json: JsonArg,
}

/// The field the part is evaluated in: a single-pose field file whole, or the part of a
/// five-axis map (`map --poses`) at the part's pose (`placement.pose_deg`, axes not named at 0),
/// found as `sample` finds a point's (within 1e-9°). The field must hold the inputs `inputs`
/// asks for.
pub(super) fn open_field(
    path: &Path,
    part: &PartFile,
    inputs: &InputsArg,
) -> Result<LoadedField, Failure> {
    volmap::io::source::note_source(path);
    let file = FieldFile::open(path).flag("--field")?;
    inputs.check_field(&file)?;
    open_part(&file, part).flag("--field")
}

/// The part of `file` to evaluate `part` in (see [`open_field`]).
fn open_part(file: &FieldFile, part: &PartFile) -> Result<LoadedField, FieldError> {
    if !file.is_multipart() {
        return LoadedField::open_part(file, 0);
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
    LoadedField::open_part(file, file.part_at(degrees, &words)?)
}

/// Neither `--field` nor `--machine`: checked before the part is read.
fn no_error_source() -> Failure {
    Failure::input(
        "say where the machine's error comes from: --field FILE.exr, or --machine NAME or FILE.toml (`volmap machines` lists the embedded ones)",
    )
}

pub fn run(args: FeaturesArgs) -> Result<ExitCode, Failure> {
    if args.field.is_none() && args.machine.machine.is_none() {
        return Err(no_error_source());
    }
    let part_name = args.part.display().to_string();
    let part = PartFile::read(&args.part).flag("--part")?;
    // Every output before any work: --json, --per-sample and each feature's deviation file.
    let plies: Vec<(String, std::path::PathBuf)> = part
        .ply_paths()
        .into_iter()
        .map(|(name, path)| (format!("--part: feature `{name}`'s ply"), path))
        .collect();
    let mut outputs: Vec<(&str, Option<&Path>)> = vec![
        ("--json", args.json.json.as_deref()),
        ("--per-sample", args.per_sample.as_deref()),
    ];
    outputs.extend(
        plies
            .iter()
            .map(|(label, path)| (label.as_str(), Some(path.as_path()))),
    );
    check_distinct_outputs(&outputs)?;
    if let (Some(tolerances), Some(name)) = (&args.tolerances, &args.machine.machine) {
        return run_conformance(&args, &part, &part_name, tolerances, name);
    }
    let field;
    let machine;
    let source = match (&args.field, &args.machine.machine) {
        (Some(path), _) => {
            field = open_field(path, &part, &args.inputs)?;
            ErrorSource::Field(&field)
        }
        (None, Some(name)) => {
            machine = args
                .inputs
                .machine_at(&load_machine(name, &args.machine.reach)?)?
                .0;
            ErrorSource::Exact(&machine)
        }
        (None, None) => return Err(no_error_source()),
    };
    let (at, on) = match &source {
        ErrorSource::Exact(machine) => (inputs_words(machine), machine.name.clone()),
        ErrorSource::Field(field) => (
            field.info.inputs.describe(),
            format!(
                "the field {}",
                args.field.as_deref().unwrap_or(Path::new("")).display()
            ),
        ),
    };
    // Only a report needs it: hashing the machine's files is work a plain run need not do.
    let envelope = args.json.json.is_some().then(|| {
        match &source {
            ErrorSource::Exact(machine) => Envelope::new("features").machine(machine),
            ErrorSource::Field(field) => Envelope::new("features").field(&field.info),
        }
        .pose(part_pose(&part))
    });
    let rows = part::evaluate(&part, source, &part_name)?;
    let mut pose: Vec<(&String, &f64)> = part.placement.pose_deg.iter().collect();
    pose.sort_by(|a, b| a.0.cmp(b.0));
    let pose = if pose.is_empty() {
        String::new()
    } else {
        let words: Vec<String> = pose
            .iter()
            .map(|(a, d)| format!("{a}={}", numbers::degrees(**d)))
            .collect();
        format!(", pose {}", words.join(" "))
    };
    outln!(
        "{} ({} features) on {on} at {at}{pose}",
        part.name,
        rows.len()
    );
    let against_of = |r: &part::FeatureResult| match r.evaluation {
        Evaluation::MinimumZone => "minimum zone".to_string(),
        Evaluation::Nominal => "nominal".to_string(),
        Evaluation::BestFit => "best fit".to_string(),
        Evaluation::Datums => format!("datums {}", r.datums.join(" ")),
    };
    let against: Vec<String> = rows.iter().map(against_of).collect();
    // The column as wide as its longest entry (datums of several features).
    let wide = against
        .iter()
        .map(|a| a.chars().count())
        .max()
        .unwrap_or(0)
        .max(16);
    outln!(
        "  {:<24} {:<18} {:>12} {:>12} {:>12} {:>8}  {:<8} {:<16} {:<wide$} worst point (commanded X Y Z, mm)",
        "feature",
        "kind",
        "error µm",
        "U µm (k=2)",
        "tolerance µm",
        "safety",
        "verdict",
        "ISO 14253-1",
        "against"
    );
    for (r, against) in rows.iter().zip(&against) {
        let safety = r.safety.map_or("-".to_string(), numbers::quantity);
        let verdict = match r.verdict {
            Verdict::Unfit => "unfit",
            Verdict::Inspect => "inspect",
            Verdict::Fit => "fit",
        };
        let area = r.area_outside.map_or(String::new(), |a| {
            format!(
                "  ({} of the area outside the zone)",
                numbers::percent(100.0 * a)
            )
        });
        outln!(
            "  {:<24} {:<18} {:>12} {:>12} {:>12} {:>8}  {:<8} {:<16} {:<wide$} {} {} {}{area}",
            r.name,
            r.kind,
            numbers::error(r.error_mm),
            numbers::error(r.u_expanded_mm),
            numbers::error(r.tolerance_mm),
            safety,
            verdict,
            r.conformance.words(),
            against,
            numbers::length(r.worst_point[0]),
            numbers::length(r.worst_point[1]),
            numbers::length(r.worst_point[2])
        );
    }
    // The deviations of each meshed surface that asks for them, written by the evaluation.
    for feature in &part.features {
        if let part::FeatureSpec::Profile {
            name,
            ply: Some(file),
            ..
        } = feature
        {
            outln!(
                "  wrote {} (deviations of `{name}`)",
                part.base.join(file).display()
            );
        }
    }
    if let (Some(path), Some(envelope)) = (&args.json.json, &envelope) {
        envelope.write(path, "--json", &rows)?;
    }
    Ok(exit_code(&rows))
}

/// 3 where any feature does not conform (by ISO 14253-1: beyond its tolerance by more than the
/// error's expanded uncertainty), else 5 where any cannot be decided, else 0. Without
/// uncertainties (U = 0) no feature is undecided: 3 where any error exceeds its tolerance.
fn exit_code(rows: &[part::FeatureResult]) -> ExitCode {
    let any = |c: Conformance| rows.iter().any(|r| r.conformance == c);
    if any(Conformance::DoesNotConform) {
        ExitCode::from(3)
    } else if any(Conformance::Undecided) {
        ExitCode::from(5)
    } else {
        ExitCode::SUCCESS
    }
}

/// The part's pose (`placement.pose_deg`) as a report's `pose_deg` holds it.
fn part_pose(part: &PartFile) -> serde_json::Value {
    part.placement
        .pose_deg
        .iter()
        .map(|(axis, degrees)| (axis.clone(), serde_json::json!(degrees)))
        .collect::<serde_json::Map<_, _>>()
        .into()
}

/// Every feature on machines built to the tolerances: the fraction on which it conforms.
fn run_conformance(
    args: &FeaturesArgs,
    part: &PartFile,
    part_name: &str,
    tolerances: &Path,
    machine_name: &str,
) -> Result<ExitCode, Failure> {
    let loaded = load_machine(machine_name, &args.machine.reach)?;
    let file = ToleranceFile::load(tolerances, &loaded).flag("--tolerances")?;
    // The machines are drawn around the machine at the evaluation inputs.
    let (machine, _) = args.inputs.machine_at(&loaded)?;
    let confidence = check_confidence(args.confidence).flag("--confidence")?;
    let samples = check_samples(args.samples.unwrap_or(1)).flag("--samples")?;
    let study = Study {
        machine: &machine,
        tolerances: &file.tolerances,
        grids: &[],
        seed: args.seed,
    };
    // Before any device is chosen, as `budget` does: the machines' angles where the positions
    // pass takes the machine's own (its pose, the linear axes at zero).
    let mut pose = part.pose();
    pose[..3].fill(0.0);
    let at_pose = [volmap::model::grid::Grid {
        dims: [1, 1, 1],
        origin_mm: [0.0; 3],
        spacing_mm: [0.0; 3],
        pose,
    }];
    volmap::design::plausible::check_angles(
        &Study {
            grids: &at_pose,
            ..study
        },
        &vec![1.0; file.tolerances.len()],
    )
    .flag("--tolerances")?;
    let (engine, note) = args.device.engine()?;
    if let Some(note) = note {
        errln!("volmap: {note}");
    }
    let range = match args.shard {
        Some(shard) => shard.range(samples).flag("--shard")?,
        None => 0..samples,
    };
    let bar = progress(Some(range.len() as u64), "evaluating", "machines");
    // The points each machine is evaluated at, for the rate the estimate states (a part that
    // cannot be evaluated fails in the evaluation itself, with its message).
    let points_each =
        part::cutter_positions(part, part_name).map_or(0.0, |t| t.positions.len() as f64);
    let estimate = Estimate::new(
        range.len(),
        points_each,
        format!("evaluating {} machines", range.len()),
    );
    let result = feature_errors(&engine, &study, part, part_name, range.clone(), |n| {
        estimate.progress(n, |line| bar.suspend(|| errln!("{line}")));
        bar.set_position(n as u64)
    });
    bar.finish_and_clear();
    let (nominal, errors) = result?;
    let per_sample = args.per_sample.as_ref().map(|path| {
        let key = StudyKey {
            machine: machine.name.clone(),
            machine_sha256: Some(digest::of_machine(&machine)),
            tolerances: file.tolerances.iter().map(tolerance_text).collect(),
            grid: [0; 3],
            poses: Vec::new(),
            approach: machine.inputs.record(&machine).approach_text(),
            temperatures: machine.inputs.record(&machine).temperatures_text(),
            seed: args.seed,
            samples,
            spec_mm: None,
            part: Some(part_name.to_string()),
            confidence: Some(confidence),
        };
        let file = SampleFile::of_features(key, range.start, nominal.clone(), errors.clone());
        (
            path,
            serde_json::to_string_pretty(&file).expect("plain numbers and text") + "\n",
        )
    });
    let rows = summarize(nominal, errors, confidence);
    if let Some(shard) = args.shard {
        outln!(
            "Shard {}/{}: samples {}..{} of {samples}",
            shard.index,
            shard.count,
            range.start,
            range.end
        );
    }
    outln!(
        "{} ({} features) on {} machines built to {} around {} at {} (seed {}), VE and OE on the {}; fit where at least {} conform",
        part.name,
        rows.len(),
        range.len(),
        tolerances.display(),
        machine.name,
        inputs_words(&machine),
        args.seed,
        engine.name(),
        numbers::percent(100.0 * confidence)
    );
    print_conformance(&rows);
    if let Some((path, text)) = per_sample {
        write_file(path, |out| out.write_all(text.as_bytes())).flag("--per-sample")?;
        errln!("per-sample: {}", path.display());
    }
    if let Some(path) = &args.json.json {
        Envelope::new("features")
            .machine(&machine)
            .pose(part_pose(part))
            .write(path, "--json", &rows)?;
    }
    if rows.iter().any(|r| r.verdict == Verdict::Unfit) {
        return Ok(ExitCode::from(3));
    }
    Ok(ExitCode::SUCCESS)
}

/// The table of the features over the samples.
pub fn print_conformance(rows: &[FeatureConformance]) {
    outln!(
        "  {:<24} {:<18} {:>12} {:>12} {:>12} {:>12} {:>11} {:>17}  verdict",
        "feature",
        "kind",
        "tolerance µm",
        "nominal µm",
        "P50 µm",
        "P95 µm",
        "conforming",
        "95% CI"
    );
    for r in rows {
        outln!(
            "  {:<24} {:<18} {:>12} {:>12} {:>12} {:>12} {:>11} {:>17}  {}",
            r.name,
            r.kind,
            numbers::error(r.tolerance_mm),
            numbers::error(r.error_mm),
            numbers::error(r.error_p50_mm),
            numbers::error(r.error_p95_mm),
            numbers::percent(100.0 * r.conforming_fraction),
            format!(
                "{}-{}",
                numbers::percent(100.0 * r.conforming_ci95[0]),
                numbers::percent(100.0 * r.conforming_ci95[1])
            ),
            if r.verdict == Verdict::Fit {
                "fit"
            } else {
                "unfit"
            }
        );
    }
}

/// The inputs the machine is evaluated at, in words.
fn inputs_words(machine: &volmap::model::Machine) -> String {
    machine.inputs.describe(machine)
}
