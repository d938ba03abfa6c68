//! Writing the compensated blocks: numbers replaced where they stand, words added or removed only
//! where the coordinates need it, pieces added after their block.

use super::parse::{Line, Word};
use super::program::{Motion, State, AXIS_LETTERS, MM_PER_INCH};
use super::{NcError, Options};

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

/// Writes the block's output: the original line with its coordinates replaced by the first
/// piece's (an arc that became lines turns G2/G3 into G1 and loses its centre words), then one
/// added line per further piece. Returns the number of lines written.
pub(super) fn write_block(
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
pub(super) fn removal(line: &Line, w: &Word) -> std::ops::Range<usize> {
    let mut start = w.letter_at;
    if start > 0 && line.text.as_bytes()[start - 1] == b' ' {
        start -= 1;
    }
    start..w.number.end
}
