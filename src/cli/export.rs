//! `volmap export`: the machine's correction as a controller's compensation table, with the
//! residual the control leaves when it applies the table as written.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::export::{self, ExportError, Report, Request, TableSize};
use volmap::plot::{self, Color, Marker, Series};

use super::args::{InputsArg, JsonArg, MachineArg, PoseArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::{check_distinct_outputs, check_plot_paths, progress, write_plot, written_by};

const UM_PER_MM: f64 = 1000.0;
/// Below this the structure's remainder is the arithmetic's, mm.
const NEGLIGIBLE_MM: f64 = 1e-6;

#[derive(clap::Args)]
pub struct ExportArgs {
    #[command(flatten)]
    machine: MachineArg,
    /// The controller format: grid-csv, linuxcnc, klipper, klipper-twist, marlin, rrf,
    /// rrf-heightmap, siemens, heidenhain, fanuc, fanuc-3d, isg or isg-axis (see docs/export/
    /// for each format's tables, limits and how to load them).
    #[arg(long)]
    format: String,
    /// Where to write: the file for a one-file format (grid-csv, klipper, klipper-twist, marlin,
    /// rrf, fanuc-3d), a folder (created) for a format of several files or a file and a report
    /// (linuxcnc, rrf-heightmap, siemens, heidenhain, fanuc, isg, isg-axis).
    #[arg(long, required_unless_present = "sweep_points")]
    out: Option<PathBuf>,
    /// Spacing between table nodes, mm (per axis, the nodes from the start of each travel to
    /// its end or beyond).
    #[arg(long, conflicts_with = "points")]
    spacing: Option<f64>,
    /// Points per table (per axis for a 3-D grid); default: the format's (see docs/export/).
    #[arg(long)]
    points: Option<usize>,
    #[command(flatten)]
    pose: PoseArg,
    #[command(flatten)]
    inputs: InputsArg,
    /// The tool's length, mm, along the machine file's tool direction (its tool offset's, or
    /// −Z): the tables and the residual are for this tool (a control that takes the length from
    /// its tool data, ISG's, is given the direction alone); default: the machine file's tool
    /// offset.
    #[arg(long)]
    tool_length: Option<f64>,
    /// The version of the control the files are for, where a format is written differently
    /// for each: linuxcnc `2.9` (the current stable release: joint compensation files alone,
    /// no squareness) or `2.10` (with matrixkins); default: the first.
    #[arg(long)]
    control: Option<String>,
    /// fanuc: the pitch error compensation point numbers the tables may take, `FIRST-LAST`
    /// (the control's pool, or the part of it no other axis uses), in six equal blocks: X, Y,
    /// Z travelling +, then X, Y, Z travelling −; default 0-1023.
    #[arg(long, value_parser = parse_point_numbers)]
    point_numbers: Option<[i64; 2]>,
    /// klipper-twist: the probe's offset from the nozzle, `X,Y` mm (Klipper's `[probe]`
    /// x_offset, y_offset).
    #[arg(long, value_parser = parse_probe_offset, allow_hyphen_values = true)]
    probe_offset: Option<[f64; 2]>,
    /// Refuse the export (write nothing, exit 2) when the largest residual is above this, mm.
    #[arg(long)]
    max_residual: Option<f64>,
    /// Points per linear axis of the grid the residual is measured on (default: twice the
    /// table's density, 41 to 81).
    #[arg(long)]
    residual_grid: Option<usize>,
    /// Instead of writing a table: the residual for each of these numbers of points per table,
    /// e.g. `2,3,5,9,17,33`.
    #[arg(long, conflicts_with_all = ["out", "points", "spacing", "max_residual"])]
    sweep_points: Option<String>,
    /// With --sweep-points: a plot of the residual against the number of points (SVG or PNG).
    #[arg(long, requires = "sweep_points")]
    plot: Option<PathBuf>,
    #[command(flatten)]
    json: JsonArg,
}

/// `FIRST-LAST`, two whole numbers.
fn parse_point_numbers(text: &str) -> Result<[i64; 2], String> {
    let bad = || format!("`{text}`: expected FIRST-LAST, two whole numbers, e.g. 0-1023");
    let (first, last) = text.split_once('-').ok_or_else(bad)?;
    let number = |t: &str| t.trim().parse::<i64>().map_err(|_| bad());
    Ok([number(first)?, number(last)?])
}

/// `X,Y`, two numbers, mm.
fn parse_probe_offset(text: &str) -> Result<[f64; 2], String> {
    let bad = || format!("`{text}`: expected X,Y in mm, e.g. 25,-10");
    let (x, y) = text.split_once(',').ok_or_else(bad)?;
    let number = |t: &str| t.trim().parse::<f64>().map_err(|_| bad());
    Ok([number(x)?, number(y)?])
}

pub fn run(args: ExportArgs) -> Result<ExitCode, Failure> {
    check_distinct_outputs(&[
        ("--out", args.out.as_deref()),
        ("--plot", args.plot.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    if let Some(path) = &args.plot {
        check_plot_paths(&[path], "--plot")?;
    }
    let format = export::format_named(&args.format).flag("--format")?;
    if let Some(limit) = args.max_residual {
        if !(limit.is_finite() && limit >= 0.0) {
            return Err(Failure::input(format!(
                "--max-residual {limit}: it must be a number of mm, zero or more"
            )));
        }
    }
    let machine = args.machine.load()?;
    let inputs = args.inputs.on(&machine)?;
    let pose = args.pose.on(&machine)?;
    let size = match (args.points, args.spacing) {
        (Some(n), _) => TableSize::Points(n),
        (_, Some(s)) => TableSize::Spacing(s),
        _ => TableSize::Default,
    };
    let size_flag = match size {
        TableSize::Points(_) => "--points",
        TableSize::Spacing(_) => "--spacing",
        TableSize::Default => "--format",
    };
    let request = Request {
        machine: &machine,
        inputs: &inputs,
        pose,
        size,
        evaluation_points: args.residual_grid,
        written_by: written_by(),
        file_name: args
            .out
            .as_deref()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned()),
        tool_length_mm: args.tool_length,
        control: args.control.clone(),
        point_numbers: args.point_numbers,
        probe_offset_mm: args.probe_offset,
    };
    if let Some(list) = &args.sweep_points {
        return sweep(format, &request, list, &args);
    }
    let bar = progress(None, "exporting", "steps");
    let result = export::export(format, &request);
    bar.finish_and_clear();
    let exported = result.map_err(|e| flag_of(e, size_flag))?;
    print_report(&exported.report);
    let r = &exported.report;
    if r.residual.max_mm > r.before.max_mm {
        let why = if r.residual_offset_free.max_mm < r.before_offset_free.max_mm {
            format!(
                "less a work offset it leaves {} against {}: what it adds is a constant offset, which a work offset (touch-off) takes up",
                numbers::error_um(r.residual_offset_free.max_mm),
                numbers::error_um(r.before_offset_free.max_mm)
            )
        } else {
            "it holds too little of this machine's error to help".to_string()
        };
        errln!(
            "warning: the {} table leaves a larger largest error than the machine has without it ({} against {}); {why}",
            r.format,
            numbers::error_um(r.residual.max_mm),
            numbers::error_um(r.before.max_mm)
        );
    }
    if let Some(limit) = args.max_residual {
        exported.check_residual(limit).flag("--max-residual")?;
    }
    let out = args
        .out
        .as_ref()
        .expect("clap requires --out without --sweep-points");
    let paths = exported.write(out).flag("--out")?;
    for path in &paths {
        outln!("  wrote                  {}", path.display());
    }
    if let Some(path) = &args.json.json {
        let written: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
        envelope_of(&request).write(
            path,
            "--json",
            &serde_json::json!({ "written": written, "report": exported.report }),
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The envelope of the JSON report of an export of `request`.
fn envelope_of(request: &Request) -> Envelope {
    Envelope::new("export")
        .machine(request.machine)
        .at_inputs(request.machine, request.inputs)
        .at_pose(request.machine, &request.pose)
}

/// An export error with the flag it comes from.
fn flag_of(error: ExportError, size_flag: &str) -> Failure {
    let flag = match &error {
        ExportError::NoTableSize { .. }
        | ExportError::TooManyPoints { .. }
        | ExportError::TooFewPoints { .. }
        | ExportError::SpacingTooSmall { .. }
        | ExportError::BadSpacing(_)
        | ExportError::SpacingTooLarge { .. } => Some(size_flag),
        ExportError::NothingHeld { .. }
        | ExportError::BeyondFormat { .. }
        | ExportError::Unrepresentable { .. } => Some("--format"),
        ExportError::BadEvaluationGrid { .. } => Some("--residual-grid"),
        ExportError::Singular => Some("--pose"),
        ExportError::BadToolLength(_) => Some("--tool-length"),
        ExportError::NoControlChoice { .. } | ExportError::UnknownControl { .. } => {
            Some("--control")
        }
        ExportError::NoPointNumbers { .. } | ExportError::BadPointNumbers { .. } => {
            Some("--point-numbers")
        }
        ExportError::NoProbeOffset { .. }
        | ExportError::NoProbe { .. }
        | ExportError::BadProbeOffset { .. } => Some("--probe-offset"),
        ExportError::MissingAxes { .. } | ExportError::NoSolution { .. } => Some("--machine"),
        _ => None,
    };
    match flag {
        Some(flag) => Failure::from(error).context(flag.to_string()),
        None => Failure::from(error),
    }
}

fn print_report(r: &Report) {
    outln!("{}: {} for {}", r.format, r.controller, r.machine);
    outln!("  inputs                 {}", r.inputs);
    outln!("  pose                   {}", r.pose);
    outln!("  tool                   {}", r.tool);
    for t in &r.tables {
        outln!("  table {:<16} {}", t.name, t.size);
    }
    let g = &r.grid;
    outln!(
        "  residual measured on   {} x {} x {} points over the travels at the pose (spacing {} x {} x {} mm)",
        g.points[0],
        g.points[1],
        g.points[2],
        numbers::length(g.spacing_mm[0]),
        numbers::length(g.spacing_mm[1]),
        numbers::length(g.spacing_mm[2])
    );
    let at = |a: [f64; 3]| {
        let [x, y, z] = a.map(numbers::length);
        format!("X={x} Y={y} Z={z}")
    };
    outln!(
        "  error before           largest {}, RMS {} (largest at {})",
        numbers::error_um(r.before.max_mm),
        numbers::error_um(r.before.rms_mm),
        at(r.before.at_mm)
    );
    outln!(
        "  residual               largest {}, RMS {} (largest at {})",
        numbers::error_um(r.residual.max_mm),
        numbers::error_um(r.residual.rms_mm),
        at(r.residual.at_mm)
    );
    outln!(
        "  less a work offset     largest {} before, {} after (each less its mean over the grid)",
        numbers::error_um(r.before_offset_free.max_mm),
        numbers::error_um(r.residual_offset_free.max_mm)
    );
    if r.uses_direction {
        outln!("  directions             the control picks each axis's table by the direction it moves; the residual is for the approach above");
    }
    if let Some(u) = &r.uncertainty {
        for t in &u.tables {
            outln!(
                "  uncertainty of {}: largest node u {}, U = {} (k = 2), correcting {}",
                t.table,
                numbers::error_um(t.u_mm),
                numbers::error_um(t.u_expanded_mm),
                t.corrects
            );
        }
        // The rule (docs/export.md): the largest residual against the largest node U.
        let (within, reading) = if u.within_u {
            (
                "within",
                ": the residual is below what the measurements can know",
            )
        } else {
            ("beyond", "")
        };
        outln!(
            "  residual against U     largest {} {within} the largest node U = {} (k = 2){reading}",
            numbers::error_um(r.residual.max_mm),
            numbers::error_um(u.u_expanded_mm)
        );
    }
    outln!("  holds                  {}", r.holds);
    if r.not_held.is_empty() && r.structural_mm < NEGLIGIBLE_MM {
        outln!("  cannot hold            nothing of this machine's correction at the pose");
    } else {
        if r.structural_mm < NEGLIGIBLE_MM {
            outln!("  cannot hold            nothing of the whole correction at any table size (the parts below cancel); of each error alone:");
        } else if r.not_held.is_empty() {
            outln!(
                "  cannot hold            up to {} of the correction at any table size (no single error's part above 0.001 µm)",
                numbers::error_um(r.structural_mm)
            );
        } else {
            outln!(
                "  cannot hold            up to {} of the correction at any table size; of each error alone:",
                numbers::error_um(r.structural_mm)
            );
        }
        for n in &r.not_held {
            outln!(
                "    {:<8} {} of the {} it causes alone",
                n.error,
                numbers::error_um(n.not_held_mm),
                numbers::error_um(n.alone_mm)
            );
        }
    }
}

/// `--sweep-points`: the residual for each number of points, a table and a plot.
fn sweep(
    format: &'static dyn export::Format,
    request: &Request,
    list: &str,
    args: &ExportArgs,
) -> Result<ExitCode, Failure> {
    let points: Vec<usize> = list
        .split(',')
        .map(|p| p.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            Failure::input(format!(
                "--sweep-points `{list}`: expected numbers of points separated by commas, e.g. 2,3,5,9,17"
            ))
        })?;
    if points.is_empty() {
        return Err(Failure::input("--sweep-points: no numbers of points"));
    }
    let bar = progress(Some(points.len() as u64), "exporting", "tables");
    let mut rows = Vec::new();
    for &n in &points {
        let asked = Request {
            size: TableSize::Points(n),
            written_by: request.written_by.clone(),
            file_name: request.file_name.clone(),
            control: request.control.clone(),
            ..*request
        };
        let exported = export::export(format, &asked).map_err(|e| flag_of(e, "--sweep-points"));
        bar.inc(1);
        rows.push((n, exported?.report));
    }
    bar.finish_and_clear();
    let first = &rows[0].1;
    outln!(
        "{}: {} for {} ({}; pose {})",
        first.format,
        first.controller,
        first.machine,
        first.inputs,
        first.pose
    );
    outln!(
        "  error before: largest {}, RMS {}",
        numbers::error_um(first.before.max_mm),
        numbers::error_um(first.before.rms_mm)
    );
    outln!(
        "  {:>7} {:>16} {:>16}",
        "points",
        "residual max",
        "residual RMS"
    );
    for (n, r) in &rows {
        outln!(
            "  {n:>7} {:>16} {:>16}",
            numbers::error_um(r.residual.max_mm),
            numbers::error_um(r.residual.rms_mm)
        );
    }
    if let Some(path) = &args.plot {
        let x: Vec<f64> = rows.iter().map(|(n, _)| *n as f64).collect();
        let series = vec![
            Series {
                name: "residual, largest".into(),
                x: x.clone(),
                y: rows
                    .iter()
                    .map(|(_, r)| r.residual.max_mm * UM_PER_MM)
                    .collect(),
                color: Color::RED,
                dashed: false,
                marker: Marker::Up,
                band: None,
            },
            Series {
                name: "residual, RMS".into(),
                x: x.clone(),
                y: rows
                    .iter()
                    .map(|(_, r)| r.residual.rms_mm * UM_PER_MM)
                    .collect(),
                color: Color::BLUE,
                dashed: false,
                marker: Marker::Up,
                band: None,
            },
        ];
        let title = format!(
            "{} residual of {} against table size",
            first.format, first.machine
        );
        let drawing = plot::log_chart(&title, "points per table", "residual (µm)", &series, true)?;
        write_plot(&drawing, path, "--plot")?;
    }
    if let Some(path) = &args.json.json {
        let json: Vec<serde_json::Value> = rows
            .iter()
            .map(|(n, r)| serde_json::json!({ "points": n, "report": r }))
            .collect();
        envelope_of(request).write(path, "--json", &json)?;
    }
    Ok(ExitCode::SUCCESS)
}
