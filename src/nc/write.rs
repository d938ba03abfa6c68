//! Writing the compensated blocks: numbers replaced where they stand, words added or removed only
//! where the coordinates need it, pieces added after their block; and the note at the head of a
//! compensated program that says how it was made.

use super::arcs::radius_sign;
use super::error::NcError;
use super::options::Options;
use super::program::modal::{Motion, State, AXIS_LETTERS, MM_PER_INCH};
use super::program::parse::{Line, Word};
use super::program::settings::definite_g10;
use super::program::tcpm::Tcpm;
use super::tcpm::vector_decimals;

/// Formats a value in program units with `decimals`, trailing zeros trimmed to one.
pub(super) fn format_value(value: f64, decimals: usize) -> String {
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

/// How a block's numbers are written: its decimals, unit and letter case, whether its words are
/// spaced.
struct Style {
    decimals: usize,
    rotary_decimals: usize,
    /// Rotary words carry the compensation (the orientation is compensated).
    rotary_compensated: bool,
    /// mm per program unit.
    unit: f64,
    lower: bool,
    separator: &'static str,
    absolute: bool,
    /// The letters of the six values: A B C, or under G43.5 the tool vector's I J K.
    letters: [char; 6],
}

/// A value of axis `d` (mm, degrees) as the output writes it, in inch where `inch`.
pub(super) fn as_written(v: f64, d: usize, inch: bool, options: &Options) -> f64 {
    Style::numbers(inch, options).rounded(v, d)
}

impl Style {
    fn of(line: &Line, state: &State, options: &Options) -> Style {
        Style {
            lower: line.words.iter().any(|w| w.lower) && !line.words.iter().any(|w| !w.lower),
            separator: if line.spaced { " " } else { "" },
            absolute: state.absolute,
            ..Style::numbers(state.inch, options)
        }
        .with_vector(state, options)
    }

    /// Under G43.5 the last three values are the tool vector (see `tcpm::write`).
    fn with_vector(self, state: &State, options: &Options) -> Style {
        if state.tcpm != Some(Tcpm::Vector) {
            return self;
        }
        Style {
            letters: ['X', 'Y', 'Z', 'I', 'J', 'K'],
            rotary_decimals: vector_decimals(options),
            ..self
        }
    }

    /// How numbers are written, in inch where `inch`.
    fn numbers(inch: bool, options: &Options) -> Style {
        let decimals = options.decimals.unwrap_or(if inch { 5 } else { 4 });
        Style {
            decimals,
            // Compensated rotary words: 6 decimals of a degree at least (rounding ≤ 8.7e-9 rad).
            rotary_decimals: decimals.max(if options.orientation_tolerance_rad.is_some() {
                6
            } else {
                4
            }),
            rotary_compensated: options.orientation_tolerance_rad.is_some(),
            unit: if inch { MM_PER_INCH } else { 1.0 },
            lower: false,
            separator: "",
            absolute: true,
            letters: AXIS_LETTERS,
        }
    }

    fn letter(&self, c: char) -> char {
        if self.lower {
            c.to_ascii_lowercase()
        } else {
            c
        }
    }

    /// A value of axis `d` as written, rounded, so that increments add up to exactly what was
    /// written.
    fn rounded(&self, v: f64, d: usize) -> f64 {
        let r = if d < 3 {
            let scale = 10f64.powi(self.decimals as i32);
            (v / self.unit * scale).round() / scale * self.unit
        } else {
            let scale = 10f64.powi(self.rotary_decimals as i32);
            (v * scale).round() / scale
        };
        // A value so large that scaling it overflows (A-1e306 on an axis volmap passes by) has
        // no decimals to round: it stays as it is, a number.
        if r.is_finite() {
            r
        } else {
            v
        }
    }

    /// Whether a written value of axis `d` moves by at least half a unit of its last decimal.
    fn changes(&self, a: f64, b: f64, d: usize) -> bool {
        let half = if d < 3 {
            0.5 * 10f64.powi(-(self.decimals as i32)) * self.unit
        } else {
            0.5 * 10f64.powi(-(self.rotary_decimals as i32))
        };
        (a - b).abs() > half
    }

    /// Whether axis `d`'s word is written for `a` where `b` was written: under G43.5 the tool
    /// vector is written whole (a control reads I J K together).
    fn changed(&self, a: &[f64; 6], b: &[f64; 6], d: usize) -> bool {
        if d >= 3 && self.letters[3] == 'I' {
            return (3..6).any(|k| self.changes(a[k], b[k], k));
        }
        self.changes(a[d], b[d], d)
    }

    /// The text of axis `d`'s word for `target`, absolute or an increment from `written`.
    fn value_text(&self, target: f64, d: usize, written: &[f64; 6]) -> String {
        let v = if self.absolute {
            target
        } else {
            target - written[d]
        };
        if d < 3 {
            format_value(v / self.unit, self.decimals)
        } else {
            format_value(v, self.rotary_decimals)
        }
    }

    /// An added axis word.
    fn axis_word(&self, d: usize, target: f64, written: &[f64; 6]) -> String {
        format!(
            "{}{}",
            self.letter(self.letters[d]),
            self.value_text(target, d, written)
        )
    }
}

/// Writes a block that names the point where the tool stands anew (G92, G10 L20; already taken
/// into `state`). The control takes the point it has, the compensated one: each axis value is
/// moved by the correction there (`point`: the programmed and the written position before the
/// block), so the shift or offset it sets is the program's (up to half a unit of the last
/// decimal written). An axis not written since a machine position stands uncorrected.
pub(super) fn write_setting(
    line: &Line,
    point: ([f64; 6], [f64; 6]),
    state: &mut State,
    out: &mut String,
    options: &Options,
) {
    let style = Style::numbers(state.inch, options);
    let (programmed, written) = point;
    let mut edits: Vec<Edit> = Vec::new();
    // G92, or G10 L20 of the offset in force: the coordinates the tool is at change now.
    let g92 = line
        .words
        .iter()
        .any(|w| w.letter == 'G' && w.value == 92.0);
    let moves_frame = g92 || definite_g10(line) == Some(state.offset);
    for w in &line.words {
        let Some(d) = AXIS_LETTERS.iter().position(|&a| a == w.letter) else {
            continue;
        };
        let correction = written[d] - programmed[d];
        if !correction.is_finite() || !style.changes(written[d], programmed[d], d) {
            continue;
        }
        let value = if d < 3 { w.value * style.unit } else { w.value };
        let target = style.rounded(value + correction, d);
        edits.push((
            w.number.clone(),
            style.value_text(target, d, &state.written),
        ));
        if moves_frame {
            // Where the control has the tool now: the value as written, rounded.
            state.written[d] += target - (value + correction);
        }
    }
    let mut text = line.text.clone();
    for (range, replacement) in edits.iter().rev() {
        text.replace_range(range.clone(), replacement);
    }
    out.push_str(&text);
    out.push_str(line.ending);
}

/// A replacement of bytes of the line's text.
type Edit = (std::ops::Range<usize>, String);

/// Writes the block's output: the original line with its coordinates replaced by the first
/// piece's (an arc whose first piece is straight turns G2/G3 into G1 and loses its centre
/// words), then one added line per further piece: G1, or G2/G3 with its centre for the pieces in
/// `arcs` (by index in `pieces`). Returns the number of lines written.
pub(super) fn write_block(
    line: &Line,
    state: &mut State,
    start: &[f64; 6],
    pieces: &[[f64; 6]],
    arcs: &[(usize, [f64; 2])],
    out: &mut String,
    options: &Options,
) -> Result<usize, NcError> {
    let style = Style::of(line, state, options);
    let centre_of = |i: usize| arcs.iter().find(|(k, _)| *k == i).map(|(_, c)| *c);
    let keep_arc = centre_of(0);
    let arc_becomes_lines =
        matches!(state.motion, Motion::Clockwise | Motion::CounterClockwise) && keep_arc.is_none();
    let split = pieces.len() > 1;
    let first_written: [f64; 6] = std::array::from_fn(|d| {
        // Rotary words of a move that is not split stay exactly as programmed.
        if d >= 3 && !split && !style.rotary_compensated {
            state.position[d]
        } else {
            style.rounded(pieces[0][d], d)
        }
    });
    let (mut edits, added) = axis_edits(line, state, &style, &first_written, split);
    edits.extend(centre_edits(
        line,
        state,
        &style,
        (start, &first_written),
        keep_arc,
        arc_becomes_lines,
    ));
    let output_motion = if arc_becomes_lines {
        Motion::Linear
    } else {
        state.motion
    };
    edits.extend(motion_edit(
        line,
        state,
        &style,
        output_motion,
        arc_becomes_lines,
    ));
    // Added axis words after the motion word where both go at the end of the line.
    edits.extend(added);
    edits.sort_by_key(|(r, _)| (r.start, r.end));
    let mut text = line.text.clone();
    for (range, replacement) in edits.iter().rev() {
        text.replace_range(range.clone(), replacement);
    }
    out.push_str(&text);
    // Added pieces start on lines of their own, after a last line without a line end too.
    out.push_str(if line.ending.is_empty() && pieces.len() > 1 {
        "\n"
    } else {
        line.ending
    });
    // An axis sent to its reference point stays unwritten until a block names it.
    let unwritten: [bool; 6] =
        std::array::from_fn(|d| state.written[d].is_nan() && !line.has(style.letters[d]));
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
        line.ending
    };
    let centres: Vec<Option<[f64; 2]>> = (1..pieces.len()).map(centre_of).collect();
    let arc = ArcWords {
        motion: state.motion,
        radius: line.has('R'),
    };
    let pieces = (&pieces[1..], &centres[..], first_written);
    Ok(1 + write_pieces(pieces, arc, state, &style, ending, out))
}

/// The axis words: linear ones take the compensated values; rotary ones change only where the
/// move is split (each piece turns its share); missing ones are added where they change (the
/// second edit, after the last axis word).
fn axis_edits(
    line: &Line,
    state: &State,
    style: &Style,
    first_written: &[f64; 6],
    split: bool,
) -> (Vec<Edit>, Option<Edit>) {
    let mut edits = Vec::new();
    let mut last_axis_end = None;
    for w in &line.words {
        if let Some(d) = style.letters.iter().position(|&a| a == w.letter) {
            last_axis_end = Some(w.number.end);
            if d < 3 || split || style.rotary_compensated {
                edits.push((
                    w.number.clone(),
                    style.value_text(first_written[d], d, &state.written),
                ));
            }
        }
    }
    let mut added = String::new();
    for (d, &letter) in style.letters.iter().enumerate() {
        if !line.has(letter) && style.changed(first_written, &state.written, d) {
            added += style.separator;
            added += &style.axis_word(d, first_written[d], &state.written);
        }
    }
    if added.is_empty() {
        return (edits, None);
    }
    let at = last_axis_end
        .or_else(|| {
            line.words
                .iter()
                .rev()
                .find(|w| w.letter == 'G')
                .map(|w| w.number.end)
        })
        .unwrap_or(line.text.len());
    (edits, Some((at..at, added)))
}

/// The centre words of a kept arc, relative to the written start (`start` for an axis not
/// written since its reference return); removed where the arc became lines.
fn centre_edits(
    line: &Line,
    state: &State,
    style: &Style,
    (start, first_written): (&[f64; 6], &[f64; 6]),
    keep_arc: Option<[f64; 2]>,
    arc_becomes_lines: bool,
) -> Vec<Edit> {
    let mut edits = Vec::new();
    let (unit, decimals) = (style.unit, style.decimals);
    for w in &line.words {
        let centre = state.plane.centre.iter().position(|&c| c == w.letter);
        match (w.letter, centre, keep_arc) {
            ('I' | 'J' | 'K' | 'R', _, _) if arc_becomes_lines => {
                edits.push((removal(line, w), String::new()));
            }
            (_, Some(k), Some(c)) => {
                let coordinate = if k == 0 { state.plane.u } else { state.plane.v };
                let from = if state.written[coordinate].is_nan() {
                    start[coordinate]
                } else {
                    state.written[coordinate]
                };
                edits.push((
                    w.number.clone(),
                    format_value((c[k] - from) / unit, decimals),
                ));
            }
            ('R', None, Some(c)) => {
                let (u, v) = (state.plane.u, state.plane.v);
                let r = (first_written[u] - c[0]).hypot(first_written[v] - c[1]);
                // The sign the written arc needs, not the programmed one: a first piece of a
                // split arc with R < 0 turns less than half a turn.
                let from: [f64; 6] = std::array::from_fn(|d| {
                    if state.written[d].is_nan() {
                        start[d]
                    } else {
                        state.written[d]
                    }
                });
                let sign = radius_sign((&from, first_written), state.plane, c, state.motion);
                edits.push((w.number.clone(), format_value(sign * r / unit, decimals)));
            }
            _ => {}
        }
    }
    edits
}

/// The motion word: G2/G3 that became lines are G1; a block relying on a mode the output has
/// left gets its mode back.
fn motion_edit(
    line: &Line,
    state: &State,
    style: &Style,
    output_motion: Motion,
    arc_becomes_lines: bool,
) -> Option<Edit> {
    let motion_word = line
        .words
        .iter()
        .find(|w| w.letter == 'G' && (w.value as u32) < 4 && w.value.fract() == 0.0);
    match motion_word {
        Some(w) if arc_becomes_lines => {
            let digits = if line.text_of(w).starts_with('0') {
                "01"
            } else {
                "1"
            };
            Some((w.number.clone(), digits.into()))
        }
        None if output_motion != state.written_motion => {
            let at = line
                .words
                .iter()
                .find(|w| w.letter != 'N')
                .map_or(line.text.len(), |w| w.letter_at);
            let text = format!(
                "{}{}{}",
                style.letter('G'),
                output_motion.code(),
                style.separator
            );
            Some((at..at, text))
        }
        _ => None,
    }
}

/// How added arc pieces are written: the block's arc motion, and whether by R (else I J K).
#[derive(Clone, Copy)]
struct ArcWords {
    motion: Motion,
    radius: bool,
}

/// A split move: its pieces' end values, the centre of each piece that is an arc, and the
/// values its first line wrote.
type SplitMove<'a> = (&'a [[f64; 6]], &'a [Option<[f64; 2]>], [f64; 6]);

/// The added lines of a split move, one per piece after the first (a piece that moves no written
/// value is left out): straight, or an arc about `centres[i]`. Returns how many were written.
fn write_pieces(
    (pieces, centres, first_written): SplitMove<'_>,
    arc: ArcWords,
    state: &mut State,
    style: &Style,
    ending: &str,
    out: &mut String,
) -> usize {
    // Where each piece starts: the last one's end (where an axis is not written since its
    // reference return too, unlike `state.written`).
    let mut at = first_written;
    let mut count = 0;
    for (piece, centre) in pieces.iter().zip(centres) {
        let motion = if centre.is_some() {
            arc.motion
        } else {
            Motion::Linear
        };
        let motion_word = format!("{}{}", style.letter('G'), motion.code());
        let piece_written: [f64; 6] = std::array::from_fn(|d| style.rounded(piece[d], d));
        let mut words = String::new();
        if state.written_motion != motion {
            words += &motion_word;
        }
        for (d, &target) in piece_written.iter().enumerate() {
            if style.changed(&piece_written, &state.written, d) {
                if !words.is_empty() {
                    words += style.separator;
                }
                words += &style.axis_word(d, target, &state.written);
            }
        }
        if words.is_empty() || words == motion_word {
            continue;
        }
        if let Some(c) = centre {
            let (u, v) = (state.plane.u, state.plane.v);
            if arc.radius {
                let r = (piece_written[u] - c[0]).hypot(piece_written[v] - c[1]);
                let sign = radius_sign((&at, &piece_written), state.plane, *c, arc.motion);
                words += &format!(
                    "{}{}{}",
                    style.separator,
                    style.letter('R'),
                    format_value(sign * r / style.unit, style.decimals)
                );
            } else {
                for (k, d) in [u, v].into_iter().enumerate() {
                    words += &format!(
                        "{}{}{}",
                        style.separator,
                        style.letter(state.plane.centre[k]),
                        format_value((c[k] - at[d]) / style.unit, style.decimals)
                    );
                }
            }
        }
        out.push_str(&words);
        out.push_str(ending);
        at = piece_written;
        state.written = std::array::from_fn(|d| {
            if state.written[d].is_nan() {
                f64::NAN
            } else {
                piece_written[d]
            }
        });
        state.written_motion = motion;
        count += 1;
    }
    count
}

/// The bytes a word takes, with one separating space before it, for removal.
pub(super) fn removal(line: &Line, w: &Word) -> std::ops::Range<usize> {
    let mut start = w.letter_at;
    if start > 0 && line.text.as_bytes()[start - 1] == b' ' {
        start -= 1;
    }
    start..w.number.end
}

/// `program` with `note` as a comment of its own line at its head: after a leading `%` line
/// (the tape delimiter) and the program number line (`O1234`, `:1234`) where there are, since
/// FANUC-family controls expect the program number first. The note is made fit for a comment:
/// parentheses become brackets, and characters outside printable ASCII are dropped.
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
    let mut head = 0;
    let line_at = |at: usize| {
        let end = program[at..]
            .find('\n')
            .map_or(program.len(), |e| at + e + 1);
        (&program[at..end], end)
    };
    let (first, end) = line_at(head);
    if first.trim() == "%" {
        head = end;
    }
    let (number, end) = line_at(head);
    if is_program_number(number) {
        head = end;
    }
    let separator = if head > 0 && !program[..head].ends_with('\n') {
        "\n"
    } else {
        ""
    };
    format!(
        "{}{separator}{comment}{}",
        &program[..head],
        &program[head..]
    )
}

/// `O1234` or `:1234` (with anything after it: a comment, the program's name).
fn is_program_number(line: &str) -> bool {
    let mut chars = line.trim_start().chars();
    matches!(chars.next(), Some('O' | 'o' | ':'))
        && chars.next().is_some_and(|c| c.is_ascii_digit())
}
