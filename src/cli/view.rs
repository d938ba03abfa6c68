//! `volmap view`: one self-contained HTML page of a field (or of a machine mapped on the fly)
//! and, with `--part`, its features and their verdicts.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::engine::Engine;
use volmap::io::field::FieldFile;
use volmap::part::{self, ErrorSource, PartFile};
use volmap::view::{self, ViewFeature, ViewPart};

use super::args::{full_travel, GridArg, InputsArg, MachineArg, PoseArg};
use super::failure::{Failure, FlagContext};
use super::output::{check_distinct_outputs, progress, write_file};

#[derive(clap::Args)]
#[command(mut_arg("grid", |a| a.default_value("32x32x32").help("With --machine: grid points along X, Y and Z over the travels, `NXxNYxNZ` (shown at --max-nodes)")))]
pub struct ViewArgs {
    /// The field file (written by `volmap map`) to show; or --machine to map one here.
    field: Option<PathBuf>,
    /// Map this machine here on the CPU (an embedded machine's name or a machine file) instead
    /// of reading a field.
    #[command(flatten)]
    machine: MachineArg,
    #[command(flatten)]
    grid: GridArg,
    #[command(flatten)]
    pose: PoseArg,
    /// With --machine: the evaluation inputs.
    #[command(flatten)]
    inputs: InputsArg,
    /// A part file (TOML, as `volmap features` reads): its features drawn on the sections and
    /// listed with their verdicts.
    #[arg(long)]
    part: Option<PathBuf>,
    /// Nodes shown along each axis at most: a larger field is shown at evenly spaced nodes, the
    /// ends included (fields of many poses at fewer, so that the page stays small).
    #[arg(long, default_value_t = view::MAX_NODES as u64, value_parser = clap::value_parser!(u64).range(2..=256))]
    max_nodes: u64,
    /// The HTML page to write.
    #[arg(long)]
    out: PathBuf,
}

/// Nodes the page holds over every pose at most (64³ · 2, about 17 MB of values in base64).
const MAX_PAGE_NODES: f64 = 524_288.0;
/// Nodes shown along an axis at the least, however many poses.
const LEAST_NODES: usize = 8;

pub fn run(args: ViewArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[("--out", Some(args.out.as_path()))])?;
    let part_file = match &args.part {
        Some(path) => Some(PartFile::read(path).flag("--part")?),
        None => None,
    };
    let mut data = match (&args.field, &args.machine.machine) {
        (Some(_), Some(_)) => {
            return Err(Failure::input(
                "give a field file or --machine, not both".to_string(),
            ))
        }
        (None, None) => {
            return Err(Failure::input(
                "say what to show: a field file (volmap view FIELD.exr --out page.html), or --machine M to map one here".to_string(),
            ))
        }
        (Some(path), None) => field_data(&args, path)?,
        (None, Some(_)) => machine_data(&args)?,
    };
    if let (Some(part), Some(path)) = (&part_file, &args.part) {
        let name = path.display().to_string();
        let rows = match &args.field {
            Some(field) => {
                let loaded = super::features::open_field(field, part, &args.inputs)?;
                part::evaluate(part, ErrorSource::Field(&loaded), &name)?
            }
            None => {
                let (machine, _) = args.inputs.machine_at(&args.machine.load()?)?;
                part::evaluate(part, ErrorSource::Exact(&machine), &name)?
            }
        };
        let positions = part::cutter_positions(part, &name)?;
        data.features = rows.iter().map(ViewFeature::of).collect();
        data.cutter_points_mm = view::thin_points(&positions.positions);
        data.part_file = Some(name);
    }
    let html = view::page(&data);
    write_file(&args.out, |w| w.write_all(html.as_bytes())).map_err(|e| e.context("--out"))?;
    let part = &data.parts[0];
    outln!(
        "wrote {} ({} MB): {} pose{}, {} nodes shown of {}{}",
        args.out.display(),
        volmap::report::numbers::quantity(html.len() as f64 / 1e6),
        data.parts.len(),
        if data.parts.len() == 1 { "" } else { "s" },
        part.dims.map(|d| d.to_string()).join("x"),
        part.full_dims.map(|d| d.to_string()).join("x"),
        if data.features.is_empty() {
            String::new()
        } else {
            format!(", {} features", data.features.len())
        }
    );
    Ok(ExitCode::SUCCESS)
}

/// Every pose of the field file at `path`, each at the nodes the page can hold.
fn field_data(args: &ViewArgs, path: &std::path::Path) -> Result<view::ViewData, Failure> {
    volmap::io::source::note_source(path);
    let file = FieldFile::open(path).flag("FIELD")?;
    // The file's parts of values (a part of uncertainties travels with its pose).
    let parts = file.parts();
    let least = (LEAST_NODES.pow(3) * parts) as f64;
    if least > MAX_PAGE_NODES {
        return Err(Failure::input(format!(
            "{}: {parts} poses are more than one page holds ({} at {LEAST_NODES}³ nodes each); map fewer poses into a field for the page",
            path.display(),
            (MAX_PAGE_NODES as usize) / LEAST_NODES.pow(3)
        )));
    }
    let per_part = ((MAX_PAGE_NODES / parts as f64).cbrt().floor() as usize).max(LEAST_NODES);
    let max = (args.max_nodes as usize).min(per_part);
    let bar = progress(Some(parts as u64), "reading", "poses");
    let mut shown: Vec<ViewPart> = Vec::with_capacity(parts);
    for p in 0..parts {
        shown.push(view::read_part(&file, p, max).flag("FIELD")?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let info = file.info_without_machine(0);
    Ok(view::view_data(
        (&info.machine_name, &info.chain),
        format!(
            "the field {}",
            path.file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned())
        ),
        info.device,
        shown,
    ))
}

/// The machine of --machine mapped over --grid on the CPU engine (f64), at --max-nodes.
fn machine_data(args: &ViewArgs) -> Result<view::ViewData, Failure> {
    let loaded = args.machine.load()?;
    let (machine, _) = args.inputs.machine_at(&loaded)?;
    let grid = full_travel(&machine, &args.grid, &args.pose)?;
    let nodes = grid.points() as f64;
    if nodes > MAX_PAGE_NODES {
        return Err(Failure::input(format!(
            "--grid {}: {} points are more than one page holds ({}); map a field and view it, which shows it at --max-nodes",
            grid.dims.map(|d| d.to_string()).join("x"),
            grid.points(),
            MAX_PAGE_NODES as u64
        )));
    }
    let words = (
        volmap::model::poses::pose_name(&grid.pose, &machine),
        machine.inputs.describe(&machine),
    );
    let part = view::map_part(
        &machine,
        &grid,
        &Engine::Cpu,
        args.max_nodes as usize,
        words,
    )?;
    Ok(view::view_data(
        (&machine.name, &machine.chain.hwang_notation()),
        format!("{} mapped here", machine.name),
        "CPU engine (f64)".into(),
        vec![part],
    ))
}
