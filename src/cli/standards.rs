//! `volmap test`, `volmap fit`, `volmap build`: standard tests from a model, measured data in.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use volmap::io::embedded;
use volmap::standards::{self, Setup, TestResult};

use super::super::{bad_input, write_atomically, Failure};

/// Three numbers `X,Y,Z` in mm.
fn parse_xyz(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{text}`: expected three numbers X,Y,Z (mm)"))?;
    <[f64; 3]>::try_from(values).map_err(|_| format!("`{text}`: expected three numbers X,Y,Z (mm)"))
}

#[derive(clap::Args)]
pub struct TestArgs {
    #[command(subcommand)]
    kind: TestKind,
}

/// What every test takes besides its own parameters.
#[derive(clap::Args)]
struct Common {
    /// An embedded machine's name (see `volmap machines`) or a machine file (TOML).
    #[arg(long, default_value = embedded::DEFAULT_MACHINE)]
    machine: String,
    /// Positions of rotary axes not under test, degrees, e.g. `B=30,C=0` (not named: 0).
    #[arg(long, default_value = "")]
    pose: String,
    /// Measured results to compare with (CSV; the layout of each test is in the README).
    #[arg(long)]
    measured: Option<PathBuf>,
    /// Draw the error curve, predicted and measured, into this file (.svg or .png).
    #[arg(long)]
    plot: Vec<PathBuf>,
    /// Also write the result (curves and figures, mm) as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(clap::Subcommand)]
enum TestKind {
    /// ISO 230-2 positioning of one linear axis: figures A, B, E, M, R.
    Positioning {
        /// The axis: X, Y or Z.
        #[arg(long)]
        axis: String,
        /// Targets evenly over the travel (default: 5 per metre, at least 5).
        #[arg(long)]
        targets: Option<usize>,
        /// Runs per approach direction.
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Where the other linear axes stand, `X,Y,Z` mm (default: mid-travel).
        #[arg(long, value_parser = parse_xyz)]
        at: Option<[f64; 3]>,
        #[command(flatten)]
        common: Common,
    },
    /// ISO 230-6 displacement along a body (PPP NPP PNP PPN) or face (XY-PP, XY-NP, ...)
    /// diagonal.
    Diagonal {
        /// The diagonal's name; it spans the travel box unless --from and --to are given.
        #[arg(long)]
        diagonal: Option<String>,
        /// Start, `X,Y,Z` mm.
        #[arg(long, value_parser = parse_xyz, requires = "to")]
        from: Option<[f64; 3]>,
        /// End, `X,Y,Z` mm.
        #[arg(long, value_parser = parse_xyz, requires = "from")]
        to: Option<[f64; 3]>,
        /// Points along the diagonal, ends included.
        #[arg(long, default_value_t = 21)]
        points: usize,
        #[command(flatten)]
        common: Common,
    },
    /// ISO 230-4 circular test (ballbar): radial deviation around a circle, circular deviation G.
    Circular {
        /// XY, YZ or ZX.
        #[arg(long)]
        plane: String,
        /// Centre, `X,Y,Z` mm (default: mid-travel).
        #[arg(long, value_parser = parse_xyz)]
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
        #[command(flatten)]
        common: Common,
    },
    /// R-test of a rotary axis: the sphere's displacement in X, Y, Z while the linear axes
    /// follow it.
    Rtest {
        /// The rotary axis: A, B or C.
        #[arg(long)]
        axis: String,
        /// The sphere's centre in the workpiece frame, `X,Y,Z` mm (default: the tool tip at
        /// mid-travel).
        #[arg(long, value_parser = parse_xyz)]
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

pub fn run_test(args: TestArgs) -> Result<ExitCode, Failure> {
    let plots = match &args.kind {
        TestKind::Positioning { common, .. }
        | TestKind::Diagonal { common, .. }
        | TestKind::Circular { common, .. }
        | TestKind::Rtest { common, .. } => &common.plot,
    };
    for path in plots {
        volmap::plot::format_of(path).map_err(bad_input)?;
    }
    let (common, result) = match args.kind {
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
                pose: common.pose.clone(),
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
                pose: common.pose.clone(),
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
            common,
        } => {
            let spec = standards::CircularSpec {
                plane,
                centre_mm: centre,
                radius_mm: radius,
                points,
                direction,
                start_deg: start,
                pose: common.pose.clone(),
                csv: common.measured.clone(),
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
                pose: common.pose.clone(),
                csv: common.measured.clone(),
            };
            let result = run_on_machine(&common, |setup| standards::rtest(setup, &spec))?;
            (common, result)
        }
    };
    print_result(&result);
    for path in &common.plot {
        super::plots::write_test_plot(path, &result)?;
    }
    if let Some(path) = &common.json {
        let text = serde_json::to_string_pretty(&result).context("encoding the result")?;
        write_atomically(path, |out| writeln!(out, "{text}"))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs a test on the machine `common` names, with the rotary axes at its pose.
fn run_on_machine(
    common: &Common,
    test: impl FnOnce(&Setup) -> Result<TestResult, standards::StandardsError>,
) -> Result<TestResult, Failure> {
    let machine = embedded::load(&common.machine).map_err(bad_input)?;
    let setup = Setup::new(&machine, &common.pose).map_err(bad_input)?;
    test(&setup).map_err(bad_input)
}

const UM_PER_MM: f64 = 1000.0;

/// The point-by-point table (µm) and the figures, predicted and measured side by side.
fn print_result(result: &TestResult) {
    println!("{}", result.title);
    let width = result.position_label.chars().count().max(10);
    let cell = 12;
    let mut header = format!("  {:>width$}", result.position_label);
    let mut units = format!("  {:>width$}", "");
    for name in &result.curve_names {
        header += &format!(" | {name:>cell$}");
        units += &format!(" | {:>cell$}", "predicted µm");
        if result.measured.is_some() {
            header += &format!(" {:>cell$} {:>cell$}", "", "");
            units += &format!(" {:>cell$} {:>cell$}", "measured µm", "difference");
        }
    }
    println!("{header}\n{units}");
    for (n, position) in result.positions.iter().enumerate() {
        let mut row = format!("  {position:>width$.3}");
        for (c, curve) in result.predicted.iter().enumerate() {
            let p = curve[n] * UM_PER_MM;
            row += &format!(" | {p:>cell$.3}");
            if let Some(m) = &result.measured {
                let v = m[c][n] * UM_PER_MM;
                row += &format!(" {v:>cell$.3} {:>cell$.3}", v - p);
            }
        }
        println!("{row}");
    }
    println!();
    let name_width = result
        .figures
        .iter()
        .map(|f| f.name.chars().count())
        .max()
        .unwrap_or(6)
        .max(6);
    let mut header = format!("  {:<name_width$} {:>cell$}", "figure", "predicted µm");
    if result.measured.is_some() {
        header += &format!(" {:>cell$} {:>cell$}", "measured µm", "difference");
    }
    println!("{header}  meaning");
    for f in &result.figures {
        let p = f.predicted_mm * UM_PER_MM;
        let mut row = format!("  {:<name_width$} {p:>cell$.3}", f.name);
        if let Some(m) = f.measured_mm {
            let m = m * UM_PER_MM;
            row += &format!(" {m:>cell$.3} {:>cell$.3}", m - p);
        }
        println!("{row}  {}", f.meaning);
    }
    if let Some(d) = standards::largest_difference(result) {
        println!(
            "\n  largest |measured − predicted|: {:.3} µm",
            d * UM_PER_MM
        );
    }
}

#[derive(clap::Args)]
pub struct FitArgs {
    /// The machine whose location errors are estimated (embedded name or file); its other
    /// errors are taken as they are.
    #[arg(long, default_value = embedded::DEFAULT_MACHINE)]
    machine: String,
    /// The measurements file (TOML): `estimate = [...]` and the tests with their CSV files.
    #[arg(long)]
    measurements: PathBuf,
    /// Write the machine file with the estimates in.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the estimates as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run_fit(args: FitArgs) -> Result<ExitCode, Failure> {
    use volmap::calibrate::fit;
    let machine = embedded::load(&args.machine).map_err(bad_input)?;
    let file = fit::FitFile::read(&args.measurements).map_err(bad_input)?;
    let report = fit::fit(&machine, &file).map_err(bad_input)?;
    println!(
        "least-squares fit of {} location error(s) to {} measured points ({} degrees of freedom)",
        report.estimates.len(),
        report.points,
        report.degrees_of_freedom
    );
    println!(
        "  {:<6} {:>14} {:>14} {:>14}  unit",
        "error", "as given", "estimate", "uncertainty"
    );
    for e in &report.estimates {
        println!(
            "  {:<6} {:>14.6e} {:>14.6e} {:>14.3e}  {}",
            e.name, e.initial, e.value, e.uncertainty, e.unit
        );
    }
    println!(
        "  RMS residual: {:.3} µm with the machine as given, {:.3} µm with the estimates",
        report.rms_before_mm * UM_PER_MM,
        report.rms_after_mm * UM_PER_MM
    );
    println!("  (uncertainty: one standard uncertainty, from the residuals)");
    if let Some(path) = &args.out {
        let text = fit::fitted_machine_toml(&machine, &report.estimates).map_err(bad_input)?;
        write_atomically(path, |out| out.write_all(text.as_bytes()))?;
        println!("  machine with the estimates: {}", path.display());
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report).context("encoding the report")?;
        write_atomically(path, |out| writeln!(out, "{text}"))?;
    }
    Ok(ExitCode::SUCCESS)
}

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
}

pub fn run_build(args: BuildArgs) -> Result<ExitCode, Failure> {
    use volmap::calibrate::build;
    use volmap::model::AxisLetter;
    let base = embedded::load(&args.base).map_err(bad_input)?;
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
                bad_input(anyhow::anyhow!(
                    "--axis {pair}: expected AXIS=FILE.csv, e.g. X=x.csv"
                ))
            })?;
        axes.push((letter, PathBuf::from(path.trim())));
    }
    let asked = build::parse_interp_choices(&args.interp).map_err(bad_input)?;
    let axes_ref: Vec<_> = axes.iter().map(|(l, p)| (*l, p.as_path())).collect();
    let (text, built) = build::build(&base, &axes_ref, &asked).map_err(bad_input)?;
    // The new file must read back as a machine before it replaces anything.
    let folder = args
        .out
        .parent()
        .map(std::path::Path::to_path_buf)
        .unwrap_or_default();
    volmap::model::Machine::from_toml(&text, &args.out.display().to_string(), Some(&folder))
        .map_err(bad_input)?;
    write_atomically(&args.out, |out| out.write_all(text.as_bytes()))?;
    println!(
        "{}: {} component table(s) from measurements",
        args.out.display(),
        built.len()
    );
    println!(
        "  {:<5} {:>5}  {:<10} {:>32}  why",
        "error", "nodes", "interp", "leave-one-out RMS (µm or µrad)"
    );
    for c in &built {
        let scores: Vec<String> = c
            .leave_one_out
            .iter()
            .map(|(name, s)| {
                format!(
                    "{name} {:.3}",
                    s * 1e3_f64.powi(if c.index < 3 { 1 } else { 2 })
                )
            })
            .collect();
        println!(
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
    Ok(ExitCode::SUCCESS)
}
