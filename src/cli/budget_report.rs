//! What `volmap budget` puts out besides the budget's table: the Monte Carlo table, the JSON of
//! the budget and of Monte Carlo, one CSV row per sampled machine, and the plot.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{json, Map, Value};
use volmap::design::budget::{worst_at, Budget};
use volmap::design::monte_carlo::{MonteCarlo, Study};
use volmap::design::summary::Summary;
use volmap::model::statistics::FieldStats;
use volmap::model::{AxisLetter, Command, Machine};
use volmap::plot::{bar_chart, histogram, stacked, Bar};

use super::failure::Failure;
use super::numbers;
use super::output::write_plot;

/// The machine's axes in the order X Y Z A B C with their positions in `command`.
pub fn axis_positions(machine: &Machine, command: &Command) -> Vec<(AxisLetter, f64)> {
    AxisLetter::ALL
        .iter()
        .filter(|&&l| machine.axis(l).is_some())
        .map(|&l| (l, command[l.index()]))
        .collect()
}

/// The machine's axes with their positions in `command`, as a summary prints them
/// (`X=565.217 Y=0.000 Z=-120.500 B=30.000`: mm, and degrees for a rotary axis).
pub fn position_words(machine: &Machine, command: &Command) -> String {
    axis_positions(machine, command)
        .iter()
        .map(|(l, v)| {
            if l.is_linear() {
                format!("{l}={}", numbers::length(*v))
            } else {
                format!("{l}={}", numbers::rotary(*v))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn position_json(machine: &Machine, command: &Command) -> Value {
    let mut map = Map::new();
    for (letter, value) in axis_positions(machine, command) {
        map.insert(letter.to_string(), json!(value));
    }
    Value::Object(map)
}

pub fn budget_json(machine: &Machine, budget: &Budget) -> Value {
    budget
        .rows
        .iter()
        .map(|row| {
            json!({
                "term": row.tolerance.perturbation.target.key(),
                "distribution": row.tolerance.distribution.name(),
                "shape": row.tolerance.perturbation.shape.name(),
                "limit": row.limit,
                "max_ve_mm": row.stats.max_ve_mm,
                "rms_ve_mm": row.stats.rms_ve_mm(),
                "max_oe_rad": row.stats.max_oe_rad,
                "max_ve_axis_mm": row.stats.max_axis_mm,
                "share": row.share,
                "worst_at": position_json(machine, &row.worst_at),
            })
        })
        .collect()
}

/// The statistics over the samples, one row per statistic of a machine's field.
fn statistics(mc: &MonteCarlo) -> [(&'static str, &'static str, Summary); 6] {
    [
        ("max_ve_mm", "max |VE| µm", mc.max_ve_mm),
        ("rms_ve_mm", "RMS |VE| µm", mc.rms_ve_mm),
        ("max_oe_rad", "max |OE| µrad", mc.max_oe_rad),
        ("max_ve_x_mm", "max |VE·x| µm", mc.max_ve_axis_mm[0]),
        ("max_ve_y_mm", "max |VE·y| µm", mc.max_ve_axis_mm[1]),
        ("max_ve_z_mm", "max |VE·z| µm", mc.max_ve_axis_mm[2]),
    ]
}

/// Prints the Monte Carlo statistics; `inputs` are the evaluation inputs of the machine the
/// samples are drawn around, in words.
pub fn print_monte_carlo(mc: &MonteCarlo, engine: String, inputs: &str) {
    outln!(
        "Monte Carlo: {} machines built to the tolerances around the machine at {inputs} (seed {}), each field's statistics on the {engine}",
        mc.samples, mc.seed
    );
    outln!(
        "  {:<16} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "statistic",
        "mean",
        "std",
        "P5",
        "P50",
        "P95",
        "P99"
    );
    for (_, label, s) in statistics(mc) {
        let cell = |v: f64| {
            if label.ends_with("µrad") {
                format!("{:>12}", numbers::angle(v))
            } else {
                format!("{:>12}", numbers::error(v))
            }
        };
        outln!(
            "  {label:<16} {} {} {} {} {} {}",
            cell(s.mean),
            cell(s.std),
            cell(s.p5),
            cell(s.p50),
            cell(s.p95),
            cell(s.p99)
        );
    }
    if let Some(w) = &mc.within_spec {
        outln!(
            "  within {}: {} of the machines (95% CI {} to {})",
            spec_words(w.spec_mm),
            numbers::percent(100.0 * w.fraction.fraction),
            numbers::percent(100.0 * w.fraction.ci95[0]),
            numbers::percent(100.0 * w.fraction.ci95[1])
        );
    }
}

/// A specification as a summary prints it: in µm where that is short (`140.000 µm`), else in
/// mm in scientific notation (`1e308 mm`, not 309 digits).
pub fn spec_words(spec_mm: f64) -> String {
    if spec_mm.abs() < 1e6 {
        numbers::error_um(spec_mm)
    } else {
        format!("{} mm", volmap::limits::number_words(spec_mm))
    }
}

pub fn monte_carlo_json(mc: &MonteCarlo) -> Value {
    let mut out = json!({ "samples": mc.samples, "seed": mc.seed });
    for (key, _, s) in statistics(mc) {
        out[key] = json!(s);
    }
    if let Some(w) = &mc.within_spec {
        out["within_spec"] = json!({
            "spec_mm": w.spec_mm,
            "fraction": w.fraction.fraction,
            "ci95": w.fraction.ci95,
        });
    }
    out
}

/// One row per sampled machine: its statistics, the commanded position of its largest |VE|,
/// and its amplitude of every tolerance (mm or rad).
pub fn per_sample_csv(
    machine: &Machine,
    study: &Study,
    first: usize,
    stats: &[FieldStats],
) -> String {
    let axes = axis_positions(machine, &[0.0; 6]);
    let mut text =
        String::from("sample,max_ve_mm,rms_ve_mm,max_oe_rad,max_ve_x_mm,max_ve_y_mm,max_ve_z_mm");
    for (letter, _) in &axes {
        let _ = write!(text, ",worst_{letter}");
    }
    for t in study.tolerances {
        let _ = write!(text, ",{}", t.perturbation.target.key());
    }
    text.push('\n');
    let ones = vec![1.0; study.tolerances.len()];
    for (first, chunk) in (first..).step_by(4096).zip(stats.chunks(4096)) {
        let amplitudes = study.amplitudes(first, chunk.len(), &ones);
        for (b, (s, row)) in chunk.iter().zip(&amplitudes).enumerate() {
            let _ = write!(
                text,
                "{},{},{},{},{},{},{}",
                first + b,
                s.max_ve_mm,
                s.rms_ve_mm(),
                s.max_oe_rad,
                s.max_axis_mm[0],
                s.max_axis_mm[1],
                s.max_axis_mm[2]
            );
            for (_, v) in axis_positions(machine, &worst_at(s, study.grids)) {
                let _ = write!(text, ",{v}");
            }
            for a in row {
                let _ = write!(text, ",{a}");
            }
            text.push('\n');
        }
    }
    text
}

/// The budget as a bar chart, above the histogram of max |VE| over the samples where there are
/// samples.
pub fn plot(
    machine: &Machine,
    budget: &Budget,
    samples: Option<&(Vec<f64>, Option<f64>)>,
    path: &Path,
) -> Result<(), Failure> {
    let bars: Vec<Bar> = budget
        .rows
        .iter()
        .map(|row| Bar {
            label: row.tolerance.perturbation.target.key(),
            value: row.stats.max_ve_mm * 1000.0,
            note: format!(
                "{:.2} µm, {:.1}%",
                row.stats.max_ve_mm * 1000.0,
                100.0 * row.share
            ),
        })
        .collect();
    let total = budget.total_rss_mm * 1000.0;
    let mut drawings = vec![bar_chart(
        &format!(
            "Error budget of {}: max |VE| of each term alone at its limit",
            machine.name
        ),
        "max |VE|, µm (a term's share is its square's part of the sum of squares)",
        &bars,
        Some((total, &format!("RSS {total:.2} µm"))),
    )?];
    if let Some((values, spec)) = samples {
        let microns: Vec<f64> = values.iter().map(|v| v * 1000.0).collect();
        let marker = spec
            .filter(|s| (s * 1000.0).is_finite())
            .map(|s| (s * 1000.0, format!("spec {}", spec_words(s))));
        drawings.push(histogram(
            &format!(
                "max |VE| of {} machines built to the tolerances",
                values.len()
            ),
            "max |VE| over the grid, µm",
            &microns,
            30,
            marker.as_ref().map(|(v, l)| (*v, l.as_str())),
        )?);
    }
    write_plot(&stacked(drawings), path, "--plot")
}
