//! `volmap compensate`: an NC program rewritten so the real tool tip lands on the programmed one.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::nc::{self, NcError, NcOption, Options, ToolLengths};

use super::args::{InputsArg, JsonArg, MachineArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, progress, write_file};

#[derive(clap::Args)]
pub struct CompensateArgs {
    #[command(flatten)]
    machine: MachineArg,
    /// The part program (ISO 6983 / Fanuc style).
    #[arg(long)]
    program: PathBuf,
    /// The compensated program to write (never the input).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    setup: SetupArgs,
    /// Largest distance of the real tool tip from the intended path, mm.
    #[arg(long, default_value_t = 0.001)]
    chord_tolerance: f64,
    /// Decimals of the coordinates written (default 4 in mm, 5 in inch; at most 15).
    #[arg(long)]
    decimals: Option<usize>,
    /// Pass blocks volmap does not understand through unchanged instead of stopping.
    #[arg(long)]
    pass_unknown: bool,
    /// Write the program (exit 0, the lines named in a warning) even where the model, run along
    /// it as written, puts the tool tip beyond the chord tolerance of the intended path.
    #[arg(long)]
    allow_residual: bool,
    /// Compensate the tool orientation too (five-axis machines): X, Y, Z and both rotary axes
    /// are solved so the real tool tip and tool axis are the intended ones; rotary words are
    /// rewritten.
    #[arg(long)]
    orientation: bool,
    /// With --orientation: largest angle between the real and the intended tool axis along the
    /// path, rad.
    #[arg(long, default_value_t = nc::DEFAULT_ANGULAR_TOLERANCE_RAD, requires = "orientation")]
    angular_tolerance: f64,
    /// With --orientation: largest turn of the rotary axes from their programmed positions, the
    /// two as a vector, degrees. Near a singular pose (the tool along a rotary axis, e.g. B0 on a
    /// C table) the full correction would turn them further; the part of the tool axis's error
    /// the bound leaves is reported per line.
    #[arg(long, default_value_t = nc::DEFAULT_MAX_ROTARY_CORRECTION_DEG, requires = "orientation")]
    max_rotary_correction: f64,
    // `--temperatures` hold for the whole program; `--approach` gives the directions of the
    // axes at its start (each axis then approaches in the direction of its programmed motion).
    #[command(flatten)]
    inputs: InputsArg,
    #[command(flatten)]
    json: JsonArg,
}

/// Where the program runs on the machine: its work offsets and tool lengths.
#[derive(clap::Args)]
pub struct SetupArgs {
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
}

impl SetupArgs {
    /// The options of a compensation with these work offsets and tool lengths at `inputs`.
    pub fn options(
        &self,
        machine: &volmap::model::Machine,
        inputs: volmap::model::inputs::Inputs,
    ) -> Result<Options, Failure> {
        let mut options = Options {
            tool_lengths: ToolLengths::parse(&self.tool_length).map_err(option_failure)?,
            inputs,
            ..Options::default()
        };
        if let Some(path) = &self.work_offset_file {
            for (n, offset) in nc::read_work_offsets(path).flag("--work-offset-file")? {
                options.work_offsets.insert(n, offset);
            }
        }
        let in_file: Vec<u32> = options.work_offsets.keys().copied().collect();
        for text in &self.work_offsets {
            let (n, offset) = nc::parse_work_offset(text).map_err(option_failure)?;
            if options.work_offsets.insert(n, offset).is_some() {
                // Which one the user meant is not for volmap to guess.
                return Err(Failure::input(format!(
                    "--work-offset: G{n} is given twice{}",
                    if !in_file.is_empty() {
                        " (here or in --work-offset-file)"
                    } else {
                        ""
                    }
                )));
            }
        }
        // The library refuses it too; here the message names the flag that gave the offset.
        nc::check_work_offsets(machine, &options.work_offsets).map_err(|e| {
            let flag = match e {
                NcError::WorkOffsetAxis { number, .. } if in_file.contains(&number) => {
                    "--work-offset-file"
                }
                _ => "--work-offset",
            };
            Failure::from(e).context(flag)
        })?;
        Ok(options)
    }
}

pub fn run(args: CompensateArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[
        ("--out", Some(&args.out)),
        ("--json", args.json.json.as_deref()),
    ])?;
    let machine = args.machine.load()?;
    let inputs = args.inputs.on(&machine)?;
    // Only a report needs it: hashing the machine's files is work a plain run need not do.
    let envelope = args.json.json.is_some().then(|| {
        Envelope::new("compensate")
            .machine(&machine)
            .at_inputs(&machine, &inputs)
    });
    let options = Options {
        chord_tolerance_mm: args.chord_tolerance,
        decimals: args.decimals,
        pass_unknown: args.pass_unknown,
        orientation_tolerance_rad: args.orientation.then_some(args.angular_tolerance),
        max_rotary_correction_deg: args.max_rotary_correction,
        ..args.setup.options(&machine, inputs)?
    };
    let program =
        volmap::io::read_bytes(&args.program, volmap::io::SourceKind::Program).flag("--program")?;
    // Refused before the work, as every writer would refuse it after.
    volmap::io::source::check_not_source(&args.out).flag("--out")?;
    let bar = progress(None, "compensating", "lines");
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
    let compensated = compensated.map_err(option_failure)?;
    // The program says what it was compensated for (MODEL: every output records its inputs).
    let text = nc::with_note(
        &compensated.text,
        &format!(
            "compensated by volmap for {} at {}; each axis then approaches in the direction it moves",
            machine.name, compensated.report.inputs.description
        ),
    );
    let text = corrupted_for_tests(text);
    let residual = check(&machine, &program, &text, &compensated, &args, &options)?;
    let report = compensated.report;
    write_file(&args.out, |out| out.write_all(text.as_bytes())).flag("--out")?;
    outln!("{}: compensated for {}", args.out.display(), machine.name);
    outln!(
        "  inputs                      {} (at the start; then each axis approaches in the direction it moves)",
        report.inputs.description
    );
    outln!("  points compensated          {}", report.points);
    outln!(
        "  largest correction          {}",
        numbers::error_um(report.largest_correction_mm)
    );
    outln!("  blocks changed              {}", report.blocks_changed);
    outln!("  blocks added                {}", report.blocks_added);
    outln!(
        "  largest tool-tip error along the feed moves: {} before, {} after (chord tolerance {})",
        numbers::error_um(report.largest_error_before_mm),
        numbers::error_um(report.largest_error_after_mm),
        numbers::error_um(options.chord_tolerance_mm)
    );
    // The largest error left against its U, for the text and the JSON alike.
    let mut left = LeftAgainstU::default();
    if let Some(worst) = residual
        .worst
        .as_ref()
        .filter(|_| !machine.uncertainty.is_empty())
    {
        let name = args.program.display().to_string();
        let u = nc::expanded_uncertainty_at(&machine, worst, &name, &options)
            .map_err(option_failure)?;
        left = LeftAgainstU {
            largest_error_left_mm: Some(worst.deviation_mm),
            largest_error_left_line: Some(worst.line),
            u_expanded_mm: Some(u),
            within_u: Some(worst.deviation_mm <= u),
        };
        // ISO 14253-1's reading: an error within U cannot be told from none.
        let (within, reading) = if worst.deviation_mm <= u {
            ("within", ": below what the measurements can know")
        } else {
            ("beyond", "")
        };
        outln!(
            "  largest error after         {} at line {} (the model traced every {}), {within} U = {} (k = 2) there{reading}",
            numbers::error_um(worst.deviation_mm),
            worst.line,
            numbers::length_mm(residual.step_mm),
            numbers::error_um(u)
        );
    }
    if report.cycle_holes_expanded > 0 {
        outln!(
            "  canned cycle holes          {} expanded into rapid and feed moves, each compensated",
            report.cycle_holes_expanded
        );
    }
    if !report.not_compensated.is_empty() {
        let lines: Vec<String> = report
            .not_compensated
            .iter()
            .map(|p| format!("{} ({})", p.line, p.code))
            .collect();
        outln!(
            "  not compensated             {} blocks passed as they are, lines {}: the errors above cover the compensated moves only",
            lines.len(),
            lines.join(", ")
        );
    }
    if !report.moves_not_compensated.is_empty() {
        let lines: Vec<String> = report
            .moves_not_compensated
            .iter()
            .map(|m| m.to_string())
            .collect();
        outln!(
            "  moves left as they are      {}, lines {}: they depend on what a block volmap does not follow may have moved; no word is added to them",
            lines.len(),
            lines.join(", ")
        );
    }
    if let Some(tolerance) = options.orientation_tolerance_rad {
        outln!(
            "  largest tool orientation error along the feed moves: {} before, {} after (angular tolerance {})",
            numbers::angle_urad(report.largest_orientation_error_before_rad),
            numbers::angle_urad(report.largest_orientation_error_after_rad),
            numbers::angle_urad(tolerance)
        );
        outln!(
            "  largest rotary correction   {} (at most {})",
            numbers::degrees(report.largest_rotary_correction_deg),
            numbers::degrees(options.max_rotary_correction_deg)
        );
        if let Some(worst) = report.largest_orientation_left() {
            // The lines, the first ten (`--json` has them all, each with its angle).
            let left = &report.orientation_left;
            let mut lines: Vec<String> = left.iter().take(10).map(|l| l.line.to_string()).collect();
            if left.len() > 10 {
                lines.push("…".into());
            }
            outln!(
                "  orientation left            {} line{} ({}) near a singular pose, where the rotary axes cannot turn the tool axis within {}: largest {} at line {} (the tip is compensated)",
                left.len(),
                if left.len() == 1 { "" } else { "s" },
                lines.join(", "),
                numbers::degrees(options.max_rotary_correction_deg),
                numbers::angle_urad(worst.left_rad),
                worst.line
            );
        }
    }
    if report.take_ups > 0 {
        outln!(
            "  take-ups at reversals       {} (an axis with a reversal error turns)",
            report.take_ups
        );
    }
    if report.against_direction > 0 {
        errln!(
            "warning: {} compensated pieces run against the programmed direction of an axis with a reversal error: the machine approaches them the other way than they were compensated for",
            report.against_direction
        );
    }
    if let (Some(path), Some(envelope)) = (&args.json.json, &envelope) {
        envelope.write(
            path,
            "--json",
            &Reported {
                report: &report,
                left,
            },
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The largest error the model leaves along the written program (traced every step) against
/// its expanded uncertainty, as the text says it; every field `null` where the machine gives no
/// uncertainties or the program has no feed move.
#[derive(Default, serde::Serialize)]
struct LeftAgainstU {
    largest_error_left_mm: Option<f64>,
    largest_error_left_line: Option<usize>,
    /// `U = 2·|u(VE)|` (k = 2) there, mm, as `features` names its U.
    u_expanded_mm: Option<f64>,
    /// Whether the error left is at most U: below what the measurements can know.
    within_u: Option<bool>,
}

/// The JSON report: the compensation's and the error left against U.
#[derive(serde::Serialize)]
struct Reported<'a> {
    #[serde(flatten)]
    report: &'a nc::Report,
    #[serde(flatten)]
    left: LeftAgainstU,
}

/// Tests corrupt the output on purpose (`VOLMAP_TEST_CORRUPT_OUTPUT`: a move after the last) to
/// see a failed check write nothing; such an output never passes the check.
pub(super) fn corrupted_for_tests(text: String) -> String {
    match std::env::var_os("VOLMAP_TEST_CORRUPT_OUTPUT") {
        Some(v) if !v.is_empty() => format!("{text}\nG1 X0 Y0 Z0 F100\n"),
        _ => text,
    }
}

/// The written program read back and walked beside the program (exit 1 where it strays: volmap's
/// own work is wrong), then the model run along it: beyond the chord tolerance, exit 4 unless
/// `--allow-residual`. Either way before anything is written.
fn check(
    machine: &volmap::model::Machine,
    program: &[u8],
    text: &str,
    compensated: &nc::Compensated,
    args: &CompensateArgs,
    options: &Options,
) -> Result<nc::Residual, Failure> {
    let name = args.program.display().to_string();
    let bounds = nc::CheckBounds::of(compensated.report.largest_correction_mm, options);
    nc::check_written(machine, program, text.as_bytes(), &name, options, bounds).map_err(|e| {
        Failure::from(e).context(format!("nothing was written to {}", args.out.display()))
    })?;
    let residual =
        nc::residual(machine, program, compensated, &name, options).map_err(option_failure)?;
    if residual.lines.is_empty() {
        return Ok(residual);
    }
    let lines: Vec<String> = residual.lines.iter().map(|l| l.to_string()).collect();
    let message = format!(
        "{name}: the model run along the compensated program as written puts the tool tip up to {:.4} mm from the intended path, beyond the chord tolerance of {} mm, on lines {}",
        residual.largest_mm,
        options.chord_tolerance_mm,
        lines.join(", ")
    );
    if args.allow_residual {
        errln!("warning: {message} (written as --allow-residual asks)");
        return Ok(residual);
    }
    Err(Failure::beyond_tolerance(format!(
        "{message}; nothing was written to {}",
        args.out.display()
    ))
    .hint("--allow-residual writes it anyway"))
}

/// The flag of each compensation option.
fn flag_of(option: NcOption) -> &'static str {
    match option {
        NcOption::ToolLengths => "--tool-length",
        NcOption::WorkOffsets => "--work-offset",
        NcOption::ChordTolerance => "--chord-tolerance",
        NcOption::Orientation => "--orientation",
        NcOption::AngularTolerance => "--angular-tolerance",
        NcOption::MaxRotaryCorrection => "--max-rotary-correction",
        NcOption::Decimals => "--decimals",
        NcOption::TraceStep => "--step",
    }
}

/// A compensation error with the flag it concerns: an option's bad value names its flag, a value
/// the program needs but was not given gets a hint of the flag that gives it.
pub(super) fn option_failure(error: NcError) -> Failure {
    match &error {
        NcError::Option { option, .. } => {
            let flag = flag_of(*option);
            Failure::from(error).context(flag)
        }
        NcError::Missing { option, .. } => {
            let example = match option {
                NcOption::ToolLengths => "T1=80,T2=120",
                NcOption::WorkOffsets => "G55=100,50,-200",
                NcOption::ChordTolerance => "0.001",
                NcOption::Orientation => "",
                NcOption::AngularTolerance => "1e-5",
                NcOption::MaxRotaryCorrection => "1",
                NcOption::Decimals => "4",
                NcOption::TraceStep => "0.5",
            };
            let hint = format!(
                "{} gives it, e.g. {} {example}",
                flag_of(*option),
                flag_of(*option)
            );
            Failure::from(error).hint(hint)
        }
        NcError::Unsupported { .. } => {
            Failure::from(error).hint("--pass-unknown passes such blocks unchanged")
        }
        _ => Failure::from(error),
    }
}
