//! Blocks volmap does not model, passed as they are (`pass_unknown`), and the axes they leave
//! unknown. Such a block may move the axes it names (a macro expression, `G1 X[1+2]`, a code
//! volmap does not follow): volmap cannot know where they stand after it, so it adds no word for
//! them and compensates no move until a block sets every one of them absolutely again; the
//! moves in between pass as they are and are listed (`LeftAlone`). A code volmap does not follow
//! may move axes it does not name, or change how the following blocks are read (a call whose
//! body is not in the file, a control's own cycle or mode): every axis the program names becomes
//! unknown. A line of macro words only (`#100=5`, `F#1`, `S[#2*2] M3`) moves what it names, and an
//! assignment nothing.

use super::approach::line_directions;
use super::modal::{LeftAlone, State, AXIS_LETTERS, MM_PER_INCH};
use super::parse::{Line, Word};
use crate::error::excerpt;
use crate::nc::error::NcError;

/// G codes that may stand on a line of macro words, taken into the modal state: the modes volmap
/// follows. Any other G code beside an expression is refused.
const MODAL_G: [u32; 20] = [
    0, 1, 2, 3, 17, 18, 19, 20, 21, 40, 49, 54, 55, 56, 57, 58, 59, 80, 90, 91,
];

/// What a line volmap cannot read names: its words with a plain number and the letters given
/// by an expression (`#`, `[ ]`).
struct MacroWords {
    plain: Vec<(char, String)>,
    expressions: Vec<char>,
    /// The line assigns a variable (`#100=5`): it moves nothing.
    assignment: bool,
}

/// Reads what it can of a line of macro variables or expressions (`#`, `[ ]`, `=`): `None` where
/// it is not one.
fn macro_words(body: &str) -> Option<MacroWords> {
    let code: String = strip_comments(body);
    if !code.contains(['#', '[', '=']) {
        return None;
    }
    let bytes = code.as_bytes();
    let mut words = MacroWords {
        plain: Vec::new(),
        expressions: Vec::new(),
        assignment: false,
    };
    let mut i = 0;
    let skip_space = |i: &mut usize| {
        while *i < bytes.len() && (bytes[*i] == b' ' || bytes[*i] == b'\t') {
            *i += 1;
        }
    };
    skip_space(&mut i);
    if i < bytes.len() && bytes[i] == b'/' {
        i += 1;
    }
    while i < bytes.len() {
        skip_space(&mut i);
        if i >= bytes.len() {
            break;
        }
        let c = bytes[i] as char;
        if c == '#' && words.plain.iter().all(|(l, _)| *l == 'N') && words.expressions.is_empty() {
            words.assignment = true;
            return Some(words);
        }
        if !c.is_ascii_alphabetic() {
            // Not a word: something volmap cannot place (a keyword's operand, an operator).
            words.expressions.push('?');
            return Some(words);
        }
        let letter = c.to_ascii_uppercase();
        i += 1;
        if i < bytes.len() && bytes[i].is_ascii_alphabetic() {
            // IF, GOTO, WHILE, DO, END...: a jump or a loop.
            words.expressions.push('!');
            return Some(words);
        }
        skip_space(&mut i);
        let start = i;
        if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
            i += 1;
        }
        if i < bytes.len() && (bytes[i] == b'#' || bytes[i] == b'[') {
            words.expressions.push(letter);
            // The expression: a variable number or a bracketed expression, to the next letter.
            let mut depth = 0usize;
            while i < bytes.len() {
                match bytes[i] {
                    b'[' => depth += 1,
                    b']' => depth = depth.saturating_sub(1),
                    b if depth == 0 && b.is_ascii_alphabetic() => break,
                    _ => {}
                }
                i += 1;
            }
            continue;
        }
        while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
            i += 1;
        }
        words.plain.push((letter, code[start..i].to_string()));
        if start == i {
            words.expressions.push('?');
            return Some(words);
        }
    }
    Some(words)
}

/// The line's text without comments `( )` and what follows `;`.
fn strip_comments(body: &str) -> String {
    let mut out = String::with_capacity(body.len());
    let mut depth = 0usize;
    for c in body.chars() {
        match c {
            ';' if depth == 0 => break,
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            c if depth == 0 => out.push(c),
            _ => {}
        }
    }
    out
}

/// A line volmap cannot read, passed (`pass_unknown`): the modal G codes it gives in plain
/// numbers as its words, the line itself as the code volmap does not follow. A jump or loop,
/// or a G, M or T word given by an expression, is refused: which blocks run next, the modes or
/// the tool after it are not known. `None` where the line holds no macro words (something else
/// volmap cannot read: it passes wordless, and may move any axis).
pub(super) fn unread_line(
    body: &str,
    ending: &'static str,
    number: usize,
    path: &str,
) -> Result<Option<Line>, NcError> {
    let Some(read) = macro_words(body) else {
        return Ok(None);
    };
    let refuse = |why: String| Err(NcError::line(path, number, why));
    if read.expressions.contains(&'!') {
        return refuse("a jump or loop (IF, GOTO, WHILE): which blocks the control runs after it is not known, so it cannot be passed".into());
    }
    if let Some(l) = read
        .expressions
        .iter()
        .find(|l| matches!(l, 'G' | 'M' | 'T'))
    {
        return refuse(format!("{l} given by an expression: the modes, calls or tool after this block are not known, so it cannot be passed"));
    }
    let mut words = Vec::new();
    for (letter, text) in &read.plain {
        let value: f64 = text.parse().unwrap_or(f64::NAN);
        if *letter == 'T' {
            return refuse(format!("T{text} beside a macro expression: the tool after this block is not known, so it cannot be passed"));
        }
        if *letter != 'G' {
            continue;
        }
        if value.fract() != 0.0 || !MODAL_G.contains(&(value as u32)) {
            return refuse(format!(
                "G{text} beside a macro expression: volmap follows only modes (G0–G3, G17–G21, G40, G49, G54–G59, G80, G90, G91) on such a block"
            ));
        }
        // Its place in the line is not kept (the line passes as it is): no message quotes it.
        words.push(Word {
            letter: 'G',
            value,
            letter_at: 0,
            number: 0..0,
            lower: false,
        });
    }
    Ok(Some(Line {
        number,
        text: body.into(),
        ending,
        words,
        spaced: false,
        unknown: Some(excerpt(body.trim()).into_owned()),
    }))
}

/// The axes a passed block makes unknown (see the module's documentation).
fn unknown_axes(line: &Line, state: &State) -> [bool; 6] {
    let named = |d: usize| line.has(AXIS_LETTERS[d]);
    let read = macro_words(&line.text).filter(|_| is_unread(line));
    match read {
        Some(read) if !read.calls() => {
            if read.assignment {
                return [false; 6];
            }
            std::array::from_fn(|d| {
                read.expressions.contains(&AXIS_LETTERS[d])
                    || read.plain.iter().any(|(l, _)| *l == AXIS_LETTERS[d])
            })
        }
        _ => std::array::from_fn(|d| named(d) || state.named[d]),
    }
}

impl MacroWords {
    /// A subprogram call or return: its moves are elsewhere.
    fn calls(&self) -> bool {
        self.plain
            .iter()
            .any(|(l, t)| *l == 'M' && matches!(t.parse::<f64>(), Ok(v) if v == 98.0 || v == 99.0))
    }
}

/// Takes a passed block (modal words already taken): the axes it may move become unknown (see
/// the module's documentation).
pub(super) fn pass_block(line: &Line, state: &mut State) {
    let axes = unknown_axes(line, state);
    for (unknown, _) in state.unknown.iter_mut().zip(axes).filter(|(_, a)| *a) {
        unknown.get_or_insert(line.number);
    }
}

/// Whether a line volmap could not read names an axis (or is not one of macro words at all).
pub(super) fn unread_names_axis(line: &Line) -> bool {
    match macro_words(&line.text) {
        Some(read) => {
            !read.assignment
                && AXIS_LETTERS
                    .iter()
                    .any(|a| read.expressions.contains(a) || read.plain.iter().any(|(l, _)| l == a))
        }
        None => true,
    }
}

/// Whether a line is one volmap could not read (a line of macro words).
pub(super) fn is_unread(line: &Line) -> bool {
    line.unknown.is_some() && macro_words(&line.text).is_some()
}

/// A move while an axis is unknown, or under a work offset or tool data volmap does not know:
/// it passes as it is, and the axes it sets absolutely are known again after it. `Some` where the
/// move is left alone (its line, the unknown axes, where the first became unknown).
pub(super) fn leave_alone(line: &Line, state: &mut State) -> Option<LeftAlone> {
    let offset = state.offsets_unknown.get(&state.offset).copied();
    let tool = state.tool_data_unknown.filter(|_| state.tool_length_on);
    let unknown: Vec<usize> = (0..6).filter(|&d| state.unknown[d].is_some()).collect();
    if unknown.is_empty() && offset.is_none() && tool.is_none() {
        return None;
    }
    let mut axes: Vec<String> = unknown
        .iter()
        .map(|&d| AXIS_LETTERS[d].to_string())
        .collect();
    if offset.is_some() {
        axes.push(format!("G{} work offset", state.offset));
    }
    if tool.is_some() {
        axes.push("tool length".into());
    }
    let since = unknown
        .iter()
        .filter_map(|&d| state.unknown[d])
        .chain(offset)
        .chain(tool)
        .min()
        .unwrap_or(line.number);
    let left = LeftAlone {
        line: line.number,
        axes: axes.join(" "),
        since,
    };
    let before = state.position;
    follow_passed(line, state);
    state.approach = line_directions(&before, &state.position, &state.approach);
    state.programmed = line_directions(&before, &state.position, &state.programmed);
    Some(left)
}

/// The position after a block passed as it is: the axes it names where it sends them (an axis set
/// absolutely is known again; one moved by an increment stays as known as it was), in the
/// program and in the output alike.
pub(in crate::nc) fn follow_passed(line: &Line, state: &mut State) {
    for (d, &letter) in AXIS_LETTERS.iter().enumerate() {
        let Some(w) = line.word(letter) else {
            continue;
        };
        let value = if state.inch && d < 3 {
            w.value * MM_PER_INCH
        } else {
            w.value
        };
        if state.absolute {
            state.position[d] = value;
            state.written[d] = value;
            state.unknown[d] = None;
            state.set[d] = super::modal::AxisSet::Yes;
        } else {
            state.position[d] += value;
            state.written[d] += value;
        }
    }
}
