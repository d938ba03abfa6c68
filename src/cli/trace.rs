//! `volmap trace`: the real tool-tip deviation along an NC program, predicted before it cuts,
//! without rewriting it; with `--compensate`, also along the program compensation would write,
//! measured from the intended path, so a shop sees before and after.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use volmap::nc::{self, Options, TraceSample};
use volmap::plot::{self, Color, Marker, Series};

use super::args::{InputsArg, JsonArg, MachineArg};
use super::compensate::{corrupted_for_tests, option_failure, SetupArgs};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, check_plot_paths, write_plot};

#[derive(clap::Args)]
pub struct TraceArgs {
    #[command(flatten)]
    machine: MachineArg,
    /// The part program (ISO 6983 / Fanuc style).
    #[arg(long)]
    program: PathBuf,
    #[command(flatten)]
    setup: SetupArgs,
    /// Also trace the program as `volmap compensate` would write it (same chord tolerance and
    /// decimals), against the intended path.
    #[arg(long)]
    compensate: bool,
    /// With --compensate: largest distance of the real tool tip from the intended path, mm.
    #[arg(long, default_value_t = 0.001)]
    chord_tolerance: f64,
    /// With --compensate: decimals of the coordinates written (default 4 in mm, 5 in inch; at
    /// most 15).
    #[arg(long)]
    decimals: Option<usize>,
    /// Largest distance between samples along a move, mm (every move gets at least 4).
    #[arg(long, default_value_t = 0.5)]
    step: f64,
    /// Pass blocks volmap does not understand, as `compensate --pass-unknown` does: the moves
    /// that depend on what they may move are not traced, and are listed.
    #[arg(long)]
    pass_unknown: bool,
    /// The samples as CSV: program (as-programmed or compensated), line, motion (G code),
    /// distance_mm along the path, x_mm y_mm z_mm (program coordinates), deviation_mm.
    #[arg(long)]
    out: Option<PathBuf>,
    /// A plot of the deviation along the path (SVG or PNG by the extension).
    #[arg(long)]
    plot: Option<PathBuf>,
    #[command(flatten)]
    inputs: InputsArg,
    #[command(flatten)]
    json: JsonArg,
}

/// What a trace found, per program traced.
#[derive(serde::Serialize)]
struct Summary {
    program: &'static str,
    /// The moves the largest deviation covers: the feed moves (G1 G2 G3), as `compensate`
    /// reports its errors before and after (rapids apart: the control does not hold their path).
    covers: &'static str,
    /// The largest deviation along the feed moves and its line (1-based, of the input program;
    /// 0 where there is none).
    largest_mm: f64,
    largest_line: usize,
    /// The largest deviation along the rapids (G0).
    largest_rapid_mm: f64,
    /// The largest deviation of every block that moves: `[line, mm]`.
    per_block: Vec<(usize, f64)>,
}

/// A trace summed up as its samples arrive (nothing per sample is held but the plot's points,
/// where one is asked for).
struct Tally {
    program: &'static str,
    /// The largest feed deviation and its line (the last of equal ones).
    worst: Option<(f64, usize)>,
    largest_rapid_mm: f64,
    blocks: nc::PerBlock,
    /// Distance along the path (mm) and deviation (µm) of every sample, for the plot.
    plotted: Option<Vec<(f32, f32)>>,
}

impl Tally {
    fn new(program: &'static str, plotted: bool) -> Tally {
        Tally {
            program,
            worst: None,
            largest_rapid_mm: 0.0,
            blocks: nc::PerBlock::default(),
            plotted: plotted.then(Vec::new),
        }
    }

    fn add(&mut self, s: &TraceSample) {
        if s.motion == 0 {
            self.largest_rapid_mm = self.largest_rapid_mm.max(s.deviation_mm);
        } else if self.worst.is_none_or(|(mm, _)| s.deviation_mm >= mm) {
            self.worst = Some((s.deviation_mm, s.line));
        }
        self.blocks.add(s.line, s.deviation_mm);
        if let Some(points) = &mut self.plotted {
            points.push((s.distance_mm as f32, (s.deviation_mm * 1000.0) as f32));
        }
    }

    /// The summary, and the plot's points.
    fn summary(self) -> (Summary, Vec<(f32, f32)>) {
        let summary = Summary {
            program: self.program,
            covers: "feed moves (G1 G2 G3)",
            largest_mm: self.worst.map_or(0.0, |w| w.0),
            largest_line: self.worst.map_or(0, |w| w.1),
            largest_rapid_mm: self.largest_rapid_mm,
            per_block: self.blocks.by_line(),
        };
        (summary, self.plotted.unwrap_or_default())
    }
}

/// The most points a plotted series keeps: beyond it, each run of consecutive samples keeps its
/// lowest and highest point, so the drawn envelope is the samples' (a figure 900 points wide
/// shows no more).
const MAX_PLOTTED_POINTS: usize = 8192;

/// `points` thinned to at most [`MAX_PLOTTED_POINTS`], every run's extremes kept in order.
fn thinned(points: &[(f32, f32)]) -> (Vec<f64>, Vec<f64>) {
    let runs = MAX_PLOTTED_POINTS / 2;
    if points.len() <= MAX_PLOTTED_POINTS {
        return points.iter().map(|&(x, y)| (x as f64, y as f64)).unzip();
    }
    let mut kept = Vec::with_capacity(MAX_PLOTTED_POINTS);
    for run in points.chunks(points.len().div_ceil(runs)) {
        let low = run
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a run");
        let high = run
            .iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a run");
        let (first, second) = if low.0 <= high.0 {
            (low, high)
        } else {
            (high, low)
        };
        kept.push(*first);
        kept.push(*second);
    }
    kept.iter().map(|&(x, y)| (x as f64, y as f64)).unzip()
}

/// The CSV of `--out`, written as the samples arrive; the first write error is kept.
struct Rows {
    file: volmap::io::atomic::AtomicFile,
    error: Option<std::io::Error>,
}

impl Rows {
    fn add(&mut self, program: &str, s: &TraceSample) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = writeln!(
            self.file,
            "{program},{},G{},{:.6},{:.6},{:.6},{:.6},{:.9}",
            s.line,
            s.motion,
            s.distance_mm,
            s.program[0],
            s.program[1],
            s.program[2],
            s.deviation_mm
        ) {
            self.error = Some(e);
        }
    }
}

pub fn run(args: TraceArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[
        ("--out", args.out.as_deref()),
        ("--plot", args.plot.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    if let Some(path) = &args.plot {
        check_plot_paths(&[path], "--plot")?;
    }
    if args.step.is_nan() || args.step <= 0.0 {
        return Err(Failure::input(format!(
            "--step {}: it must be positive",
            args.step
        )));
    }
    let machine = args.machine.load()?;
    let inputs = args.inputs.on(&machine)?;
    // Only a report needs it: hashing the machine's files is work a plain run need not do.
    let envelope = args.json.json.is_some().then(|| {
        Envelope::new("trace")
            .machine(&machine)
            .at_inputs(&machine, &inputs)
    });
    let options = Options {
        chord_tolerance_mm: args.chord_tolerance,
        decimals: args.decimals,
        pass_unknown: args.pass_unknown,
        ..args.setup.options(&machine, inputs)?
    };
    if args.compensate {
        // What the compensation would write is checked before the program is traced.
        nc::check_written_options(&options).map_err(option_failure)?;
    }
    let program =
        volmap::io::read_bytes(&args.program, volmap::io::SourceKind::Program).flag("--program")?;
    let name = args.program.display().to_string();
    let mut rows = match &args.out {
        Some(path) => {
            let mut file = volmap::io::atomic::AtomicFile::create(path, 1 << 20).flag("--out")?;
            let header = writeln!(
                file,
                "program,line,motion,distance_mm,x_mm,y_mm,z_mm,deviation_mm"
            );
            let error = header.err();
            Some(Rows { file, error })
        }
        None => None,
    };
    let plotted = args.plot.is_some();
    let mut before = Tally::new("as-programmed", plotted);
    nc::trace_each(&machine, &program, &name, &options, args.step, |s| {
        before.add(&s);
        if let Some(rows) = &mut rows {
            rows.add("as-programmed", &s);
        }
    })
    .map_err(option_failure)?;
    let mut tallies = vec![before];
    if args.compensate {
        let mut compensated =
            nc::compensate(&machine, &program, &name, &options).map_err(option_failure)?;
        // What is traced is what `compensate` would keep: checked as it checks it (exit 1).
        compensated.text = corrupted_for_tests(compensated.text);
        let bounds = nc::CheckBounds::of(compensated.report.largest_correction_mm, &options);
        nc::check_written(
            &machine,
            &program,
            compensated.text.as_bytes(),
            &name,
            &options,
            bounds,
        )?;
        let mut after = Tally::new("compensated", plotted);
        nc::trace_compensated_each(
            &machine,
            (&program, &compensated),
            &name,
            &options,
            args.step,
            |s| {
                after.add(&s);
                if let Some(rows) = &mut rows {
                    rows.add("compensated", &s);
                }
            },
        )
        .map_err(option_failure)?;
        tallies.push(after);
    }
    if let Some(rows) = rows {
        match rows.error {
            Some(e) => return Err(Failure::from(rows.file.error(e)).context("--out")),
            None => rows.file.commit().flag("--out")?,
        }
    }
    let (summaries, plotted): (Vec<Summary>, Vec<Vec<(f32, f32)>>) =
        tallies.into_iter().map(Tally::summary).unzip();
    outln!("{name}: tool-tip deviation on {}", machine.name);
    for s in &summaries {
        outln!(
            "  {:<14} largest {} along the feed moves at line {}, {} along the rapids ({} blocks that move)",
            s.program,
            numbers::error_um(s.largest_mm),
            s.largest_line,
            numbers::error_um(s.largest_rapid_mm),
            s.per_block.len()
        );
    }
    let left = nc::moves_left_alone(&machine, &program, &name, &options).map_err(option_failure)?;
    if !left.is_empty() {
        let lines: Vec<String> = left.iter().map(|m| m.to_string()).collect();
        outln!(
            "  not traced     {} moves, lines {}: they depend on what a block volmap does not follow may have moved",
            lines.len(),
            lines.join(", ")
        );
    }
    outln!("  the blocks with the largest deviation (line: µm):");
    let mut worst = summaries[0].per_block.clone();
    worst.sort_by(|a, b| b.1.total_cmp(&a.1));
    for (line, mm) in worst.iter().take(10) {
        let after = summaries
            .get(1)
            .and_then(|s| s.per_block.iter().find(|b| b.0 == *line))
            .map_or(String::new(), |b| {
                format!(", {} compensated", numbers::error(b.1))
            });
        outln!("    {line:>6}: {}{after}", numbers::error(*mm));
    }
    if let Some(path) = &args.plot {
        let colours = [Color::RED, Color::BLUE];
        let series: Vec<Series> = summaries
            .iter()
            .zip(&plotted)
            .zip(colours)
            .map(|((summary, points), color)| {
                let (x, y) = thinned(points);
                Series {
                    name: summary.program.replace('-', " "),
                    x,
                    y,
                    color,
                    dashed: false,
                    marker: Marker::None,
                    band: None,
                }
            })
            .collect();
        let title = format!("Tool-tip deviation along {name} on {}", machine.name);
        let drawing = plot::line_chart(
            &title,
            "distance along the path (mm)",
            "deviation (µm)",
            &series,
        )?;
        write_plot(&drawing, path, "--plot")?;
    }
    if let (Some(path), Some(envelope)) = (&args.json.json, &envelope) {
        envelope.write(path, "--json", &summaries)?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thinned_series_keeps_every_runs_extremes_in_order() {
        // A ramp with one spike up and one down: both survive thinning, the x stay in order.
        let mut points: Vec<(f32, f32)> = (0..100_000).map(|k| (k as f32, 1.0)).collect();
        points[31_337].1 = 50.0;
        points[77_001].1 = -3.0;
        let (x, y) = thinned(&points);
        assert_eq!(x.len(), y.len());
        assert!(x.len() <= MAX_PLOTTED_POINTS && x.len() > MAX_PLOTTED_POINTS / 2);
        assert!(x.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(y.iter().copied().fold(f64::MIN, f64::max), 50.0);
        assert_eq!(y.iter().copied().fold(f64::MAX, f64::min), -3.0);
        assert_eq!(x[y.iter().position(|&v| v == 50.0).unwrap()], 31_337.0);
        // Few points pass as they are.
        let few = &points[..100];
        assert_eq!(thinned(few).0.len(), 100);
    }
}
