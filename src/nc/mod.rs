//! Offline NC program compensation (Dobariya, Patel and Jani 2015): the coordinates of an ISO 6983 /
//! Fanuc-style part program are rewritten so that the real tool tip lands where the program
//! wants it.
//!
//! Frames: program coordinates are the work coordinate system of the active work offset
//! (G54–G59), in mm or inch; the machine is commanded at `q = program + work offset` (mm and
//! degrees), which is docs/model.md's commanded position. The programmed point is where the ideal
//! machine puts the tool tip, `ideal(q)`; the compensated command `q'` is the one whose real tool
//! tip lands there, `real(q') = ideal(q)` (workpiece frame), found by Newton steps with the ideal
//! machine's Jacobian in X, Y, Z (exact: the nominal tip is affine in them) until it agrees to
//! 1e-9 mm. Rotary axes stay as programmed: on a five-axis machine the tool tip is put back
//! where it belongs with the rotary axes where the program has them; the tool's orientation error
//! is not corrected (rotary words are never changed) unless the orientation is compensated too
//! (`orientation_tolerance_rad`, see `orientation`): then X, Y, Z and the two rotary axes are
//! solved together so that the real tool tip and tool axis are the ideal ones, and the rotary
//! words are rewritten (with at least 6 decimals of a degree, 9e-9 rad).
//!
//! Between points the control interpolates the compensated commands. A feed move (G1, G2, G3) is
//! split until the real tool tip along every piece stays within the chord tolerance of the
//! intended path at the same fraction of the move (sampled along each piece); an arc stays an
//! arc (with compensated ends and centre) when that already keeps it within the tolerance, and
//! is split into compensated arcs otherwise (`arcs`). Every piece is planned and checked as the
//! output writes it (rounded). Rapid moves (G0) get compensated end points and are not split:
//! the control does not hold their path. `trace` samples the model along a program.
//!
//! Evaluation inputs (docs/model.md): the machine is at the options' temperatures for the whole
//! program; every point is compensated for the approach direction of each axis there, taken
//! from the programmed path (`approach`): the direction the axis moves in on the move, or at
//! that point of an arc, or of its last move where it does not move (the options' initial
//! directions before its first). Where an axis with a reversal error reverses, at the start of
//! a move or at an arc's turning point, a take-up piece moves the command from the point
//! compensated for the old direction to the same point compensated for the new one.
//!
//! Before any of this the program is read as the control runs it: subprogram calls whose body
//! is in the file are run in place (`subprograms`) and canned drilling cycles become the rapid
//! and feed moves the control makes of them (`cycles`), each then compensated like any move.

mod approach;
mod arcs;
mod compensate;
mod cycles;
mod kinematics;
mod orientation;
pub mod parse;
mod program;
mod rotation;
mod subprograms;
mod toolpath;
mod trace;
mod walk;
mod write;

pub use compensate::{compensate, compensate_with_progress, trace, Compensated, TracePoint};
pub use cycles::MAX_PECKS;
pub use subprograms::MAX_EXPANDED_WORDS;

/// The blocks of `program` (its bytes; `path` names it in errors) as the control runs them:
/// subprogram calls and canned cycles expanded, coordinate rotations (G68) applied. With
/// `pass_unknown`, blocks volmap does not follow pass as they are.
pub fn blocks_as_run(
    program: &[u8],
    path: &str,
    pass_unknown: bool,
) -> Result<Vec<parse::Line>, NcError> {
    compensate::as_run(program, path, pass_unknown).map(|(lines, _)| lines)
}
pub use trace::{per_block, trace_compensated, trace_path, TraceSample};

use std::collections::{BTreeMap, HashMap};

use crate::io::{read_text, FileError};
use crate::model::inputs::Inputs;
use crate::model::Machine;

/// Which option of a compensation an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcOption {
    ToolLengths,
    WorkOffsets,
    ChordTolerance,
    Orientation,
    AngularTolerance,
    Decimals,
    /// The distance between the samples of a trace.
    TraceStep,
}

impl std::fmt::Display for NcOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NcOption::ToolLengths => "tool lengths",
            NcOption::WorkOffsets => "work offset",
            NcOption::ChordTolerance => "chord tolerance",
            NcOption::Orientation => "orientation compensation",
            NcOption::AngularTolerance => "angular tolerance",
            NcOption::Decimals => "decimals",
            NcOption::TraceStep => "sampling step",
        })
    }
}

/// What is wrong with a program or the options of its compensation.
#[derive(Debug, thiserror::Error)]
pub enum NcError {
    #[error("{path}: line {line}: {message}")]
    Line {
        path: String,
        line: usize,
        message: String,
    },
    /// The program needs a value of `option` here that was not given.
    #[error("{path}: line {line}: {message}")]
    Missing {
        path: String,
        line: usize,
        option: NcOption,
        message: String,
    },
    /// A block with a code volmap does not follow.
    #[error("{path}: line {line}: {code} is not supported (volmap follows G0 G1 G2 G3 G4 G17 G18 G19 G20 G21 G28 G40 G43 G49 G53 G54–G59 G61 G64 G68 G69 G73 G80–G83 G85 G89 G90 G91 G94 G95 G98 G99, M98 and G65 with their body in the file)")]
    Unsupported {
        path: String,
        line: usize,
        code: String,
    },
    #[error(transparent)]
    File(#[from] FileError),
    /// A work offset file that does not hold work offsets.
    #[error("{path}: {message}")]
    OffsetFile { path: String, message: String },
    /// A work offset turns a rotary axis the machine lacks: the turn would be dropped unseen.
    #[error(
        "G{number} turns {axis} by {turn}°, but the machine (chain {chain}) has no {axis} axis"
    )]
    WorkOffsetAxis {
        number: u32,
        axis: crate::model::AxisLetter,
        /// The turn as shown (degrees).
        turn: String,
        chain: String,
    },
    /// An option's value is wrong.
    #[error("{option} `{value}`: {message}")]
    Option {
        option: NcOption,
        value: String,
        message: String,
    },
}

crate::error::input_errors!(NcError);

impl NcError {
    pub fn line(path: &str, line: usize, message: String) -> NcError {
        NcError::Line {
            path: path.to_string(),
            line,
            message,
        }
    }
}

/// Tool lengths: one for every tool, or per tool number.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolLengths {
    pub all: Option<f64>,
    pub per_tool: HashMap<u32, f64>,
}

impl ToolLengths {
    /// One length for every tool, `120`, or lengths per tool, `T1=80,T2=120.5` (mm, along the spindle axis).
    pub fn parse(text: &str) -> Result<ToolLengths, NcError> {
        let mut lengths = ToolLengths::default();
        let bad = |message: &str| NcError::Option {
            option: NcOption::ToolLengths,
            value: crate::error::excerpt(text).into_owned(),
            message: format!("{message}: a length in mm, or T1=80,T2=120 per tool"),
        };
        if text.trim().is_empty() {
            return Ok(lengths);
        }
        let most = crate::io::machine_file::MAX_PLAUSIBLE_LENGTH_MM;
        let length = |value: &str| {
            value
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.abs() <= most)
                .ok_or_else(|| {
                    bad(&format!(
                        "`{}` is not a length of at most {most} mm",
                        crate::error::excerpt(value.trim())
                    ))
                })
        };
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        for part in &parts {
            match part.split_once('=') {
                None if part.is_empty() => return Err(bad("an empty item")),
                None if parts.len() > 1 => {
                    return Err(bad("one length for every tool stands alone"))
                }
                None => lengths.all = Some(length(part)?),
                Some((tool, value)) => {
                    let number = tool.trim().trim_start_matches(['T', 't']);
                    let number = number.parse().map_err(|_| {
                        bad(&format!("`{}` is not a tool", crate::error::excerpt(tool)))
                    })?;
                    if lengths.per_tool.insert(number, length(value)?).is_some() {
                        return Err(bad(&format!("T{number} is given twice")));
                    }
                }
            }
        }
        Ok(lengths)
    }
}

/// What the compensation needs besides the machine and the program.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Work offsets by number (54–59): machine X, Y, Z (mm) and A, B, C (degrees) of the work
    /// zero. G54 is zero unless given.
    pub work_offsets: HashMap<u32, [f64; 6]>,
    /// Tool lengths; without any, the machine file's tool offset stands.
    pub tool_lengths: ToolLengths,
    /// Largest distance of the real tool tip from the intended path, mm.
    pub chord_tolerance_mm: f64,
    /// Decimals written (default 4 in mm, 5 in inch).
    pub decimals: Option<usize>,
    /// Pass blocks volmap does not understand through unchanged instead of failing.
    pub pass_unknown: bool,
    /// The temperatures of the machine's thermal inputs for the whole program, and the approach
    /// direction of every axis at its start (before the axis first moves).
    pub inputs: Inputs,
    /// Where given, the tool orientation is compensated too (five-axis machines): the largest
    /// angle between the real and the intended tool axis along the path, rad.
    pub orientation_tolerance_rad: Option<f64>,
}

/// The largest chord tolerance, mm: a kilometre, the largest length a machine file holds.
pub const MAX_CHORD_TOLERANCE_MM: f64 = 1e6;

/// The default angular tolerance of the orientation compensation, rad.
pub const DEFAULT_ANGULAR_TOLERANCE_RAD: f64 = 1e-5;

impl Default for Options {
    fn default() -> Options {
        Options {
            work_offsets: HashMap::new(),
            tool_lengths: ToolLengths::default(),
            chord_tolerance_mm: 0.001,
            decimals: None,
            pass_unknown: false,
            inputs: Inputs::default(),
            orientation_tolerance_rad: None,
        }
    }
}

/// Refuses a work offset that turns A, B or C on a machine without that axis (zeros are taken),
/// lowest offset number first.
pub fn check_work_offsets(
    machine: &Machine,
    work_offsets: &HashMap<u32, [f64; 6]>,
) -> Result<(), NcError> {
    let mut numbers: Vec<u32> = work_offsets.keys().copied().collect();
    numbers.sort_unstable();
    for number in numbers {
        let offset = work_offsets[&number];
        for axis in crate::model::AxisLetter::ALL
            .into_iter()
            .filter(|l| !l.is_linear())
        {
            let turn = offset[axis.index()];
            if turn != 0.0 && machine.axis(axis).is_none() {
                return Err(NcError::WorkOffsetAxis {
                    number,
                    axis,
                    turn: crate::error::shown(turn),
                    chain: machine.chain.hwang_notation(),
                });
            }
        }
    }
    Ok(())
}

/// `G54=100,50,-200` (X, Y, Z mm, then optionally A, B, C degrees).
pub fn parse_work_offset(text: &str) -> Result<(u32, [f64; 6]), NcError> {
    let bad = || NcError::Option {
        option: NcOption::WorkOffsets,
        value: crate::error::excerpt(text).into_owned(),
        message: "expected G54=X,Y,Z (mm), e.g. G54=100,50,-200".into(),
    };
    let (name, values) = text.split_once('=').ok_or_else(bad)?;
    let number: u32 = name
        .trim()
        .trim_start_matches(['G', 'g'])
        .parse()
        .map_err(|_| bad())?;
    if !(54..=59).contains(&number) {
        return Err(bad());
    }
    let values: Vec<f64> = values
        .split(',')
        .map(|v| v.trim().parse())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    if values.len() != 3 && values.len() != 6 {
        return Err(bad());
    }
    if let Some(n) = values.iter().position(|v| !v.is_finite()) {
        return Err(NcError::Option {
            option: NcOption::WorkOffsets,
            value: crate::error::excerpt(text).into_owned(),
            message: format!(
                "G{number}: its {} value is not a finite number",
                ["X", "Y", "Z", "A", "B", "C"][n]
            ),
        });
    }
    let mut offset = [0.0; 6];
    offset[..values.len()].copy_from_slice(&values);
    Ok((number, offset))
}

/// Work offsets from a TOML file: `G54 = [X, Y, Z]` (mm, then optionally A, B, C degrees) per
/// offset.
pub fn read_work_offsets(path: &std::path::Path) -> Result<Vec<(u32, [f64; 6])>, NcError> {
    let name = path.display().to_string();
    let file_error = |message: String| NcError::OffsetFile {
        path: name.clone(),
        message,
    };
    let text = read_text(path)?;
    if let Some(message) = crate::error::toml_too_deep(&text) {
        return Err(file_error(message));
    }
    let table: std::collections::BTreeMap<String, Vec<f64>> =
        toml::from_str(&text).map_err(|e| file_error(crate::error::toml_message(&e, &text)))?;
    table
        .into_iter()
        .map(|(key, values)| {
            let text = format!(
                "{key}={}",
                values
                    .iter()
                    .map(f64::to_string)
                    .collect::<Vec<_>>()
                    .join(",")
            );
            parse_work_offset(&text).map_err(|e| file_error(e.to_string()))
        })
        .collect()
}

/// What a compensation run did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Report {
    /// Programmed points compensated (block end points and added pieces).
    pub points: usize,
    pub largest_correction_mm: f64,
    pub blocks_changed: usize,
    pub blocks_added: usize,
    /// Largest distance of the real tool tip from the intended path along the feed moves,
    /// with the program as it was and as compensated, mm; the compensated figure is that of the
    /// program as written (its numbers rounded, arcs about the centres their words give).
    pub largest_error_before_mm: f64,
    pub largest_error_after_mm: f64,
    /// Where the orientation is compensated: the largest angle between the real and the intended
    /// tool axis along the feed moves, with the program as it was and as compensated (rotary
    /// words as written), rad.
    pub largest_orientation_error_before_rad: f64,
    pub largest_orientation_error_after_rad: f64,
    /// Take-up pieces added where an axis with a reversal error reverses (at the start of a
    /// move or at an arc's turning point).
    pub take_ups: usize,
    /// Pieces whose compensated motion runs against the programmed direction of an axis with a
    /// reversal error: the machine approaches them the other way than they were compensated for
    /// (only where a reversal error makes a reversing move shorter than the programmed one).
    pub against_direction: usize,
    /// Canned cycle blocks (holes, modal repeats included) expanded into their rapid and feed
    /// moves, each compensated like any move.
    pub cycle_holes_expanded: usize,
    /// Blocks passed as they are with `pass_unknown` (codes volmap does not follow): not
    /// compensated, and outside the error figures above, which cover compensated moves only.
    pub not_compensated: Vec<PassedBlock>,
    /// The evaluation inputs the program was compensated for.
    pub inputs: ReportInputs,
}

/// A block passed uncompensated: its line and the code volmap does not follow.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassedBlock {
    pub line: usize,
    pub code: String,
}

/// The evaluation inputs of a compensation as a report records them.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ReportInputs {
    /// The direction of every axis of the chain before it first moves (`+` or `-`); after that
    /// each axis approaches in the direction of its programmed motion.
    pub approach_at_start: BTreeMap<char, char>,
    /// The temperature of every declared thermal input for the whole program, °C.
    pub temperatures_c: BTreeMap<String, f64>,
    /// The machine's reference temperature, where it declares thermal inputs.
    pub reference_c: Option<f64>,
    /// The same in words.
    pub description: String,
}

impl ReportInputs {
    pub fn of(inputs: &Inputs, machine: &Machine) -> ReportInputs {
        let thermal = machine.thermal.as_ref();
        ReportInputs {
            approach_at_start: machine
                .chain
                .axes()
                .map(|l| (l.as_char(), inputs.approach[l.index()].sign()))
                .collect(),
            temperatures_c: thermal.map_or_else(BTreeMap::new, |t| {
                t.inputs
                    .iter()
                    .map(|i| (i.clone(), inputs.temperature_c(i, t.reference_c)))
                    .collect()
            }),
            reference_c: thermal.map(|t| t.reference_c),
            description: inputs.describe(machine),
        }
    }
}

/// `program` with `note` as a comment of its own line at its head (after a leading `%` line, the
/// tape delimiter, where there is one): how the program was made. The note is made fit for a
/// comment: parentheses become brackets, and characters outside printable ASCII are dropped.
pub fn with_note(program: &str, note: &str) -> String {
    let note: String = note
        .chars()
        .map(|c| match c {
            '(' => '[',
            ')' => ']',
            c => c,
        })
        .filter(|c| c.is_ascii() && !c.is_ascii_control())
        .collect();
    let comment = format!("({})\n", note.trim());
    let first_line_end = program.find('\n').map_or(program.len(), |e| e + 1);
    if program[..first_line_end].trim() == "%" {
        format!(
            "{}{comment}{}",
            &program[..first_line_end],
            &program[first_line_end..]
        )
    } else {
        format!("{comment}{program}")
    }
}
