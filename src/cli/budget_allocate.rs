//! `volmap budget --allocate`: the allocation's run and report, and the scaled tolerance file it
//! writes: the widths of the chosen terms times the factor, each stopped at the widest the
//! tolerance file's reader accepts, and the text read back with that reader before it is kept.

use std::path::Path;

use serde_json::{json, Value};
use volmap::design::allocate::{allocate, Allocation, Target};
use volmap::design::monte_carlo::Study;
use volmap::io::tolerance_file::{most_width, ToleranceFile};
use volmap::limits::number_words;
use volmap::model::Machine;

use super::budget_report;
use super::estimate::Estimate;
use super::failure::Failure;
use super::numbers;
use super::output::progress;

pub fn run_allocation(
    engine: &volmap::engine::Engine,
    study: &Study,
    target: &Target,
    points_each: f64,
) -> Result<Allocation, Failure> {
    outln!(
        "Allocation: the largest common factor on {} of the {} tolerances for which {} of {} machines hold max |VE| ≤ {}",
        target.chosen.iter().filter(|&&c| c).count(),
        target.chosen.len(),
        numbers::percent(100.0 * target.confidence),
        target.samples,
        budget_report::spec_words(target.spec_mm)
    );
    let bar = progress(Some(target.samples as u64), "allocating", "machines");
    let estimate = Estimate::new(
        target.samples,
        points_each,
        format!(
            "each of the allocation's runs (12 to 30) of {} machines",
            target.samples
        ),
    );
    let result = allocate(
        engine,
        study,
        target,
        |factor, fraction| {
            bar.suspend(|| {
                outln!(
                    "  factor {:<12} {:>6} within the specification",
                    numbers::quantity(factor),
                    numbers::percent(100.0 * fraction)
                )
            });
            bar.set_position(0);
        },
        |n| {
            estimate.progress(n, |line| bar.suspend(|| errln!("{line}")));
            bar.set_position(n as u64)
        },
    );
    bar.finish_and_clear();
    let allocation = result?;
    let w = allocation.within.fraction;
    outln!(
        "  largest factor {}: {} of the machines within (95% CI {} to {}), {} Monte Carlo runs on the same draws",
        numbers::quantity(allocation.factor),
        numbers::percent(100.0 * w.fraction),
        numbers::percent(100.0 * w.ci95[0]),
        numbers::percent(100.0 * w.ci95[1]),
        allocation.tried.len()
    );
    Ok(allocation)
}

pub fn allocation_json(
    file: &ToleranceFile,
    chosen: &[bool],
    target: &Target,
    allocation: &Allocation,
    out: Option<&Path>,
) -> Value {
    let terms = allocation_json_terms(file, chosen);
    let key = |t: usize| file.tolerances[t].perturbation.target.key();
    json!({
        "factor": allocation.factor,
        "terms": terms,
        "widths": file.tolerances.iter().zip(&allocation.scale).enumerate()
            .filter(|(t, _)| chosen[*t])
            .map(|(t, (tolerance, k))| json!({"term": key(t), "width": tolerance.distribution.scaled(*k).width().min(most_width(tolerance.perturbation.target).0)}))
            .collect::<Vec<_>>(),
        "stopped_at_limit": allocation.stopped.iter().map(|&t| key(t)).collect::<Vec<_>>(),
        "stopped_at_angle_limit": allocation.at_angle_limit,
        "spec_mm": target.spec_mm,
        "confidence": target.confidence,
        "fraction": allocation.within.fraction.fraction,
        "ci95": allocation.within.fraction.ci95,
        "tried": allocation.tried.iter().map(|(f, p)| json!({"factor": f, "fraction": p})).collect::<Vec<_>>(),
        "out": out.map(|p| p.display().to_string()),
    })
}

/// Says which chosen terms stopped at the widest the tolerance file may give, and whether the
/// factor stopped at the kernels' limit on angles, rather than where the fraction falls.
pub fn print_stopped(file: &ToleranceFile, allocation: &Allocation) {
    if !allocation.stopped.is_empty() {
        let terms: Vec<String> = allocation
            .stopped
            .iter()
            .map(|&t| {
                let tolerance = &file.tolerances[t];
                let (most, unit) = most_width(tolerance.perturbation.target);
                format!(
                    "{} ({} {unit})",
                    tolerance.perturbation.target.key(),
                    number_words(most)
                )
            })
            .collect();
        outln!(
            "  stopped at the widest a tolerance file may give (wider is no machine tool's error): {}",
            terms.join(", ")
        );
    }
    if allocation.at_angle_limit {
        outln!(
            "  stopped where the machines drawn could reach {} rad of angular errors over the grid, the most volmap evaluates on every device",
            volmap::gpu::MAX_ERROR_ANGLE_RAD
        );
    }
}

/// The scaled tolerance file, read back with the tolerance file's reader (for `machine`): an
/// allocation never writes a file volmap refuses.
pub fn allocated_text(
    file: &ToleranceFile,
    chosen: &[bool],
    target: &Target,
    allocation: &Allocation,
    seed: u64,
    machine: &Machine,
    out: &Path,
) -> Result<String, Failure> {
    let stopped = if allocation.stopped.is_empty() {
        String::new()
    } else {
        format!(
            " ({} stopped at the widest a tolerance file may give)",
            allocation
                .stopped
                .iter()
                .map(|&t| file.tolerances[t].perturbation.target.key())
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let text = format!(
        "# Scaled by `volmap budget --allocate`: the widths of {} times {:.6}{stopped}, for which {:.2}% of {} machines of {} hold max |VE| <= {} mm (seed {seed}).\n{}",
        allocation_json_terms(file, chosen).join(", "),
        allocation.factor,
        100.0 * allocation.within.fraction.fraction,
        target.samples,
        machine.name,
        number_words(target.spec_mm),
        file.scaled_text(|t| chosen[t].then_some(allocation.scale[t]))
    );
    ToleranceFile::parse(&text, out, machine).map_err(|e| {
        Failure::work(anyhow::anyhow!(
            "the allocated tolerances do not read back as a tolerance file ({e}); nothing written"
        ))
    })?;
    Ok(text)
}

/// The keys of the tolerances an allocation scales.
fn allocation_json_terms(file: &ToleranceFile, chosen: &[bool]) -> Vec<String> {
    file.tolerances
        .iter()
        .zip(chosen)
        .filter(|(_, &c)| c)
        .map(|(t, _)| t.perturbation.target.key())
        .collect()
}
