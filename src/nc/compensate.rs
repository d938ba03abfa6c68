//! The compensation itself (see the module's documentation): each block's end points moved so
//! that the real tool tip lands where the ideal one would, feed moves split until the real tip
//! stays within the chord tolerance of the intended path, arcs kept where they can be.

use super::arcs::ArcPieces;
use super::block::{Block, Split, MAX_PIECES};
use super::error::{NcError, NcOption};
use super::kinematics::Compensator;
use super::options::{check_work_offsets, Options, MAX_CHORD_TOLERANCE_MM};
use super::orientation::{check_options, rotary_axes};
use super::program::approach::{line_directions, segment_at, segments, Segment};
use super::program::as_run;
use super::program::modal::{Directions, Motion, State, AXIS_LETTERS};
use super::program::parse::Line;
use super::program::reader::{first_state, take_line, unknown_code, Step};
use super::program::settings::names_current_point;
use super::program::tcpm;
use super::program::toolpath::{arc_path, Toolpath};
use super::report::{Compensated, LeftMove, PassedBlock, Report, ReportInputs};
use super::standing::{standing, standing_feed};
use super::walk::Walk;
use super::write::write_setting;
use crate::limits::{number_words, MAX_COMPENSATED_BLOCKS, MAX_COMPENSATED_BYTES, MAX_DECIMALS};
use crate::model::Machine;

/// The program's lines as the control runs them, its state before the first, the machine per
/// tool, and the number of cycle holes expanded.
pub(super) fn begin<'a>(
    machine: &'a Machine,
    program: &[u8],
    path: &'a str,
    options: &'a Options,
) -> Result<(Vec<Line>, State, Compensator<'a>, usize), NcError> {
    check_work_offsets(machine, &options.work_offsets)?;
    let (lines, holes) = as_run(program, path, options.pass_unknown, &options.work_offsets)?;
    let (state, named) = first_state(&lines, machine, path, options)?;
    if options.orientation_tolerance_rad.is_some() {
        // The correction turns both rotary axes: from a position the program never sets it
        // would turn the axis from wherever it stands to the model's 0 (a table at C37 turned
        // by −37°), and in G91 its first word would be an increment from nowhere.
        if let Some(&d) = rotary_axes(machine).iter().find(|&&d| !named[d]) {
            return Err(NcError::line(
                path,
                1,
                format!(
                    "the program never sets {}: compensating the tool orientation turns it, and where it stands is not known; set it in the first positioning block (e.g. {}0)",
                    AXIS_LETTERS[d], AXIS_LETTERS[d]
                ),
            ));
        }
    }
    Ok((
        lines,
        state,
        Compensator::new(path, options, machine),
        holes,
    ))
}

/// Checks the options of what a compensation writes (the chord tolerance, the decimals) before
/// any work: `trace --compensate` asks it before it traces the program as programmed.
pub fn check_written_options(options: &Options) -> Result<(), NcError> {
    let chord = options.chord_tolerance_mm;
    if !(chord > 0.0 && chord <= MAX_CHORD_TOLERANCE_MM) {
        return Err(NcError::Option {
            option: NcOption::ChordTolerance,
            value: crate::error::shown(chord),
            message: format!("it must be positive and at most {MAX_CHORD_TOLERANCE_MM} mm"),
        });
    }
    if let Some(decimals) = options.decimals.filter(|&d| d > MAX_DECIMALS) {
        return Err(NcError::Option {
            option: NcOption::Decimals,
            value: decimals.to_string(),
            message: format!("at most {MAX_DECIMALS} decimals are written"),
        });
    }
    if let Some(decimals) = options.decimals {
        // Every compensated point is written rounded: half a unit of the last decimal (mm; an
        // inch program rounds 25.4 times coarser) beyond the tolerance cannot be met however the
        // moves are split.
        let rounding_mm = 0.5 * 10f64.powi(-(decimals as i32));
        if rounding_mm > chord {
            let needed = (0.5 / chord).log10().ceil().max(0.0);
            return Err(NcError::Option {
                option: NcOption::Decimals,
                value: decimals.to_string(),
                message: format!(
                    "numbers written to {decimals} decimals are rounded by up to {} mm, more than the chord tolerance of {} mm: no split of the moves meets it; write at least {needed} decimals (or a larger chord tolerance)",
                    number_words(rounding_mm),
                    number_words(chord)
                ),
            });
        }
    }
    Ok(())
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
    check_written_options(options)?;
    check_options(machine, options)?;
    let (lines, mut state, mut compensator, holes) = begin(machine, program, path, options)?;
    let mut report = Report {
        cycle_holes_expanded: holes,
        errors_cover: "feed moves (G1 G2 G3)".into(),
        inputs: ReportInputs::of(&options.inputs, machine),
        ..Report::default()
    };
    let mut out = String::with_capacity(program.len() * 2);
    let mut start_compensated = false;
    let mut origins = Vec::with_capacity(lines.len());
    for (index, line) in lines.iter().enumerate() {
        if index % 1024 == 0 {
            on_progress(index, lines.len());
        }
        let before = out.len();
        if let Some(code) = unknown_code(line).filter(|_| options.pass_unknown) {
            if report.not_compensated.last().map(|p| p.line) != Some(line.number) {
                report.not_compensated.push(PassedBlock {
                    line: line.number,
                    code,
                });
            }
        }
        let emitted = process_line(
            &lines,
            index,
            &mut state,
            &mut compensator,
            &mut report,
            &mut out,
            &mut start_compensated,
        )?;
        if let Some(left) = state.left_alone.take() {
            report.moves_not_compensated.push(LeftMove {
                line: left.line,
                unknown: left.axes,
                since_line: left.since,
            });
        }
        if emitted > 1 {
            report.blocks_added += emitted - 1;
        }
        if out[before..] != format!("{}{}", line.text, line.ending)[..] {
            report.blocks_changed += 1;
        }
        origins.extend(std::iter::repeat_n(line.number, emitted));
        output_within_limits(&out, origins.len(), (line, lines.len()), path, options)?;
    }
    Ok(Compensated {
        text: out,
        report,
        origins,
    })
}

/// The compensated program so far within what volmap reads back as a program
/// ([`MAX_COMPENSATED_BLOCKS`], [`MAX_COMPENSATED_BYTES`]), checked after every block: beyond it,
/// the tolerance that split the moves is named with its figure (the output never grows far past
/// the bound: one block adds at most [`MAX_PIECES`] blocks).
fn output_within_limits(
    out: &str,
    blocks: usize,
    (line, lines): (&Line, usize),
    path: &str,
    options: &Options,
) -> Result<(), NcError> {
    let too_many = blocks as u64 > MAX_COMPENSATED_BLOCKS;
    if !too_many && out.len() as u64 <= MAX_COMPENSATED_BYTES {
        return Ok(());
    }
    let what = if too_many {
        format!("more than {MAX_COMPENSATED_BLOCKS} blocks")
    } else {
        format!(
            "more than {}",
            crate::io::source::describe_bytes(MAX_COMPENSATED_BYTES)
        )
    };
    let chord = number_words(options.chord_tolerance_mm);
    let tolerance = match options.orientation_tolerance_rad {
        Some(angle) => format!(
            "the chord tolerance of {chord} mm (and the angular tolerance of {} rad)",
            number_words(angle)
        ),
        None => format!("the chord tolerance of {chord} mm"),
    };
    Err(NcError::Option {
        option: NcOption::ChordTolerance,
        value: chord,
        message: format!(
            "{path}: the compensated program reaches {what} at line {} (of {lines} blocks run), the most volmap writes and reads back as a program: {tolerance} split the moves this finely; give a larger tolerance, or compensate the program in parts",
            line.number
        ),
    })
}

/// An absolute arc left alone (it depends on an axis not known) passes as it is: its centre
/// words are relative to its start, so it must start where the program has it in its plane,
/// or the control finds start and end at different distances from the centre (an alarm, or
/// another path). Refused where a compensated move before it put the start elsewhere.
fn arc_left_at_its_start(
    line: &Line,
    point: ([f64; 6], [f64; 6]),
    state: &State,
    path: &str,
) -> Result<(), NcError> {
    let arc = matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise);
    if !arc || !state.absolute {
        return Ok(());
    }
    let (programmed, written) = point;
    for d in [state.plane.u, state.plane.v] {
        let off = written[d] - programmed[d];
        if off.abs() > ARC_START_MM {
            let left = state.left_alone.as_ref().expect("a move left alone");
            return Err(NcError::line(
                path,
                line.number,
                format!(
                    "this arc cannot be compensated ({} not known since line {}) and would pass as it is, but the move before it was compensated: it starts {:.4} mm from its programmed start in {}, so its centre words no longer fit; give {} absolutely before the arc",
                    left.axes,
                    left.since,
                    off.abs(),
                    AXIS_LETTERS[d],
                    left.axes
                ),
            ));
        }
    }
    Ok(())
}

/// How far an arc passed as it is may start from its programmed start, mm: the rounding of
/// the written numbers, well inside any control's tolerance on an arc's radius.
const ARC_START_MM: f64 = 1e-4;

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
    let before = tcpm::switches(line).then(|| state.clone());
    let standing = standing(state);
    let point = (state.position, state.written);
    let step = take_line(lines, index, state, path, options.pass_unknown)?;
    super::tcpm::follow(line, before, state, comp)?;
    if state.left_alone.is_some() {
        arc_left_at_its_start(line, point, state, path)?;
    }
    if step == Step::Pass && names_current_point(line) && unknown_code(line).is_none() {
        write_setting(line, point, state, out, options);
        return Ok(1);
    }
    if step == Step::Pass {
        out.push_str(&line.text);
        out.push_str(line.ending);
        return Ok(1);
    }
    if state.offset != 54 && !state.work_offsets.contains_key(&state.offset) {
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
    if let Some(written) = standing_feed((path, line), &standing, state, report, out)? {
        return Ok(written);
    }
    let end = super::tcpm::move_end(line, state, comp)?;
    let mut block = Block::new(
        path,
        line.number,
        comp.offset(state, line.number)?,
        comp.kinematics(state.tool, line.number)?,
        state.inch,
        line.word('R').is_some(),
        options,
    );
    block.tcpm = state.tcpm;
    // Where the move starts, an axis at its G53 position stands there, uncorrected.
    block.held = standing.map(|s| s.is_some());
    if !*start_compensated {
        // The output starts where the compensated start of the program is, for the axes it
        // does not leave unwritten (see `begin`).
        let compensated = block.compensate_point(&state.position, &state.approach)?;
        state.written = std::array::from_fn(|d| {
            if state.written[d].is_nan() {
                f64::NAN
            } else {
                compensated[d]
            }
        });
        *start_compensated = true;
    }
    let (start, motion) = (state.position, state.motion);
    let mut pieces: Vec<[f64; 6]> = Vec::new();
    let mut arcs = ArcPieces::new();
    // Where the output has the tool at the start (see `written_start`).
    let from = block.written_start(state.written, &start, &state.approach)?;
    // An axis the block names is corrected at its end; one it does not name stays.
    block.held = std::array::from_fn(|d| block.held[d] && !line.has(AXIS_LETTERS[d]));
    if motion == Motion::Rapid {
        let programmed = line_directions(&start, &end, &state.programmed);
        let mut walk = Walk {
            at: from,
            directions: state.approach,
        };
        let line = Toolpath::Line {
            from: start,
            to: end,
        };
        let piece = block.piece(&line, (0.0, 1.0), &programmed, &walk, false)?;
        block.accept(&piece, &mut walk, &mut pieces);
        state.approach = walk.directions;
        state.programmed = programmed;
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
        let segments = segments(&intended, &state.programmed, block.kin.reversing());
        report.largest_error_before_mm = report
            .largest_error_before_mm
            .max(block.error_before(&intended, &segments));
        report.largest_orientation_error_before_rad = report
            .largest_orientation_error_before_rad
            .max(block.angle_before(&|t| intended.at(t), &|t| {
                segment_at(&segments, t).directions
            }));
        let mut walk = Walk {
            at: from,
            directions: state.approach,
        };
        block.feed_move(
            &intended,
            &segments,
            &mut walk,
            motion,
            (&mut pieces, &mut arcs),
            report,
        )?;
        state.approach = walk.directions;
        state.programmed = segments.last().expect("a move has a segment").directions;
    }
    report.take_ups += block.take_ups.get();
    report.against_direction += block.against.get();
    report.points += pieces.len();
    report.largest_correction_mm = report.largest_correction_mm.max(block.largest_correction());
    block.report_orientation(report);
    state.position = end;
    super::tcpm::write(&block, line, state, &from, &pieces, &arcs, out)
}

/// Points sampled along an intended move of `length` mm: every 0.5 mm, from 8 to 256.
fn samples(length: f64) -> usize {
    ((length / 0.5).ceil() as usize).clamp(8, 256)
}

impl Block<'_> {
    /// The largest distance of the real tool tip from the intended path along the move, as the
    /// program had it (each point approached in the direction of its segment).
    fn error_before(&self, intended: &Toolpath, segments: &[Segment]) -> f64 {
        let n = samples(intended.length());
        (0..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let q = self.command(&intended.at(t));
                self.kin.miss(&q, &q, &segment_at(segments, t).directions)
            })
            .fold(0.0, f64::max)
    }

    /// The pieces of a feed move along `intended`, segment by segment, starting where `walk`
    /// is (see `walk`); an arc stays one arc where that fits (a move of one segment
    /// that needs no take-up), and is split into arc pieces otherwise (see `arcs`).
    fn feed_move(
        &self,
        intended: &Toolpath,
        segments: &[Segment],
        walk: &mut Walk,
        motion: Motion,
        (pieces, arcs): (&mut Vec<[f64; 6]>, &mut ArcPieces),
        report: &mut Report,
    ) -> Result<(), NcError> {
        if let [segment] = segments {
            let piece = self.piece(intended, (0.0, 1.0), &segment.directions, walk, true)?;
            if piece.take_up.is_none() && !piece.against {
                let ends = (walk.at, piece.end);
                if let Some(centre) =
                    self.arc_within_tolerance(intended, ends, motion, &piece.directions, report)
                {
                    self.accept(&piece, walk, pieces);
                    arcs.push((0, centre));
                    return Ok(());
                }
            }
        }
        for segment in segments {
            match intended {
                Toolpath::Arc { .. } => self.arc_segment(
                    intended,
                    segment,
                    motion,
                    walk,
                    (&mut *pieces, &mut *arcs),
                    report,
                ),
                Toolpath::Line { .. } => self.walk_segment(intended, segment, walk, pieces, report),
            }
            .map_err(|e| match e {
                Split::Pieces(option) => self.too_many_pieces(option),
                Split::Point(e) => e,
            })?;
        }
        Ok(())
    }

    /// A move split into more than [`MAX_PIECES`] pieces: the tolerance that split it named,
    /// with its figure.
    fn too_many_pieces(&self, option: NcOption) -> NcError {
        let value = match option {
            NcOption::AngularTolerance => self.options.orientation_tolerance_rad.unwrap_or(0.0),
            _ => self.tolerance,
        };
        let unit = if option == NcOption::AngularTolerance {
            "rad"
        } else {
            "mm"
        };
        NcError::Option {
            option,
            value: number_words(value),
            message: format!(
                "{}: line {}: the move needs more than {MAX_PIECES} blocks to stay within the {option} of {} {unit}, the most one move may become: give a larger tolerance",
                self.path,
                self.line,
                number_words(value)
            ),
        }
    }

    /// Where the output has the tool at the start of a move; an axis not written since its
    /// reference return is taken where the program has it.
    fn written_start(
        &self,
        written: [f64; 6],
        start: &[f64; 6],
        directions: &Directions,
    ) -> Result<[f64; 6], NcError> {
        let mut from = written;
        if from.iter().any(|v| v.is_nan()) {
            let start_compensated = self.compensate_point(start, directions)?;
            for d in 0..6 {
                if from[d].is_nan() {
                    from[d] = start_compensated[d];
                }
            }
        }
        Ok(from)
    }

    /// An arc kept as an arc, with compensated ends `from`, `to` and its centre moved by the mean
    /// correction of its ends, where that keeps the real tool tip along the arc as written
    /// within the tolerance of the intended arc: the new centre.
    fn arc_within_tolerance(
        &self,
        intended: &Toolpath,
        (from, to): ([f64; 6], [f64; 6]),
        motion: Motion,
        directions: &Directions,
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
        let commanded = self.written_arc((&from, &to), plane, moved, motion)?;
        let Toolpath::Arc { radii, .. } = commanded else {
            unreachable!("written_arc returns arcs")
        };
        if (radii[0] - radii[1]).abs() > self.tolerance
            || !self.keeps_directions(&commanded, directions)
        {
            return None;
        }
        let worst = self.path_error(intended, (0.0, 1.0), &commanded, directions);
        let turn = (3..6).map(|d| (to[d] - from[d]).abs()).fold(0.0, f64::max);
        let angle = self.angle_along(&|t| commanded.at(t), &|t| intended.at(t), turn, directions);
        let allowed = self.angle_allowed((from, to), (start, end), directions);
        (worst <= self.tolerance && angle <= allowed).then(|| {
            report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
            report.largest_orientation_error_after_rad =
                report.largest_orientation_error_after_rad.max(angle);
            moved
        })
    }
}
