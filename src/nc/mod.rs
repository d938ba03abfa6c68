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

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use crate::machine::{AxisLetter, Command, Machine};
use crate::reference;
use parse::{parse_program, Line, Word};

#[derive(Debug, thiserror::Error)]
pub enum NcError {
    #[error("{path}: line {line}: {message}")]
    Line {
        path: String,
        line: usize,
        message: String,
    },
    #[error("{0}")]
    Options(String),
}

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
    /// `--tool-length 120` or `--tool-length T1=80,T2=120.5` (mm, along the spindle axis).
    pub fn parse(text: &str) -> Result<ToolLengths, NcError> {
        let mut lengths = ToolLengths::default();
        let bad = || {
            NcError::Options(format!(
                "--tool-length {text}: a length in mm, or T1=80,T2=120 per tool"
            ))
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
    let bad = || {
        NcError::Options(format!(
            "--work-offset {text}: expected G54=X,Y,Z (mm), e.g. G54=100,50,-200"
        ))
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

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Motion {
    Rapid,
    Linear,
    Clockwise,
    CounterClockwise,
}

impl Motion {
    fn code(self) -> u32 {
        match self {
            Motion::Rapid => 0,
            Motion::Linear => 1,
            Motion::Clockwise => 2,
            Motion::CounterClockwise => 3,
        }
    }
}

/// The arc plane: the program axes (indices into X Y Z) of its first and second coordinates and
/// of the helix, and the letters of the centre offsets along the first and second.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Plane {
    u: usize,
    v: usize,
    w: usize,
    centre: [char; 2],
}

const XY: Plane = Plane {
    u: 0,
    v: 1,
    w: 2,
    centre: ['I', 'J'],
};
const ZX: Plane = Plane {
    u: 2,
    v: 0,
    w: 1,
    centre: ['K', 'I'],
};
const YZ: Plane = Plane {
    u: 1,
    v: 2,
    w: 0,
    centre: ['J', 'K'],
};

const AXIS_LETTERS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];
const MM_PER_INCH: f64 = 25.4;
/// The most pieces one move is split into.
const MAX_PIECES: usize = 100_000;
/// G codes that change nothing volmap must follow: cutter compensation off, tool length
/// compensation, cycle cancel, feed modes, exact stop and cutting modes, cycle return levels.
const PASSIVE_G: [u32; 9] = [40, 43, 49, 80, 94, 95, 61, 64, 98];

/// The intended path of a move, `t` from 0 to 1, in program coordinates (mm, degrees).
#[derive(Debug, Clone, Copy)]
enum Path {
    Line {
        from: [f64; 6],
        to: [f64; 6],
    },
    Arc {
        from: [f64; 6],
        to: [f64; 6],
        plane: Plane,
        centre: [f64; 2],
        start_angle: f64,
        sweep: f64,
        radii: [f64; 2],
    },
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

impl Path {
    fn at(&self, t: f64) -> [f64; 6] {
        match *self {
            Path::Line { from, to } => std::array::from_fn(|d| lerp(from[d], to[d], t)),
            Path::Arc {
                from,
                to,
                plane,
                centre,
                start_angle,
                sweep,
                radii,
            } => {
                let mut p: [f64; 6] = std::array::from_fn(|d| lerp(from[d], to[d], t));
                let (s, c) = (start_angle + sweep * t).sin_cos();
                let r = lerp(radii[0], radii[1], t);
                p[plane.u] = centre[0] + r * c;
                p[plane.v] = centre[1] + r * s;
                p
            }
        }
    }

    fn length(&self) -> f64 {
        match *self {
            Path::Line { from, to } => (0..3)
                .map(|d| (to[d] - from[d]).powi(2))
                .sum::<f64>()
                .sqrt(),
            Path::Arc {
                from,
                to,
                plane,
                sweep,
                radii,
                ..
            } => {
                let planar = sweep.abs() * 0.5 * (radii[0] + radii[1]);
                planar.hypot(to[plane.w] - from[plane.w])
            }
        }
    }
}

/// The machine as one tool sees it, with its ideal twin.
struct Kinematics {
    real: Machine,
    ideal: Machine,
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
                    return Err(NcError::line(
                        self.path,
                        line,
                        match tool {
                            Some(t) => {
                                format!("no length for tool T{t}: add T{t}=<mm> to --tool-length")
                            }
                            None => {
                                "no tool is active yet and --tool-length names tools only".into()
                            }
                        },
                    ))
                }
            };
            let mut real = self.base.clone();
            if let Some(l) = length {
                real.tool_offset_mm = [0.0, 0.0, -l];
            }
            let ideal = real.without_errors();
            self.tools.insert(tool, Kinematics { real, ideal });
        }
        Ok(&self.tools[&tool])
    }
}

impl Kinematics {
    fn tip(machine: &Machine, q: &Command) -> Vector3<f64> {
        reference::tool_pose(machine, q).0
    }

    /// The ideal tip's derivative in X, Y, Z (constant at fixed rotary positions).
    fn jacobian(&self, q: &Command) -> Matrix3<f64> {
        let base = Self::tip(&self.ideal, q);
        let column = |d: usize| {
            let mut p = *q;
            p[d] += 1.0;
            Self::tip(&self.ideal, &p) - base
        };
        Matrix3::from_columns(&[column(0), column(1), column(2)])
    }

    /// The command whose real tip lands on the ideal tip of `q`.
    fn compensate(&self, q: &Command) -> Option<Command> {
        let target = Self::tip(&self.ideal, q);
        let inverse = self.jacobian(q).try_inverse()?;
        let mut c = *q;
        for _ in 0..50 {
            let r = Self::tip(&self.real, &c) - target;
            if r.norm() < 1e-10 {
                return Some(c);
            }
            let step = inverse * r;
            for d in 0..3 {
                c[d] -= step[d];
            }
        }
        None
    }

    /// Distance of the real tip at command `c` from the ideal tip at command `q`.
    fn miss(&self, c: &Command, q: &Command) -> f64 {
        (Self::tip(&self.real, c) - Self::tip(&self.ideal, q)).norm()
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

/// A program's modal state.
#[derive(Debug, Clone)]
struct State {
    motion: Motion,
    plane: Plane,
    absolute: bool,
    inch: bool,
    offset: u32,
    tool: Option<u32>,
    pending_tool: Option<u32>,
    /// Where the program has the tool (program coordinates, mm and degrees).
    position: [f64; 6],
    /// Where the output program has the tool, as written (mm and degrees).
    written: [f64; 6],
    /// The motion mode the output program is in.
    written_motion: Motion,
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
        return Err(NcError::Options(format!(
            "--chord-tolerance {}: it must be positive",
            options.chord_tolerance_mm
        )));
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
            ideal: Kinematics::tip(&kin.ideal, &command),
            real: Kinematics::tip(&kin.real, &command),
        });
        state.position = end;
    }
    Ok(points)
}

/// Where each axis is before the program moves it: the first absolute value the program gives
/// it (rotary axes the program never names: 0). An axis first moved incrementally, or a linear
/// axis never set, has no known start.
fn starting_position(
    lines: &[Line],
    machine: &Machine,
    path: &str,
    options: &Options,
) -> Result<[f64; 6], NcError> {
    let mut start: [Option<f64>; 6] = [None; 6];
    let mut absolute = true;
    let mut inch = false;
    for line in lines {
        distance_and_units(line, &mut absolute, &mut inch);
        if is_dwell(line) || is_reference_return(line) || !is_understood(line, options.pass_unknown)
        {
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
                    start[d] = Some(if inch && d < 3 {
                        w.value * MM_PER_INCH
                    } else {
                        w.value
                    });
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
                return Err(NcError::line(
                    path,
                    1,
                    format!(
                        "the program never sets {}: its height is not known",
                        AXIS_LETTERS[d]
                    ),
                ))
            }
        };
    }
    Ok(position)
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

/// G28: to the reference point through the intermediate point its axis words give.
fn is_reference_return(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'G' && w.value == 28.0)
}

/// Where axis `d` is next set absolutely after line `from` (for an axis the program sent to
/// its reference point: the machine's reference is not in the program). Modal distance and
/// units are followed from `state`.
fn next_absolute(
    lines: &[Line],
    from: usize,
    d: usize,
    state: &State,
    path: &str,
) -> Result<Option<f64>, NcError> {
    let (mut absolute, mut inch) = (state.absolute, state.inch);
    for line in &lines[from + 1..] {
        distance_and_units(line, &mut absolute, &mut inch);
        if is_dwell(line) || is_reference_return(line) {
            continue;
        }
        if let Some(w) = line.word(AXIS_LETTERS[d]) {
            if !absolute {
                return Err(NcError::line(
                    path,
                    line.number,
                    format!(
                        "{} moves incrementally after a return to the reference point: where it starts is not known",
                        AXIS_LETTERS[d]
                    ),
                ));
            }
            return Ok(Some(if inch && d < 3 {
                w.value * MM_PER_INCH
            } else {
                w.value
            }));
        }
    }
    Ok(None)
}

/// A G28 block passes as it is; the axes it names are at the machine's reference afterwards,
/// which the program does not know: they take the value the program next gives them, and the
/// output writes them afresh.
fn reference_return(
    lines: &[Line],
    index: usize,
    state: &mut State,
    path: &str,
) -> Result<(), NcError> {
    let line = &lines[index];
    for (d, &letter) in AXIS_LETTERS.iter().enumerate() {
        if line.has(letter) {
            if let Some(v) = next_absolute(lines, index, d, state, path)? {
                state.position[d] = v;
            }
            state.written[d] = f64::NAN;
        }
    }
    Ok(())
}

/// Whether every G code of the line is one volmap follows (or the user passes unknown ones).
fn is_understood(line: &Line, pass_unknown: bool) -> bool {
    pass_unknown || unknown_code(line).is_none()
}

fn unknown_code(line: &Line) -> Option<String> {
    for w in &line.words {
        match w.letter {
            'G' => {
                let g = w.value;
                let known = g.fract() == 0.0
                    && matches!(g as u32, 0..=4 | 17..=21 | 28 | 90 | 91 | 54..=59)
                    || PASSIVE_G.contains(&(g as u32)) && g.fract() == 0.0;
                if !known {
                    return Some(format!("G{}", w.text));
                }
            }
            'U' | 'V' | 'W' | 'Q' | 'L' | 'E' => return Some(format!("{}{}", w.letter, w.text)),
            // Subprogram calls and returns: their moves are elsewhere.
            'M' if w.value == 98.0 || w.value == 99.0 => return Some(format!("M{}", w.text)),
            _ => {}
        }
    }
    None
}

/// What a line does once its modal words are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    /// It moves no axis volmap follows: it is copied as it is.
    Pass,
    /// It moves the tool to a programmed point.
    Move,
}

/// Takes a line's modal words (motion, plane, distance, units, work offset, tool), and says
/// whether it moves. Lines with codes volmap does not follow are errors, or with `pass_unknown`
/// passed, their axis words moving the program's tool as straight moves would.
fn take_line(
    lines: &[Line],
    index: usize,
    state: &mut State,
    path: &str,
    pass_unknown: bool,
) -> Result<Step, NcError> {
    let line = &lines[index];
    if line.words.is_empty() {
        return Ok(Step::Pass);
    }
    if let Some(code) = unknown_code(line) {
        if !pass_unknown {
            return Err(NcError::line(
                path,
                line.number,
                format!("{code} is not supported (volmap follows G0 G1 G2 G3 G4 G17 G18 G19 G20 G21 G28 G40 G43 G49 G54–G59 G61 G64 G80 G90 G91 G94 G95 G98); --pass-unknown passes such blocks unchanged"),
            ));
        }
        apply_modals(line, state, path)?;
        let end = end_position(line, state);
        state.position = end;
        state.written = end;
        return Ok(Step::Pass);
    }
    apply_modals(line, state, path)?;
    if is_reference_return(line) {
        reference_return(lines, index, state, path)?;
        return Ok(Step::Pass);
    }
    if let Some(t) = line.word('T') {
        state.pending_tool = Some(t.value as u32);
    }
    if line.words.iter().any(|w| w.letter == 'M' && w.value == 6.0) {
        state.tool = state.pending_tool;
    }
    let dwell = is_dwell(line);
    let has_axis = line.words.iter().any(|w| AXIS_LETTERS.contains(&w.letter));
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
    Ok(Step::Move)
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
        return Err(NcError::line(
            path,
            line.number,
            format!(
                "G{} is active but its work offset was not given (--work-offset G{}=X,Y,Z)",
                state.offset, state.offset
            ),
        ));
    }
    let tool = state.tool;
    let kin = comp.kinematics(tool, line.number)?;
    let command = |p: &[f64; 6]| -> Command { std::array::from_fn(|d| p[d] + offset[d]) };
    let travel = |p: &[f64; 6], what: &str| -> Result<(), NcError> {
        let q = command(p);
        for axis in &kin.real.axes {
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
            .map_err(|e| match e {
                NcError::Options(message) => NcError::line(path, line.number, message),
                other => other,
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
) -> Result<(), NcError> {
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
        return Err(NcError::Options(format!(
            "a move needs more than {MAX_PIECES} pieces to stay within the chord tolerance of {tolerance} mm"
        )));
    }
    if worst <= tolerance || depth >= 24 {
        report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
        pieces.push(b);
        return Ok(());
    }
    let tm = 0.5 * (ta + tb);
    let m = compensate_point(&intended.at(tm))?;
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

fn apply_modals(line: &Line, state: &mut State, path: &str) -> Result<(), NcError> {
    let mut motions = 0;
    for w in line.words.iter().filter(|w| w.letter == 'G') {
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
            g @ 54..=59 => state.offset = g,
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
fn end_position(line: &Line, state: &State) -> [f64; 6] {
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

fn angle_of(p: &[f64; 6], plane: Plane, centre: [f64; 2]) -> f64 {
    (p[plane.v] - centre[1]).atan2(p[plane.u] - centre[0])
}

/// The arc from `from` to `to` about `centre` in `plane`, in the direction of `motion`; a full
/// turn where the ends coincide. `None` where an end sits on the centre.
fn arc_through(
    from: [f64; 6],
    to: [f64; 6],
    plane: Plane,
    centre: [f64; 2],
    motion: Motion,
) -> Option<Path> {
    let r0 = (from[plane.u] - centre[0]).hypot(from[plane.v] - centre[1]);
    let r1 = (to[plane.u] - centre[0]).hypot(to[plane.v] - centre[1]);
    if r0 < 1e-9 || r1 < 1e-9 {
        return None;
    }
    let a0 = angle_of(&from, plane, centre);
    let a1 = angle_of(&to, plane, centre);
    let tau = std::f64::consts::TAU;
    let same = (from[plane.u] - to[plane.u]).hypot(from[plane.v] - to[plane.v]) < 1e-9;
    let sweep = match motion {
        Motion::CounterClockwise => {
            let s = (a1 - a0).rem_euclid(tau);
            if same || s < 1e-12 {
                tau
            } else {
                s
            }
        }
        _ => {
            let s = (a1 - a0).rem_euclid(tau) - tau;
            if same || s > -1e-12 {
                -tau
            } else {
                s
            }
        }
    };
    Some(Path::Arc {
        from,
        to,
        plane,
        centre,
        start_angle: a0,
        sweep,
        radii: [r0, r1],
    })
}

/// The intended arc of a G2/G3 block: centre from I/J/K (from the start) or R.
fn arc_path(
    line: &Line,
    state: &State,
    start: [f64; 6],
    end: [f64; 6],
    path: &str,
) -> Result<Path, NcError> {
    let plane = state.plane;
    let scale = if state.inch { MM_PER_INCH } else { 1.0 };
    let offsets: Vec<Option<f64>> = plane
        .centre
        .iter()
        .map(|&c| line.word(c).map(|w| w.value * scale))
        .collect();
    let centre = if let Some(r) = line.word('R') {
        let r = r.value * scale;
        let (du, dv) = (end[plane.u] - start[plane.u], end[plane.v] - start[plane.v]);
        let chord = du.hypot(dv);
        if chord < 1e-9 {
            return Err(NcError::line(
                path,
                line.number,
                "an R arc cannot be a full circle: give its centre with I, J, K".into(),
            ));
        }
        let h2 = r * r - chord * chord / 4.0;
        if h2 < -1e-6 * r * r.max(1.0) {
            return Err(NcError::line(
                path,
                line.number,
                format!(
                    "radius R{} is shorter than half the chord ({:.4} mm)",
                    r / scale,
                    chord / 2.0
                ),
            ));
        }
        let h = h2.max(0.0).sqrt();
        let left = [-dv / chord, du / chord];
        // Counter-clockwise arcs of at most 180° (R > 0) turn about a centre left of the chord.
        let side = if state.motion == Motion::CounterClockwise {
            1.0
        } else {
            -1.0
        } * r.signum();
        let mid = [start[plane.u] + du / 2.0, start[plane.v] + dv / 2.0];
        [mid[0] + side * h * left[0], mid[1] + side * h * left[1]]
    } else if offsets.iter().any(Option::is_some) {
        [
            start[plane.u] + offsets[0].unwrap_or(0.0),
            start[plane.v] + offsets[1].unwrap_or(0.0),
        ]
    } else {
        return Err(NcError::line(
            path,
            line.number,
            format!(
                "an arc (G{}) needs its centre ({} {}) or its radius (R)",
                state.motion.code(),
                plane.centre[0],
                plane.centre[1]
            ),
        ));
    };
    let arc = arc_through(start, end, plane, centre, state.motion).ok_or_else(|| {
        NcError::line(
            path,
            line.number,
            "the arc's start or end lies on its centre".into(),
        )
    })?;
    if let Path::Arc { radii, .. } = arc {
        if (radii[0] - radii[1]).abs() > 1e-3 * scale.max(1.0) + 1e-6 * radii[0] {
            return Err(NcError::line(
                path,
                line.number,
                format!("the arc's end is not on its circle: radius {:.4} at the start, {:.4} at the end (mm)", radii[0], radii[1]),
            ));
        }
    }
    Ok(arc)
}

/// Formats a value in program units with `decimals`, trailing zeros trimmed to one.
fn format_value(value: f64, decimals: usize) -> String {
    let mut text = format!("{value:.decimals$}");
    if text.contains('.') {
        while text.ends_with('0') && !text.ends_with(".0") {
            text.pop();
        }
    }
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text.remove(0);
    }
    text
}

/// Writes the block's output: the original line with its coordinates replaced by the first
/// piece's (an arc that became lines turns G2/G3 into G1 and loses its centre words), then one
/// added line per further piece. Returns the number of lines written.
fn write_block(
    line: &Line,
    state: &mut State,
    pieces: &[[f64; 6]],
    keep_arc: Option<[f64; 2]>,
    out: &mut String,
    options: &Options,
) -> Result<usize, NcError> {
    let decimals = options.decimals.unwrap_or(if state.inch { 5 } else { 4 });
    let rotary_decimals = decimals.max(4);
    let unit = if state.inch { MM_PER_INCH } else { 1.0 };
    let lower = line.words.iter().any(|w| w.lower) && !line.words.iter().any(|w| !w.lower);
    let letter = |c: char| if lower { c.to_ascii_lowercase() } else { c };
    let sep = if line.spaced { " " } else { "" };
    let arc_becomes_lines =
        matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise) && keep_arc.is_none();
    // Values as written, rounded, so increments add up to exactly what was written.
    let rounded = |v: f64, d: usize| -> f64 {
        if d < 3 {
            let scale = 10f64.powi(decimals as i32);
            (v / unit * scale).round() / scale * unit
        } else {
            let scale = 10f64.powi(rotary_decimals as i32);
            (v * scale).round() / scale
        }
    };
    // Whether a written value moves by at least half a unit of its last decimal.
    let changes = |a: f64, b: f64, d: usize| {
        let half = if d < 3 {
            0.5 * 10f64.powi(-(decimals as i32)) * unit
        } else {
            0.5 * 10f64.powi(-(rotary_decimals as i32))
        };
        (a - b).abs() > half
    };
    let value_text = |target: f64, d: usize, written: &[f64; 6], absolute: bool| -> String {
        let v = if absolute {
            target
        } else {
            target - written[d]
        };
        if d < 3 {
            format_value(v / unit, decimals)
        } else {
            format_value(v, rotary_decimals)
        }
    };
    let split = pieces.len() > 1;
    let first_written: [f64; 6] = std::array::from_fn(|d| {
        // Rotary words of a move that is not split stay exactly as programmed.
        if d >= 3 && !split {
            state.position[d]
        } else {
            rounded(pieces[0][d], d)
        }
    });
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    // Axis words: linear ones take the compensated values; rotary ones change only where the
    // move is split (each piece turns its share); missing ones are added where they change.
    let mut last_axis_end = None;
    for w in &line.words {
        if let Some(d) = AXIS_LETTERS.iter().position(|&a| a == w.letter) {
            last_axis_end = Some(w.number.end);
            if d < 3 || split {
                edits.push((
                    w.number.clone(),
                    value_text(first_written[d], d, &state.written, state.absolute),
                ));
            }
        }
    }
    let mut added = String::new();
    for d in 0..6 {
        if !line.has(AXIS_LETTERS[d]) && changes(first_written[d], state.written[d], d) {
            added += &format!(
                "{sep}{}{}",
                letter(AXIS_LETTERS[d]),
                value_text(first_written[d], d, &state.written, state.absolute)
            );
        }
    }
    // Centre words of a kept arc, relative to the written start; removed where the arc became
    // lines.
    let start_written = state.written;
    for w in &line.words {
        let centre = state.plane.centre.iter().position(|&c| c == w.letter);
        match (w.letter, centre) {
            ('I' | 'J' | 'K' | 'R', _) if arc_becomes_lines => {
                edits.push((removal(line, w), String::new()));
            }
            (_, Some(k)) => {
                if let Some(c) = keep_arc {
                    let coordinate = if k == 0 { state.plane.u } else { state.plane.v };
                    edits.push((
                        w.number.clone(),
                        format_value((c[k] - start_written[coordinate]) / unit, decimals),
                    ));
                }
            }
            ('R', None) => {
                if let Some(c) = keep_arc {
                    let (u, v) = (state.plane.u, state.plane.v);
                    let r = (first_written[u] - c[0]).hypot(first_written[v] - c[1]);
                    edits.push((
                        w.number.clone(),
                        format_value(r * w.value.signum() / unit, decimals),
                    ));
                }
            }
            _ => {}
        }
    }
    // The motion word: G2/G3 that became lines are G1; a block relying on a mode the output has
    // left gets its mode back.
    let motion_word = line
        .words
        .iter()
        .find(|w| w.letter == 'G' && (w.value as u32) < 4 && w.value.fract() == 0.0);
    let output_motion = if arc_becomes_lines {
        Motion::Linear
    } else {
        state.motion
    };
    match motion_word {
        Some(w) if arc_becomes_lines => {
            let digits = if w.text.starts_with('0') { "01" } else { "1" };
            edits.push((w.number.clone(), digits.into()));
        }
        None if output_motion != state.written_motion => {
            let at = line
                .words
                .iter()
                .find(|w| w.letter != 'N')
                .map_or(line.text.len(), |w| w.letter_at);
            let text = format!("{}{}{sep}", letter('G'), output_motion.code());
            edits.push((at..at, text));
        }
        _ => {}
    }
    if !added.is_empty() {
        let at = last_axis_end
            .or_else(|| {
                line.words
                    .iter()
                    .rev()
                    .find(|w| w.letter == 'G')
                    .map(|w| w.number.end)
            })
            .unwrap_or(line.text.len());
        edits.push((at..at, added));
    }
    edits.sort_by_key(|(r, _)| (r.start, r.end));
    let mut text = line.text.clone();
    for (range, replacement) in edits.iter().rev() {
        text.replace_range(range.clone(), replacement);
    }
    out.push_str(&text);
    out.push_str(&line.ending);
    // An axis sent to its reference point stays unwritten until a block names it.
    let unwritten: [bool; 6] =
        std::array::from_fn(|d| state.written[d].is_nan() && !line.has(AXIS_LETTERS[d]));
    state.written = std::array::from_fn(|d| {
        if unwritten[d] {
            f64::NAN
        } else {
            first_written[d]
        }
    });
    state.written_motion = output_motion;
    let ending = if line.ending.is_empty() {
        "\n"
    } else {
        &line.ending
    };
    let mut count = 1;
    for piece in &pieces[1..] {
        let piece_written: [f64; 6] = std::array::from_fn(|d| rounded(piece[d], d));
        let mut words = String::new();
        if state.written_motion != Motion::Linear {
            words += &format!("{}1", letter('G'));
        }
        for d in 0..6 {
            if changes(piece_written[d], state.written[d], d) {
                if !words.is_empty() {
                    words += sep;
                }
                words += &format!(
                    "{}{}",
                    letter(AXIS_LETTERS[d]),
                    value_text(piece_written[d], d, &state.written, state.absolute)
                );
            }
        }
        if words.is_empty() || words == format!("{}1", letter('G')) {
            continue;
        }
        out.push_str(&words);
        out.push_str(ending);
        state.written = std::array::from_fn(|d| {
            if state.written[d].is_nan() {
                f64::NAN
            } else {
                piece_written[d]
            }
        });
        state.written_motion = Motion::Linear;
        count += 1;
    }
    Ok(count)
}

/// The bytes a word takes, with one separating space before it, for removal.
fn removal(line: &Line, w: &Word) -> std::ops::Range<usize> {
    let mut start = w.letter_at;
    if start > 0 && line.text.as_bytes()[start - 1] == b' ' {
        start -= 1;
    }
    start..w.number.end
}
