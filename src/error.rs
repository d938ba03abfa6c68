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
        assert_eq!(excerpt(&wide), wide);
    }
}
