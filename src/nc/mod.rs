//! Offline NC program compensation (Dobariya et al., seed 004): the coordinates of an ISO 6983 /
//! Fanuc-style part program are rewritten so that the real tool tip lands where the program
//! wants it.
//!
//! Frames: program coordinates are the work coordinate system of the active work offset
//! (G54–G59), in mm or inch; the machine is commanded at `q = program + work offset` (mm and
//! degrees), which is MODEL.md's commanded position. The programmed point is where the ideal
//! machine puts the tool tip, `ideal(q)`; the compensated command `q'` is the one whose real tool
//! tip lands there, `real(q') = ideal(q)` (workpiece frame), found by Newton steps with the ideal
//! machine's Jacobian in X, Y, Z (exact: the nominal tip is affine in them) until it agrees to
//! 1e-9 mm. Rotary axes stay as programmed: on a five-axis machine the tool tip is put back
//! where it belongs with the rotary axes where the program has them; the tool's orientation error
//! is not corrected (rotary words are never changed).
//!
//! Between points the control interpolates the compensated commands. A feed move (G1, G2, G3) is
//! split until the real tool tip along every piece stays within the chord tolerance of the
//! intended path at the same fraction of the move (sampled along each piece); an arc stays an
//! arc (with compensated ends and centre) when that already keeps it within the tolerance, and
//! becomes compensated straight pieces otherwise. Rapid moves (G0) get compensated end points
//! and are not split: the control does not hold their path.

pub mod parse;
mod path;
mod program;
mod write;

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use crate::io::{read_text, FileError};
use crate::model::{Command, Machine};
use crate::reference::Twin;
use parse::{parse_program, Line};
use path::{arc_path, arc_through, lerp, Path};
use program::{end_position, starting_position, take_line, Motion, State, Step, XY};
use write::write_block;

/// Which option of a compensation an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcOption {
    ToolLengths,
    WorkOffsets,
    ChordTolerance,
}

impl std::fmt::Display for NcOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NcOption::ToolLengths => "tool lengths",
            NcOption::WorkOffsets => "work offset",
            NcOption::ChordTolerance => "chord tolerance",
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
    #[error("{path}: line {line}: {code} is not supported (volmap follows G0 G1 G2 G3 G4 G17 G18 G19 G20 G21 G28 G40 G43 G49 G54–G59 G61 G64 G80 G90 G91 G94 G95 G98)")]
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
        let bad = || NcError::Option {
            option: NcOption::ToolLengths,
            value: text.to_string(),
            message: "a length in mm, or T1=80,T2=120 per tool".into(),
        };
        for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            match part.split_once('=') {
                None => lengths.all = Some(part.parse().map_err(|_| bad())?),
                Some((tool, value)) => {
                    let tool = tool.trim().trim_start_matches(['T', 't']);
                    lengths.per_tool.insert(
                        tool.parse().map_err(|_| bad())?,
                        value.trim().parse().map_err(|_| bad())?,
                    );
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
}

impl Default for Options {
    fn default() -> Options {
        Options {
            work_offsets: HashMap::new(),
            tool_lengths: ToolLengths::default(),
            chord_tolerance_mm: 0.001,
            decimals: None,
            pass_unknown: false,
        }
    }
}

/// `G54=100,50,-200` (X, Y, Z mm, then optionally A, B, C degrees).
pub fn parse_work_offset(text: &str) -> Result<(u32, [f64; 6]), NcError> {
    let bad = || NcError::Option {
        option: NcOption::WorkOffsets,
        value: text.to_string(),
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
    let table: std::collections::BTreeMap<String, Vec<f64>> =
        toml::from_str(&read_text(path)?).map_err(|e| file_error(e.to_string()))?;
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
    /// with the program as it was and as compensated, mm.
    pub largest_error_before_mm: f64,
    pub largest_error_after_mm: f64,
}

/// The most pieces one move is split into.
const MAX_PIECES: usize = 100_000;

/// The machine as one tool sees it, with its ideal twin.
struct Kinematics {
    twin: Twin,
    /// The inverse of the ideal tip's Jacobian in X, Y, Z at the last rotary positions it was
    /// asked for: the same for every point until the rotary axes move.
    inverse: std::cell::RefCell<Option<([f64; 3], Matrix3<f64>)>>,
}

struct Compensator<'a> {
    path: &'a str,
    options: &'a Options,
    base: &'a Machine,
    tools: HashMap<Option<u32>, Kinematics>,
}

impl Compensator<'_> {
    fn kinematics(&mut self, tool: Option<u32>, line: usize) -> Result<&Kinematics, NcError> {
        if !self.tools.contains_key(&tool) {
            let lengths = &self.options.tool_lengths;
            let length = match tool.and_then(|t| lengths.per_tool.get(&t)) {
                Some(&l) => Some(l),
                None if lengths.per_tool.is_empty() || lengths.all.is_some() => lengths.all,
                None => {
                    return Err(NcError::Missing {
                        path: self.path.to_string(),
                        line,
                        option: NcOption::ToolLengths,
                        message: match tool {
                            Some(t) => format!("no length for tool T{t} among the tool lengths"),
                            None => {
                                "no tool is active yet and the tool lengths name tools only".into()
                            }
                        },
                    })
                }
            };
            let mut real = self.base.clone();
            if let Some(l) = length {
                real.tool_offset_mm = [0.0, 0.0, -l];
            }
            self.tools.insert(
                tool,
                Kinematics {
                    twin: Twin::new(real),
                    inverse: Default::default(),
                },
            );
        }
        Ok(&self.tools[&tool])
    }
}

impl Kinematics {
    /// The inverse of the ideal tip's derivative in X, Y, Z at `q` (constant at fixed rotary
    /// positions, so kept until they change); `None` where the linear axes do not span X, Y, Z.
    fn inverse_jacobian(&self, q: &Command) -> Option<Matrix3<f64>> {
        let rotary = [q[3], q[4], q[5]];
        let mut cache = self.inverse.borrow_mut();
        match *cache {
            Some((at, inverse)) if at == rotary => Some(inverse),
            _ => {
                let inverse = self.twin.ideal_jacobian(q).try_inverse()?;
                *cache = Some((rotary, inverse));
                Some(inverse)
            }
        }
    }

    /// The command whose real tip lands on the ideal tip of `q`.
    fn compensate(&self, q: &Command) -> Option<Command> {
        let inverse = self.inverse_jacobian(q)?;
        self.twin
            .real_command_for(self.twin.ideal_tip(q), q, &inverse)
    }

    /// Distance of the real tip at command `c` from the ideal tip at command `q`.
    fn miss(&self, c: &Command, q: &Command) -> f64 {
        (self.twin.real_tip(c) - self.twin.ideal_tip(q)).norm()
    }
}

/// The program's lines, its state before the first, and the machine per tool.
fn begin<'a>(
    machine: &'a Machine,
    program: &[u8],
    path: &'a str,
    options: &'a Options,
) -> Result<(Vec<Line>, State, Compensator<'a>), NcError> {
    let lines = parse_program(program, path, options.pass_unknown)?;
    let start = starting_position(&lines, machine, path, options)?;
    let state = State {
        motion: Motion::Rapid,
        plane: XY,
        absolute: true,
        inch: false,
        offset: 54,
        tool: None,
        pending_tool: None,
        position: start,
        written: start,
        written_motion: Motion::Rapid,
    };
    let compensator = Compensator {
        path,
        options,
        base: machine,
        tools: HashMap::new(),
    };
    Ok((lines, state, compensator))
}

/// A compensated program.
#[derive(Debug, Clone, PartialEq)]
pub struct Compensated {
    pub text: String,
    pub report: Report,
    /// For each line of `text`, the input line (1-based) it comes from: the line itself, or the
    /// move it adds a piece to.
    pub origins: Vec<usize>,
}

/// Compensates `program` (its bytes; `path` names it in errors) for `machine`.
pub fn compensate(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
) -> Result<Compensated, NcError> {
    compensate_with_progress(machine, program, path, options, |_, _| {})
}

/// [`compensate`], telling `on_progress(lines done, lines)` as it goes.
pub fn compensate_with_progress(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
    mut on_progress: impl FnMut(usize, usize),
) -> Result<Compensated, NcError> {
    if options.chord_tolerance_mm.is_nan() || options.chord_tolerance_mm <= 0.0 {
        return Err(NcError::Option {
            option: NcOption::ChordTolerance,
            value: options.chord_tolerance_mm.to_string(),
            message: "it must be positive".into(),
        });
    }
    let (lines, mut state, mut compensator) = begin(machine, program, path, options)?;
    let mut report = Report::default();
    let mut out = String::with_capacity(program.len() * 2);
    let mut start_compensated = false;
    let mut origins = Vec::with_capacity(lines.len());
    for (index, line) in lines.iter().enumerate() {
        if index % 1024 == 0 {
            on_progress(index, lines.len());
        }
        let before = out.len();
        let emitted = process_line(
            &lines,
            index,
            &mut state,
            &mut compensator,
            &mut report,
            &mut out,
            &mut start_compensated,
        )?;
        if emitted > 1 {
            report.blocks_added += emitted - 1;
        }
        if out[before..] != format!("{}{}", line.text, line.ending)[..] {
            report.blocks_changed += 1;
        }
        origins.extend(std::iter::repeat_n(line.number, emitted));
    }
    Ok(Compensated {
        text: out,
        report,
        origins,
    })
}

/// Where a program puts the tool at the end of each move, as the control runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct TracePoint {
    /// The program's line (1-based).
    pub line: usize,
    /// The end point in program coordinates (mm, degrees).
    pub program: [f64; 6],
    /// The machine command there.
    pub command: Command,
    /// The ideal and the real tool tip there (workpiece frame, mm).
    pub ideal: Vector3<f64>,
    pub real: Vector3<f64>,
}

/// Runs a program through the model: every move's end point with the ideal and the real tool
/// tip (the check that a compensated program lands where the original one was meant to).
pub fn trace(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
) -> Result<Vec<TracePoint>, NcError> {
    let (lines, mut state, mut compensator) = begin(machine, program, path, options)?;
    let mut points = Vec::new();
    for (index, line) in lines.iter().enumerate() {
        if take_line(&lines, index, &mut state, path, options.pass_unknown)? == Step::Pass {
            continue;
        }
        let end = end_position(line, &state);
        if matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise) {
            arc_path(line, &state, state.position, end, path)?;
        }
        let offset = *options.work_offsets.get(&state.offset).unwrap_or(&[0.0; 6]);
        let command: Command = std::array::from_fn(|d| end[d] + offset[d]);
        let kin = compensator.kinematics(state.tool, line.number)?;
        points.push(TracePoint {
            line: line.number,
            program: end,
            command,
            ideal: kin.twin.ideal_tip(&command),
            real: kin.twin.real_tip(&command),
        });
        state.position = end;
    }
    Ok(points)
}

/// Handles one line; returns the number of output lines written for it (0 when it was passed
/// through unchanged by a path that writes it itself, which does not happen: 1 or more).
fn process_line(
    lines: &[Line],
    index: usize,
    state: &mut State,
    comp: &mut Compensator,
    report: &mut Report,
    out: &mut String,
    start_compensated: &mut bool,
) -> Result<usize, NcError> {
    let line = &lines[index];
    let path = comp.path;
    let options = comp.options;
    let pass = |out: &mut String| {
        out.push_str(&line.text);
        out.push_str(&line.ending);
        1
    };
    if take_line(lines, index, state, path, options.pass_unknown)? == Step::Pass {
        return Ok(pass(out));
    }
    let offset = *options.work_offsets.get(&state.offset).unwrap_or(&[0.0; 6]);
    if state.offset != 54 && !options.work_offsets.contains_key(&state.offset) {
        return Err(NcError::Missing {
            path: path.to_string(),
            line: line.number,
            option: NcOption::WorkOffsets,
            message: format!(
                "G{} is active but its work offset was not given",
                state.offset
            ),
        });
    }
    let tool = state.tool;
    let kin = comp.kinematics(tool, line.number)?;
    let command = |p: &[f64; 6]| -> Command { std::array::from_fn(|d| p[d] + offset[d]) };
    let travel = |p: &[f64; 6], what: &str| -> Result<(), NcError> {
        let q = command(p);
        for axis in &kin.twin.real().axes {
            let value = q[axis.letter.index()];
            let [lo, hi] = axis.range;
            if value < lo - 1e-6 || value > hi + 1e-6 {
                return Err(NcError::line(
                    path,
                    line.number,
                    format!("{what}: {}={value:.4} (machine) lies outside the travel of {} ({lo} to {hi})", axis.letter, axis.letter),
                ));
            }
        }
        Ok(())
    };
    let largest_correction = std::cell::Cell::new(0.0f64);
    let compensate_point = |p: &[f64; 6]| -> Result<[f64; 6], NcError> {
        travel(p, "the programmed point")?;
        let q = command(p);
        let c = kin.compensate(&q).ok_or_else(|| {
            NcError::line(
                path,
                line.number,
                "the compensation does not converge at this point".into(),
            )
        })?;
        let mut p2 = *p;
        for d in 0..3 {
            p2[d] = c[d] - offset[d];
        }
        travel(&p2, "the compensated point")?;
        let correction = (0..3).map(|d| (p2[d] - p[d]).powi(2)).sum::<f64>().sqrt();
        largest_correction.set(largest_correction.get().max(correction));
        Ok(p2)
    };
    if !*start_compensated {
        // The output starts where the compensated start of the program is.
        state.written = compensate_point(&state.position)?;
        *start_compensated = true;
    }
    let start = state.position;
    let end = end_position(line, state);
    let motion = state.motion;
    let tolerance = options.chord_tolerance_mm;
    // The intended path of this block.
    let intended = match motion {
        Motion::Rapid | Motion::Linear => Path::Line {
            from: start,
            to: end,
        },
        Motion::Clockwise | Motion::CounterClockwise => arc_path(line, state, start, end, path)?,
    };
    let samples = |length: f64| ((length / 0.5).ceil() as usize).clamp(8, 256);
    let mut pieces: Vec<[f64; 6]> = Vec::new();
    let mut keep_arc: Option<[f64; 2]> = None;
    if motion == Motion::Rapid {
        pieces.push(compensate_point(&end)?);
    } else {
        // The error the program had along this move.
        let n = samples(intended.length());
        for k in 0..=n {
            let p = intended.at(k as f64 / n as f64);
            let q = command(&p);
            report.largest_error_before_mm = report.largest_error_before_mm.max(kin.miss(&q, &q));
        }
        // Where the output has the tool; an axis not written since its reference return is
        // taken where the program has it.
        let mut from = state.written;
        if from.iter().any(|v| v.is_nan()) {
            let start_comp = compensate_point(&start)?;
            for d in 0..6 {
                if from[d].is_nan() {
                    from[d] = start_comp[d];
                }
            }
        }
        let to = compensate_point(&end)?;
        if let Path::Arc { plane, centre, .. } = intended {
            // Try the arc itself with compensated ends and centre.
            let shift = [
                0.5 * (from[plane.u] - start[plane.u] + to[plane.u] - end[plane.u]),
                0.5 * (from[plane.v] - start[plane.v] + to[plane.v] - end[plane.v]),
            ];
            let c2 = [centre[0] + shift[0], centre[1] + shift[1]];
            if let Some(commanded) = arc_through(from, to, plane, c2, motion) {
                let radii = match commanded {
                    Path::Arc { radii, .. } => radii,
                    _ => unreachable!("arc_through returns arcs"),
                };
                if (radii[0] - radii[1]).abs() <= tolerance {
                    let n = samples(intended.length()) * 2;
                    let worst = (1..n)
                        .map(|k| {
                            let t = k as f64 / n as f64;
                            kin.miss(&command(&commanded.at(t)), &command(&intended.at(t)))
                        })
                        .fold(0.0, f64::max);
                    if worst <= tolerance {
                        report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
                        keep_arc = Some(c2);
                        pieces.push(to);
                    }
                }
            }
        }
        if keep_arc.is_none() {
            split(
                &intended,
                0.0,
                1.0,
                from,
                to,
                &|p| compensate_point(p),
                kin,
                &command,
                tolerance,
                0,
                &mut pieces,
                report,
            )
            .map_err(|message| match message {
                Split::Pieces(message) => NcError::line(path, line.number, message),
                Split::Point(e) => e,
            })?;
        }
    }
    report.points += pieces.len();
    report.largest_correction_mm = report.largest_correction_mm.max(largest_correction.get());
    state.position = end;
    write_block(line, state, &pieces, keep_arc, out, options)
}

/// Program point to compensated program point.
type PointCompensation<'a> = dyn Fn(&[f64; 6]) -> Result<[f64; 6], NcError> + 'a;

/// Why a move could not be split: too many pieces, or a point that does not compensate.
enum Split {
    Pieces(String),
    Point(NcError),
}

/// Recursive bisection of the intended path on `[ta, tb]` with compensated ends `a`, `b`:
/// accepts the straight piece when the real tip along it stays within the tolerance of the
/// intended path at the same fraction.
#[allow(clippy::too_many_arguments)]
fn split(
    intended: &Path,
    ta: f64,
    tb: f64,
    a: [f64; 6],
    b: [f64; 6],
    compensate_point: &PointCompensation,
    kin: &Kinematics,
    command: &dyn Fn(&[f64; 6]) -> Command,
    tolerance: f64,
    depth: usize,
    pieces: &mut Vec<[f64; 6]>,
    report: &mut Report,
) -> Result<(), Split> {
    let length = (0..3).map(|d| (b[d] - a[d]).powi(2)).sum::<f64>().sqrt();
    let n = ((length / 0.5).ceil() as usize).clamp(8, 64);
    let worst = (1..n)
        .map(|k| {
            let s = k as f64 / n as f64;
            let commanded: [f64; 6] = std::array::from_fn(|d| lerp(a[d], b[d], s));
            kin.miss(
                &command(&commanded),
                &command(&intended.at(lerp(ta, tb, s))),
            )
        })
        .fold(0.0, f64::max);
    if pieces.len() >= MAX_PIECES {
        return Err(Split::Pieces(format!(
            "a move needs more than {MAX_PIECES} pieces to stay within the chord tolerance of {tolerance} mm"
        )));
    }
    if worst <= tolerance || depth >= 24 {
        report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
        pieces.push(b);
        return Ok(());
    }
    let tm = 0.5 * (ta + tb);
    let m = compensate_point(&intended.at(tm)).map_err(Split::Point)?;
    split(
        intended,
        ta,
        tm,
        a,
        m,
        compensate_point,
        kin,
        command,
        tolerance,
        depth + 1,
        pieces,
        report,
    )?;
    split(
        intended,
        tm,
        tb,
        m,
        b,
        compensate_point,
        kin,
        command,
        tolerance,
        depth + 1,
        pieces,
        report,
    )
}
