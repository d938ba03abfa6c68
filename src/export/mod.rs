//! `volmap export`: one machine model, every controller's compensation table, each with the
//! residual the control leaves when it applies the table as written.
//!
//! The correction a table should hold is the command correction that puts the tool tip on
//! target ([`fitting`]): `d(t) = c(t) − t`, `c(t)` the command whose real tip lands where the
//! ideal machine puts it at `t`. Each format ([`format::Format`], one file each) fits its tables
//! to it within its limits and writes them; the core reads the written text back with the
//! format's reader, runs the control's command `c_ctrl(t)` through the model over a grid
//! of the workspace ([`residual`]) and reports the residual `|p_real(c_ctrl(t)) − p_ideal(t)|`
//! against the error before, with what the format cannot hold.
//!
//! Layer: above model, reference and io; the command line is the only thing that uses it.

pub mod fitting;
pub mod format;
pub mod nodes;
pub mod residual;

mod axis_tables;
mod fanuc;
mod fanuc_lattice;
mod grid_csv;
mod heidenhain;
mod isg;
mod isg_axis;
mod klipper;
mod linuxcnc;
mod marlin;
mod siemens;
mod skew;

use std::path::{Path, PathBuf};

use crate::error::{Classify, ErrorKind};
use crate::io::atomic::AtomicFile;
use crate::io::FileError;
use crate::model::inputs::Inputs;
use crate::model::{Command, Machine};

pub use fitting::{Field, Fitting};
pub use format::{Control, Format, Layout, Limits, Nodes, Structure, TableInfo, TableSize, Term};
pub use residual::{EvaluationGrid, Figures, NotHeld};

/// Every format volmap writes, in the order `--format` lists them.
pub static FORMATS: &[&dyn Format] = &[
    &grid_csv::GridCsv,
    &linuxcnc::LinuxCnc,
    &klipper::Klipper,
    &marlin::Marlin,
    &siemens::Siemens,
    &heidenhain::Heidenhain,
    &fanuc::FanucPitch,
    &fanuc_lattice::FanucLattice,
    &isg::Isg,
    &isg_axis::IsgAxis,
];

/// The format named `name`.
pub fn format_named(name: &str) -> Result<&'static dyn Format, ExportError> {
    FORMATS
        .iter()
        .copied()
        .find(|f| f.name() == name)
        .ok_or_else(|| ExportError::UnknownFormat {
            name: name.to_string(),
            known: FORMATS
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("`{name}` is not a format volmap exports (formats: {known})")]
    UnknownFormat { name: String, known: String },
    #[error("the machine (chain {chain}) has no {missing} axis: a compensation table corrects X, Y and Z")]
    MissingAxes { chain: String, missing: String },
    #[error("the linear axes do not span X, Y and Z at the pose")]
    Singular,
    #[error("no command puts the real tool tip on the target X={:.3} Y={:.3} Z={:.3} mm (the Newton steps do not converge): the machine's errors are too large", at_mm[0], at_mm[1], at_mm[2])]
    NoSolution { at_mm: [f64; 3] },
    #[error("{format} holds fixed factors, not tables: there is no table size to choose")]
    NoTableSize { format: &'static str },
    #[error(
        "{points} points{axis} is more than a {format} table holds: at most {max} ({limits_from})"
    )]
    TooManyPoints {
        format: &'static str,
        axis: String,
        points: usize,
        max: usize,
        limits_from: &'static str,
    },
    #[error("{points} points is fewer than a {format} table needs: at least {min}")]
    TooFewPoints {
        format: &'static str,
        points: usize,
        min: usize,
    },
    #[error("a spacing of {spacing_mm} mm{axis} is below the smallest a {format} table takes: {min_mm} mm ({limits_from})")]
    SpacingTooSmall {
        format: &'static str,
        axis: String,
        spacing_mm: f64,
        min_mm: f64,
        limits_from: &'static str,
    },
    #[error("{what} would be {value}: {format} holds {holds}")]
    BeyondFormat {
        format: &'static str,
        what: String,
        value: f64,
        holds: &'static str,
    },
    #[error("a spacing of {0} mm: it must be a positive number of mm")]
    BadSpacing(f64),
    #[error(
        "{points} points per axis for the residual: at least 2 and at most {}",
        residual::MAX_RESIDUAL_GRID_POINTS
    )]
    BadEvaluationGrid { points: usize },
    #[error("{format} can hold none of this machine's errors: {holds}; the table as written corrects nothing")]
    NothingHeld {
        format: &'static str,
        holds: &'static str,
    },
    #[error("the residual of the {format} table, {residual_um:.3} µm largest ({rms_um:.3} µm RMS; {before_um:.3} µm largest before), is above the {limit_um:.3} µm asked for: nothing written")]
    ResidualAbove {
        format: &'static str,
        residual_um: f64,
        rms_um: f64,
        before_um: f64,
        limit_um: f64,
    },
    #[error("the {format} export cannot hold this machine's errors: {message}")]
    Unrepresentable {
        format: &'static str,
        message: String,
    },
    #[error("{0} is not a folder: a {1} export writes several files into a folder")]
    NotAFolder(String, &'static str),
    #[error("reading back {file}: line {line}: {message}")]
    Read {
        file: String,
        line: usize,
        message: String,
    },
    #[error(transparent)]
    File(#[from] FileError),
}

impl Classify for ExportError {
    fn kind(&self) -> ErrorKind {
        match self {
            ExportError::File(e) => e.kind(),
            // What volmap wrote and cannot read back is its own failure, not the user's.
            ExportError::Read { .. } => ErrorKind::Work,
            _ => ErrorKind::Input,
        }
    }
}

/// What to export.
pub struct Request<'a> {
    /// As loaded (its input-dependent errors unresolved).
    pub machine: &'a Machine,
    pub inputs: &'a Inputs,
    /// Every axis's command; the rotary axes' positions are the pose, X, Y, Z unused.
    pub pose: Command,
    pub size: TableSize,
    /// Points per linear axis of the residual's grid (`None`: [`EvaluationGrid::default_points`]).
    pub evaluation_points: Option<usize>,
    /// The first line of every file's header: who wrote it, when, with which command.
    pub written_by: String,
}

/// What an export wrote and what it leaves.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Report {
    pub format: &'static str,
    pub controller: &'static str,
    pub machine: String,
    /// The evaluation inputs in words.
    pub inputs: String,
    /// The rotary axes' positions in words (`B=30 C=0`), or `none`.
    pub pose: String,
    pub files: Vec<String>,
    pub tables: Vec<TableInfo>,
    pub grid: EvaluationGrid,
    pub before: Figures,
    pub residual: Figures,
    /// Both less their mean vector over the grid: what is left once a work offset (a
    /// touch-off) takes up the constant part, which no table needs to hold.
    pub before_offset_free: Figures,
    pub residual_offset_free: Figures,
    /// What the format holds and cannot hold, in words.
    pub holds: &'static str,
    /// Whether the control picks forward or reverse tables by the approach direction.
    pub uses_direction: bool,
    /// The largest part of the machine's correction no table size of the format holds, mm.
    pub structural_mm: f64,
    /// The machine's errors the format cannot hold (all or part), the largest first.
    pub not_held: Vec<NotHeld>,
}

/// An export: the files as written and the report.
pub struct Export {
    pub layout: Layout,
    pub format: &'static str,
    pub files: Vec<format::WrittenFile>,
    pub report: Report,
}

/// The rotary axes of `machine` at `pose`, in words.
pub fn pose_text(machine: &Machine, pose: &Command) -> String {
    let rotary = machine.rotary_axes();
    if rotary.is_empty() {
        return "none (no rotary axes)".into();
    }
    rotary
        .iter()
        .map(|l| format!("{l}={}", pose[l.index()]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The points per axis (`None`: a fixed-factor format) and the spacing asked for, checked
/// against the format's limits over the travels `ranges`.
pub fn table_points(
    format: &dyn Format,
    size: TableSize,
    ranges: &[[f64; 2]; 3],
) -> Result<(Option<[usize; 3]>, Option<f64>), ExportError> {
    let limits = format.limits();
    let name = format.name();
    if limits.nodes == Nodes::Fixed {
        return match size {
            TableSize::Default => Ok((None, None)),
            _ => Err(ExportError::NoTableSize { format: name }),
        };
    }
    let length = |d: usize| ranges[d][1] - ranges[d][0];
    let too_close = |d: usize, spacing: f64| ExportError::SpacingTooSmall {
        format: name,
        axis: format!(" along {}", fitting::LINEAR[d]),
        spacing_mm: spacing,
        min_mm: limits.min_spacing_mm,
        limits_from: limits.source,
    };
    match size {
        TableSize::Default => {
            let points = std::array::from_fn(|d| {
                let fit = if limits.min_spacing_mm > 0.0 {
                    (length(d) / limits.min_spacing_mm).floor() as usize + 1
                } else {
                    usize::MAX
                };
                limits.default_points.min(fit).max(limits.min_points)
            });
            Ok((Some(points), None))
        }
        TableSize::Points(n) => {
            if n < limits.min_points {
                return Err(ExportError::TooFewPoints {
                    format: name,
                    points: n,
                    min: limits.min_points,
                });
            }
            if n > limits.max_points {
                return Err(ExportError::TooManyPoints {
                    format: name,
                    axis: String::new(),
                    points: n,
                    max: limits.max_points,
                    limits_from: limits.source,
                });
            }
            for d in 0..3 {
                let spacing = length(d) / (n - 1) as f64;
                if spacing < limits.min_spacing_mm {
                    return Err(too_close(d, spacing));
                }
            }
            Ok((Some([n; 3]), None))
        }
        TableSize::Spacing(s) => {
            if !(s.is_finite() && s > 0.0) {
                return Err(ExportError::BadSpacing(s));
            }
            if s < limits.min_spacing_mm {
                return Err(ExportError::SpacingTooSmall {
                    format: name,
                    axis: String::new(),
                    spacing_mm: s,
                    min_mm: limits.min_spacing_mm,
                    limits_from: limits.source,
                });
            }
            let mut points = [0; 3];
            for (d, count) in points.iter_mut().enumerate() {
                // The nodes cover the travel: the last at or beyond its end.
                let n = (length(d) / s - 1e-9).ceil().max(1.0) as usize + 1;
                if n > limits.max_points {
                    return Err(ExportError::TooManyPoints {
                        format: name,
                        axis: format!(" along {} ({} mm at {s} mm)", fitting::LINEAR[d], length(d)),
                        points: n,
                        max: limits.max_points,
                        limits_from: limits.source,
                    });
                }
                *count = n.max(limits.min_points);
            }
            Ok((Some(points), Some(s)))
        }
    }
}

/// Fits, writes (in memory), reads back and measures an export of `request` in `format`.
pub fn export(format: &dyn Format, request: &Request) -> Result<Export, ExportError> {
    let machine = request.machine;
    let inputs = request.inputs;
    let pose_words = pose_text(machine, &request.pose);
    let header = vec![
        request.written_by.clone(),
        format!("machine: {}", machine.name),
        format!("inputs: {}", inputs.describe(machine)),
        format!("pose (rotary axes, degrees): {pose_words}"),
    ];
    let fitting = Fitting::new(machine, inputs, request.pose, header)?;
    let ranges = fitting.ranges;
    let (points, spacing) = table_points(format, request.size, &ranges)?;
    let files = format.write(&fitting, points, spacing)?;
    let control = format.read_for(&files, &fitting)?;
    let tables = control.tables();
    let table_points = tables.iter().map(|t| t.points).max().unwrap_or(2);
    let n = match request.evaluation_points {
        Some(n) if !(2..=residual::MAX_RESIDUAL_GRID_POINTS).contains(&n) => {
            return Err(ExportError::BadEvaluationGrid { points: n })
        }
        Some(n) => n,
        None => EvaluationGrid::default_points(table_points),
    };
    let grid = EvaluationGrid::new([n; 3], &ranges);
    let measured = residual::measure(
        fitting.field(),
        control.as_ref(),
        &inputs.approach,
        &grid,
        &ranges,
    );
    if measured.largest_applied_mm == 0.0 {
        return Err(ExportError::NothingHeld {
            format: format.name(),
            holds: format.holds(),
        });
    }
    let at_inputs = machine.at(inputs);
    let structure = format.structure();
    let not_held = residual::not_held(&at_inputs, structure, request.pose, &ranges)?;
    let coarse: [Vec<f64>; 3] =
        std::array::from_fn(|d| fitting.travel(d, fitting::AVERAGING_POINTS));
    let structural_mm = fitting::structural_remainder(fitting.field(), structure, &coarse)?;
    let report = Report {
        format: format.name(),
        controller: format.title(),
        machine: machine.name.clone(),
        inputs: inputs.describe(machine),
        pose: pose_words,
        files: files.iter().map(|f| f.name.clone()).collect(),
        tables,
        grid,
        before: measured.before,
        residual: measured.residual,
        before_offset_free: measured.before_offset_free,
        residual_offset_free: measured.residual_offset_free,
        holds: format.holds(),
        uses_direction: format.uses_direction(),
        structural_mm,
        not_held,
    };
    Ok(Export {
        layout: format.layout(),
        format: format.name(),
        files,
        report,
    })
}

impl Export {
    /// Refuses the export when its largest residual is above `limit_mm`.
    pub fn check_residual(&self, limit_mm: f64) -> Result<(), ExportError> {
        let r = &self.report;
        if r.residual.max_mm > limit_mm {
            return Err(ExportError::ResidualAbove {
                format: self.format,
                residual_um: r.residual.max_mm * 1e3,
                rms_um: r.residual.rms_mm * 1e3,
                before_um: r.before.max_mm * 1e3,
                limit_um: limit_mm * 1e3,
            });
        }
        Ok(())
    }

    /// Writes the files: to `out` for a one-file format, into the folder `out` (created) for
    /// the others. Every file goes to a temporary name first and all are renamed into place
    /// only when all are written, so a failure leaves none of them. Returns the paths written.
    pub fn write(&self, out: &Path) -> Result<Vec<PathBuf>, ExportError> {
        let paths: Vec<PathBuf> = match self.layout {
            Layout::File => vec![out.to_path_buf()],
            Layout::Folder => {
                if out.exists() && !out.is_dir() {
                    return Err(ExportError::NotAFolder(
                        out.display().to_string(),
                        self.format,
                    ));
                }
                std::fs::create_dir_all(out).map_err(|e| FileError::write(out, e))?;
                self.files.iter().map(|f| out.join(&f.name)).collect()
            }
        };
        let mut pending = Vec::new();
        for (path, file) in paths.iter().zip(&self.files) {
            let mut atomic = AtomicFile::create(path, 1 << 16)?;
            use std::io::Write;
            atomic
                .write_all(file.text.as_bytes())
                .map_err(|e| atomic.error(e))?;
            pending.push(atomic);
        }
        for atomic in pending {
            atomic.commit()?;
        }
        Ok(paths)
    }
}
