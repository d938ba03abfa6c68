//! The compensation itself (see the module's documentation): each block's end points moved so
//! that the real tool tip lands where the ideal one would, feed moves split until the real tip
//! stays within the chord tolerance of the intended path, arcs kept where they can be.

use std::cell::Cell;
use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use super::parse::{parse_program, Line};
use super::program::{end_position, starting_position, take_line, Motion, State, Step, XY};
use super::toolpath::{arc_path, arc_through, lerp, Toolpath};
use super::write::write_block;
use super::{NcError, NcOption, Options, Report};
use crate::model::{Command, Machine};
use crate::reference::Twin;

/// The most pieces one move is split into.
const MAX_PIECES: usize = 100_000;

/// The machine as one tool sees it, with its ideal twin.
struct Kinematics {
    twin: Twin,
    /// The inverse of the ideal tip's Jacobian in X, Y, Z at the last rotary positions it was
    /// asked for: the same for every point until the rotary axes move.
    inverse: std::cell::RefCell<Option<([f64; 3], Matrix3<f64>)>>,
}

/// The compensation of one program: its name, its options, the machine, the machine per tool.
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

/// Handles one line; returns the number of output lines written for it (1 or more).
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
    let (path, options) = (comp.path, comp.options);
    if take_line(lines, index, state, path, options.pass_unknown)? == Step::Pass {
        out.push_str(&line.text);
        out.push_str(&line.ending);
        return Ok(1);
    }
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
    let block = Block {
        path,
        line: line.number,
        offset: *options.work_offsets.get(&state.offset).unwrap_or(&[0.0; 6]),
        kin: comp.kinematics(state.tool, line.number)?,
        tolerance: options.chord_tolerance_mm,
        largest_correction: Cell::new(0.0),
    };
    if !*start_compensated {
        // The output starts where the compensated start of the program is.
        state.written = block.compensate_point(&state.position)?;
        *start_compensated = true;
    }
    let (start, end, motion) = (state.position, end_position(line, state), state.motion);
    let mut pieces: Vec<[f64; 6]> = Vec::new();
    let mut keep_arc: Option<[f64; 2]> = None;
    if motion == Motion::Rapid {
        pieces.push(block.compensate_point(&end)?);
    } else {
        let intended = match motion {
            Motion::Clockwise | Motion::CounterClockwise => {
                arc_path(line, state, start, end, path)?
            }
            _ => Toolpath::Line {
                from: start,
                to: end,
            },
        };
        report.largest_error_before_mm = report
            .largest_error_before_mm
            .max(block.error_before(&intended));
        let from = block.written_start(state.written, &start)?;
        let to = block.compensate_point(&end)?;
        keep_arc = block.arc_within_tolerance(&intended, from, to, motion, report);
        match keep_arc {
            Some(_) => pieces.push(to),
            None => block
                .split(&intended, (0.0, 1.0), (from, to), 0, &mut pieces, report)
                .map_err(|e| match e {
                    Split::Pieces(message) => NcError::line(path, line.number, message),
                    Split::Point(e) => e,
                })?,
        }
    }
    report.points += pieces.len();
    report.largest_correction_mm = report
        .largest_correction_mm
        .max(block.largest_correction.get());
    state.position = end;
    write_block(line, state, &pieces, keep_arc, out, options)
}

/// Points sampled along an intended move of `length` mm: every 0.5 mm, from 8 to 256.
fn samples(length: f64) -> usize {
    ((length / 0.5).ceil() as usize).clamp(8, 256)
}

/// One block being compensated: the line its errors name, the active work offset, the machine
/// of the active tool, and the largest correction made so far.
struct Block<'a> {
    path: &'a str,
    line: usize,
    offset: [f64; 6],
    kin: &'a Kinematics,
    tolerance: f64,
    largest_correction: Cell<f64>,
}

/// Why a move could not be split: too many pieces, or a point that does not compensate.
enum Split {
    Pieces(String),
    Point(NcError),
}

impl Block<'_> {
    /// The machine command of a point in program coordinates.
    fn command(&self, p: &[f64; 6]) -> Command {
        std::array::from_fn(|d| p[d] + self.offset[d])
    }

    /// Every axis of the command of `p` within its travel.
    fn check_travel(&self, p: &[f64; 6], what: &str) -> Result<(), NcError> {
        let q = self.command(p);
        for axis in &self.kin.twin.real().axes {
            let value = q[axis.letter.index()];
            let [lo, hi] = axis.range;
            if value < lo - 1e-6 || value > hi + 1e-6 {
                return Err(NcError::line(
                    self.path,
                    self.line,
                    format!(
                        "{what}: {}={value:.4} (machine) lies outside the travel of {} ({lo} to {hi})",
                        axis.letter, axis.letter
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The program point whose real tool tip lands on the ideal tool tip of `p`.
    fn compensate_point(&self, p: &[f64; 6]) -> Result<[f64; 6], NcError> {
        self.check_travel(p, "the programmed point")?;
        let c = self.kin.compensate(&self.command(p)).ok_or_else(|| {
            NcError::line(
                self.path,
                self.line,
                "the compensation does not converge at this point".into(),
            )
        })?;
        let mut compensated = *p;
        for d in 0..3 {
            compensated[d] = c[d] - self.offset[d];
        }
        self.check_travel(&compensated, "the compensated point")?;
        let correction = (0..3)
            .map(|d| (compensated[d] - p[d]).powi(2))
            .sum::<f64>()
            .sqrt();
        self.largest_correction
            .set(self.largest_correction.get().max(correction));
        Ok(compensated)
    }

    /// The largest distance of the real tool tip from the intended path along the move, as the
    /// program had it.
    fn error_before(&self, intended: &Toolpath) -> f64 {
        let n = samples(intended.length());
        (0..=n)
            .map(|k| {
                let q = self.command(&intended.at(k as f64 / n as f64));
                self.kin.miss(&q, &q)
            })
            .fold(0.0, f64::max)
    }

    /// Where the output has the tool at the start of a move; an axis not written since its
    /// reference return is taken where the program has it.
    fn written_start(&self, written: [f64; 6], start: &[f64; 6]) -> Result<[f64; 6], NcError> {
        let mut from = written;
        if from.iter().any(|v| v.is_nan()) {
            let start_compensated = self.compensate_point(start)?;
            for d in 0..6 {
                if from[d].is_nan() {
                    from[d] = start_compensated[d];
                }
            }
        }
        Ok(from)
    }

    /// An arc kept as an arc, with compensated ends `from`, `to` and its centre moved by the mean
    /// correction of its ends, where that keeps the real tool tip within the tolerance of the
    /// intended arc: the new centre.
    fn arc_within_tolerance(
        &self,
        intended: &Toolpath,
        from: [f64; 6],
        to: [f64; 6],
        motion: Motion,
        report: &mut Report,
    ) -> Option<[f64; 2]> {
        let Toolpath::Arc {
            from: start,
            to: end,
            plane,
            centre,
            ..
        } = *intended
        else {
            return None;
        };
        let shift = [
            0.5 * (from[plane.u] - start[plane.u] + to[plane.u] - end[plane.u]),
            0.5 * (from[plane.v] - start[plane.v] + to[plane.v] - end[plane.v]),
        ];
        let moved = [centre[0] + shift[0], centre[1] + shift[1]];
        let commanded = arc_through(from, to, plane, moved, motion)?;
        let Toolpath::Arc { radii, .. } = commanded else {
            unreachable!("arc_through returns arcs")
        };
        if (radii[0] - radii[1]).abs() > self.tolerance {
            return None;
        }
        let n = samples(intended.length()) * 2;
        let worst = (1..n)
            .map(|k| {
                let t = k as f64 / n as f64;
                self.kin.miss(
                    &self.command(&commanded.at(t)),
                    &self.command(&intended.at(t)),
                )
            })
            .fold(0.0, f64::max);
        (worst <= self.tolerance).then(|| {
            report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
            moved
        })
    }

    /// Recursive bisection of the intended path on `[ta, tb]` with compensated ends `a`, `b`:
    /// accepts the straight piece when the real tip along it stays within the tolerance of the
    /// intended path at the same fraction.
    fn split(
        &self,
        intended: &Toolpath,
        (ta, tb): (f64, f64),
        (a, b): ([f64; 6], [f64; 6]),
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
                self.kin.miss(
                    &self.command(&commanded),
                    &self.command(&intended.at(lerp(ta, tb, s))),
                )
            })
            .fold(0.0, f64::max);
        if pieces.len() >= MAX_PIECES {
            return Err(Split::Pieces(format!(
                "a move needs more than {MAX_PIECES} pieces to stay within the chord tolerance of {} mm",
                self.tolerance
            )));
        }
        if worst <= self.tolerance || depth >= 24 {
            report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
            pieces.push(b);
            return Ok(());
        }
        let tm = 0.5 * (ta + tb);
        let m = self
            .compensate_point(&intended.at(tm))
            .map_err(Split::Point)?;
        self.split(intended, (ta, tm), (a, m), depth + 1, pieces, report)?;
        self.split(intended, (tm, tb), (m, b), depth + 1, pieces, report)
    }
}
