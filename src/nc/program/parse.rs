//! Reading ISO 6983 / Fanuc-style blocks into words, keeping where each word's number sits in
//! the line so the compensated program can change numbers and nothing else.

use crate::error::excerpt;
use crate::limits::{MAX_PROGRAM_BLOCKS, MAX_PROGRAM_WORDS, MAX_TRACE_SAMPLES};
use crate::nc::error::NcError;

/// A word: its letter (upper case), value, and the byte range of its number in the line (the
/// number as written is [`Line::text_of`]: a word holds no text of its own, so that a program
/// of millions of blocks takes a few dozen bytes a word).
#[derive(Debug, Clone, PartialEq)]
pub struct Word {
    pub letter: char,
    pub value: f64,
    /// Byte range of the letter and of the number within the line.
    pub letter_at: usize,
    pub number: std::ops::Range<usize>,
    /// Whether the letter was written in lower case.
    pub lower: bool,
}

/// One line of the program.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// 1-based line number in the file.
    pub number: usize,
    /// The line's text without its line ending.
    pub text: String,
    /// `"\n"`, `"\r\n"` or `""` (a last line without one).
    pub ending: &'static str,
    pub words: Vec<Word>,
    /// Whether words are separated by spaces (new words are written the same way).
    pub spaced: bool,
    /// A code volmap does not follow that governs this line though it is not in it (a hole of
    /// a canned cycle volmap does not expand).
    pub unknown: Option<String>,
}

impl Line {
    pub fn word(&self, letter: char) -> Option<&Word> {
        self.words.iter().find(|w| w.letter == letter)
    }

    pub fn has(&self, letter: char) -> bool {
        self.words.iter().any(|w| w.letter == letter)
    }

    /// The number of `word` (one of this line's) as written.
    pub fn text_of(&self, word: &Word) -> &str {
        self.text.get(word.number.clone()).unwrap_or_default()
    }
}

/// Splits a program into lines of words. A file that is not text (NUL bytes, control
/// characters, invalid UTF-8) is an error naming the first line that is not; a line that cannot
/// be read is one too, unless `pass_unread` keeps it, wordless, to be copied as it is.
pub fn parse_program(bytes: &[u8], path: &str, pass_unread: bool) -> Result<Vec<Line>, NcError> {
    // A program saved by an editor may start with a UTF-8 byte-order mark.
    let bytes = crate::io::source::without_byte_order_mark(bytes);
    let text = match std::str::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let line = bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1;
            return Err(NcError::line(
                path,
                line,
                "not a text file (invalid UTF-8)".into(),
            ));
        }
    };
    let blocks = text.split_inclusive('\n').count();
    if blocks as u64 > MAX_PROGRAM_BLOCKS {
        return Err(NcError::Program {
            path: path.to_string(),
            message: format!(
                "the program has {blocks} blocks, more than the limit of {MAX_PROGRAM_BLOCKS}: each move is traced at 4 samples at least and {MAX_TRACE_SAMPLES} samples are the most; split the program"
            ),
        });
    }
    let mut lines = Vec::with_capacity(blocks);
    let mut words = 0u64;
    for (n, raw) in text.split_inclusive('\n').enumerate() {
        let number = n + 1;
        let (body, ending) = if let Some(b) = raw.strip_suffix("\r\n") {
            (b, "\r\n")
        } else if let Some(b) = raw.strip_suffix('\n') {
            (b, "\n")
        } else {
            (raw, "")
        };
        if let Some(c) = body
            .chars()
            .find(|c| c.is_control() && *c != '\t' && *c != '\x0c')
        {
            return Err(NcError::line(
                path,
                number,
                format!("not a text file (control character U+{:04X})", c as u32),
            ));
        }
        match parse_line(body, ending, number, path) {
            Ok(line) => {
                words += line.words.len() as u64;
                if words > MAX_PROGRAM_WORDS {
                    return Err(NcError::line(
                        path,
                        number,
                        format!("the program's words up to this line are more than the limit of {MAX_PROGRAM_WORDS}"),
                    ));
                }
                lines.push(line)
            }
            // Passed as it is: macro words leave the axes they name unknown, anything else every
            // axis (`unknown`).
            Err(NcError::Line { .. }) if pass_unread => lines.push(
                match super::unknown::unread_line(body, ending, number, path)? {
                    Some(line) => line,
                    None => Line {
                        number,
                        text: body.into(),
                        ending,
                        words: Vec::new(),
                        spaced: false,
                        unknown: Some(excerpt(body.trim()).into_owned()),
                    },
                },
            ),
            Err(e) => return Err(e),
        }
    }
    Ok(lines)
}

pub(super) fn parse_line(
    body: &str,
    ending: &'static str,
    number: usize,
    path: &str,
) -> Result<Line, NcError> {
    let mut words = Vec::new();
    let bytes = body.as_bytes();
    let mut i = 0;
    let trimmed = body.trim_start();
    // `%` delimits the program; `O1234` / `:1234` name it: such lines pass as they are.
    if trimmed.starts_with('%') {
        return Ok(Line {
            number,
            text: body.into(),
            ending,
            words,
            spaced: false,
            unknown: None,
        });
    }
    while i < bytes.len() {
        let c = bytes[i] as char;
        match c {
            '(' => match body[i..].find(')') {
                Some(end) => i += end + 1,
                None => {
                    return Err(NcError::line(
                        path,
                        number,
                        "a comment `(` is not closed on its line".into(),
                    ))
                }
            },
            ';' => break,
            ' ' | '\t' => i += 1,
            '/' if words.is_empty() => i += 1,
            c if c.is_ascii_alphabetic() => {
                let letter_at = i;
                i += 1;
                while i < bytes.len() && (bytes[i] == b' ' || bytes[i] == b'\t') {
                    i += 1;
                }
                let start = i;
                if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
                    i += 1;
                }
                while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                    i += 1;
                }
                let text = &body[start..i];
                let value: f64 = text
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| {
                        NcError::line(
                            path,
                            number,
                            if text.is_empty() {
                                format!("`{c}` without a number")
                            } else {
                                format!("`{c}{}`: not a number", excerpt(text))
                            },
                        )
                    })?;
                let whole = value.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&value);
                if c.eq_ignore_ascii_case(&'T') && !whole {
                    return Err(NcError::line(
                        path,
                        number,
                        format!(
                            "`{c}{}`: a tool number is a whole number from 0 to {}",
                            excerpt(text),
                            u32::MAX
                        ),
                    ));
                }
                words.push(Word {
                    letter: c.to_ascii_uppercase(),
                    value,
                    letter_at,
                    number: start..i,
                    lower: c.is_ascii_lowercase(),
                });
            }
            '#' | '[' | '=' => {
                return Err(NcError::line(
                    path,
                    number,
                    format!("`{c}`: macro variables and expressions are not supported"),
                ))
            }
            other => {
                return Err(NcError::line(
                    path,
                    number,
                    format!(
                        "cannot read `{}` here",
                        body.get(i..)
                            .and_then(|rest| rest.chars().next())
                            .unwrap_or(other)
                    ),
                ));
            }
        }
    }
    words.shrink_to_fit();
    Ok(Line {
        number,
        text: body.into(),
        ending,
        spaced: spaced_words(body, &words),
        words,
        unknown: None,
    })
}

/// Whether most gaps between neighbouring words hold a space (`G1 X10. Y5.` against
/// `g1x10.y5.`): words volmap adds are written the same way; a line of one word has no gap to
/// tell, and takes a space (`Y35. X49.926` rather than `Y35.X49.926`).
fn spaced_words(body: &str, words: &[Word]) -> bool {
    let gaps = words.windows(2).count();
    let spaced = words
        .windows(2)
        .filter(|pair| body[pair[0].number.end..pair[1].letter_at].contains([' ', '\t']))
        .count();
    gaps == 0 || 2 * spaced >= gaps
}
