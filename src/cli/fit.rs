//! `volmap fit`: location and spindle errors, and their thermal coefficients, estimated from
//! standard-test measurements by least squares.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::calibrate::{self, fit, identifiability};

use super::args::{JsonArg, MachineArg, ReachArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_machine_text, copy_tables, out_folder, write_file, written_by};

const UM_PER_MM: f64 = 1000.0;

#[derive(clap::Args)]
pub struct FitArgs {
    #[command(flatten)]
    machine: MachineArg,
    /// The measurements file (TOML): `estimate = [...]` and the tests with their CSV files (and
    /// the temperatures each was measured at).
    #[arg(long)]
    measurements: PathBuf,
    /// Write the machine file with the estimates in, each with its standard uncertainty `u`, and
    /// their covariances in `[covariance]`.
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: FitArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[
        ("--out", args.out.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    let machine = args.machine.load()?;
    let file = fit::FitFile::read_reaching(&args.measurements, args.machine.reach.reach())
        .map_err(|e| {
            let outside = e.is_outside_folder();
            ReachArg::hint(Failure::from(e).context("--measurements"), outside)
        })?;
    let report = fit::fit(&machine, &file)?;
    outln!(
        "least-squares fit of {} unknown(s) to {} measured points ({} degrees of freedom)",
        report.estimates.len(),
        report.points,
        report.degrees_of_freedom
    );
    let width = report
        .estimates
        .iter()
        .map(|e| e.name.chars().count())
        .max()
        .unwrap_or(6)
        .max(6);
    outln!(
        "  {:<width$} {:>14} {:>14} {:>14}  unit",
        "error",
        "as given",
        "estimate",
        "uncertainty"
    );
    for e in &report.estimates {
        let (shown, unit) = shown_in(&e.unit);
        outln!(
            "  {:<width$} {:>14} {:>14} {:>14}  {unit}",
            e.name,
            shown(e.initial),
            shown(e.value),
            shown(e.uncertainty),
        );
    }
    print_identifiability(&report, width);
    outln!(
        "  RMS residual: {} with the machine as given, {} with the estimates",
        numbers::error_um(report.rms_before_mm),
        numbers::error_um(report.rms_after_mm)
    );
    outln!("  (uncertainty: one standard uncertainty, from the residuals)");
    if let Some(path) = &args.out {
        let text = fit::fitted_machine_toml(&machine, &report)?;
        let names: Vec<&str> = report.estimates.iter().map(|e| e.name.as_str()).collect();
        let text = calibrate::with_header(
            &text,
            &[
                written_by(),
                format!(
                    "The machine `{}` with {} fitted to the tests of {} ({} points, RMS residual {:.3} µm).",
                    machine.name,
                    names.join(", "),
                    args.measurements.display(),
                    report.points,
                    report.rms_after_mm * UM_PER_MM
                ),
                "Each estimate written with its standard uncertainty u, to a thousandth of it; their covariances in [covariance].".to_string(),
            ],
        );
        let folder = out_folder(path);
        let rebased = calibrate::rebase_tables(&text, &machine, path)?;
        copy_tables(&folder, &rebased.copies, "--out")?;
        let text = rebased.text;
        check_machine_text(&text, path, &folder)?;
        write_file(path, |out| out.write_all(text.as_bytes())).flag("--out")?;
        outln!("  machine with the estimates: {}", path.display());
    }
    if let Some(path) = &args.json.json {
        Envelope::new("fit")
            .machine(&machine)
            .write(path, "--json", &report)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// What the tests can see of each estimate: figures of the model and the tests' positions, not of
/// the measured values.
fn print_identifiability(report: &fit::FitReport, width: usize) {
    let figures = &report.identifiability;
    outln!(
        "  what the tests see (from the model and the tests' positions, not the measured values):"
    );
    outln!(
        "  {:<width$} {:>20} {:>12} {:>10}",
        "error",
        "sensitivity",
        "independence",
        "valuation"
    );
    for (c, e) in report.estimates.iter().enumerate() {
        let weak = if figures.valuation[c] < identifiability::VALUATION_WEAK {
            "  weak: the tests barely resolve it"
        } else {
            ""
        };
        outln!(
            "  {:<width$} {:>20} {:>12} {:>10}{weak}",
            e.name,
            sensitivity(figures.sensitivity[c], &e.unit),
            numbers::quantity(figures.independence[c]),
            numbers::quantity(figures.valuation[c]),
        );
    }
    outln!(
        "  condition number {} (of the readings' Jacobian, columns scaled to unit norm)",
        numbers::quantity(figures.condition_number)
    );
    if report.estimates.len() > 1 {
        outln!("  correlations of the estimates:");
        for (a, row) in figures.correlation.iter().enumerate() {
            let cells: Vec<String> = row
                .iter()
                .map(|r| format!("{:>9}", numbers::quantity(*r)))
                .collect();
            outln!("  {:<width$} {}", report.estimates[a].name, cells.join(" "));
        }
    }
    outln!(
        "  (sensitivity: RMS change of the readings per unit of the error; independence: the part of it no other estimate imitates, 0 to 1; valuation: 1 µm of a length or 10 µrad of an angle, per K for a coefficient, in standard uncertainties were the instruments to scatter 1 µm; below {} the tests barely resolve it)",
        identifiability::VALUATION_WEAK
    );
}

/// How an estimate in `unit` (the machine file's: mm, rad, mm/K, rad/K) is printed, and the unit
/// printed: lengths in µm and angles in µrad as every error, their coefficients per K in the same.
fn shown_in(unit: &str) -> (fn(f64) -> String, &str) {
    match unit {
        "mm" => (numbers::error, "µm"),
        "rad" => (numbers::angle, "µrad"),
        "mm/K" => (|v| numbers::quantity(v * 1e3), "µm/K"),
        "rad/K" => (|v| numbers::quantity(v * 1e6), "µrad/K"),
        _ => (numbers::quantity, unit),
    }
}

/// The RMS change of the readings (mm) per unit of an error (its machine-file unit).
fn sensitivity(value: f64, unit: &str) -> String {
    if unit.contains('/') {
        format!("{} mm/({unit})", numbers::quantity(value))
    } else {
        format!("{} mm/{unit}", numbers::quantity(value))
    }
}
