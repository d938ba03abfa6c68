//! `volmap budget`: machine design from tolerances. The error budget (each toleranced term alone
//! at its limit on the ideal machine), Monte Carlo over machines built to the tolerances, and
//! tolerance allocation against a specification.

use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::json;
use volmap::design::allocate::Target;
use volmap::design::budget::{budget, Budget};
use volmap::design::monte_carlo::{check_confidence, check_samples, check_spec, MonteCarlo, Study};
use volmap::design::plausible::check_angles;
use volmap::design::shards::{tolerance_text, SampleFile, Shard, StudyKey};
use volmap::error::excerpt;
use volmap::io::tolerance_file::ToleranceFile;
use volmap::model::grid::Grid;
use volmap::model::perturbation::{Distribution, Tolerance};
use volmap::model::poses::pose_name;
use volmap::model::Machine;

use super::args::{
    sweep_grids, DeviceArg, GridArg, InputsArg, JsonArg, MachineArg, PoseArg, PosesArg,
};
use super::budget_allocate::{allocated_text, allocation_json, print_stopped, run_allocation};
use super::budget_report::{self, position_words};
use super::envelope::{pose_of, Envelope};
use super::estimate::{check_machine_points, Estimate};
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, check_plot_paths, progress, write_file};
use volmap::io::digest;

#[derive(clap::Args)]
pub struct BudgetArgs {
    #[command(flatten)]
    machine: MachineArg,
    /// The tolerance file (TOML): how far each error of the machines built may lie from the
    /// machine file's value.
    #[arg(long)]
    tolerances: PathBuf,
    #[command(flatten)]
    grid: GridArg,
    #[command(flatten)]
    pose: PoseArg,
    #[command(flatten)]
    poses: PosesArg,
    /// The evaluation inputs of the machine the Monte Carlo machines are drawn around (the
    /// budget's ideal machine has no errors, so no inputs change it).
    #[command(flatten)]
    inputs: InputsArg,
    /// Also draw N machines built to the tolerances and give the statistics of their fields.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    samples: Option<u64>,
    /// A specification of max |VE|, mm: the fraction of sampled machines at or below it.
    #[arg(long, requires = "samples", allow_negative_numbers = true)]
    spec: Option<f64>,
    /// The seed of the draws: the same seed gives the same machines on every device.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The fraction of machines that must hold the specification (allocation).
    #[arg(long, default_value_t = 0.95, allow_negative_numbers = true)]
    confidence: f64,
    /// Find the largest common factor on the tolerances for which the fraction of machines
    /// within --spec reaches --confidence.
    #[arg(long, requires = "spec")]
    allocate: bool,
    /// Scale only these terms in the allocation (comma-separated keys: axes.Y.EC0Y or EC0Y).
    #[arg(long, requires = "allocate", value_delimiter = ',')]
    allocate_terms: Vec<String>,
    /// Write the tolerance file scaled by the allocated factor here.
    #[arg(long, requires = "allocate")]
    out: Option<PathBuf>,
    /// Write one CSV row per sampled machine: its statistics, where it is worst, its draws; or,
    /// to a .json file, the statistics `merge-samples` reads.
    #[arg(long, requires = "samples")]
    per_sample: Option<PathBuf>,
    /// Compute only the K-th (from 0) of M equal ranges of the samples (a job of a batch
    /// scheduler's array), written with --per-sample FILE.json for `merge-samples`.
    #[arg(
        long,
        value_name = "K/M",
        requires = "per_sample",
        conflicts_with = "allocate"
    )]
    shard: Option<Shard>,
    /// Draw the budget as a bar chart (and the histogram of max |VE| with --samples): .svg or
    /// .png.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[command(flatten)]
    json: JsonArg,
    #[command(flatten)]
    device: DeviceArg,
}

pub fn run(args: BudgetArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[
        ("--out", args.out.as_deref()),
        ("--per-sample", args.per_sample.as_deref()),
        ("--plot", args.plot.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    let loaded = args.machine.load()?;
    let file = ToleranceFile::load(&args.tolerances, &loaded).flag("--tolerances")?;
    // Machines are drawn around the machine at the evaluation inputs.
    let (machine, _) = args.inputs.machine_at(&loaded)?;
    let grids = sweep_grids(&machine, &args.grid, &args.pose, &args.poses)?;
    let spec = args.spec.map(check_spec).transpose().flag("--spec")?;
    let confidence = check_confidence(args.confidence).flag("--confidence")?;
    let samples = args
        .samples
        .map(check_samples)
        .transpose()
        .flag("--samples")?;
    let chosen = chosen_terms(&file.tolerances, &args.allocate_terms)?;
    if let Some(plot) = &args.plot {
        check_plot_paths(&[plot], "--plot")?;
    }
    let tolerances = &file.tolerances;
    let study = Study {
        machine: &machine,
        tolerances,
        grids: &grids,
        seed: args.seed,
    };
    // Before any device is chosen: every engine refuses the same runs and answers the others.
    let terms = tolerances.len() as u64;
    let drawn = samples.unwrap_or(0) as u64;
    let points_each = check_machine_points(
        terms + drawn,
        &format!("({terms} terms + {drawn} machines drawn)"),
        &grids,
        "--samples, --grid, --poses",
    )? / (terms + drawn) as f64;
    if samples.is_some() {
        check_angles(&study, &vec![1.0; tolerances.len()]).flag("--tolerances")?;
    }
    let (engine, note) = args.device.engine()?;
    if let Some(note) = note {
        errln!("volmap: {note}");
    }

    let bar = progress(Some(tolerances.len() as u64), "budgeting", "terms");
    let result = budget(&engine, &machine, tolerances, &grids, |n| {
        bar.set_position(n as u64)
    });
    bar.finish_and_clear();
    let budget = result?;
    print_budget(&machine, &args, &grids, &budget);
    let mut json = json!({
        "machine": machine.name,
        "tolerances": args.tolerances.display().to_string(),
        "grid": args.grid.grid,
        "poses": grids.iter().map(|g| pose_name(&g.pose, &machine)).collect::<Vec<_>>(),
        "inputs": {
            "approach": machine.inputs.record(&machine).approach_text(),
            "temperatures": machine.inputs.record(&machine).temperatures_text(),
        },
        "budget": budget_report::budget_json(&machine, &budget),
        "total_rss_mm": budget.total_rss_mm,
    });

    let mut histogram = None;
    if let Some(samples) = samples {
        let range = match args.shard {
            Some(shard) => shard.range(samples).flag("--shard")?,
            None => 0..samples,
        };
        let bar = progress(Some(range.len() as u64), "sampling", "machines");
        let ones = vec![1.0; tolerances.len()];
        let estimate = Estimate::new(
            range.len(),
            points_each,
            format!("sampling {} machines", range.len()),
        );
        let stats = study.range_stats(&engine, range.clone(), &ones, |n| {
            estimate.progress(n, |line| bar.suspend(|| errln!("{line}")));
            bar.set_position(n as u64)
        });
        bar.finish_and_clear();
        let stats = stats?;
        let monte_carlo = MonteCarlo::of(&stats, args.seed, spec);
        let inputs = machine.inputs.describe(&machine);
        if let Some(shard) = args.shard {
            outln!(
                "Shard {}/{}: samples {}..{} of {samples}",
                shard.index,
                shard.count,
                range.start,
                range.end
            );
            json["shard"] = json!({
                "index": shard.index, "count": shard.count, "first": range.start, "samples": range.len(),
            });
        }
        budget_report::print_monte_carlo(&monte_carlo, engine.name(), &inputs);
        json["monte_carlo"] = budget_report::monte_carlo_json(&monte_carlo);
        // Written once the whole run has succeeded: a failed allocation leaves no file.
        let per_sample = args.per_sample.as_ref().map(|path| {
            let text = if path.extension().is_some_and(|e| e == "json") {
                let key = study_key(&machine, &study, &args, samples, spec);
                let file = SampleFile::of_fields(key, range.start, &stats);
                serde_json::to_string_pretty(&file).expect("plain numbers and text") + "\n"
            } else {
                budget_report::per_sample_csv(&machine, &study, range.start, &stats)
            };
            (path, text)
        });
        histogram = Some((stats.iter().map(|s| s.max_ve_mm).collect::<Vec<_>>(), spec));
        if args.allocate {
            let target = Target {
                chosen: &chosen,
                samples,
                spec_mm: spec.unwrap_or(0.0),
                confidence,
            };
            let allocation =
                run_allocation(&engine, &study, &target, points_each).flag("--allocate")?;
            print_stopped(&file, &allocation);
            json["allocation"] =
                allocation_json(&file, &chosen, &target, &allocation, args.out.as_deref());
            if let Some(out) = &args.out {
                let text = allocated_text(
                    &file,
                    &chosen,
                    &target,
                    &allocation,
                    args.seed,
                    &loaded,
                    out,
                )?;
                write_file(out, |w| w.write_all(text.as_bytes())).flag("--out")?;
                outln!("  scaled tolerances written to {}", out.display());
            }
        }
        if let Some((path, text)) = per_sample {
            write_file(path, |out| out.write_all(text.as_bytes())).flag("--per-sample")?;
            errln!("per-sample: {}", path.display());
        }
    }
    if let Some(path) = &args.plot {
        budget_report::plot(&machine, &budget, histogram.as_ref(), path)?;
    }
    if let Some(path) = &args.json.json {
        let poses = grids.iter().map(|g| pose_of(&machine, &g.pose)).collect();
        Envelope::new("budget")
            .machine(&machine)
            .pose(serde_json::Value::Array(poses))
            .write(path, "--json", &json)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// What every shard of this run shares, for `merge-samples` to check.
fn study_key(
    machine: &Machine,
    study: &Study,
    args: &BudgetArgs,
    samples: usize,
    spec_mm: Option<f64>,
) -> StudyKey {
    let inputs = machine.inputs.record(machine);
    StudyKey {
        machine: machine.name.clone(),
        machine_sha256: Some(digest::of_machine(machine)),
        tolerances: study.tolerances.iter().map(tolerance_text).collect(),
        grid: args.grid.grid,
        poses: study
            .grids
            .iter()
            .map(|g| pose_name(&g.pose, machine))
            .collect(),
        approach: inputs.approach_text(),
        temperatures: inputs.temperatures_text(),
        seed: study.seed,
        samples,
        spec_mm,
        part: None,
        confidence: None,
    }
}

/// Which tolerances `--allocate-terms` names (all of them when it names none).
fn chosen_terms(tolerances: &[Tolerance], names: &[String]) -> Result<Vec<bool>, Failure> {
    if names.is_empty() {
        return Ok(vec![true; tolerances.len()]);
    }
    let mut chosen = vec![false; tolerances.len()];
    for name in names.iter().map(|n| n.trim()) {
        let hits: Vec<usize> = tolerances
            .iter()
            .enumerate()
            .filter(|(_, t)| {
                let key = t.perturbation.target.key();
                key == name || key.rsplit('.').next() == Some(name)
            })
            .map(|(n, _)| n)
            .collect();
        if hits.is_empty() {
            let keys: Vec<String> = tolerances
                .iter()
                .map(|t| t.perturbation.target.key())
                .collect();
            return Err(Failure::input(format!(
                "--allocate-terms: `{name}` is not a term of the tolerance file (its terms: {})",
                keys.join(", ")
            )));
        }
        if hits.iter().any(|&n| chosen[n]) {
            return Err(Failure::input(format!(
                "--allocate-terms: `{}` names a term already named",
                excerpt(name)
            )));
        }
        for n in hits {
            chosen[n] = true;
        }
    }
    Ok(chosen)
}

fn print_budget(machine: &Machine, args: &BudgetArgs, grids: &[Grid], budget: &Budget) {
    let [nx, ny, nz] = args.grid.grid;
    let over = match grids {
        [grid] if !machine.rotary_axes().is_empty() => {
            format!(" at {}", pose_name(&grid.pose, machine))
        }
        [_] => String::new(),
        _ => format!(" over {} poses", grids.len()),
    };
    outln!(
        "Error budget of {}: {} toleranced terms of {}, each alone at its limit on the ideal machine, grid {nx}x{ny}x{nz}{over}",
        machine.name,
        budget.rows.len(),
        args.tolerances.display()
    );
    outln!(
        "  {:<16} {:>22} {:>12} {:>12} {:>13} {:>16} {:>7}  worst at",
        "term",
        "limit",
        "max |VE| µm",
        "RMS |VE| µm",
        "max |OE| µrad",
        "largest axis µm",
        "share"
    );
    for row in &budget.rows {
        let (axis, largest) = row.stats.largest_axis();
        outln!(
            "  {:<16} {:>22} {:>12} {:>12} {:>13} {:>16} {:>7}  {}",
            row.tolerance.perturbation.target.key(),
            limit_text(&row.tolerance),
            numbers::error(row.stats.max_ve_mm),
            numbers::error(row.stats.rms_ve_mm()),
            numbers::angle(row.stats.max_oe_rad),
            format!("{} {}", ["X", "Y", "Z"][axis], numbers::error(largest)),
            numbers::percent(100.0 * row.share),
            position_words(machine, &row.worst_at)
        );
    }
    outln!(
        "  total (root sum of squares of max |VE|): {}",
        numbers::error_um(budget.total_rss_mm)
    );
}

/// `±h µm (U)` (uniform) or `2σ = v µrad (N)` (normal).
fn limit_text(tolerance: &Tolerance) -> String {
    let shown = |v: f64| {
        if tolerance.perturbation.target.is_angular() {
            numbers::angle_urad(v)
        } else {
            numbers::error_um(v)
        }
    };
    match tolerance.distribution {
        Distribution::Uniform { half_width } => format!("±{} (U)", shown(half_width)),
        Distribution::Normal { sigma } => format!("2σ = {} (N)", shown(2.0 * sigma)),
    }
}
