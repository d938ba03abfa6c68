//! `volmap trace`: the real tool-tip deviation along an NC program, predicted before it cuts,
//! without rewriting it; with `--compensate`, also along the program compensation would write,
//! measured from the intended path, so a shop sees before and after.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::nc::{self, Options, TraceSample};
use volmap::plot::{self, Color, Marker, Series};

use super::args::{InputsArg, JsonArg, MachineArg};
use super::compensate::{corrupted_for_tests, option_failure, SetupArgs};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, check_plot_paths, write_file, write_plot};

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

fn summary(program: &'static str, samples: &[TraceSample]) -> Summary {
    let worst = samples
        .iter()
        .filter(|s| s.motion != 0)
        .max_by(|a, b| a.deviation_mm.total_cmp(&b.deviation_mm));
    Summary {
        program,
        covers: "feed moves (G1 G2 G3)",
        largest_mm: worst.map_or(0.0, |s| s.deviation_mm),
        largest_line: worst.map_or(0, |s| s.line),
        largest_rapid_mm: samples
            .iter()
            .filter(|s| s.motion == 0)
            .map(|s| s.deviation_mm)
            .fold(0.0, f64::max),
        per_block: nc::per_block(samples),
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
    let mut traces = vec![(
        "as-programmed",
        nc::trace_path(&machine, &program, &name, &options, args.step).map_err(option_failure)?,
    )];
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
        let after = nc::trace_compensated(
            &machine,
            (&program, &compensated),
            &name,
            &options,
            args.step,
        )
        .map_err(option_failure)?;
        traces.push(("compensated", after));
    }
    let summaries: Vec<Summary> = traces.iter().map(|(p, s)| summary(p, s)).collect();
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
    if let Some(path) = &args.out {
        write_file(path, |out| {
            writeln!(
                out,
                "program,line,motion,distance_mm,x_mm,y_mm,z_mm,deviation_mm"
            )?;
            for (program, samples) in &traces {
                for s in samples {
                    writeln!(
                        out,
                        "{program},{},G{},{:.6},{:.6},{:.6},{:.6},{:.9}",
                        s.line,
                        s.motion,
                        s.distance_mm,
                        s.program[0],
                        s.program[1],
                        s.program[2],
                        s.deviation_mm
                    )?;
                }
            }
            Ok(())
        })
        .flag("--out")?;
    }
    if let Some(path) = &args.plot {
        let colours = [Color::RED, Color::BLUE];
        let series: Vec<Series> = traces
            .iter()
            .zip(colours)
            .map(|((program, samples), color)| Series {
                name: program.replace('-', " "),
                x: samples.iter().map(|s| s.distance_mm).collect(),
                y: samples.iter().map(|s| s.deviation_mm * 1000.0).collect(),
                color,
                dashed: false,
                marker: Marker::None,
                band: None,
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
