//! What kind of failure an error is. Every error type of the library says whether its input was
//! at fault (a file, a key, a value) or the work itself failed (the device, the file system while
//! writing), so that a caller decides what to do by kind and never by where the error came from:
//! the command line maps [`ErrorKind::Input`] to exit code 2 and [`ErrorKind::Work`] to 1, in one
//! place.

/// Whose fault an error is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The input is wrong: a file that is missing or malformed, a key or value out of range.
    Input,
    /// The work failed on correct input: the device, the file system while writing.
    Work,
}

/// An error that knows its [`ErrorKind`].
pub trait Classify: std::error::Error {
    fn kind(&self) -> ErrorKind;
}

/// Implements [`Classify`] for error types whose every variant is bad input.
macro_rules! input_errors {
    ($($t:ty),* $(,)?) => {
        $(impl $crate::error::Classify for $t {
            fn kind(&self) -> $crate::error::ErrorKind {
                $crate::error::ErrorKind::Input
            }
        })*
    };
}
pub(crate) use input_errors;

/// The most characters of an input that a message quotes.
pub const EXCERPT_CHARS: usize = 80;

/// `text` as a message quotes it: whole up to [`EXCERPT_CHARS`] characters, else its first
/// characters and `…`, so that no line of input (a 1 MB line, a number of 400 digits, the first
/// line of a file that is not what it should be) is echoed whole.
pub fn excerpt(text: &str) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(EXCERPT_CHARS) {
        None => std::borrow::Cow::Borrowed(text),
        Some((end, _)) => std::borrow::Cow::Owned(format!("{}…", &text[..end])),
    }
}

/// A number as a message shows it: as Rust writes it where that is short, in exponent form
/// where it would run to many digits (`1e300`, not 301 digits).
pub fn shown(value: f64) -> String {
    let plain = value.to_string();
    if plain.len() <= 24 {
        plain
    } else {
        format!("{value:e}")
    }
}

/// A message as it is shown, whatever its parts quote: each span between backticks cut to
/// [`excerpt`], and each number written with many digits (the `{}` of 1e300 has 301) in
/// exponent form. A last guard for messages built from input that no reader cut first.
pub fn capped(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(4096));
    let mut rest = message;
    while let Some(open) = rest.find('`') {
        out.push_str(&short_numbers(&rest[..open]));
        let after = &rest[open + 1..];
        let (quoted, next) = match after.find('`') {
            Some(close) => (&after[..close], &after[close + 1..]),
            None => (after, ""),
        };
        out.push('`');
        out.push_str(&excerpt(quoted));
        if !next.is_empty() || after.contains('`') {
            out.push('`');
        }
        rest = next;
    }
    out.push_str(&short_numbers(rest));
    out
}

/// `text` with every number longer than 24 characters that stands alone (not part of a word or
/// a file name) written by [`shown`].
fn short_numbers(text: &str) -> std::borrow::Cow<'_, str> {
    let is_digit = |c: char| c.is_ascii_digit() || c == '.';
    if !text.split(|c: char| !is_digit(c)).any(|run| run.len() > 24) {
        return std::borrow::Cow::Borrowed(text);
    }
    let in_word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || "_/\\".contains(c));
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut n = 0;
    while n < chars.len() {
        if !is_digit(chars[n]) {
            out.push(chars[n]);
            n += 1;
            continue;
        }
        let end = (n..chars.len())
            .find(|&k| !is_digit(chars[k]))
            .unwrap_or(chars.len());
        let run: String = chars[n..end].iter().collect();
        let alone =
            !in_word(n.checked_sub(1).map(|k| chars[k])) && !in_word(chars.get(end).copied());
        match run.parse::<f64>() {
            Ok(v) if alone && run.len() > 24 && v.is_finite() => out.push_str(&shown(v)),
            _ => out.push_str(&run),
        }
        n = end;
    }
    std::borrow::Cow::Owned(out)
}

/// `text` safe to show on a terminal: every control character but the newline and the tab
/// (escape sequences, a carriage return, a NUL, the C1 controls) written as its escape, `\u{1b}`,
/// so that nothing read from an input (a feature's name, a CSV field, a key) can move the
/// cursor, rewrite a line or hide text in a message or a table.
pub fn terminal_safe(text: &str) -> std::borrow::Cow<'_, str> {
    let unsafe_char = |c: char| c.is_control() && c != '\n' && c != '\t';
    if !text.chars().any(unsafe_char) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if unsafe_char(c) {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// A TOML parse error of `text` as a message says it: `line L, column C: what`, then the line
/// quoted around the column (at most [`EXCERPT_CHARS`] characters of it, where the parser's own
/// message would quote the whole line however long).
pub fn toml_message(error: &toml::de::Error, text: &str) -> String {
    located_message(error.message(), error.span(), text)
}

/// The deepest nesting of arrays and inline tables a TOML file may have: the TOML parser
/// recurses once per level, and a file of ten thousand unclosed `{` overflows the stack before it
/// reports anything. volmap's own files nest four levels at most.
pub const MAX_TOML_DEPTH: usize = 64;

/// The most parts a dotted key (`a.b.c = 1`, `[a.b.c]`) may have: the parser recurses once per
/// part too, and reports a thousand of them as a recursion limit with no line. volmap's own keys
/// have three at most.
pub const MAX_TOML_KEY_PARTS: usize = 64;

/// The most values a TOML file may hold in its arrays and inline tables (counted by their
/// separating commas and their brackets). The parsers hold 150 to 280 bytes per value (an array of
/// 30 million numbers in a 60 MB file ran out of 4 GiB), so the bound keeps any file within the
/// 64 MiB text limit under about 700 MB of parsing. `build` writes a measured table inline: two
/// components of 400,000 nodes each fit.
pub const MAX_TOML_VALUES: usize = 2_500_000;

/// The most keys a TOML file may hold (each `=`) with its table headers. A key costs the parsers
/// up to 700 bytes (a million took 670 MB in the parser of tolerance files): the bound keeps
/// that under about 180 MB. volmap's files hold hundreds.
pub const MAX_TOML_KEYS: usize = 250_000;

/// Where `text` is beyond what a TOML file may hold, the message a parse error would give (`line
/// L, column C: …`, the line quoted); `None` where it is within the bounds. The bounds, checked
/// before the file is parsed: arrays and inline tables nested at most [`MAX_TOML_DEPTH`] levels,
/// dotted keys of at most [`MAX_TOML_KEY_PARTS`] parts, at most [`MAX_TOML_VALUES`] values and
/// [`MAX_TOML_KEYS`] keys.
/// Brackets, commas and dots inside strings and comments do not count.
pub fn toml_beyond_limits(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let at = |what: String, n: usize| Some(located_message(&what, Some(n..n + 1), text));
    // What each open bracket is: `[`/`{` of a value, or a table header (`[a]`, `[[a]]`).
    let mut open: Vec<u8> = Vec::new();
    let (mut values, mut keys) = (0usize, 0usize);
    // Whether a key is being read (at a line's start outside arrays, after `{` or `,` in an
    // inline table, in a header), and its dots so far.
    let mut in_key = true;
    let mut key_parts = 1usize;
    let mut n = 0;
    while n < bytes.len() {
        match bytes[n] {
            b'#' => {
                while n < bytes.len() && bytes[n] != b'\n' {
                    n += 1;
                }
                continue;
            }
            b'\n' if !open.contains(&b'[') => {
                in_key = true;
                key_parts = 1;
            }
            quote @ (b'"' | b'\'') => {
                let triple = bytes[n..].starts_with(&[quote; 3]);
                n += if triple { 3 } else { 1 };
                while n < bytes.len() {
                    if quote == b'"' && bytes[n] == b'\\' {
                        n += 2;
                        continue;
                    }
                    if !triple && bytes[n] == b'\n' {
                        break;
                    }
                    if bytes[n] == quote && (!triple || bytes[n..].starts_with(&[quote; 3])) {
                        // A closing triple quote may have up to two more quotes before it.
                        if triple {
                            while bytes[n..].starts_with(&[quote; 4]) {
                                n += 1;
                            }
                            n += 2;
                        }
                        break;
                    }
                    n += 1;
                }
            }
            b'[' if in_key && open.is_empty() => {
                // A table header: its key follows, up to the closing bracket.
                if bytes[n..].starts_with(b"[[") {
                    n += 1;
                }
                open.push(b'h');
                keys += 1;
                key_parts = 1;
            }
            b'[' | b'{' => {
                if open.len() >= MAX_TOML_DEPTH {
                    return at(
                        format!("arrays and inline tables nested more than {MAX_TOML_DEPTH} levels deep"),
                        n,
                    );
                }
                open.push(bytes[n]);
                values += 1;
                in_key = bytes[n] == b'{';
                key_parts = 1;
            }
            b']' | b'}' => {
                if open.pop() == Some(b'h') {
                    in_key = false;
                }
                in_key &= open.last() == Some(&b'{');
            }
            b'=' => {
                keys += 1;
                in_key = false;
            }
            b',' => {
                values += 1;
                in_key = open.last() == Some(&b'{');
                key_parts = 1;
            }
            b'.' if in_key || open.last() == Some(&b'h') => {
                key_parts += 1;
                if key_parts > MAX_TOML_KEY_PARTS {
                    return at(
                        format!("a dotted key of more than {MAX_TOML_KEY_PARTS} parts"),
                        n,
                    );
                }
            }
            _ => {}
        }
        if values > MAX_TOML_VALUES {
            return at(
                format!(
                    "more than {MAX_TOML_VALUES} values in arrays and inline tables: a table this large belongs in a CSV file"
                ),
                n,
            );
        }
        if keys > MAX_TOML_KEYS {
            return at(format!("more than {MAX_TOML_KEYS} keys and tables"), n);
        }
        n += 1;
    }
    None
}

/// [`toml_message`] for an error of `toml_edit` (the parser of files volmap edits in place).
pub fn toml_edit_message(error: &toml_edit::TomlError, text: &str) -> String {
    located_message(error.message(), error.span(), text)
}

/// `what` went wrong at `span` of `text`: the line, the column and the line quoted around it.
fn located_message(what: &str, span: Option<std::ops::Range<usize>>, text: &str) -> String {
    let what = double_quotes_cut(what.trim_end());
    let Some(span) = span else {
        return what;
    };
    let start = floor_char_boundary(text, span.start.min(text.len()));
    let line_start = text[..start].rfind('\n').map_or(0, |n| n + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |n| start + n);
    let line = text[..start].matches('\n').count() + 1;
    let column = text[line_start..start].chars().count() + 1;
    // Up to half the excerpt before the column, the rest after it.
    let before: Vec<char> = text[line_start..start].chars().collect();
    let skip = before.len().saturating_sub(EXCERPT_CHARS / 2);
    let shown_before: String = before[skip..].iter().collect();
    let after = excerpt(&text[start..line_end]);
    let lead = if skip > 0 { "…" } else { "" };
    let quoted = format!("{lead}{shown_before}{after}");
    let quoted = excerpt(quoted.trim_end_matches('\r'));
    format!("line {line}, column {column}: {what}\n  | {quoted}")
}

/// `text` with each span between double quotes cut to [`excerpt`]: the parsers' messages quote
/// a string of the input so (`invalid type: string "…", expected a sequence`), and it may be a
/// megabyte long.
pub fn double_quotes_cut(text: &str) -> String {
    let mut out = String::with_capacity(text.len().min(4096));
    for (n, part) in text.split('"').enumerate() {
        if n > 0 {
            out.push('"');
        }
        if n % 2 == 1 {
            out.push_str(&excerpt(part));
        } else {
            out.push_str(part);
        }
    }
    out
}

/// The largest char boundary of `text` at or before `index`.
fn floor_char_boundary(text: &str, mut index: usize) -> usize {
    while !text.is_char_boundary(index) {
        index -= 1;
    }
    index
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_keep_short_text_and_cut_long_text() {
        assert_eq!(excerpt("1.5e-3"), "1.5e-3");
        let long = "9".repeat(400);
        let cut = excerpt(&long);
        assert_eq!(cut.chars().count(), EXCERPT_CHARS + 1);
        assert!(cut.ends_with('…'));
        assert_eq!(shown(12.5), "12.5");
        assert_eq!(shown(1e300), "1e300");
        assert_eq!(shown(-1.5e-300), "-1.5e-300");
        let wide = "é".repeat(EXCERPT_CHARS);
        assert!(excerpt(&format!("{wide}é")).ends_with('…'));
        assert_eq!(excerpt(&wide), wide);
    }
}

#[cfg(test)]
mod toml_tests {
    use super::*;

    #[test]
    fn nesting_beyond_the_limit_is_found_outside_strings_and_comments() {
        let deep = "a = ".to_string() + &"[".repeat(MAX_TOML_DEPTH + 1);
        let message = toml_beyond_limits(&deep).unwrap();
        assert!(
            message.starts_with("line 1, column 69: arrays and inline tables nested more than 64"),
            "{message}"
        );
        let unclosed = "x = { [1.0]\n".repeat(100);
        assert!(toml_beyond_limits(&unclosed)
            .unwrap()
            .starts_with("line 64, column 7:"));
        let fine = format!(
            "# {}\na = \"{}\"\nb = '{}'\nc = \"\"\"\n{}\"\"\"\nd = '''{}'''\ne = \"\\\"[\"\n[t]\nf = [[1, 2], {{ g = [3] }}]\n[[u]]\n",
            "[".repeat(100),
            "{".repeat(100),
            "[".repeat(100),
            "[".repeat(100),
            "{".repeat(100)
        );
        assert_eq!(toml_beyond_limits(&fine), None, "{fine}");
        let at_limit =
            "a = ".to_string() + &"[".repeat(MAX_TOML_DEPTH) + &"]".repeat(MAX_TOML_DEPTH);
        assert_eq!(toml_beyond_limits(&at_limit), None);
        assert!(toml::from_str::<toml::Table>(&at_limit).is_ok());
    }

    #[test]
    fn elements_and_dotted_keys_beyond_the_limits_are_found_before_parsing() {
        // One array a value more than the bound (its bracket is one): refused at its last
        // comma; one key more than the bound, as separate lines, at its `=`.
        let values = "0,".repeat(MAX_TOML_VALUES - 1);
        let at_limit = format!("a = [{values}0]\n");
        assert_eq!(toml_beyond_limits(&at_limit), None);
        let over = format!("a = [{values}0,0]\n");
        let message = toml_beyond_limits(&over).unwrap();
        assert!(message.starts_with("line 1, column "), "{message}");
        assert!(
            message.contains(&format!("more than {MAX_TOML_VALUES} values")),
            "{message}"
        );
        let keys: String = (0..=MAX_TOML_KEYS).map(|k| format!("k{k} = 1\n")).collect();
        let message = toml_beyond_limits(&keys).unwrap();
        assert!(
            // `k250000 = 1`: the `=` at column 9.
            message.starts_with(&format!("line {}, column 9:", MAX_TOML_KEYS + 1))
                && message.contains(&format!("more than {MAX_TOML_KEYS} keys")),
            "{message}"
        );
        let at_limit: String = (1..MAX_TOML_KEYS).map(|k| format!("k{k} = 1\n")).collect();
        assert_eq!(toml_beyond_limits(&format!("[t]\n{at_limit}")), None);
        // Commas, dots and brackets in strings and comments are not elements or parts.
        let quoted = format!("a = \"{}\" # {}\n", ",".repeat(2_000_000), ".".repeat(100));
        assert_eq!(toml_beyond_limits(&quoted), None);
        let parts = |n: usize| vec!["k"; n].join(".");
        for text in [
            format!("{} = 1\n", parts(MAX_TOML_KEY_PARTS)),
            format!("[{}]\n", parts(MAX_TOML_KEY_PARTS)),
            format!("t = {{ {} = 1.5 }}\n", parts(MAX_TOML_KEY_PARTS)),
            "x = 1.5\ny = [1.5, 2.5, { a.b = 3.5 }]\n".to_string(),
        ] {
            assert_eq!(toml_beyond_limits(&text), None, "{text}");
            assert!(toml::from_str::<toml::Table>(&text).is_ok(), "{text}");
        }
        for (text, line) in [
            (format!("x = 1\n{} = 1\n", parts(MAX_TOML_KEY_PARTS + 1)), 2),
            (format!("[[{}]]\n", parts(MAX_TOML_KEY_PARTS + 1)), 1),
            (format!("a = 1\nt = {{ b = 2, {} = 1 }}\n", parts(500)), 2),
        ] {
            let message = toml_beyond_limits(&text).unwrap();
            assert!(
                message.starts_with(&format!("line {line}, column "))
                    && message.contains("a dotted key of more than 64 parts"),
                "{message}"
            );
        }
    }

    #[test]
    fn control_characters_are_shown_escaped_but_newlines_and_tabs_kept() {
        assert_eq!(
            terminal_safe("a\u{1b}[2K\rfit\u{1b}[8m\0\u{9b}b\n\tc"),
            "a\\u{1b}[2K\\u{d}fit\\u{1b}[8m\\u{0}\\u{9b}b\n\tc"
        );
        assert!(matches!(
            terminal_safe("plain µm ±"),
            std::borrow::Cow::Borrowed(_)
        ));
    }

    #[test]
    fn capped_messages_cut_quotes_and_long_numbers() {
        let long = "x".repeat(1000);
        let message = capped(&format!(
            "a.csv: line 2: `{long}` in column `X` is not a number"
        ));
        assert!(message.len() < 200, "{message}");
        assert!(
            message.ends_with("…` in column `X` is not a number"),
            "{message}"
        );
        let message = capped(&format!("X={} lies outside", 1e300));
        assert_eq!(message, "X=1e300 lies outside");
        assert_eq!(
            capped("line 7: X=12.5 (0 to 600)"),
            "line 7: X=12.5 (0 to 600)"
        );
        let name = format!("run_{}.csv: cannot read", "1".repeat(30));
        assert_eq!(capped(&name), name);
        let unclosed = capped(&format!("found `{long}"));
        assert!(unclosed.len() < 120, "{unclosed}");
    }

    #[test]
    fn toml_errors_quote_a_window_of_their_line() {
        let text = format!("a = 1\nb = \"{}", "x".repeat(100_000));
        let error = toml::from_str::<toml::Table>(&text).unwrap_err();
        let message = toml_message(&error, &text);
        assert!(message.starts_with("line 2, column"), "{message}");
        assert!(message.len() < 400, "{message}");
        let text = "a = 1\nb = = 2\n";
        let error = toml::from_str::<toml::Table>(text).unwrap_err();
        let message = toml_message(&error, text);
        assert!(message.starts_with("line 2, column 5: "), "{message}");
        assert!(message.ends_with("| b = = 2"), "{message}");
    }

    /// A string of the input the parser's own message quotes (found by fuzzing: a work offset
    /// file of one 20 kB string gave a message of 20 kB).
    #[test]
    fn toml_errors_cut_the_strings_their_message_quotes() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct Offsets {
            g54: Vec<f64>,
        }
        let text = format!("g54 = \"{}\"\n", "a.".repeat(10_000));
        let error = toml::from_str::<Offsets>(&text).unwrap_err();
        let message = toml_message(&error, &text);
        assert!(message.len() < 400, "{message}");
        assert!(message.contains("invalid type: string \"a.a."), "{message}");
    }
}
