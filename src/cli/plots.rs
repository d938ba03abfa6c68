//! `--plot` of the tests and `volmap plot`: drawings written to the files the command line names.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use volmap::plot::{self, Color, Series};
use volmap::standards::TestResult;

use super::super::{bad_input, Failure};

/// A plot written to its file: an unknown extension is bad input, a failed write a failure.
fn write(drawing: &plot::Drawing, path: &Path) -> Result<(), Failure> {
    drawing.write(path).map_err(|e| match e {
        plot::PlotError::Format { .. } => bad_input(e),
        other => other.into(),
    })?;
    eprintln!("plot: {}", path.display());
    Ok(())
}

const CURVE_COLOURS: [Color; 3] = [Color::BLUE, Color::ORANGE, Color::GREEN];

/// The test's curves, predicted solid and measured dashed, in one chart (polar for circles).
pub fn write_test_plot(path: &Path, result: &TestResult) -> Result<(), Failure> {
    let mut series = Vec::new();
    for (n, name) in result.curve_names.iter().enumerate() {
        let colour = CURVE_COLOURS[n % CURVE_COLOURS.len()];
        let scale = if result.polar.is_some() { 1.0 } else { 1000.0 };
        series.push(Series {
            name: format!("{name}, predicted"),
            x: result.positions.clone(),
            y: result.predicted[n].iter().map(|v| v * scale).collect(),
            color: colour,
            dashed: false,
        });
        if let Some(measured) = &result.measured {
            series.push(Series {
                name: format!("{name}, measured"),
                x: result.positions.clone(),
                y: measured[n].iter().map(|v| v * scale).collect(),
                color: if result.curve_names.len() == 1 {
                    Color::RED
                } else {
                    colour
                },
                dashed: true,
            });
        }
    }
    let drawing = match result.polar {
        Some([first, second]) => plot::polar_chart(
            &result.title,
            (&first.to_string(), &second.to_string()),
            &series,
        ),
        None => plot::line_chart(&result.title, &result.position_label, "error (µm)", &series),
    }
    .map_err(bad_input)?;
    write(&drawing, path)
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
        /// The axis across the slice: x, y or z.
        #[arg(long, default_value = "z")]
        normal: String,
        /// Where to cut, mm along that axis (the nearest grid plane; default: the middle).
        #[arg(long, allow_hyphen_values = true)]
        at: Option<f64>,
        /// What to show: VE (|VE|, mm), OE (|OE|, rad) or one channel: VE.X … OE.Z.
        #[arg(long, default_value = "VE")]
        quantity: String,
        /// Output files (.svg or .png).
        #[arg(long, required = true)]
        out: Vec<PathBuf>,
    },
    /// The workspace grid displaced by the magnified volumetric error (Hwang et al., Fig. 9).
    Grid {
        /// An embedded machine's name or a machine file.
        #[arg(long, default_value = volmap::io::embedded::DEFAULT_MACHINE)]
        machine: String,
        /// Grid lines along X, Y, Z.
        #[arg(long, default_value = "5x5x5")]
        grid: String,
        /// Rotary axes' positions, degrees.
        #[arg(long, default_value = "")]
        pose: String,
        /// Magnification of the error (default: the largest error drawn as 8% of the workspace).
        #[arg(long)]
        scale: Option<f64>,
        /// Output files (.svg or .png).
        #[arg(long, required = true)]
        out: Vec<PathBuf>,
    },
}

pub fn run_plot(args: PlotArgs) -> Result<ExitCode, Failure> {
    let outputs = match &args.kind {
        PlotKind::Slice { out, .. } | PlotKind::Grid { out, .. } => out,
    };
    for path in outputs {
        plot::format_of(path).map_err(bad_input)?;
    }
    match args.kind {
        PlotKind::Slice {
            field,
            normal,
            at,
            quantity,
            out,
        } => {
            let slice =
                volmap::query::field_slice(&field, &normal, at, &quantity).map_err(bad_input)?;
            let drawing = plot::colour_map(
                &slice.title,
                (&slice.labels[0], &slice.labels[1]),
                slice.extent,
                slice.cols,
                slice.rows,
                &slice.values,
                &slice.unit,
            )
            .map_err(bad_input)?;
            for path in &out {
                write(&drawing, path)?;
            }
        }
        PlotKind::Grid {
            machine,
            grid,
            pose,
            scale,
            out,
        } => {
            let machine = volmap::io::embedded::load(&machine).map_err(bad_input)?;
            let dims = volmap::model::grid::parse_dims(&grid).map_err(bad_input)?;
            let pose = volmap::model::grid::parse_pose(&pose, &machine).map_err(bad_input)?;
            let grid =
                volmap::model::grid::Grid::full_travel(&machine, dims, pose).map_err(bad_input)?;
            let deformed = volmap::query::deformed_grid(&machine, &grid, scale);
            let drawing = plot::deformed_grid(
                &format!(
                    "{}: the workspace deformed by its volumetric error",
                    machine.name
                ),
                &format!(
                    "error magnified {:.0}×; largest |VE| {:.1} µm",
                    deformed.scale,
                    deformed.largest_mm * 1000.0
                ),
                &deformed.nominal,
                &deformed.deformed,
            )
            .map_err(bad_input)?;
            for path in &out {
                write(&drawing, path)?;
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
