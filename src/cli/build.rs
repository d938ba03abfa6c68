//! `volmap build`: a machine file from component errors measured at sparse positions.

use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::json;
use volmap::calibrate::{self, build, CalibrateError};
use volmap::error::excerpt;
use volmap::io::digest;
use volmap::io::source::Reach;
use volmap::model::AxisLetter;

use super::args::{load_machine_flag, JsonArg, ReachArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_machine_text, copy_tables, out_folder, write_file, written_by};

#[derive(clap::Args)]
pub struct BuildArgs {
    /// The machine whose chain, travels, offsets and unmeasured errors the new file keeps
    /// (embedded name or file).
    #[arg(long)]
    base: String,
    /// A measured axis and its CSV, `X=x.csv` (repeat per axis).
    #[arg(long = "axis", required = true)]
    axes: Vec<String>,
    /// Interpolation per component instead of the automatic choice, `EZZ=quadratic,EXX=linear`.
    #[arg(long, default_value = "")]
    interp: String,
    /// The machine file to write.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    reach: ReachArg,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: BuildArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[
        ("--out", Some(args.out.as_path())),
        ("--json", args.json.json.as_deref()),
    ])?;
    let base = load_machine_flag(&args.base, &args.reach, "--base")?;
    let mut axes = Vec::new();
    for pair in &args.axes {
        let (letter, path) = pair
            .split_once('=')
            .and_then(|(l, p)| {
                let mut chars = l.trim().chars();
                let letter = chars.next().and_then(AxisLetter::from_char);
                (chars.next().is_none())
                    .then_some(letter)
                    .flatten()
                    .map(|l| (l, p))
            })
            .ok_or_else(|| {
                Failure::input(format!(
                    "--axis {}: expected AXIS=FILE.csv, e.g. X=x.csv",
                    excerpt(pair)
                ))
            })?;
        let path = path.trim();
        if path.is_empty() {
            return Err(Failure::input(format!(
                "--axis {}: no file named after `=`",
                excerpt(pair)
            )));
        }
        if path.split(',').skip(1).any(|item| {
            item.split_once('=').is_some_and(|(l, _)| {
                l.trim().len() == 1 && l.trim().chars().all(|c| AxisLetter::from_char(c).is_some())
            })
        }) {
            return Err(Failure::input(format!(
                "--axis {}: one AXIS=FILE.csv each; repeat --axis for another axis",
                excerpt(pair)
            )));
        }
        axes.push((letter, PathBuf::from(path)));
    }
    let axes_ref: Vec<_> = axes.iter().map(|(l, p)| (*l, p.as_path())).collect();
    let asked = build::parse_interp_choices(&args.interp).flag("--interp")?;
    // Apart from an interpolation for a component not measured, what goes wrong is in the
    // --axis files: an axis the base lacks or given twice, or the measurements they hold.
    let (text, built) = match build::build(&base, &axes_ref, &asked) {
        Err(e @ CalibrateError::InterpChoice(_)) => Err(e).flag("--interp"),
        result => result.flag("--axis"),
    }?;
    let measured: Vec<String> = axes
        .iter()
        .map(|(letter, path)| format!("{letter}={}", path.display()))
        .collect();
    let components: Vec<String> = built
        .iter()
        .map(|c| format!("{} {}", c.name, c.interp))
        .collect();
    let text = calibrate::with_header(
        &text,
        &[
            written_by(),
            format!(
                "The base machine `{}` ({}) with the components measured in {}: {}.",
                base.name,
                args.base,
                measured.join(", "),
                components.join(", ")
            ),
            format!(
                "Measured values rounded to {} significant digits.",
                calibrate::SIGNIFICANT_DIGITS
            ),
        ],
    );
    // The base's CSV tables are named relative to its own folder; the new file's names them
    // from its folder, and must read back as a machine before it replaces anything.
    let folder = out_folder(&args.out);
    let rebased = calibrate::rebase_tables(&text, &base, &args.out)?;
    copy_tables(&folder, &rebased.copies, "--out")?;
    let text = rebased.text;
    check_machine_text(&text, &args.out, &folder)?;
    write_file(&args.out, |out| out.write_all(text.as_bytes())).flag("--out")?;
    outln!(
        "{}: {} component table(s) from measurements",
        args.out.display(),
        built.len()
    );
    outln!(
        "  {:<5} {:>5}  {:<10} {:>32}  why",
        "error",
        "nodes",
        "interp",
        "leave-one-out RMS (µm or µrad)"
    );
    for c in &built {
        let scores: Vec<String> = c
            .leave_one_out
            .iter()
            .map(|(name, s)| {
                if c.index < 3 {
                    format!("{name} {}", numbers::error(*s))
                } else {
                    format!("{name} {}", numbers::angle(*s))
                }
            })
            .collect();
        outln!(
            "  {:<5} {:>5}  {:<10} {:>32}  {}",
            c.name,
            c.nodes.len(),
            c.interp,
            if scores.is_empty() {
                "-".to_string()
            } else {
                scores.join(", ")
            },
            c.reason
        );
    }
    let uncertain: Vec<String> = built
        .iter()
        .filter_map(|c| {
            c.u.as_ref()
                .map(|(column, _)| format!("{} ({column})", c.name))
        })
        .collect();
    if !uncertain.is_empty() {
        outln!(
            "  with the standard uncertainty of each node: {}",
            uncertain.join(", ")
        );
    }
    if let Some(path) = &args.json.json {
        // What every command reads from the file written: its hash as read back.
        let written =
            volmap::io::embedded::load_reaching(&args.out.display().to_string(), Reach::Folder)
                .map(|m| digest::of_machine(&m))
                .flag("--out")?;
        let components: Vec<serde_json::Value> = built
            .iter()
            .map(|c| {
                // Linear components (EXX…) in mm, angular ones in rad.
                let unit = if c.index < 3 { "rms_mm" } else { "rms_rad" };
                let scores: Vec<serde_json::Value> = c
                    .leave_one_out
                    .iter()
                    .map(|(name, s)| json!({ "interp": name, unit: s }))
                    .collect();
                json!({
                    "name": c.name,
                    "nodes": c.nodes.len(),
                    "interp": c.interp.to_string(),
                    "leave_one_out": scores,
                    "reason": c.reason,
                })
            })
            .collect();
        Envelope::new("build").machine(&base).write(
            path,
            "--json",
            &json!({
                "written": { "file": args.out.display().to_string(), "sha256": written },
                "measured": measured,
                "components": components,
            }),
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
