//! Predicting a program before it cuts: the real tool tip at the end of every move, or sampled
//! along every move, as the model has it, against the ideal one. A program's own deviation is
//! the distance of the real tip from the ideal tip of the same command; a compensated program is
//! measured against the intended path of the program it was made from (its origins), so before
//! and after read alike.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::compensate::begin;
use super::error::{NcError, NcOption};
use super::kinematics::beyond_travel;
use super::options::Options;
use super::program::approach::{line_directions, segment_at, segments, Segment};
use super::program::modal::{Motion, State};
use super::program::parse::Line;
use super::program::reader::{take_line, Step};
use super::program::tcpm;
use super::program::toolpath::{arc_path, Toolpath};
use super::report::Compensated;
use super::tcpm::{command_of, follow, move_end};
use crate::limits::{self, number_words, MAX_TRACE_SAMPLES};
use crate::model::inputs::Approach;
use crate::model::{Command, Machine};

/// Where a program puts the tool at the end of each move, as the control runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct TracePoint {
    /// The program's line (1-based).
    pub line: usize,
    /// The end point in program coordinates (mm, degrees).
    pub program: [f64; 6],
    /// The machine command there.
    pub command: Command,
    /// The direction every axis approaches it in (X Y Z A B C): that of the move's motion
    /// arriving there (on an arc, at its end), or of the axis's last move.
    pub approach: [Approach; 6],
    /// The ideal and the real tool tip there (workpiece frame, mm), the real one approached in
    /// `approach` at the options' temperatures.
    pub ideal: Vector3<f64>,
    pub real: Vector3<f64>,
}

/// Runs a program through the model: every move's end point with the ideal and the real tool
/// tip, each axis approaching in the direction of its motion in this program (the check that a
/// compensated program lands where the original one was meant to).
pub fn trace(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
) -> Result<Vec<TracePoint>, NcError> {
    let (lines, mut state, mut compensator, _) = begin(machine, program, path, options)?;
    let mut points = Vec::new();
    for (index, line) in lines.iter().enumerate() {
        let before = tcpm::switches(line).then(|| state.clone());
        let step = take_line(&lines, index, &mut state, path, options.pass_unknown)?;
        follow(line, before, &mut state, &mut compensator)?;
        if step == Step::Pass {
            continue;
        }
        let end = move_end(line, &mut state, &mut compensator)?;
        let approach = if matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise) {
            let arc = arc_path(line, &state, state.position, end, path)?;
            let segments = segments(&arc, &state.approach, &[true; 6]);
            segments.last().expect("a move has a segment").directions
        } else {
            line_directions(&state.position, &end, &state.approach)
        };
        let offset = compensator.offset(&state, line.number)?;
        let kin = compensator.kinematics(state.tool, line.number)?;
        let command = command_of(kin, state.tcpm.is_some(), &offset, &end);
        points.push(TracePoint {
            line: line.number,
            program: end,
            command,
            approach,
            ideal: kin.ideal_tip(&command),
            real: kin.twin(&approach).real_tip(&command),
        });
        state.position = end;
        state.approach = approach;
    }
    Ok(points)
}

/// One point of a move, sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceSample {
    /// The program's line (1-based).
    pub line: usize,
    /// The motion's G code (0 rapid, 1 straight, 2 and 3 arcs).
    pub motion: u32,
    /// Distance along the programmed path from the program's first point, mm.
    pub distance_mm: f64,
    /// The point in program coordinates (mm, degrees).
    pub program: [f64; 6],
    /// The ideal and the real tool tip (workpiece frame, mm).
    pub ideal: Vector3<f64>,
    pub real: Vector3<f64>,
    /// The distance of the real tool tip from where it was meant to be, mm.
    pub deviation_mm: f64,
    /// The machine command there, the direction every axis approaches it in, and the active
    /// tool: what the machine's error there depends on (its uncertainty, say).
    pub command: Command,
    pub approach: [Approach; 6],
    pub tool: Option<u32>,
}

/// The samples of one move: its path, from its start to its end.
fn move_path(line: &Line, state: &State, end: [f64; 6], path: &str) -> Result<Toolpath, NcError> {
    if matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise) {
        arc_path(line, state, state.position, end, path)
    } else {
        Ok(Toolpath::Line {
            from: state.position,
            to: end,
        })
    }
}

/// Runs a program through the model, sampling every move at least every `step_mm` (at least 4
/// samples a move, its start excluded, its end included): the ideal and the real tool tip, each
/// axis approaching in the direction of its programmed motion there.
pub fn trace_path(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
    step_mm: f64,
) -> Result<Vec<TraceSample>, NcError> {
    let mut samples = Vec::new();
    trace_each(machine, program, path, options, step_mm, |s| {
        samples.push(s)
    })?;
    Ok(samples)
}

/// [`trace_path`], handing every sample to `each` in order and holding none: a trace's memory
/// is the program's blocks, whatever the number of samples.
pub fn trace_each(
    machine: &Machine,
    program: &[u8],
    path: &str,
    options: &Options,
    step_mm: f64,
    mut each: impl FnMut(TraceSample),
) -> Result<(), NcError> {
    if !(step_mm > 0.0 && step_mm.is_finite()) {
        return Err(NcError::Option {
            option: NcOption::TraceStep,
            value: number_words(step_mm),
            message: "it must be a positive number of mm".into(),
        });
    }
    let (lines, mut state, mut compensator, _) = begin(machine, program, path, options)?;
    let mut count = 0usize;
    let mut travelled = 0.0;
    // The samples the moves so far take at any step: 4 a move that goes somewhere, else 1.
    let mut fewest = 0.0;
    for (index, line) in lines.iter().enumerate() {
        let before = tcpm::switches(line).then(|| state.clone());
        let step = take_line(&lines, index, &mut state, path, options.pass_unknown)?;
        follow(line, before, &mut state, &mut compensator)?;
        if step == Step::Pass {
            continue;
        }
        let end = move_end(line, &mut state, &mut compensator)?;
        let intended = move_path(line, &state, end, path)?;
        let segments = match state.motion {
            Motion::Rapid => vec![Segment {
                t: (0.0, 1.0),
                directions: line_directions(&state.position, &end, &state.approach),
            }],
            _ => segments(&intended, &state.approach, &[true; 6]),
        };
        // The work offset, and with G43 the tool's length along Z (see `Compensator::offset`).
        let offset = compensator.offset(&state, line.number)?;
        let kin = compensator.kinematics(state.tool, line.number)?;
        let length = intended.length();
        // A rotary axis swings the tip along a curve: a degree of turn is sampled as a mm of
        // path. A move that goes nowhere (a block of modes, a repeated point) is one sample.
        let turn_deg = (3..6)
            .map(|d| (end[d] - state.position[d]).abs())
            .fold(0.0, f64::max);
        let n = if length > 0.0 || turn_deg > 0.0 {
            (length.max(turn_deg) / step_mm).ceil().max(4.0)
        } else {
            1.0
        };
        fewest += n.min(4.0);
        if fewest > MAX_TRACE_SAMPLES as f64 {
            // No step helps: the moves themselves are too many.
            return Err(NcError::Program {
                path: path.to_string(),
                message: format!(
                    "the moves up to line {} take at least {} samples at any step (4 a move), more than the limit of {MAX_TRACE_SAMPLES} samples: the most moves a trace follows are about {}; split the program",
                    line.number,
                    limits::count_words(fewest),
                    MAX_TRACE_SAMPLES / 4
                ),
            });
        }
        let n = limits::within(count as f64 + n, MAX_TRACE_SAMPLES)
            .map(|total| total as usize - count)
            .map_err(|e| NcError::Option {
                option: NcOption::TraceStep,
                value: number_words(step_mm),
                message: format!(
                    "the moves up to line {} sampled at this step give {} samples, more than the limit of {}: take a longer step (every move takes 4 samples at least, at any step)",
                    line.number,
                    limits::count_words(e.count),
                    e.limit
                ),
            })?;
        for k in 1..=n {
            let t = k as f64 / n as f64;
            let p = intended.at(t);
            let command = command_of(kin, state.tcpm.is_some(), &offset, &p);
            // Where the machine cannot go, the model says nothing (as compensate and sample).
            if let Some((axis, value)) = beyond_travel(machine, &command) {
                return Err(NcError::Line {
                    path: path.to_string(),
                    line: line.number,
                    message: format!(
                        "the move reaches {}={} (machine), outside the travel of {} ({} to {}): check the work offsets and tool lengths",
                        axis.letter,
                        number_words(value),
                        axis.letter,
                        number_words(axis.range[0]),
                        number_words(axis.range[1])
                    ),
                });
            }
            let directions = segment_at(&segments, t).directions;
            let (ideal, real) = (
                kin.ideal_tip(&command),
                kin.twin(&directions).real_tip(&command),
            );
            if !(real - ideal).norm().is_finite() {
                return Err(NcError::Line {
                    path: path.to_string(),
                    line: line.number,
                    message: format!(
                        "the tool tip's deviation at X={} Y={} Z={} mm (machine) is not a finite number: the point lies far beyond the machine's travel (check the work offsets and tool lengths)",
                        number_words(command[0]),
                        number_words(command[1]),
                        number_words(command[2])
                    ),
                });
            }
            count += 1;
            each(TraceSample {
                line: line.number,
                motion: state.motion.code(),
                distance_mm: travelled + t * length,
                program: p,
                ideal,
                real,
                deviation_mm: (real - ideal).norm(),
                command,
                approach: directions,
                tool: state.tool,
            });
        }
        travelled += length;
        state.position = end;
        state.approach = segments.last().expect("a move has a segment").directions;
    }
    Ok(())
}

/// A straight move whose real tool tip ends within this of where it started (mm) is a take-up.
const TIP_STANDS_MM: f64 = 1e-4;

/// The point of the polyline through `points` nearest `p` at or after position `from`: its
/// position along the polyline in points (0 at the first, `points.len() - 1` at the last) and
/// its distance. From `from` on: a path may come back to a point (a full circle).
fn nearest_on_polyline(p: &Vector3<f64>, points: &[Vector3<f64>], from: f64) -> (f64, f64) {
    if let [only] = points {
        return (0.0, (p - only).norm());
    }
    let first = (from.floor().max(0.0) as usize).min(points.len() - 2);
    points
        .windows(2)
        .enumerate()
        .skip(first)
        .map(|(i, w)| {
            let (a, b) = (w[0], w[1]);
            let ab = b - a;
            let least = if i == first { from - i as f64 } else { 0.0 };
            let s = if ab.norm_squared() > 0.0 {
                ((p - a).dot(&ab) / ab.norm_squared()).clamp(least.clamp(0.0, 1.0), 1.0)
            } else {
                0.0
            };
            (i as f64 + s, (p - (a + s * ab)).norm())
        })
        .fold(
            (0.0, f64::INFINITY),
            |best, c| if c.1 < best.1 { c } else { best },
        )
}

/// The polyline through `points` at position `u` (in points, see `nearest_on_polyline`).
fn on_polyline(points: &[Vector3<f64>], u: f64) -> Vector3<f64> {
    let last = points.len() - 1;
    if last == 0 {
        return points[0];
    }
    let i = (u.floor().max(0.0) as usize).min(last - 1);
    let s = (u - i as f64).clamp(0.0, 1.0);
    points[i] + s * (points[i + 1] - points[i])
}

/// The samples of a compensated program, each deviation the distance of its real tool tip from
/// the intended path at the same fraction of the move, as the chord tolerance is held and
/// `compensate` reports it: the intended path is the ideal tip along the original program's move
/// the sample comes from (sampled every `step_mm / 8`), and a written piece runs from where the
/// real tip at its start lies on it to where the real tip at its end does (a piece's ends land
/// on the intended path, to within the rounding). `original` is the program `compensated` was
/// made from.
pub fn trace_compensated(
    machine: &Machine,
    (original, compensated): (&[u8], &Compensated),
    path: &str,
    options: &Options,
    step_mm: f64,
) -> Result<Vec<TraceSample>, NcError> {
    let mut samples = Vec::new();
    trace_compensated_each(
        machine,
        (original, compensated),
        path,
        options,
        step_mm,
        |s| samples.push(s),
    )?;
    Ok(samples)
}

/// [`trace_compensated`], handing every sample to `each` in order: what is held is the intended
/// path's ideal points (24 bytes a point) and one written block's samples.
pub fn trace_compensated_each(
    machine: &Machine,
    (original, compensated): (&[u8], &Compensated),
    path: &str,
    options: &Options,
    step_mm: f64,
    mut each: impl FnMut(TraceSample),
) -> Result<(), NcError> {
    // The runs of samples of each line of the original (a line run more than once has more),
    // each from the last ideal point before it: the move's start.
    let mut runs: HashMap<usize, Vec<std::ops::Range<usize>>> = HashMap::new();
    let mut ideal: Vec<Vector3<f64>> = Vec::new();
    let mut run: Option<(usize, usize)> = None;
    trace_each(machine, original, path, options, step_mm / 8.0, |s| {
        match run {
            Some((line, _)) if line == s.line => {}
            _ => {
                if let Some((line, start)) = run {
                    runs.entry(line)
                        .or_default()
                        .push(start.saturating_sub(1)..ideal.len());
                }
                run = Some((s.line, ideal.len()));
            }
        }
        ideal.push(s.ideal);
    })
    .map_err(|e| match e {
        // The step as given: the intended path is sampled eight times as densely.
        NcError::Option {
            option: NcOption::TraceStep,
            message,
            ..
        } => NcError::Option {
            option: NcOption::TraceStep,
            value: number_words(step_mm),
            message: format!("{message} (the intended path is sampled at an eighth of it)"),
        },
        other => other,
    })?;
    if let Some((line, start)) = run {
        runs.entry(line)
            .or_default()
            .push(start.saturating_sub(1)..ideal.len());
    }
    let mut measure = Measure {
        compensated,
        runs: &runs,
        ideal: &ideal,
        previous_end: None,
        last: None,
        first: true,
    };
    // A written block's samples are measured once the next block's are known (whether it
    // continues the same original move).
    let mut group: Vec<TraceSample> = Vec::new();
    trace_each(
        machine,
        compensated.text.as_bytes(),
        path,
        options,
        step_mm,
        |s| {
            if group.last().is_some_and(|g| g.line != s.line) {
                measure.group(&group, Some(s.line), &mut each);
                group.clear();
            }
            group.push(s);
        },
    )?;
    if !group.is_empty() {
        measure.group(&group, None, &mut each);
    }
    Ok(())
}

/// Measures a compensated program's samples from the intended path, one written block at a
/// time, in order.
struct Measure<'a> {
    compensated: &'a Compensated,
    runs: &'a HashMap<usize, Vec<std::ops::Range<usize>>>,
    ideal: &'a [Vector3<f64>],
    /// Where the real tip was at the end of the last block.
    previous_end: Option<Vector3<f64>>,
    /// The original line of the last piece, and where it ended along its move.
    last: Option<(usize, f64)>,
    first: bool,
}

impl Measure<'_> {
    /// The samples of one written block (`group`, its lines those of the compensated program),
    /// `next` the compensated line of the next block that moves, handed to `each` with the
    /// original's lines. A take-up (the command crossing a reversal while the tip stands) is
    /// left out: the model's step in the reversal error would put the tip off along it, where
    /// the real axis takes up its play with the tip at rest.
    fn group(
        &mut self,
        group: &[TraceSample],
        next: Option<usize>,
        each: &mut impl FnMut(TraceSample),
    ) {
        let origin = |line: usize| self.compensated.origins[line - 1];
        let end = group.last().expect("a block's samples are not empty").real;
        let stands = self
            .previous_end
            .is_some_and(|p| (end - p).norm() < TIP_STANDS_MM);
        let here = origin(group[0].line);
        let mut emit = |mut s: TraceSample| {
            s.line = origin(s.line);
            each(s);
        };
        if stands && group[0].motion == 1 {
            // A take-up that starts a move: its first piece starts at the move's start.
            if self.last.map(|(o, _)| o) != Some(here) {
                self.last = Some((here, 0.0));
            }
        } else {
            // The first piece of a move starts at its start, the next where the last ended, and
            // the last ends at the move's end.
            let ua = self
                .last
                .filter(|&(o, _)| o == here && !self.first)
                .map_or(0.0, |(_, u)| u);
            let to = if next.map(origin) == Some(here) {
                Fraction::At(end)
            } else {
                Fraction::End
            };
            match self.runs.get(&here) {
                Some(runs) => {
                    let (measured, ub) = at_same_fraction(group, (ua, to), runs, self.ideal);
                    measured.into_iter().for_each(&mut emit);
                    self.last = Some((here, ub));
                }
                None => group.iter().cloned().for_each(&mut emit),
            }
        }
        self.previous_end = Some(end);
        self.first = false;
    }
}

/// Where a written piece ends along the intended move: at its end, or where the real tip (a
/// point between pieces) lies on it.
#[derive(Debug, Clone, Copy)]
enum Fraction {
    End,
    At(Vector3<f64>),
}

/// The samples of one written piece, from position `ua` along the intended move, with their
/// deviations from the intended path at the same fraction, along the run of the original line
/// (`runs`, into `ideal`) its end lies nearest; and where it ends along that run.
fn at_same_fraction(
    group: &[TraceSample],
    (ua, to): (f64, Fraction),
    runs: &[std::ops::Range<usize>],
    ideal: &[Vector3<f64>],
) -> (Vec<TraceSample>, f64) {
    let end = group.last().expect("a chunk is not empty").real;
    let run = runs
        .iter()
        .map(|r| &ideal[r.clone()])
        .min_by(|a, b| {
            nearest_on_polyline(&end, a, ua)
                .1
                .total_cmp(&nearest_on_polyline(&end, b, ua).1)
        })
        .expect("a line traced has a run");
    let ua = ua.min((run.len() - 1) as f64);
    let ub = match to {
        Fraction::End => (run.len() - 1) as f64,
        Fraction::At(p) => nearest_on_polyline(&p, run, ua).0,
    };
    let n = group.len() as f64;
    let measured = group
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let u = ua + (ub - ua) * (k + 1) as f64 / n;
            TraceSample {
                deviation_mm: (s.real - on_polyline(run, u)).norm(),
                ..s.clone()
            }
        })
        .collect();
    (measured, ub)
}

/// The largest deviation of every block that moves, gathered as the samples arrive: a run of
/// samples of one line held as one entry.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PerBlock {
    runs: Vec<(usize, f64)>,
}

impl PerBlock {
    pub fn add(&mut self, line: usize, deviation_mm: f64) {
        match self.runs.last_mut() {
            Some((l, worst)) if *l == line => *worst = worst.max(deviation_mm),
            _ => self.runs.push((line, deviation_mm)),
        }
    }

    /// By line (increasing); a line run more than once (a subprogram, a compensated move split
    /// in pieces) once, at its largest.
    pub fn by_line(mut self) -> Vec<(usize, f64)> {
        self.runs.sort_by_key(|b| b.0);
        self.runs.dedup_by(|b, a| {
            if a.0 == b.0 {
                a.1 = a.1.max(b.1);
                true
            } else {
                false
            }
        });
        self.runs
    }
}
