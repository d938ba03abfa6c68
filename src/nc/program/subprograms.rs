//! Subprogram calls expanded where their body is in the file, before the compensation reads the
//! program: `M98 P1234` (repeated `L`/`K` times, or Fanuc's `P31234`: three times O1234) and the
//! macro call `G65 P1234` run the block from `O1234` to its `M99` in place of the call. The
//! call becomes a comment that records it, followed by the body's blocks (which keep their own
//! line numbers in errors); the body where it stands in the file passes unchanged (the control
//! reaches it only through calls). A call whose body is not in the file is an error naming the
//! call's line.

use std::collections::HashMap;

use super::parse::{parse_line, Line};
use crate::nc::error::NcError;

/// The deepest nesting of calls followed (Fanuc allows four levels).
const MAX_DEPTH: usize = 8;

/// The most that subprogram calls and canned cycles together may add to a program, counted in
/// words, each block [`BLOCK_WORDS`] more (and a long block one more for every 32 characters):
/// nested calls repeated up to 1000 times each, or pecks far smaller than their holes, would
/// otherwise expand a few lines past any memory and any time. Four million (about 330,000
/// blocks of four words, or 500,000 blocks of none) are read in about 0.3 s and 200 MB;
/// compensating them is the work of a program that long.
pub const MAX_EXPANDED_WORDS: usize = 4_000_000;

/// What a block costs of [`MAX_EXPANDED_WORDS`] besides its words: a block held in memory takes
/// about as much as eight words (a thousand thousand calls of a body of two comments took
/// 600 MB when a block counted one).
pub const BLOCK_WORDS: usize = 8;

/// What the expansion of calls and cycles may still add (see [`MAX_EXPANDED_WORDS`]).
pub(super) struct Room {
    left: usize,
}

impl Room {
    pub(super) fn new() -> Room {
        Room {
            left: MAX_EXPANDED_WORDS,
        }
    }

    /// Takes what `line` adds ([`BLOCK_WORDS`] and its words, one more for every 32 characters
    /// of a long block); false where that is more than is left.
    pub(super) fn take(&mut self, line: &Line) -> bool {
        self.take_blocks(BLOCK_WORDS + line.words.len() + line.text.len() / 32)
    }

    /// Takes `n` (blocks and words); false where that is more than is left.
    pub(super) fn take_blocks(&mut self, n: usize) -> bool {
        match self.left.checked_sub(n) {
            Some(left) => {
                self.left = left;
                true
            }
            None => {
                self.left = 0;
                false
            }
        }
    }

    /// What is left.
    pub(super) fn left(&self) -> usize {
        self.left
    }
}

fn is_call(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| (w.letter == 'M' && w.value == 98.0) || (w.letter == 'G' && w.value == 65.0))
}

fn ends_body(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'M' && w.value == 99.0)
}

fn ends_program(line: &Line) -> bool {
    line.words
        .iter()
        .any(|w| w.letter == 'M' && (w.value == 30.0 || w.value == 2.0))
}

/// The program with every subprogram call expanded (see the module's documentation); bodies
/// pass as written whether called or not.
/// With `pass_unknown` a call whose body is not in the file passes as written.
pub(super) fn expand_subprograms(
    lines: Vec<Line>,
    path: &str,
    pass_unknown: bool,
    room: &mut Room,
) -> Result<Vec<Line>, NcError> {
    // Bodies: an `O` block that ends with M99 before any program end.
    let mut bodies: HashMap<u32, (usize, usize)> = HashMap::new();
    let mut in_body = vec![false; lines.len()];
    let mut i = 0;
    while i < lines.len() {
        let number = lines[i].words.first().filter(|w| w.letter == 'O');
        if let Some(number) = number {
            let end = lines[i + 1..]
                .iter()
                .position(|l| ends_body(l) || ends_program(l) || l.word('O').is_some())
                .map(|k| i + 1 + k);
            if let Some(end) = end.filter(|&e| ends_body(&lines[e])) {
                bodies.insert(number.value as u32, (i + 1, end));
                in_body[i..=end].iter_mut().for_each(|b| *b = true);
                i = end + 1;
                continue;
            }
        }
        i += 1;
    }
    let mut out = Vec::with_capacity(lines.len());
    for (k, line) in lines.iter().enumerate() {
        if in_body[k] {
            // Reached through calls only: passes as written.
            out.push(Line {
                words: Vec::new(),
                unknown: None,
                ..line.clone()
            });
        } else {
            match expand_line(&lines, line, &bodies, path, 0, room, &mut out) {
                Err(NcError::Line { .. }) if pass_unknown => out.push(line.clone()),
                result => result?,
            }
        }
    }
    Ok(out)
}

fn expand_line(
    lines: &[Line],
    line: &Line,
    bodies: &HashMap<u32, (usize, usize)>,
    path: &str,
    depth: usize,
    room: &mut Room,
    out: &mut Vec<Line>,
) -> Result<(), NcError> {
    if !is_call(line) {
        // The file's own blocks pass; those of the calls' bodies are what the calls add.
        if depth > 0 && !room.take(line) {
            return Err(NcError::line(
                path,
                line.number,
                format!(
                    "the calls add more than {MAX_EXPANDED_WORDS} words and blocks to the program"
                ),
            ));
        }
        out.push(line.clone());
        return Ok(());
    }
    let call = if line
        .words
        .iter()
        .any(|w| w.letter == 'G' && w.value == 65.0)
    {
        "G65"
    } else {
        "M98"
    };
    let error = |message: String| NcError::line(path, line.number, format!("{call}: {message}"));
    let p = line
        .word('P')
        .ok_or_else(|| error("the call needs the subprogram's number P".into()))?;
    if p.value.fract() != 0.0 || p.value < 0.0 {
        return Err(error(format!(
            "`P{}`: not a program number",
            crate::error::excerpt(line.text_of(p))
        )));
    }
    let mut number = p.value as u64;
    let mut repeats = line.word('L').or(line.word('K')).map_or(1.0, |w| w.value);
    if call == "M98" && number > 9999 && !line.has('L') && !line.has('K') {
        // Fanuc's P31234: the repeats ahead of a four-digit program number.
        repeats = (number / 10000) as f64;
        number %= 10000;
    }
    if repeats.fract() != 0.0 || !(0.0..=1000.0).contains(&repeats) {
        return Err(error(
            "the repeats (L or K) must be a whole number up to 1000".into(),
        ));
    }
    let &(start, end) = bodies.get(&(number as u32)).ok_or_else(|| {
        error(format!(
            "subprogram O{number} is not in the file (from O{number} to its M99): its moves cannot be compensated"
        ))
    })?;
    if depth >= MAX_DEPTH {
        return Err(error(format!("calls nest deeper than {MAX_DEPTH} levels")));
    }
    let comment = format!(
        "({call} call expanded: {})",
        line.text.trim().replace('(', "[").replace(')', "]")
    );
    let ending = if line.ending.is_empty() {
        "\n"
    } else {
        line.ending
    };
    let comment = parse_line(&comment, ending, line.number, path)?;
    // A call inside a body is a block the calls add, as its body's blocks are.
    if depth > 0 && !room.take(&comment) {
        return Err(error(format!(
            "the calls add more than {MAX_EXPANDED_WORDS} words and blocks to the program"
        )));
    }
    out.push(comment);
    // The call's other words (M98: feed, spindle, coolant, tool, a move) act before the body
    // runs, as FANUC runs them: on a block of their own. G65's other words are the macro's
    // arguments.
    if call == "M98" {
        let kept: Vec<&str> = line
            .words
            .iter()
            .filter(|w| {
                !matches!(w.letter, 'M' | 'P' | 'L' | 'K' | 'N')
                    || w.letter == 'M' && w.value != 98.0
            })
            .map(|w| line.text[w.letter_at..w.number.end].trim())
            .collect();
        if !kept.is_empty() {
            let mut kept = parse_line(&kept.join(" "), ending, line.number, path)?;
            // Words volmap adds to it are spaced as the call's were.
            kept.spaced = line.spaced;
            if depth > 0 && !room.take(&kept) {
                return Err(error(format!(
                    "the calls add more than {MAX_EXPANDED_WORDS} words and blocks to the program"
                )));
            }
            out.push(kept);
        }
    }
    for _ in 0..repeats as usize {
        for body_line in &lines[start..end] {
            expand_line(lines, body_line, bodies, path, depth + 1, room, out).map_err(|e| {
                // Calls that add too much are named by the outermost of them.
                if room.left() == 0 {
                    error(format!(
                        "the calls add more than {MAX_EXPANDED_WORDS} words and blocks to the program"
                    ))
                } else {
                    e
                }
            })?;
        }
    }
    Ok(())
}
