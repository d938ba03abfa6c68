//! `volmap test`: the standard tests predicted from a machine model, against measured results
//! where given.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::error::excerpt;
use volmap::part::uncertainty::COVERAGE_FACTOR;
use volmap::standards::{self, Setup, TestResult};

use super::args::{InputsArg, JsonArg, MachineArg, PoseArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};
use super::numbers;
use super::output::check_plot_paths;
use super::plot::write_test_plot;

/// Three numbers `X,Y,Z` in mm.
fn parse_xyz(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{}`: expected three numbers X,Y,Z (mm)", excerpt(text)))?;
    let xyz = <[f64; 3]>::try_from(values)
        .map_err(|_| format!("`{}`: expected three numbers X,Y,Z (mm)", excerpt(text)))?;
    match xyz.iter().position(|v| !v.is_finite()) {
        Some(n) => Err(format!(
            "`{}`: {} is not a finite number",
            excerpt(text),
            ["X", "Y", "Z"][n]
        )),
        None => Ok(xyz),
    }
}

#[derive(clap::Args)]
pub struct TestArgs {
    #[command(subcommand)]
    kind: TestKind,
}

/// What every test takes besides its own parameters.
#[derive(clap::Args)]
struct Common {
    #[command(flatten)]
    machine: MachineArg,
    #[command(flatten)]
    pose: PoseArg,
    /// The evaluation inputs. The temperatures hold for every point of the test; the axes the
    /// test moves approach in the direction the path moves them, so `--approach` sets only the
    /// axes that stand still.
    #[command(flatten)]
    inputs: InputsArg,
    /// Measured results to compare with (CSV; the layout of each test is in docs/standard-tests.md).
    #[arg(long)]
    measured: Option<PathBuf>,
    /// Draw the error curve, predicted and measured, into this file (.svg or .png).
    #[arg(long)]
    plot: Vec<PathBuf>,
    /// Print the point-by-point rows however many there are (without it, a test of more than
    /// 40 points prints its figures and diagnostics alone; --json always holds the rows).
    #[arg(long)]
    table: bool,
    #[command(flatten)]
    json: JsonArg,
}

/// What `--approach` does in a test, shown under every test's options.
const DIRECTIONS: &str =
    "The axes a test moves approach each point in the direction its path moves \
them there (positioning: + in the ↑ runs, − in the ↓ runs; circular: as each axis moves along the \
circle, keeping its direction at a turning point; diagonal: from the start to the end; rtest: the \
rotary axis +, the linear axes as they follow the sphere). --approach sets only the axes the test \
does not move; --temperatures hold for every point.";

#[derive(clap::Subcommand)]
enum TestKind {
    /// ISO 230-2 positioning of one axis: figures A, B, E, M, R (µm; arc-seconds for a rotary
    /// axis, against an angle reference).
    #[command(after_help = DIRECTIONS)]
    Positioning {
        /// The axis: X, Y or Z; A, B or C for a rotary axis.
        #[arg(long)]
        axis: String,
        /// Targets evenly over the travel (default: 5 per metre, at least 5; a rotary axis every
        /// 30° at most, at least 5).
        #[arg(long)]
        targets: Option<usize>,
        /// Runs per approach direction.
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Where the other linear axes stand, `X,Y,Z` mm (default: mid-travel).
        #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true)]
        at: Option<[f64; 3]>,
        #[command(flatten)]
        common: Common,
    },
    /// ISO 230-6 displacement along a body (PPP NPP PNP PPN) or face (XY-PP, XY-NP, ...)
    /// diagonal.
    #[command(after_help = DIRECTIONS)]
    Diagonal {
        /// The diagonal's name; it spans the travel box unless --from and --to are given.
        #[arg(long)]
        diagonal: Option<String>,
        /// Start, `X,Y,Z` mm.
        #[arg(long, value_parser = parse_xyz, requires = "to", allow_hyphen_values = true)]
        from: Option<[f64; 3]>,
        /// End, `X,Y,Z` mm.
        #[arg(long, value_parser = parse_xyz, requires = "from", allow_hyphen_values = true)]
        to: Option<[f64; 3]>,
        /// Points along the diagonal, ends included.
        #[arg(long, default_value_t = 21)]
        points: usize,
        #[command(flatten)]
        common: Common,
    },
    /// ISO 230-4 circular test (ballbar): radial deviation around a circle, circular deviation G.
    #[command(after_help = DIRECTIONS)]
    Circular {
        /// XY, YZ or ZX.
        #[arg(long)]
        plane: String,
        /// Centre, `X,Y,Z` mm (default: mid-travel).
        #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true)]
        centre: Option<[f64; 3]>,
        /// Radius, mm (default 100, less where the travel is shorter).
        #[arg(long)]
        radius: Option<f64>,
        /// Points around the circle.
        #[arg(long, default_value_t = 360)]
        points: usize,
        /// Feed direction: ccw (G3) or cw (G2).
        #[arg(long, default_value = "ccw")]
        direction: String,
        /// Where the run starts, degrees from the plane's first axis.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        start: f64,
        /// The pitch of the axes' cyclic error (a ballscrew's lead), mm: the ballbar diagnostics
        /// then give its amplitude per axis.
        #[arg(long)]
        pitch: Option<f64>,
        #[command(flatten)]
        common: Common,
    },
    /// R-test of a rotary axis: the sphere's displacement in X, Y, Z while the linear axes
    /// follow it.
    #[command(after_help = DIRECTIONS)]
    Rtest {
        /// The rotary axis: A, B or C.
        #[arg(long)]
        axis: String,
        /// The sphere's centre in the workpiece frame, `X,Y,Z` mm (default: the tool tip at
        /// mid-travel where the linear axes can follow it over the sweep, else the nearest they
        /// can follow: towards a table's axis or on it, then over the travels).
        #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true)]
        sphere: Option<[f64; 3]>,
        /// First angle, degrees (default: the start of the travel).
        #[arg(long, allow_hyphen_values = true)]
        from: Option<f64>,
        /// Last angle, degrees (default: the end of the travel).
        #[arg(long, allow_hyphen_values = true)]
        to: Option<f64>,
        /// Step, degrees.
        #[arg(long, default_value_t = 10.0)]
        step: f64,
        #[command(flatten)]
        common: Common,
    },
}

pub fn run(args: TestArgs) -> Result<ExitCode, Failure> {
    let (plots, json) = match &args.kind {
        TestKind::Positioning { common, .. }
        | TestKind::Diagonal { common, .. }
        | TestKind::Circular { common, .. }
        | TestKind::Rtest { common, .. } => (&common.plot, common.json.json.as_deref()),
    };
    check_plot_paths(plots, "--plot")?;
    let mut outputs: Vec<(&str, Option<&std::path::Path>)> = plots
        .iter()
        .map(|p| ("--plot", Some(p.as_path())))
        .collect();
    outputs.push(("--json", json));
    super::output::check_distinct_outputs(&outputs)?;
    let (common, (result, envelope)) = match args.kind {
        TestKind::Positioning {
            axis,
            targets,
            runs,
            at,
            common,
        } => {
            let spec = standards::PositioningSpec {
                axis,
                targets,
                runs,
                at_mm: at,
                pose: common.pose.pose.clone(),
                csv: common.measured.clone(),
            };
            let result = run_on_machine(&common, |setup| standards::positioning(setup, &spec))?;
            (common, result)
        }
        TestKind::Diagonal {
            diagonal,
            from,
            to,
            points,
            common,
        } => {
            let spec = standards::DiagonalSpec {
                diagonal,
                from_mm: from,
                to_mm: to,
                points,
                pose: common.pose.pose.clone(),
                csv: common.measured.clone(),
            };
            let result = run_on_machine(&common, |setup| standards::diagonal(setup, &spec))?;
            (common, result)
        }
        TestKind::Circular {
            plane,
            centre,
            radius,
            points,
            direction,
            start,
            pitch,
            common,
        } => {
            let spec = standards::CircularSpec {
                plane,
                centre_mm: centre,
                radius_mm: radius,
                points,
                direction,
                start_deg: start,
                pose: common.pose.pose.clone(),
                csv: common.measured.clone(),
                pitch_mm: pitch,
            };
            let result = run_on_machine(&common, |setup| standards::circular(setup, &spec))?;
            (common, result)
        }
        TestKind::Rtest {
            axis,
            sphere,
            from,
            to,
            step,
            common,
        } => {
            let spec = standards::RTestSpec {
                axis,
                sphere_mm: sphere,
                from_deg: from,
                to_deg: to,
                step_deg: step,
                pose: common.pose.pose.clone(),
                csv: common.measured.clone(),
            };
            let result = run_on_machine(&common, |setup| standards::rtest(setup, &spec))?;
            (common, result)
        }
    };
    print_result(&result, common.table);
    for path in &common.plot {
        write_test_plot(path, &result)?;
    }
    if let (Some(path), Some(envelope)) = (&common.json.json, &envelope) {
        envelope.write(path, "--json", &result)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs a test on the machine `common` names, with the rotary axes at its pose, at its inputs.
fn run_on_machine(
    common: &Common,
    test: impl FnOnce(&Setup) -> Result<TestResult, standards::StandardsError>,
) -> Result<(TestResult, Option<Envelope>), Failure> {
    let machine = common.machine.load()?;
    let inputs = common.inputs.on(&machine)?;
    let setup = Setup::with_inputs(&machine, &common.pose.pose, &inputs).flag("--pose")?;
    let pose = common.pose.on(&machine)?;
    // Only a report needs it: hashing the machine's files is work a plain run need not do.
    let envelope = common.json.json.is_some().then(|| {
        Envelope::new("test")
            .machine(&machine)
            .at_inputs(&machine, &inputs)
            .at_pose(&machine, &pose)
    });
    let result = test(&setup).map_err(|e| match &e {
        // A count beyond its limit comes from the flags of the spec's keys.
        standards::StandardsError::Limit { key, message } => {
            let flags: Vec<String> = key
                .split(" and ")
                .flat_map(|k| k.split(", "))
                .map(|k| format!("--{}", k.trim_end_matches("_deg")))
                .collect();
            Failure::input(format!("{}: {message}", flags.join(", ")))
        }
        _ => Failure::from(e),
    })?;
    // An approach given for an axis the test moves is the path's to decide.
    for named in common.inputs.approach.split(',') {
        let axis = named.split('=').next().unwrap_or("").trim();
        if let Some(letter) = axis.chars().next().filter(|_| axis.chars().count() == 1) {
            if result.moving_axes.contains(&letter) {
                errln!(
                    "note: --approach {axis}: the test moves {axis}, and its path decides the direction"
                );
            }
        }
    }
    Ok((result, envelope))
}

/// Rows printed without `--table`: a longer test (a circle every degree) prints its figures.
const ROWS_PRINTED: usize = 40;

/// The point-by-point table (µm, or arc-seconds for a rotary axis; with `all_rows` or at most
/// [`ROWS_PRINTED`] rows) and the figures, predicted and measured side by side.
fn print_result(result: &TestResult, all_rows: bool) {
    let (_, unit) = result.unit.shown();
    let value = |v: f64| result.unit.printed(v);
    let position_value = |p: f64| {
        if result.position_label.contains("(deg)") {
            numbers::rotary(p)
        } else {
            numbers::length(p)
        }
    };
    // With the machine's u, each prediction is followed by its expanded uncertainty U (k = 2).
    let banded = result.predicted_u.is_some();
    let predicted_label = if banded {
        format!("predicted {unit} ± U")
    } else {
        format!("predicted {unit}")
    };
    let measured_label = format!("measured {unit}");
    let predicted_cell = |p: f64, u: Option<f64>| match u {
        Some(u) => format!("{} ± {}", value(p), value(COVERAGE_FACTOR * u)),
        None => value(p),
    };
    outln!("{}", result.title);
    outln!("  inputs: {}", result.inputs);
    let width = result.position_label.chars().count().max(10);
    let cell = 12;
    let predicted_width = if banded { 22 } else { cell };
    let mut header = format!("  {:>width$}", result.position_label);
    let mut units = format!("  {:>width$}", "");
    for name in &result.curve_names {
        header += &format!(" | {name:>predicted_width$}");
        units += &format!(" | {predicted_label:>predicted_width$}");
        if result.measured.is_some() {
            header += &format!(" {:>cell$} {:>cell$}", "", "");
            units += &format!(" {measured_label:>cell$} {:>cell$}", "difference");
        }
    }
    let rows = result.positions.len();
    if !all_rows && rows > ROWS_PRINTED {
        outln!("  {rows} points: --table prints them, --json writes them");
    }
    let shown = if all_rows || rows <= ROWS_PRINTED {
        rows
    } else {
        0
    };
    if shown > 0 {
        outln!("{header}\n{units}");
    }
    for (n, position) in result.positions.iter().enumerate().take(shown) {
        let mut row = format!("  {:>width$}", position_value(*position));
        for (c, curve) in result.predicted.iter().enumerate() {
            let p = curve[n];
            let u = result.predicted_u.as_ref().map(|u| u[c][n]);
            row += &format!(" | {:>predicted_width$}", predicted_cell(p, u));
            if let Some(m) = &result.measured {
                let v = m[c][n];
                row += &format!(" {:>cell$} {:>cell$}", value(v), value(v - p));
            }
        }
        outln!("{row}");
    }
    outln!();
    let name_width = result
        .figures
        .iter()
        .map(|f| f.name.chars().count())
        .max()
        .unwrap_or(6)
        .max(6);
    let mut header = format!(
        "  {:<name_width$} {predicted_label:>predicted_width$}",
        "figure"
    );
    if result.measured.is_some() {
        header += &format!(" {measured_label:>cell$} {:>cell$}", "difference");
    }
    outln!("{header}  meaning");
    for f in &result.figures {
        let p = f.predicted;
        let mut row = format!(
            "  {:<name_width$} {:>predicted_width$}",
            f.name,
            predicted_cell(p, f.predicted_u)
        );
        if let Some(m) = f.measured {
            row += &format!(" {:>cell$} {:>cell$}", value(m), value(m - p));
        }
        outln!("{row}  {}", f.meaning);
    }
    if banded {
        outln!("\n  ± U: expanded uncertainty (k = {COVERAGE_FACTOR}) from the machine's u, first order");
    }
    if let Some(report) = &result.ballbar {
        print_ballbar(report);
    }
    if let Some(d) = standards::largest_difference(result) {
        outln!("\n  largest |measured − predicted|: {} {unit}", value(d));
    }
}

/// A circle's ballbar diagnostics, predicted and measured side by side; a reversal's step or
/// spike and a cyclic error that do not stand above the detection limit read "not detected".
fn print_ballbar(report: &standards::ballbar::BallbarReport) {
    let [u, v] = report.axes;
    outln!(
        "\n  ballbar diagnostics (radius {})",
        numbers::length_mm(report.radius_mm)
    );
    // The diagnostics are in µm and µrad already.
    let um = |value: f64| numbers::error(value / 1e3);
    let urad = |value: f64| numbers::angle(value / 1e6);
    let shown = |value: f64, found: bool| {
        if found {
            um(value)
        } else {
            "not detected".to_string()
        }
    };
    let rows = |d: &standards::ballbar::Diagnostics| -> Vec<(String, String)> {
        let mut rows = vec![
            (
                format!("squareness {u}{v} (µrad; angle − 90°)"),
                urad(d.squareness_urad),
            ),
            (
                format!("scale mismatch {u} − {v} (µm/m)"),
                numbers::quantity(d.scale_mismatch_ppm),
            ),
            (
                "scale mismatch over the radius (µm)".to_string(),
                um(d.scale_mismatch_um),
            ),
            (format!("backlash {u} (µm)"), um(d.backlash_um[0])),
            (format!("backlash {v} (µm)"), um(d.backlash_um[1])),
        ];
        for r in &d.reversals {
            rows.push((
                format!(
                    "reversal of {} at {}: step (µm)",
                    r.axis,
                    numbers::degrees(r.angle_deg)
                ),
                shown(r.step_um, r.step_detected),
            ));
            rows.push((
                format!(
                    "reversal of {} at {}: spike (µm)",
                    r.axis,
                    numbers::degrees(r.angle_deg)
                ),
                shown(r.spike_um, r.spike_detected),
            ));
        }
        if let (Some([cu, cv]), Some([fu, fv])) = (d.cyclic_um, d.cyclic_detected) {
            rows.push((format!("cyclic error {u} (µm)"), shown(cu, fu)));
            rows.push((format!("cyclic error {v} (µm)"), shown(cv, fv)));
        }
        rows.push((
            "left by the figures, RMS (µm)".to_string(),
            um(d.residual_um),
        ));
        rows.push((
            "detection limit, 3 × that RMS (µm)".to_string(),
            um(d.detection_um),
        ));
        rows
    };
    let predicted = rows(&report.predicted);
    let measured = report.measured.as_ref().map(rows);
    let width = predicted
        .iter()
        .map(|(n, _)| n.chars().count())
        .max()
        .unwrap_or(0);
    let mut header = format!("  {:<width$} {:>12}", "figure", "predicted");
    if measured.is_some() {
        header += &format!(" {:>12}", "measured");
    }
    outln!("{header}");
    for (n, (name, value)) in predicted.iter().enumerate() {
        let mut row = format!("  {name:<width$} {value:>12}");
        if let Some(m) = measured.as_ref().and_then(|m| m.get(n)) {
            row += &format!(" {:>12}", m.1);
        }
        outln!("{row}");
    }
    if report.pitch_mm.is_none() {
        outln!("  (cyclic error: give --pitch, the ballscrew's lead)");
    }
}
