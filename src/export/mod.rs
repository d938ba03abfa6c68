//! `volmap export`: one machine model, every controller's compensation table, each with the
//! residual the control leaves when it applies the table as written.
//!
//! The correction a table should hold is the command correction that puts the tool tip on
//! target ([`fitting`]): `d(t) = c(t) − t`, `c(t)` the command whose real tip lands where the
//! ideal machine puts it at `t`. Each format fits its tables to it within its limits and writes
//! them; the core reads the written text back with the format's reader, runs the control's
//! command `c_ctrl(t)` through the model over a grid of the workspace ([`residual`]) and reports
//! the residual `|p_real(c_ctrl(t)) − p_ideal(t)|` against the error before, with what the
//! format cannot hold.
//!
//! Two parts, imports pointing one way:
//! - the core, what every format shares: [`error`] (one error type), [`fitting`] (the
//!   correction, its additive fit, what a structure of tables can hold), [`nodes`] (tables'
//!   nodes), [`format`](mod@format) (a format's facts as data, [`Spec`], and its code, the
//!   [`Format`] and [`Control`] traits), [`residual`], [`uncertainty`] (the nodes' u from the
//!   machine's), and here the run of an export and its [`Report`];
//! - [`formats`]: the controller formats, one file or folder each, each with one `const SPEC:
//!   Spec` (its name, title, layout, limits, structure, what it holds, whether it reads the
//!   direction) and a unit struct implementing [`Format`]; a folder (`fanuc`, `isg`, `siemens`,
//!   `heidenhain`) splits a format into its tables as the control holds them, its writer and
//!   its reader, plain modules that import one another one way.
//!
//! The formats import the core's files, never this one nor the registry; the core reaches the
//! formats only through the registry, [`formats::FORMATS`].
//!
//! Adding a format: one file (or folder) under `formats/` with its `SPEC` and a unit struct
//! implementing [`Format`] (`spec`, `write`, `read`) whose reader hands back a [`Control`]; one
//! line in [`formats::FORMATS`]. The core does the rest: checks the table size against the
//! spec's [`Limits`], calls [`Format::write`], reads the text back with [`Format::read`],
//! refuses tables that correct nothing, and measures and reports the residual.
//!
//! Layer: above model, reference and io; the command line is the only thing that uses it.

pub mod error;
pub mod fitting;
pub mod format;
pub mod formats;
pub mod nodes;
pub mod provenance;
pub mod residual;
pub mod uncertainty;

use std::path::{Path, PathBuf};

use crate::io::atomic::AtomicFile;
use crate::io::FileError;
use crate::model::inputs::Inputs;
use crate::model::{Command, Machine};

pub use error::ExportError;
pub use fitting::{Field, Fitting, Structure, Term};
pub use format::{Control, Format, Layout, Limits, Nodes, Spec, TableInfo, TableSize};
pub use residual::{EvaluationGrid, Figures, NotHeld};
pub use uncertainty::{ExportUncertainty, TableUncertainty};

use formats::FORMATS;

/// The format named `name`.
pub fn format_named(name: &str) -> Result<&'static dyn Format, ExportError> {
    FORMATS
        .iter()
        .copied()
        .find(|f| f.spec().name == name)
        .ok_or_else(|| ExportError::UnknownFormat {
            name: name.to_string(),
            known: FORMATS
                .iter()
                .map(|f| f.spec().name)
                .collect::<Vec<_>>()
                .join(", "),
        })
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
    /// The name the file of a one-file format is written as (`None`: the format's own), for
    /// a file that names itself (Klipper's `[include …]`).
    pub file_name: Option<String>,
    /// The tool's length, mm, along the machine file's tool direction ([`tool_direction`]);
    /// `None`: the machine file's tool offset as it is.
    pub tool_length_mm: Option<f64>,
    /// The version or generation of the control ([`Format::controls`]; `None`: the default).
    pub control: Option<String>,
    /// The compensation point numbers the tables may take, first and last, for a format that
    /// numbers them ([`Format::numbers_points`]); `None`: the format's default.
    pub point_numbers: Option<[i64; 2]>,
    /// The probe's offset from the nozzle, X and Y, mm, in the machine's axes (Klipper's
    /// `[probe] x_offset, y_offset`), for a format that corrects a probe's readings.
    pub probe_offset_mm: Option<[f64; 2]>,
}

/// The control `asked` for among `format`'s, or its default.
pub fn control_of(
    format: &dyn Format,
    asked: Option<&str>,
) -> Result<Option<&'static str>, ExportError> {
    let known = format.controls();
    let name = format.spec().name;
    match asked {
        None => Ok(known.first().copied()),
        Some(_) if known.is_empty() => Err(ExportError::NoControlChoice { format: name }),
        Some(c) => known
            .iter()
            .find(|k| **k == c)
            .copied()
            .map(Some)
            .ok_or_else(|| ExportError::UnknownControl {
                format: name,
                control: c.to_string(),
                known: known.join(", "),
            }),
    }
}

/// The length of the machine's tool: its tool offset's, mm.
pub fn tool_length_mm(machine: &Machine) -> f64 {
    let o = machine.tool_offset_mm;
    (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
}

/// The direction of the machine's tool, from the spindle's end to the tool tip in the spindle
/// frame: its tool offset's, or −Z where it has none (a tool pointing down the spindle).
pub fn tool_direction(machine: &Machine) -> [f64; 3] {
    let o = machine.tool_offset_mm;
    let length = tool_length_mm(machine);
    if length > 0.0 {
        [o[0] / length, o[1] / length, o[2] / length]
    } else {
        [0.0, 0.0, -1.0]
    }
}

/// `machine` with its tool `length_mm` long along [`tool_direction`].
pub fn with_tool_length(machine: &Machine, length_mm: f64) -> Result<Machine, ExportError> {
    if !(length_mm.is_finite() && length_mm >= 0.0) {
        return Err(ExportError::BadToolLength(length_mm));
    }
    let direction = tool_direction(machine);
    let mut m = machine.clone();
    m.tool_offset_mm = direction.map(|c| c * length_mm);
    Ok(m)
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
    /// The tool the tables and the residual are for, in words: its length, direction and
    /// where the length comes from.
    pub tool: String,
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
    /// The uncertainty of the tables' nodes from the machine's u, and whether the residual is
    /// within it; `None` where the machine gives no uncertainties.
    pub uncertainty: Option<ExportUncertainty>,
}

/// An export: the files as written and the report.
pub struct Export {
    /// The format's facts: where its files go, its name for messages.
    pub spec: &'static Spec,
    /// The files the control reads.
    pub files: Vec<format::WrittenFile>,
    /// The report written beside them in a folder format's folder
    /// ([`provenance::REPORT_FILE`]; a one-file format carries it as comments).
    pub report_file: Option<format::WrittenFile>,
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

/// The tool of `machine` in words: length, direction, and whether the length was asked for.
fn tool_text(machine: &Machine, asked: bool) -> String {
    let length = tool_length_mm(machine);
    let [x, y, z] = tool_direction(machine);
    let from = if asked {
        "the length asked for"
    } else {
        "the machine file's tool offset"
    };
    format!("{length:.3} mm along ({x:.6}, {y:.6}, {z:.6}) in the spindle frame ({from})")
}

/// The points per axis (`None`: a fixed-factor format) and the spacing asked for, checked
/// against the limits of the format `spec` over the travels `ranges`.
pub fn table_points(
    spec: &Spec,
    size: TableSize,
    ranges: &[[f64; 2]; 3],
) -> Result<(Option<[usize; 3]>, Option<f64>), ExportError> {
    let limits = spec.limits;
    let name = spec.name;
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
                    points: n.to_string(),
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
            // Nodes lie up to a spacing beyond a travel's end: one wider than every travel
            // makes tables of two nodes, the last that far out, where no machine was measured.
            let longest_mm = (0..3).map(length).fold(0.0, f64::max);
            if s > longest_mm {
                return Err(ExportError::SpacingTooLarge {
                    spacing_mm: s,
                    longest_mm,
                });
            }
            let mut points = [0; 3];
            for (d, count) in points.iter_mut().enumerate() {
                // The nodes cover the travel: the last at or beyond its end. Counted in f64: a
                // spacing of 1e-310 mm makes more nodes than any integer holds.
                let n = (length(d) / s - 1e-9).ceil().max(1.0) + 1.0;
                if n.is_nan() || n > limits.max_points as f64 {
                    return Err(ExportError::TooManyPoints {
                        format: name,
                        axis: format!(
                            " along {} ({} mm at {} mm)",
                            fitting::LINEAR[d],
                            length(d),
                            crate::limits::number_words(s)
                        ),
                        points: crate::limits::count_words(n),
                        max: limits.max_points,
                        limits_from: limits.source,
                    });
                }
                let n = n as usize;
                *count = n.max(limits.min_points);
            }
            Ok((Some(points), Some(s)))
        }
    }
}

/// Fits, writes (in memory), reads back and measures an export of `request` in `format`.
pub fn export(format: &dyn Format, request: &Request) -> Result<Export, ExportError> {
    let sized;
    let machine = match request.tool_length_mm {
        Some(length) => {
            sized = with_tool_length(request.machine, length)?;
            &sized
        }
        None => request.machine,
    };
    let inputs = request.inputs;
    let pose_words = pose_text(machine, &request.pose);
    let tool_words = tool_text(machine, request.tool_length_mm.is_some());
    let control = control_of(format, request.control.as_deref())?;
    let mut header = vec![
        request.written_by.clone(),
        format!("machine: {}", machine.name),
        format!("inputs: {}", inputs.describe(machine)),
        format!("pose (rotary axes, degrees): {pose_words}"),
        format!("tool: {tool_words}"),
    ];
    if let Some(c) = control {
        header.push(format!("control: {} {c}", format.spec().name));
    }
    let spec = format.spec_for(control);
    let mut fitting = Fitting::new(machine, inputs, request.pose, header)?;
    fitting.file_name = request.file_name.clone();
    fitting.control = control;
    if let Some(numbers) = request.point_numbers {
        if !format.numbers_points() {
            return Err(ExportError::NoPointNumbers {
                format: format.spec().name,
            });
        }
        fitting.point_numbers = Some(numbers);
    }
    if let Some([x_mm, y_mm]) = request.probe_offset_mm {
        if !format.takes_probe_offset() {
            return Err(ExportError::NoProbe {
                format: format.spec().name,
            });
        }
        if !(x_mm.is_finite() && y_mm.is_finite()) {
            return Err(ExportError::BadProbeOffset { x_mm, y_mm });
        }
        fitting.probe_offset_mm = Some([x_mm, y_mm]);
    }
    let ranges = fitting.ranges;
    let (points, spacing) = table_points(spec, request.size, &ranges)?;
    let mut files = format.write(&fitting, points, spacing)?;
    let control = format.read_for(&files, &fitting)?;
    let tables = control.tables();
    let table_points = tables.iter().map(|t| t.points).max().unwrap_or(2);
    let n = match request.evaluation_points {
        Some(n) if !(2..=residual::MAX_RESIDUAL_GRID_POINTS).contains(&n) => {
            return Err(ExportError::BadEvaluationGrid {
                points: n,
                max: residual::MAX_RESIDUAL_GRID_POINTS,
            })
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
            format: spec.name,
            holds: spec.holds,
        });
    }
    let node_u = uncertainty::of_tables(
        &fitting,
        control.as_ref(),
        &tables,
        measured.residual.max_mm,
    );
    let at_inputs = machine.at(inputs);
    let structure = spec.structure;
    let not_held = residual::not_held(&at_inputs, structure, request.pose, &ranges)?;
    let coarse: [Vec<f64>; 3] =
        std::array::from_fn(|d| fitting.travel(d, fitting::AVERAGING_POINTS));
    let structural_mm = fitting::structural_remainder(fitting.field(), structure, &coarse)?;
    let mut report = Report {
        format: spec.name,
        controller: spec.title,
        machine: machine.name.clone(),
        inputs: inputs.describe(machine),
        pose: pose_words,
        tool: tool_words,
        files: files.iter().map(|f| f.name.clone()).collect(),
        tables,
        grid,
        before: measured.before,
        residual: measured.residual,
        before_offset_free: measured.before_offset_free,
        residual_offset_free: measured.residual_offset_free,
        holds: spec.holds,
        uses_direction: spec.uses_direction,
        structural_mm,
        not_held,
        uncertainty: node_u,
    };
    // Each table's uncertainty as a comment in its own file, where the format has one.
    if let Some(u) = &report.uncertainty {
        let notes: Vec<(String, String)> = u
            .tables
            .iter()
            .map(|t| (t.table.clone(), uncertainty::comment_line(t)))
            .collect();
        format.note_tables(&mut files, &notes);
    }
    // The report goes where the tables are kept, and the files are read back with it.
    let lines = provenance::report_lines(&report);
    let report_file = provenance::attach(format, &mut files, &fitting.header, &lines);
    let sample: Vec<[f64; 3]> = residual::targets(&report.grid, &ranges)
        .into_iter()
        .step_by(97)
        .collect();
    provenance::check_read_back(
        format,
        &files,
        &fitting,
        control.as_ref(),
        &sample,
        &inputs.approach,
    )?;
    report.files = files
        .iter()
        .chain(&report_file)
        .map(|f| f.name.clone())
        .collect();
    Ok(Export {
        spec,
        files,
        report_file,
        report,
    })
}

impl Export {
    /// Refuses the export when its largest residual is above `limit_mm`.
    pub fn check_residual(&self, limit_mm: f64) -> Result<(), ExportError> {
        let r = &self.report;
        if r.residual.max_mm > limit_mm {
            return Err(ExportError::ResidualAbove {
                format: self.spec.name,
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
        let paths: Vec<PathBuf> = match self.spec.layout {
            Layout::File => vec![out.to_path_buf()],
            Layout::Folder => {
                if out.exists() && !out.is_dir() {
                    return Err(ExportError::NotAFolder(
                        out.display().to_string(),
                        self.spec.name,
                    ));
                }
                std::fs::create_dir_all(out).map_err(|e| FileError::write(out, e))?;
                self.files
                    .iter()
                    .chain(&self.report_file)
                    .map(|f| out.join(&f.name))
                    .collect()
            }
        };
        let mut pending = Vec::new();
        for (path, file) in paths.iter().zip(self.files.iter().chain(&self.report_file)) {
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
