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
