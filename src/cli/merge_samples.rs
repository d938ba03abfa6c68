//! `volmap merge-samples`: the shards of a Monte Carlo study (`budget --shard K/M --per-sample
//! FILE.json`) put together into the statistics one run of all the samples gives.

use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::json;
use volmap::design::conformance::summarize;
use volmap::design::monte_carlo::MonteCarlo;
use volmap::design::shards::{merge, Merged, SampleFile, StudyKey};
use volmap::model::statistics::FieldStats;
use volmap::part::Verdict;

use super::budget_report;
use super::envelope::Envelope;
use super::failure::Failure;
use super::features::print_conformance;
use super::numbers;
use super::output::check_distinct_outputs;

#[derive(clap::Args)]
pub struct MergeSamplesArgs {
    /// The sample files of the shards (`budget --shard K/M --per-sample FILE.json`), in any
    /// order: together they must cover the study's samples once.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Write the merged statistics here (JSON, the shape of every --json: its result's
    /// `monte_carlo` is the same, byte for byte, as that of `budget --json` run over all the
    /// samples at once).
    #[arg(long)]
    out: PathBuf,
}

/// The statistics of the merged fields, printed as `budget` prints them; the JSON.
fn fields(
    study: &StudyKey,
    stats: &[FieldStats],
    args: &MergeSamplesArgs,
    files: usize,
) -> serde_json::Value {
    let monte_carlo = MonteCarlo::of(stats, study.seed, study.spec_mm);
    outln!(
        "Merged {files} sample files: {} machines of {} (grid {}x{}x{}, {} pose{})",
        study.samples,
        study.machine,
        study.grid[0],
        study.grid[1],
        study.grid[2],
        study.poses.len(),
        if study.poses.len() == 1 { "" } else { "s" }
    );
    let inputs = format!("approach {}", study.approach);
    budget_report::print_monte_carlo(&monte_carlo, format!("{files} shards"), &inputs);
    json!({
        "machine": study.machine,
        "tolerances": study.tolerances,
        "grid": study.grid,
        "poses": study.poses,
        "inputs": { "approach": study.approach, "temperatures": study.temperatures },
        "files": args.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        "monte_carlo": budget_report::monte_carlo_json(&monte_carlo),
    })
}

/// The envelope of the merged study: its machine by name and hash, its inputs as the shards
/// record them (`X=+,Y=-`, `spindle=31`).
fn envelope(study: &StudyKey) -> Envelope {
    let pairs = |text: &str| -> serde_json::Map<String, serde_json::Value> {
        text.split(',')
            .filter_map(|pair| pair.split_once('='))
            .map(|(k, v)| {
                let value = v.parse::<f64>().map_or_else(|_| json!(v), |t| json!(t));
                (k.to_string(), value)
            })
            .collect()
    };
    let poses: Vec<serde_json::Value> = study
        .poses
        .iter()
        .map(|name| serde_json::Value::Object(pairs(name)))
        .collect();
    Envelope::new("merge-samples")
        .named_machine(&study.machine, study.machine_sha256.as_deref())
        .with_inputs(json!({
            "approach": pairs(&study.approach),
            "temperatures_C": pairs(&study.temperatures),
            "reference_C": null,
            "pose_deg": poses,
        }))
}

pub fn run(args: MergeSamplesArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[("--out", Some(args.out.as_path()))])?;
    if args.files.iter().any(|f| f == &args.out) {
        return Err(Failure::input(format!(
            "--out {} is also a file to merge",
            args.out.display()
        )));
    }
    let mut files = Vec::with_capacity(args.files.len());
    for path in &args.files {
        let name = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|e| Failure::input(format!("{name}: {e}")))?;
        files.push((name.clone(), SampleFile::read(&name, &text)?));
    }
    let (study, merged) = merge(&files)?;
    match merged {
        Merged::Fields(stats) => {
            let value = fields(&study, &stats, &args, files.len());
            envelope(&study).write(&args.out, "--out", &value)?;
        }
        Merged::Features(nominal, errors) => {
            let confidence = study.confidence.unwrap_or(0.95);
            let rows = summarize(nominal, errors, confidence);
            outln!(
                "Merged {} sample files: {} ({} features) on {} machines of {} (seed {}); fit where at least {} conform",
                files.len(),
                study.part.as_deref().unwrap_or("the part"),
                rows.len(),
                study.samples,
                study.machine,
                study.seed,
                numbers::percent(100.0 * confidence)
            );
            print_conformance(&rows);
            // The same as `features --tolerances --json` over all the samples.
            envelope(&study).write(&args.out, "--out", &rows)?;
            errln!("merged: {}", args.out.display());
            // As `features` exits: 3 where a feature is unfit.
            if rows.iter().any(|r| r.verdict == Verdict::Unfit) {
                return Ok(ExitCode::from(3));
            }
            return Ok(ExitCode::SUCCESS);
        }
    }
    errln!("merged: {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}
