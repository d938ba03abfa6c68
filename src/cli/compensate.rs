//! `volmap compensate`: an NC program rewritten so the real tool tip lands on the programmed one.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use volmap::io::embedded;
use volmap::nc::{self, Options, ToolLengths};

use super::super::{bad_input, write_atomically, Failure};

#[derive(clap::Args)]
pub struct CompensateArgs {
    /// The machine (embedded name or file).
    #[arg(long, default_value = embedded::DEFAULT_MACHINE)]
    machine: String,
    /// The part program (ISO 6983 / Fanuc style).
    #[arg(long)]
    program: PathBuf,
    /// The compensated program to write (never the input).
    #[arg(long)]
    out: PathBuf,
    /// A work offset in machine coordinates, `G54=X,Y,Z` mm (optionally `,A,B,C` degrees);
    /// repeat per offset. G54 is zero unless given.
    #[arg(long = "work-offset")]
    work_offsets: Vec<String>,
    /// Work offsets from a TOML file: `G54 = [X, Y, Z]` (mm) per offset.
    #[arg(long)]
    work_offset_file: Option<PathBuf>,
    /// Tool length in mm along the spindle axis: one for every tool (`120`) or per tool
    /// (`T1=80,T2=120`); without it the machine file's tool offset stands.
    #[arg(long, default_value = "")]
    tool_length: String,
    /// Largest distance of the real tool tip from the intended path, mm.
    #[arg(long, default_value_t = 0.001)]
    chord_tolerance: f64,
    /// Decimals of the coordinates written (default 4 in mm, 5 in inch).
    #[arg(long)]
    decimals: Option<usize>,
    /// Pass blocks volmap does not understand through unchanged instead of stopping.
    #[arg(long)]
    pass_unknown: bool,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run_compensate(args: CompensateArgs) -> Result<ExitCode, Failure> {
    let machine = embedded::load(&args.machine).map_err(bad_input)?;
    let same_file = std::fs::canonicalize(&args.out)
        .ok()
        .zip(std::fs::canonicalize(&args.program).ok())
        .is_some_and(|(a, b)| a == b);
    if same_file {
        return Err(bad_input(anyhow::anyhow!(
            "--out {} is the input program: volmap never writes over it",
            args.out.display()
        )));
    }
    let mut options = Options {
        tool_lengths: ToolLengths::parse(&args.tool_length).map_err(bad_input)?,
        chord_tolerance_mm: args.chord_tolerance,
        decimals: args.decimals,
        pass_unknown: args.pass_unknown,
        ..Options::default()
    };
    if let Some(path) = &args.work_offset_file {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading {}", path.display()))
            .map_err(bad_input)?;
        let table: std::collections::BTreeMap<String, Vec<f64>> = toml::from_str(&text)
            .map_err(|e| bad_input(anyhow::anyhow!("{}: {e}", path.display())))?;
        for (key, values) in table {
            let text = format!(
                "{key}={}",
                values
                    .iter()
                    .map(f64::to_string)
                    .collect::<Vec<_>>()
                    .join(",")
            );
            let (n, offset) = nc::parse_work_offset(&text)
                .map_err(|e| bad_input(anyhow::anyhow!("{}: {e}", path.display())))?;
            options.work_offsets.insert(n, offset);
        }
    }
    for text in &args.work_offsets {
        let (n, offset) = nc::parse_work_offset(text).map_err(bad_input)?;
        options.work_offsets.insert(n, offset);
    }
    let program = std::fs::read(&args.program)
        .with_context(|| format!("reading {}", args.program.display()))
        .map_err(bad_input)?;
    let bar =
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr());
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} compensating [{bar:40}] {percent:>3}% {human_pos}/{human_len} lines, {eta} left",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let compensated = nc::compensate_with_progress(
        &machine,
        &program,
        &args.program.display().to_string(),
        &options,
        |done, lines| {
            bar.set_length(lines as u64);
            bar.set_position(done as u64);
        },
    );
    bar.finish_and_clear();
    let compensated = compensated.map_err(bad_input)?;
    let (text, report) = (compensated.text, compensated.report);
    write_atomically(&args.out, |out| out.write_all(text.as_bytes()))?;
    println!("{}: compensated for {}", args.out.display(), machine.name);
    println!("  points compensated          {}", report.points);
    println!(
        "  largest correction          {:.4} mm",
        report.largest_correction_mm
    );
    println!("  blocks changed              {}", report.blocks_changed);
    println!("  blocks added                {}", report.blocks_added);
    println!(
        "  largest tool-tip error along the feed moves: {:.4} mm before, {:.4} mm after (chord tolerance {} mm)",
        report.largest_error_before_mm, report.largest_error_after_mm, options.chord_tolerance_mm
    );
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report).context("encoding the report")?;
        write_atomically(path, |out| writeln!(out, "{text}"))?;
    }
    Ok(ExitCode::SUCCESS)
}
