//! Reading a program as the control does: the state before its first block, each block's modal
//! words taken into the state (motion, plane, distance, units, work offset, tool), which codes
//! volmap follows, where each block ends.

use super::modal::{AxisSet, Motion, State, AXIS_LETTERS, MM_PER_INCH, XY, YZ, ZX};
use super::offsets::{change_offset, offset_of, selected, shift};
use super::parse::Line;
use super::settings::{is_setting, pass_setting, take_setting, unknown_setting};
use super::tcpm;
use super::unknown::{leave_alone, pass_block};
use crate::error::excerpt;
use crate::model::{AxisLetter, Machine};
use crate::nc::error::NcError;
use crate::nc::options::{Options, ToolLengths};

/// G codes that change nothing volmap must follow: cutter compensation off, tool length
/// compensation, cycle cancel, feed modes, exact stop and cutting modes, cycle return levels.
const PASSIVE_G: [u32; 9] = [40, 43, 49, 80, 94, 95, 61, 64, 98];

/// The state before the program's first block, and which axes the program names.
pub(in crate::nc) fn first_state(
    lines: &[Line],
    machine: &Machine,
    path: &str,
    options: &Options,
) -> Result<(State, [bool; 6]), NcError> {
    let (start, named) = starting_position(lines, machine, path, options)?;
    let state = State {
        motion: Motion::Rapid,
        plane: XY,
        absolute: true,
        inch: false,
        offset: 54,
        tool: None,
        tool_length_on: false,
        tcpm: None,
        tool_lengths: options.tool_lengths.clone(),
        pending_tool: None,
        position: start,
        // An axis the program names is, for the reader of the output, where the output first
        // names it: until then the output has not written it (no word is added for it).
        written: std::array::from_fn(|d| if named[d] { f64::NAN } else { start[d] }),
        written_motion: Motion::Rapid,
        approach: options.inputs.approach,
        programmed: options.inputs.approach,
        set: [AxisSet::Never; 6],
        unknown: [None; 6],
        named,
        work_offsets: options.work_offsets.clone(),
        offsets_unknown: Default::default(),
        tool_data_unknown: None,
        local_shift: [0.0; 6],
        g92_shift: [0.0; 6],
        left_alone: None,
    };
    Ok((state, named))
}

/// Where each axis is before the program moves it: the first absolute value the program gives
/// it (rotary axes the program never names: 0), and whether the program names it. An axis first
/// moved incrementally, or a linear axis never set, has no known start.
fn starting_position(
    lines: &[Line],
    machine: &Machine,
    path: &str,
    options: &Options,
) -> Result<([f64; 6], [bool; 6]), NcError> {
    let mut start: [Option<f64>; 6] = [None; 6];
    let mut unknown_at: [Option<(usize, String)>; 6] = Default::default();
    let mut absolute = true;
    let mut inch = false;
    // Where the first Z comes under G43, the axes stand higher by the tool's length than the
    // same Z without it: the start is where they stand, in coordinates without tool length.
    let (mut length_on, mut tool, mut pending) = (false, None, None);
    // A value given under another work offset than G54 (active at the start) stands elsewhere
    // in G54's coordinates.
    let mut offset = 54;
    for line in lines {
        distance_and_units(line, &mut absolute, &mut inch);
        offset = selected(line).unwrap_or(offset);
        let to_start = shift(&options.work_offsets, offset, 54);
        for w in &line.words {
            match (w.letter, w.value) {
                ('G', 43.0) => length_on = true,
                ('G', 49.0) => length_on = false,
                ('T', t) => pending = Some(t as u32),
                ('M', 6.0) => tool = pending,
                _ => {}
            }
        }
        if is_setting(line) && unknown_code(line).is_none() {
            // G10, G52, G92: its axis words are values, not a position.
            continue;
        }
        if unknown_code(line).is_some() {
            // Named beside a code volmap does not know (passed or not, it may be anywhere): said
            // so if nothing else sets it.
            for w in &line.words {
                if let Some(d) = AXIS_LETTERS.iter().position(|&a| a == w.letter) {
                    if start[d].is_none() && unknown_at[d].is_none() {
                        unknown_at[d] = Some((line.number, unknown_code(line).unwrap_or_default()));
                    }
                }
            }
            continue;
        }
        if is_dwell(line) || is_reference_return(line) {
            continue;
        }
        for w in &line.words {
            if let Some(d) = AXIS_LETTERS.iter().position(|&a| a == w.letter) {
                if start[d].is_none() {
                    if !absolute {
                        return Err(NcError::line(
                            path,
                            line.number,
                            format!("{} moves incrementally before the program has set it: its start is not known", w.letter),
                        ));
                    }
                    let length = length_added(&options.tool_lengths, tool, length_on && d == 2);
                    start[d] = Some(
                        length
                            + to_start[d]
                            + if inch && d < 3 {
                                w.value * MM_PER_INCH
                            } else {
                                w.value
                            },
                    );
                }
            }
        }
    }
    let mut position = [0.0; 6];
    for d in 0..6 {
        position[d] = match start[d] {
            Some(v) => v,
            None if d >= 3 => 0.0,
            None if machine.axis(AxisLetter::ALL[d]).is_none() => 0.0,
            None => {
                return Err(match &unknown_at[d] {
                    Some((line, code)) => NcError::line(
                        path,
                        *line,
                        format!(
                            "{} is set only beside `{}`, a code volmap does not know: where {} starts is not known",
                            AXIS_LETTERS[d],
                            excerpt(code),
                            AXIS_LETTERS[d]
                        ),
                    ),
                    None => NcError::line(
                        path,
                        1,
                        format!(
                            "the program never sets {}: where it starts is not known",
                            AXIS_LETTERS[d]
                        ),
                    ),
                })
            }
        };
    }
    Ok((position, start.map(|s| s.is_some())))
}

/// The distance mode (G90/G91) and units (G20/G21) a line sets, for the scans ahead of the
/// program's run.
fn distance_and_units(line: &Line, absolute: &mut bool, inch: &mut bool) {
    for w in line.words.iter().filter(|w| w.letter == 'G') {
        match w.value as u32 {
            20 => *inch = true,
            21 => *inch = false,
            90 => *absolute = true,
            91 => *absolute = false,
            _ => {}
        }
    }
}

/// G4: a dwell, whose X or P is a time.
fn is_dwell(line: &Line) -> bool {
    line.words.iter().any(|w| w.letter == 'G' && w.value == 4.0)
}

/// G28 (to the reference point through the intermediate point its axis words give) or G53 (a
/// move in machine coordinates, a home or a tool-change position): where the axes it names go is
/// not a point of the program.
fn is_reference_return(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'G' && (w.value == 28.0 || w.value == 53.0))
}

/// G41/G42 (and G41.1/G42.1): cutter radius compensation, refused with why.
fn cutter_compensation(line: &Line) -> Option<&str> {
    line.words
        .iter()
        .find(|w| w.letter == 'G' && (41.0..43.0).contains(&w.value))
        .map(|w| line.text_of(w))
}

/// The length the tool-length offset adds to Z with `tool` and G43 `on` (0 without G43 or a
/// length from the options).
fn length_added(lengths: &ToolLengths, tool: Option<u32>, on: bool) -> f64 {
    tool.and_then(|t| lengths.per_tool.get(&t).copied())
        .or(lengths.all)
        .filter(|_| on)
        .unwrap_or(0.0)
}

/// A G28 or G53 block passes as it is. The axes a G53 block names stand at the machine
/// position it gives: in the program's coordinates that position less the active work offset (and
/// G52, G92 shifts) and, for Z under G43, less the tool's length (the control stands the axes at
/// program + offset + length); the output has not written them (no word is added for them until a
/// block names them). The axes G28 names go to the reference point, which the control keeps
/// (LinuxCNC in parameters 5161–5166, a Fanuc in its parameters) and the program does not give:
/// they are unknown (`unknown`) until a block sets them absolutely.
fn reference_return(line: &Line, state: &mut State, path: &str) -> Result<(), NcError> {
    let machine_position = line
        .words
        .iter()
        .any(|w| w.letter == 'G' && w.value == 53.0);
    if machine_position && !state.absolute {
        return Err(NcError::line(
            path,
            line.number,
            "G53 in G91: a machine position is absolute, an increment in machine coordinates is not read (program G90 on the G53 block)".into(),
        ));
    }
    for (d, &letter) in AXIS_LETTERS.iter().enumerate() {
        let Some(w) = line.word(letter) else {
            continue;
        };
        state.set[d] = AxisSet::Reference(line.number);
        if !machine_position {
            state.unknown[d] = Some(line.number);
            continue;
        }
        let value = if state.inch && d < 3 {
            w.value * MM_PER_INCH
        } else {
            w.value
        };
        let work = offset_of(&state.work_offsets, state.offset);
        let length = if d == 2 {
            length_added(&state.tool_lengths, state.tool, state.tool_length_on)
        } else {
            0.0
        };
        state.position[d] = value - work[d] - state.local_shift[d] - state.g92_shift[d] - length;
        state.written[d] = f64::NAN;
        state.unknown[d] = None;
    }
    Ok(())
}

/// The axes a block names have a value from then on.
fn mark_set(line: &Line, state: &mut State) {
    for (d, &letter) in AXIS_LETTERS.iter().enumerate() {
        if line.has(letter) {
            state.set[d] = AxisSet::Yes;
        }
    }
}

/// An arc turns about a centre given from its start (I J K) or found from it (R): where an axis
/// of its plane has no value the program gave it, the control's start (wherever the axis stood
/// before the program, or the machine's reference point) is not a point of the program.
fn arc_start_known(line: &Line, state: &State, path: &str) -> Result<(), NcError> {
    for d in [state.plane.u, state.plane.v] {
        let letter = AXIS_LETTERS[d];
        let why = match state.set[d] {
            AxisSet::Yes => continue,
            AxisSet::Never => "the program has not set it before this block".to_string(),
            AxisSet::Reference(at) => format!(
                "it went to the reference point or a machine position on line {at} and the program has not set it since"
            ),
        };
        return Err(NcError::line(
            path,
            line.number,
            format!("an arc (G{}) starts where {letter} is not known: {why}, so the arc's start and centre are not known; set {letter} before the arc", state.motion.code()),
        ));
    }
    Ok(())
}

pub(in crate::nc) fn unknown_code(line: &Line) -> Option<String> {
    if let Some(code) = &line.unknown {
        return Some(code.clone());
    }
    if let Some(code) = unknown_setting(line) {
        return Some(code);
    }
    let setting = is_setting(line);
    for w in &line.words {
        match w.letter {
            'G' => {
                let g = w.value;
                let known = g.fract() == 0.0
                    && matches!(g as u32, 0..=4 | 10 | 17..=21 | 28 | 52 | 53 | 90..=92 | 54..=59)
                    || PASSIVE_G.contains(&(g as u32)) && g.fract() == 0.0
                    || g == 92.1
                    || g == 92.2
                    || tcpm::mode_of(g).is_some();
                if !known {
                    return Some(format!("G{}", line.text_of(w)));
                }
            }
            'L' if setting => {}
            'U' | 'V' | 'W' | 'Q' | 'L' | 'E' => {
                return Some(format!("{}{}", w.letter, line.text_of(w)))
            }
            // Subprogram calls and returns: their moves are elsewhere.
            'M' if w.value == 98.0 || w.value == 99.0 => {
                return Some(format!("M{}", line.text_of(w)))
            }
            _ => {}
        }
    }
    None
}

/// What a line does once its modal words are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::nc) enum Step {
    /// It moves no axis volmap follows: it is copied as it is.
    Pass,
    /// It moves the tool to a programmed point.
    Move,
}

/// Takes a line's modal words (motion, plane, distance, units, work offset, tool), and says
/// whether it moves. Lines with codes volmap does not follow are errors, or with `pass_unknown`
/// passed, their axis words moving the program's tool as straight moves would.
pub(in crate::nc) fn take_line(
    lines: &[Line],
    index: usize,
    state: &mut State,
    path: &str,
    pass_unknown: bool,
) -> Result<Step, NcError> {
    let line = &lines[index];
    state.left_alone = None;
    if line.words.is_empty() && line.unknown.is_none() {
        return Ok(Step::Pass);
    }
    if let Some(code) = cutter_compensation(line) {
        return Err(NcError::line(
            path,
            line.number,
            format!("G{code}: cutter radius compensation is not supported: the path the control computes from it is not in the program, so it cannot be compensated; post the program for the tool's centre path (G40)"),
        ));
    }
    if let Some(code) = unknown_code(line) {
        if !pass_unknown {
            return Err(NcError::Unsupported {
                path: path.to_string(),
                line: line.number,
                code: crate::error::excerpt(&code).into_owned(),
            });
        }
        apply_modals(line, state, path)?;
        // It moves nothing volmap can place: what it may move becomes unknown (`unknown`).
        if is_setting(line) {
            // G10 of tool data or an offset volmap does not follow: it moves nothing, what
            // depends on it becomes unknown.
            pass_setting(line, state);
        } else {
            pass_block(line, state);
        }
        return Ok(Step::Pass);
    }
    if is_setting(line) {
        apply_modals(line, state, path)?;
        take_setting(line, state, path)?;
        return Ok(Step::Pass);
    }
    let length_before = length_added(&state.tool_lengths, state.tool, state.tool_length_on);
    apply_modals(line, state, path)?;
    if is_reference_return(line) {
        let machine_coordinates = line
            .words
            .iter()
            .any(|w| w.letter == 'G' && w.value == 53.0);
        if machine_coordinates && state.motion != Motion::Rapid {
            return Err(NcError::line(
                path,
                line.number,
                "G53 with a feed move: only rapid (G0) moves in machine coordinates are passed (homes and tool-change positions, whose path the control does not hold)".into(),
            ));
        }
        // The block passes as it is: the output reads its motion code too.
        if line
            .words
            .iter()
            .any(|w| w.letter == 'G' && (w.value as u32) < 4 && w.value.fract() == 0.0)
        {
            state.written_motion = state.motion;
        }
        reference_return(line, state, path)?;
        return Ok(Step::Pass);
    }
    if let Some(t) = line.word('T') {
        state.pending_tool = Some(t.value as u32);
    }
    if line.words.iter().any(|w| w.letter == 'M' && w.value == 6.0) {
        state.tool = state.pending_tool;
    }
    // G43, G49 and tool changes do not move the axes: where they stand is so much higher or
    // lower in the program's coordinates.
    let change =
        length_before - length_added(&state.tool_lengths, state.tool, state.tool_length_on);
    state.position[2] += change;
    state.written[2] += change;
    if let Some(at) = state.tool_data_unknown {
        // Tool data volmap does not follow: where Z stands after a change of tool or of G43 is
        // not known.
        if length_before != length_added(&state.tool_lengths, state.tool, state.tool_length_on)
            || line.words.iter().any(|w| {
                (w.letter == 'G' && (w.value == 43.0 || w.value == 49.0))
                    || (w.letter == 'M' && w.value == 6.0)
            })
        {
            state.unknown[2].get_or_insert(at);
        }
    }
    let dwell = is_dwell(line);
    // Under G43.5 a tool vector alone turns the tool.
    let has_axis = line.words.iter().any(|w| AXIS_LETTERS.contains(&w.letter))
        || tcpm::has_vector(line, state);
    let has_centre = line
        .words
        .iter()
        .any(|w| matches!(w.letter, 'I' | 'J' | 'K' | 'R'));
    let arc = matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise);
    if dwell || !(has_axis || (arc && has_centre)) {
        // The output reads this line as it is: a motion code in it sets its mode too.
        if line
            .words
            .iter()
            .any(|w| w.letter == 'G' && (w.value as u32) < 4 && w.value.fract() == 0.0)
        {
            state.written_motion = state.motion;
        }
        return Ok(Step::Pass);
    }
    if let Some(left) = leave_alone(line, state) {
        if state.written_motion != state.motion
            && !line
                .words
                .iter()
                .any(|w| w.letter == 'G' && w.value < 4.0 && w.value.fract() == 0.0)
        {
            return Err(NcError::line(
                path,
                line.number,
                format!("this move cannot be compensated ({} not known since line {}) and passes as it is, but the output is in G{} here where the program is in G{}: give the motion code on this block", left.axes, left.since, state.written_motion.code(), state.motion.code()),
            ));
        }
        state.written_motion = state.motion;
        state.left_alone = Some(left);
        return Ok(Step::Pass);
    }
    if arc {
        arc_start_known(line, state, path)?;
    }
    mark_set(line, state);
    Ok(Step::Move)
}

fn apply_modals(line: &Line, state: &mut State, path: &str) -> Result<(), NcError> {
    let mut motions = 0;
    for w in line.words.iter().filter(|w| w.letter == 'G') {
        if let Some(mode) = tcpm::mode_of(w.value) {
            state.tcpm = mode;
            // G43.4, G43.5 and G234 apply the tool length as G43 does.
            state.tool_length_on |= mode.is_some();
        }
        match w.value as u32 {
            0 => state.motion = Motion::Rapid,
            1 => state.motion = Motion::Linear,
            2 => state.motion = Motion::Clockwise,
            3 => state.motion = Motion::CounterClockwise,
            17 => state.plane = XY,
            18 => state.plane = ZX,
            19 => state.plane = YZ,
            20 => state.inch = true,
            21 => state.inch = false,
            90 => state.absolute = true,
            91 => state.absolute = false,
            g @ 54..=59 if w.value.fract() == 0.0 => change_offset(state, g),
            43 if w.value.fract() == 0.0 => state.tool_length_on = true,
            49 => state.tool_length_on = false,
            _ => {}
        }
        if (w.value as u32) < 4 {
            motions += 1;
        }
    }
    if motions > 1 {
        return Err(NcError::line(
            path,
            line.number,
            "two motion codes (G0 G1 G2 G3) in one block".into(),
        ));
    }
    Ok(())
}

/// The block's end point in program coordinates (mm, degrees).
pub(in crate::nc) fn end_position(line: &Line, state: &State) -> [f64; 6] {
    let mut end = state.position;
    for w in &line.words {
        if let Some(d) = AXIS_LETTERS.iter().position(|&a| a == w.letter) {
            let value = if state.inch && d < 3 {
                w.value * MM_PER_INCH
            } else {
                w.value
            };
            end[d] = if state.absolute {
                value
            } else {
                end[d] + value
            };
        }
    }
    end
}
