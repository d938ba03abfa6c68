//! The check of a compensated program before it is kept, independent of how it was planned: the
//! written text is read back with the program reader and walked beside the program it was made
//! from, move by move, with nothing of the compensation but its options and the bound.
//!
//! Every written move must lie, at its end and at samples along it as the control interpolates
//! it (straight, or along its arc), within the bound of the programmed path of the move it
//! belongs to, and further along that path than the moves before it (less a slack of twice the
//! bound: a take-up steps back by a reversal error); the written moves belong to the program's
//! moves in order, a rapid to a rapid and one each (the compensation does not split rapids), a
//! feed to a feed, every programmed move has at least one written move and the written program
//! reaches each one's end before the next begins; nothing is written before the first or after
//! the last. Distances are measured between machine commands (program coordinates plus the work
//! offset and tool length in force), X Y Z against the linear bound and A B C against the rotary
//! one (a distance is the larger of the two, each in units of its bound). A block the reader
//! passes as it is (a code volmap does not follow, a line it cannot read, a move that starts where
//! an axis is unknown) must be in the written program as it is, each once and in order.

use super::compensate::begin;
use super::error::NcError;
use super::options::Options;
use super::program::modal::{Motion, AXIS_LETTERS};
use super::program::parse::{parse_program, Line};
use super::program::reader::{end_position, take_line, Step};
use super::program::toolpath::{arc_path, Toolpath};
use crate::error::{excerpt, Classify, ErrorKind};
use crate::model::Machine;
use crate::reference::Twin;

/// How far the written program may stray from the programmed path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckBounds {
    /// X Y Z: the largest correction plus the chord tolerance and the rounding of the words, mm.
    pub linear_mm: f64,
    /// A B C, degrees.
    pub rotary_deg: f64,
}

impl CheckBounds {
    /// The bounds of a compensation with `options` whose largest correction was
    /// `largest_correction_mm`: that plus the chord tolerance and the rounding of three words at
    /// the output's decimals (in inch where the program is, the larger); rotary words as
    /// programmed to twice their rounding, or, where the orientation is compensated, the bound on
    /// the rotary correction plus the rounding of its six decimals.
    pub fn of(largest_correction_mm: f64, options: &Options) -> CheckBounds {
        let decimals = options.decimals.unwrap_or(4) as i32;
        let rounding_mm = 3f64.sqrt() * 0.5 * 10f64.powi(-decimals) * 25.4;
        CheckBounds {
            linear_mm: largest_correction_mm + options.chord_tolerance_mm + rounding_mm,
            rotary_deg: if options.orientation_tolerance_rad.is_some() {
                options.max_rotary_correction_deg + 1e-5
            } else {
                10f64.powi(-decimals)
            },
        }
    }
}

/// A compensated program that does not follow the program it was made from: a failure of
/// volmap's own work, never of the input.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The written program cannot be read back (or the original no longer reads).
    #[error("the compensated program cannot be read back: {0}")]
    Unreadable(NcError),
    /// A written move that is not where the program's move is.
    #[error("{path}: line {line}: the compensated program does not follow it: {message}")]
    Strays {
        path: String,
        /// The program's line the failing move belongs to (or the last one before it).
        line: usize,
        message: String,
    },
}

impl Classify for CheckError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Work
    }
}

/// The programmed arcs are followed by chords within this fraction of the bound.
const SAG: f64 = 0.02;
/// Samples along a written move: at least this many, and one at least every `SAMPLE_MM`.
const MIN_SAMPLES: usize = 4;
const SAMPLE_MM: f64 = 0.5;
const MAX_SAMPLES: usize = 4096;

/// One move as the reader has it.
struct Move {
    line: usize,
    text: String,
    rapid: bool,
    /// The path in machine commands (program coordinates plus the offset in force).
    path: Toolpath,
    offset: [f64; 6],
    /// The axes the block names.
    named: [bool; 6],
    /// The axes not known at its start, with the passed line that made each unknown.
    unknown: [Option<usize>; 6],
}

impl Move {
    fn at(&self, t: f64) -> [f64; 6] {
        let p = self.path.at(t);
        std::array::from_fn(|d| p[d] + self.offset[d])
    }
}

/// The lines (number and text) of the passed blocks that leave an axis unknown.
type Passed = Vec<(usize, String)>;
/// The blocks that may move and pass as they are (a code volmap does not follow, a line it cannot
/// read, a move from where an axis is unknown): line number and text.
type AsTheyAre = Vec<(usize, String)>;

/// The moves of `text` as the reader runs them, and the passed lines that leave axes unknown.
fn moves(
    machine: &Machine,
    text: &[u8],
    path: &str,
    options: &Options,
) -> Result<(Vec<Move>, Passed, AsTheyAre), NcError> {
    let (lines, mut state, compensator, _) = begin(machine, text, path, options)?;
    // At most a move a line: held exactly, not at twice its size by doubling.
    let mut moves = Vec::with_capacity(lines.len());
    let mut passed = Vec::new();
    let mut as_they_are = Vec::new();
    for (index, line) in lines.iter().enumerate() {
        // The reader keeps which axes a passed block left unknown, and leaves alone (passes) a
        // move that depends on one.
        let before = state.unknown;
        if take_line(&lines, index, &mut state, path, options.pass_unknown)? == Step::Pass {
            let newly = (0..6).any(|d| before[d].is_none() && state.unknown[d].is_some());
            if newly {
                passed.push((line.number, line.text.clone()));
            }
            if newly || state.left_alone.take().is_some() || is_unread(line, path) {
                as_they_are.push((line.number, line.text.trim().to_string()));
            }
            continue;
        }
        let unknown = before;
        let end = end_position(line, &state);
        let toolpath = match state.motion {
            Motion::Clockwise | Motion::CounterClockwise => {
                arc_path(line, &state, state.position, end, path)?
            }
            _ => Toolpath::Line {
                from: state.position,
                to: end,
            },
        };
        let named = std::array::from_fn(|d| line.has(AXIS_LETTERS[d]));
        moves.push(Move {
            line: line.number,
            text: line.text.clone(),
            rapid: state.motion == Motion::Rapid,
            path: toolpath,
            offset: compensator.offset(&state, line.number)?,
            named,
            unknown,
        });
        state.position = end;
    }
    Ok((moves, passed, as_they_are))
}

/// A line the reader kept without reading it (`--pass-unknown`): it has no words, yet more than
/// comments and program delimiters.
fn is_unread(line: &Line, path: &str) -> bool {
    line.words.is_empty() && parse_program(line.text.as_bytes(), path, false).is_err()
}

/// A programmed move followed by chords, with the distance along it to every vertex (in units of
/// the bound).
struct Polyline {
    points: Vec<[f64; 6]>,
    along: Vec<f64>,
}

/// The scale of each axis: distances are measured in units of the bound; unknown axes are not
/// measured.
type Scale = [f64; 6];

/// The larger of the X Y Z and the A B C distance, each in units of its bound: a move at its
/// bound in both (a rotary correction and the X Y Z that keep the tip) is within it, as each is.
fn scaled_distance(a: &[f64; 6], b: &[f64; 6], scale: &Scale) -> f64 {
    let group = |axes: std::ops::Range<usize>| {
        axes.map(|d| ((a[d] - b[d]) * scale[d]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    group(0..3).max(group(3..6))
}

impl Polyline {
    fn of(m: &Move, bounds: &CheckBounds, scale: &Scale) -> Polyline {
        let n = match m.path {
            Toolpath::Line { .. } => 1,
            Toolpath::Arc { sweep, radii, .. } => {
                let r = radii[0].max(radii[1]);
                let cos = (1.0 - SAG * bounds.linear_mm / r.max(1e-12)).clamp(-1.0, 1.0);
                let step = 2.0 * cos.acos();
                ((sweep.abs() / step.max(1e-9)).ceil() as usize).clamp(1, 1 << 20)
            }
        };
        let points: Vec<[f64; 6]> = (0..=n).map(|k| m.at(k as f64 / n as f64)).collect();
        let mut along = vec![0.0];
        for w in points.windows(2) {
            along.push(along.last().unwrap() + scaled_distance(&w[0], &w[1], scale));
        }
        Polyline { points, along }
    }

    fn length(&self) -> f64 {
        *self.along.last().unwrap()
    }

    /// The first point along the polyline at or after `from` (in units of the bound) within
    /// the bound of `p`: where along the path it is, and how far (in units of the bound); else
    /// the nearest point after `from` and its distance.
    fn find(&self, p: &[f64; 6], from: f64, scale: &Scale) -> (f64, f64) {
        let mut nearest = (from, f64::INFINITY);
        let first = self.along.partition_point(|&s| s <= from).saturating_sub(1);
        for k in first..self.points.len().saturating_sub(1).max(first + 1) {
            let (a, b) = (
                &self.points[k],
                self.points.get(k + 1).unwrap_or(&self.points[k]),
            );
            let (s0, s1) = (
                self.along[k],
                *self.along.get(k + 1).unwrap_or(&self.along[k]),
            );
            let length = s1 - s0;
            let ab: [f64; 6] = std::array::from_fn(|d| (b[d] - a[d]) * scale[d]);
            let ap: [f64; 6] = std::array::from_fn(|d| (p[d] - a[d]) * scale[d]);
            let f_min = if length > 0.0 {
                ((from - s0) / length).clamp(0.0, 1.0)
            } else {
                0.0
            };
            // The projection is Euclidean; `length` is the segment's length as distances are
            // measured (the larger of two groups), so the squared norm is taken apart.
            let norm2: f64 = ab.iter().map(|x| x * x).sum();
            let f = if length > 0.0 && norm2 > 0.0 {
                (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / norm2).clamp(f_min, 1.0)
            } else {
                0.0
            };
            let q: [f64; 6] = std::array::from_fn(|d| a[d] + f * (b[d] - a[d]));
            let distance = scaled_distance(p, &q, scale);
            if distance < nearest.1 {
                nearest = (s0 + f * length, distance);
            }
            if distance <= 1.0 + SAG {
                return (s0 + f * length, distance);
            }
        }
        nearest
    }
}

/// Where the walk stands on a programmed move.
struct OnMove {
    index: usize,
    polyline: Polyline,
    scale: Scale,
    /// How far along it the written program has come, in units of the bound.
    along: f64,
    written: usize,
    /// Whether the last written move ended at its end.
    at_end: bool,
}

/// Why a written move does not belong to a programmed move.
type Misfit = String;

/// Where the orientation is compensated the rotary words turn by up to `rotary_deg`, and X Y Z
/// move with them to keep the tip: by the turn times the tip's distance from the rotary axes.
/// That distance is the ideal tip's derivative along each rotary axis at the programmed ends
/// (mm per radian, the largest); the linear bound grows by it times the rotary bound.
fn with_rotary_lever(
    bounds: CheckBounds,
    machine: &Machine,
    options: &Options,
    programmed: &[Move],
) -> CheckBounds {
    if options.orientation_tolerance_rad.is_none() {
        return bounds;
    }
    let twin = Twin::new(machine.at(&options.inputs));
    let rotary: Vec<usize> = (3..6)
        .filter(|&d| machine.axes.iter().any(|a| a.letter.index() == d))
        .collect();
    let step_deg = 1e-3;
    let mut lever_mm_per_rad: f64 = 0.0;
    for m in programmed {
        for t in [0.0, 1.0] {
            let q = m.at(t);
            for &d in &rotary {
                let mut plus = q;
                let mut minus = q;
                plus[d] += step_deg;
                minus[d] -= step_deg;
                let moved = (twin.ideal_tip(&plus) - twin.ideal_tip(&minus)).norm();
                lever_mm_per_rad = lever_mm_per_rad.max(moved / (2.0 * step_deg.to_radians()));
            }
        }
    }
    CheckBounds {
        linear_mm: bounds.linear_mm + lever_mm_per_rad * bounds.rotary_deg.to_radians(),
        ..bounds
    }
}

/// Checks that `written` (the compensated program's text) follows `original` within `bounds`
/// (see the module's documentation); `path` names the original in errors.
pub fn check_written(
    machine: &Machine,
    original: &[u8],
    written: &[u8],
    path: &str,
    options: &Options,
    bounds: CheckBounds,
) -> Result<(), CheckError> {
    let (programmed, passed, kept) =
        moves(machine, original, path, options).map_err(CheckError::Unreadable)?;
    let (written, _, written_kept) =
        moves(machine, written, &format!("{path} (compensated)"), options)
            .map_err(CheckError::Unreadable)?;
    // What passes as it is must be written as it is, each block once and in order.
    for (k, (line, text)) in kept.iter().enumerate() {
        match written_kept.get(k) {
            Some((_, t)) if t == text => {}
            Some((out, t)) => {
                return Err(CheckError::Strays {
                    path: path.to_string(),
                    line: *line,
                    message: format!(
                        "`{}` passes as it is, but the output has `{}` (line {out} of the output) in its place",
                        excerpt(text),
                        excerpt(t)
                    ),
                })
            }
            None => {
                return Err(CheckError::Strays {
                    path: path.to_string(),
                    line: *line,
                    message: format!("`{}` passes as it is, but the output lacks it", excerpt(text)),
                })
            }
        }
    }
    if let Some((out, t)) = written_kept.get(kept.len()) {
        return Err(CheckError::Strays {
            path: path.to_string(),
            line: kept.last().map_or(0, |k| k.0),
            message: format!(
                "the output passes `{}` (line {out} of the output), which the program does not have",
                excerpt(t)
            ),
        });
    }
    let bounds = with_rotary_lever(bounds, machine, options, &programmed);
    let strays = |line: usize, message: String| CheckError::Strays {
        path: path.to_string(),
        line,
        message,
    };
    let passed_text = |line: usize| {
        passed
            .iter()
            .find(|p| p.0 == line)
            .map_or(String::new(), |p| excerpt(&p.1).into_owned())
    };
    let enter = |index: usize| {
        let m: &Move = &programmed[index];
        let scale: Scale = std::array::from_fn(|d| {
            if m.unknown[d].is_some() {
                0.0
            } else if d < 3 {
                1.0 / bounds.linear_mm
            } else {
                1.0 / bounds.rotary_deg
            }
        });
        OnMove {
            index,
            polyline: Polyline::of(m, &bounds, &scale),
            scale,
            along: 0.0,
            written: 0,
            at_end: false,
        }
    };
    let mut on: Option<OnMove> = None;
    for w in &written {
        let next_index = on.as_ref().map_or(0, |o| o.index + 1);
        let shown = format!("`{}`", excerpt(&w.text));
        // A move that has reached its end gives way to the next; else the written move is more of
        // the same programmed move.
        let mut tried_next: Option<(usize, Misfit)> = None;
        if on.as_ref().is_none_or(|o| o.at_end) && next_index < programmed.len() {
            let mut next = enter(next_index);
            match fits(&programmed[next_index], w, &mut next, &bounds, &passed_text) {
                Ok(()) => {
                    on = Some(next);
                    continue;
                }
                Err(why) => tried_next = Some((programmed[next_index].line, why)),
            }
        }
        let Some(current) = on.as_mut() else {
            let (line, why) = tried_next.unwrap_or_else(|| {
                (
                    1,
                    "the program has no move, but the compensated one has".into(),
                )
            });
            return Err(strays(line, format!("its first move, {shown}, {why}")));
        };
        let m = &programmed[current.index];
        if let Err(why) = fits(m, w, current, &bounds, &passed_text) {
            // Past the end of the current move (the only time the next is tried): a second move
            // of a block written as one (a rapid, a move from an unknown axis) is named there,
            // anything else was meant to begin the next. Both reasons either way.
            if let Some((next, why_next)) = tried_next {
                let output = format!("{shown} (line {} of the output)", w.line);
                let closed = m.rapid || m.unknown.iter().any(Option::is_some);
                return Err(if closed && current.written > 0 && w.rapid == m.rapid {
                    strays(
                        m.line,
                        format!("{output} {why}; nor does it begin line {next} ({why_next})"),
                    )
                } else {
                    strays(
                        next,
                        format!(
                            "{output} {why_next}; nor does it continue line {} ({why})",
                            m.line
                        ),
                    )
                });
            }
            let message = if current.at_end && current.index + 1 == programmed.len() {
                format!(
                    "{shown} (line {} of the output) comes after the program's last move ({why})",
                    w.line
                )
            } else {
                format!("{shown} (line {} of the output) {why}", w.line)
            };
            return Err(strays(m.line, message));
        }
    }
    match on {
        None if programmed.is_empty() => Ok(()),
        None => Err(strays(
            programmed[0].line,
            "the compensated program has none of the program's moves".into(),
        )),
        Some(o) if o.index + 1 < programmed.len() || !o.at_end => {
            let missing = if o.at_end {
                programmed[o.index + 1].line
            } else {
                programmed[o.index].line
            };
            Err(strays(
                missing,
                "the compensated program ends before this move ends".into(),
            ))
        }
        Some(_) => Ok(()),
    }
}

/// Whether the written move `w` continues the programmed move `m` from where `on` stands; moves
/// `on` along if it does.
fn fits(
    m: &Move,
    w: &Move,
    on: &mut OnMove,
    bounds: &CheckBounds,
    passed_text: &dyn Fn(usize) -> String,
) -> Result<(), Misfit> {
    if w.rapid != m.rapid {
        return Err(if w.rapid {
            "is a rapid (G0) where the program feeds".into()
        } else {
            "feeds where the program has a rapid (G0)".into()
        });
    }
    for (d, letter) in AXIS_LETTERS.iter().enumerate() {
        if let Some(at) = m.unknown[d] {
            if w.named[d] && !m.named[d] {
                return Err(format!(
                    "names {letter}, which the program's block does not, where {letter} is not known (line {at}, `{}`, passed as it is)",
                    passed_text(at)
                ));
            }
        }
    }
    if on.written > 0 {
        if m.rapid {
            return Err("adds a move to a rapid (G0), which is written as one move".into());
        }
        if let Some(d) = (0..6).find(|&d| m.unknown[d].is_some()) {
            return Err(format!(
                "adds a move to a block that starts where {} is not known, which is written as one move",
                AXIS_LETTERS[d]
            ));
        }
    }
    let length_mm = w.path.length();
    let n = ((length_mm / SAMPLE_MM).ceil() as usize).clamp(MIN_SAMPLES, MAX_SAMPLES);
    let mut along = on.along;
    let mut end_distance = f64::INFINITY;
    for k in 1..=n {
        let p = w.at(k as f64 / n as f64);
        let (s, distance) = on.polyline.find(&p, along - 2.0, &on.scale);
        if distance > 1.0 + SAG {
            return Err(stray_reason(m, w, &p, on, bounds));
        }
        along = along.max(s);
        end_distance = distance;
    }
    let end = m.at(1.0);
    let end_reached = scaled_distance(&w.at(1.0), &end, &on.scale) <= 1.0 + SAG
        && along >= on.polyline.length() - 2.0;
    on.along = along;
    on.written += 1;
    on.at_end = end_reached || (on.at_end && end_distance <= 1.0 + SAG);
    Ok(())
}

/// Why a written point `p` is not on the programmed move `m`: an axis the program's block does
/// not move, or the distance from its path, or a step back along it.
fn stray_reason(m: &Move, w: &Move, p: &[f64; 6], on: &OnMove, bounds: &CheckBounds) -> Misfit {
    let (start, end) = (m.at(0.0), m.at(1.0));
    let unit = |d: usize| if d < 3 { "mm" } else { "°" };
    let bound = |d: usize| {
        if d < 3 {
            bounds.linear_mm
        } else {
            bounds.rotary_deg
        }
    };
    let written_end = w.at(1.0);
    for d in 0..6 {
        // How far from where the program holds it: at the stray point or at the written end.
        let moved = (written_end[d] - start[d])
            .abs()
            .max((p[d] - start[d]).abs());
        if on.scale[d] > 0.0 && start[d] == end[d] && moved > bound(d) {
            return format!(
                "moves {} by {:.4} {} where the program's block does not move it (bound {:.4} {})",
                AXIS_LETTERS[d],
                moved,
                unit(d),
                bound(d),
                unit(d)
            );
        }
    }
    let (_, anywhere) = on.polyline.find(p, f64::NEG_INFINITY, &on.scale);
    let program = |d: usize| p[d] - w.offset[d];
    if anywhere <= 1.0 + SAG {
        format!(
            "goes back along the programmed path (to X{:.4} Y{:.4} Z{:.4})",
            program(0),
            program(1),
            program(2)
        )
    } else {
        let (_, scaled) = on.polyline.find(p, f64::NEG_INFINITY, &on.scale);
        format!(
            "passes {:.4} mm from the programmed path at X{:.4} Y{:.4} Z{:.4}, beyond the bound of {:.4} mm",
            scaled * bounds.linear_mm,
            program(0),
            program(1),
            program(2),
            bounds.linear_mm
        )
    }
}
