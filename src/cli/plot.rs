//! `volmap plot` (a field slice as a colour map, the deformed workspace grid) and the `--plot`
//! of the standard tests.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use volmap::io::field::FieldError;
use volmap::io::vtk;
use volmap::model::poses;
use volmap::part::uncertainty::COVERAGE_FACTOR;
use volmap::plot::{self, Color, Marker, Series};
use volmap::query::{self, Quantity, QueryError};
use volmap::standards::TestResult;

use super::args::{full_travel, DefaultMachineArg, GridArg, PoseArg};
use super::failure::{Failure, FlagContext};
use super::output::{check_plot_paths, write_plot};

const CURVE_COLOURS: [Color; 3] = [Color::BLUE, Color::ORANGE, Color::GREEN];

/// The test's curves, predicted solid and measured dashed, in one chart (polar for circles).
/// Curves of an approach direction (ISO 230-2's ↑ and ↓) mark their targets with triangles
/// pointing that way, measured runs draw their ±2s band, and a machine with `u` the band
/// predicted ± U (k = 2) about each prediction.
pub fn write_test_plot(path: &Path, result: &TestResult) -> Result<(), Failure> {
    let mut series = Vec::new();
    for (n, name) in result.curve_names.iter().enumerate() {
        let colour = CURVE_COLOURS[n % CURVE_COLOURS.len()];
        let scale = if result.polar.is_some() {
            1.0
        } else {
            result.unit.shown().0
        };
        let marker = if name.contains('↑') {
            Marker::Up
        } else if name.contains('↓') {
            Marker::Down
        } else {
            Marker::None
        };
        // The machine's u draws the band predicted ± U (k = 2) about the prediction.
        let band: Option<Vec<f64>> = result
            .predicted_u
            .as_ref()
            .map(|u| u[n].iter().map(|v| COVERAGE_FACTOR * v * scale).collect());
        series.push(Series {
            name: match band {
                Some(_) => format!("{name}, predicted (thin: ± U (k = 2))"),
                None => format!("{name}, predicted"),
            },
            x: result.positions.clone(),
            y: result.predicted[n].iter().map(|v| v * scale).collect(),
            color: colour,
            dashed: false,
            marker,
            band,
        });
        if let Some(measured) = &result.measured {
            let band = result
                .measured_2s
                .as_ref()
                .map(|b| b[n].iter().map(|v| v * scale).collect());
            series.push(Series {
                name: match band {
                    Some(_) => format!("{name}, measured (thin: ±2s)"),
                    None => format!("{name}, measured"),
                },
                x: result.positions.clone(),
                y: measured[n].iter().map(|v| v * scale).collect(),
                color: if result.curve_names.len() == 1 {
                    Color::RED
                } else {
                    colour
                },
                dashed: true,
                marker,
                band,
            });
        }
    }
    let drawing = match result.polar {
        Some([first, second]) => plot::polar_chart(
            &result.title,
            (&first.to_string(), &second.to_string()),
            &series,
        ),
        None => plot::line_chart(
            &result.title,
            &result.position_label,
            &format!("error ({})", result.unit.shown().1),
            &series,
        ),
    }?;
    write_plot(&drawing, path, "--plot")
}

#[derive(clap::Args)]
pub struct PlotArgs {
    #[command(subcommand)]
    kind: PlotKind,
}

#[derive(clap::Subcommand)]
enum PlotKind {
    /// A slice of a field file as a colour map with a scale bar.
    Slice {
        /// The field file (.exr) written by `volmap map`.
        #[arg(long)]
        field: PathBuf,
        /// The pose whose part of a five-axis map (`map --poses`) to draw, degrees, e.g.
        /// `B=30,C=45`; rotary axes not named are at 0.
        #[arg(long, allow_hyphen_values = true)]
        pose: Option<String>,
        /// The axis across the slice: x, y or z.
        #[arg(long, default_value = "z")]
        normal: String,
        /// Where to cut, mm along that axis (the nearest grid plane; default: the middle).
        #[arg(long, allow_hyphen_values = true)]
        at: Option<f64>,
        /// What to show: VE (|VE|, mm), OE (|OE|, rad) or one channel: VE.X … OE.Z; of a field
        /// mapped with --uncertainty (or --uncertainty-samples), u (|u(VE)|, the root sum of
        /// squares of u(VE.X), u(VE.Y), u(VE.Z), mm) or one channel's: u(VE.X) … u(OE.Z).
        #[arg(long, default_value = "VE")]
        quantity: String,
        /// Output files: .svg or .png, or .vti for the slice as VTK ImageData (ParaView).
        #[arg(long, required = true)]
        out: Vec<PathBuf>,
    },
    /// The workspace grid displaced by the magnified volumetric error (Hwang et al., Fig. 9).
    #[command(mut_arg("grid", |a| a.default_value("5x5x5").help("Grid lines along X, Y and Z, `NXxNYxNZ`")))]
    Grid {
        #[command(flatten)]
        machine: DefaultMachineArg,
        #[command(flatten)]
        grid: GridArg,
        #[command(flatten)]
        pose: PoseArg,
        /// Magnification of the error (default: the largest error drawn as 8% of the workspace).
        #[arg(long)]
        scale: Option<f64>,
        /// Output files (.svg or .png).
        #[arg(long, required = true)]
        out: Vec<PathBuf>,
    },
}

pub fn run(args: PlotArgs) -> Result<ExitCode, Failure> {
    let is_vti = |p: &PathBuf| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("vti"));
    let (images, outputs): (Vec<PathBuf>, Vec<PathBuf>) = match &args.kind {
        PlotKind::Slice { out, .. } => out.iter().cloned().partition(is_vti),
        PlotKind::Grid { out, .. } => (Vec::new(), out.clone()),
    };
    check_plot_paths(&outputs, "--out")?;
    let every: Vec<(&str, Option<&std::path::Path>)> = images
        .iter()
        .chain(&outputs)
        .map(|p| ("--out", Some(p.as_path())))
        .collect();
    super::output::check_distinct_outputs(&every)?;
    let drawing = match args.kind {
        PlotKind::Slice {
            field,
            pose,
            normal,
            at,
            quantity,
            ..
        } => {
            if Quantity::parse(&quantity).is_none() {
                return Err(Failure::input(format!(
                    "--quantity: `{}` is not a quantity: expected {}",
                    volmap::error::excerpt(&quantity),
                    Quantity::choices()
                )));
            }
            let degrees = pose
                .as_deref()
                .map(poses::parse_pose_degrees)
                .transpose()
                .flag("--pose")?;
            let asked = degrees.zip(pose.as_deref().map(str::trim));
            let slice =
                query::field_slice_at_pose(&field, asked, &normal, at, &quantity).map_err(|e| {
                    let (flag, hint) = match &e {
                        QueryError::SliceNormal(_) => ("--normal", None),
                        QueryError::SliceOutside { .. } => ("--at", None),
                        QueryError::Field(FieldError::NoPose { .. }) => ("--pose", None),
                        QueryError::Field(FieldError::NoUncertainty { .. }) => (
                            "--quantity",
                            Some(
                                "map the machine with --uncertainty (or --uncertainty-samples N) to write them, or ask for a quantity of the values"
                                    .to_string(),
                            ),
                        ),
                        QueryError::Field(FieldError::Poses { poses, .. }) => (
                            "--field",
                            Some(format!(
                                "--pose picks one, e.g. --pose {}",
                                poses.split(' ').next().unwrap_or_default()
                            )),
                        ),
                        _ => ("--field", None),
                    };
                    let failure = Failure::from(e).context(flag);
                    match hint {
                        Some(hint) => failure.hint(hint),
                        None => failure,
                    }
                })?;
            for path in &images {
                vtk::write_image(path, &slice.image, &slice.array_name, &slice.values)
                    .flag("--out")?;
                errln!("VTK image: {}", path.display());
            }
            if outputs.is_empty() {
                return Ok(ExitCode::SUCCESS);
            }
            plot::colour_map(
                &slice.title,
                (&slice.labels[0], &slice.labels[1]),
                slice.extent,
                slice.cols,
                slice.rows,
                &slice.values,
                plot::ColourBar {
                    label: &slice.unit,
                    signed: slice.signed,
                },
            )?
        }
        PlotKind::Grid {
            machine,
            grid,
            pose,
            scale,
            ..
        } => {
            let machine = machine.load()?;
            let grid = full_travel(&machine, &grid, &pose)?;
            let deformed = query::deformed_grid(&machine, &grid, scale).map_err(|e| {
                let flag = match &e {
                    QueryError::DrawnPoints { .. } | QueryError::NoGridLine(_) => "--grid",
                    QueryError::Scale(_) => "--scale",
                    _ => "--machine",
                };
                Failure::from(e).context(flag)
            })?;
            // A machine with rotary axes is drawn at one pose: the title says which.
            let pose = poses::pose_name(&grid.pose, &machine);
            let at = if pose.is_empty() {
                String::new()
            } else {
                format!(" at {pose}")
            };
            plot::deformed_grid(
                &format!(
                    "{}{at}: the workspace deformed by its volumetric error",
                    machine.name
                ),
                &format!(
                    "error magnified {:.0}×; largest |VE| {:.1} µm",
                    deformed.scale,
                    deformed.largest_mm * 1000.0
                ),
                &deformed.nominal,
                &deformed.deformed,
            )?
        }
    };
    for path in &outputs {
        write_plot(&drawing, path, "--out")?;
    }
    Ok(ExitCode::SUCCESS)
}
