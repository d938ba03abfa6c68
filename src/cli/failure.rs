//! The one place that turns an error into what the user sees and the exit code: bad input exits
//! with 2, a failure while working with 1 (a result beyond its tolerance with 4), by the error's
//! kind (`volmap::error::Classify`), never by where it was raised. The library's errors say which file, key or value is wrong;
//! here the command line adds which flag it came from.

use std::fmt::Display;
use std::io::Write;
use std::process::ExitCode;

use volmap::error::{Classify, ErrorKind};

/// A failed command: the error, its kind, and a hint of what to do about it.
pub struct Failure {
    kind: ErrorKind,
    error: anyhow::Error,
    hint: Option<String>,
    /// An exit code other than the kind's (4: a result beyond its tolerance).
    code: Option<u8>,
}

/// Every library error becomes a failure of its own kind, so `?` decides the exit code right.
impl<E: Classify + Send + Sync + 'static> From<E> for Failure {
    fn from(error: E) -> Failure {
        Failure {
            kind: error.kind(),
            error: error.into(),
            hint: None,
            code: None,
        }
    }
}

impl Failure {
    /// Bad input the command line itself finds (a flag's value).
    pub fn input(message: impl Display + std::fmt::Debug + Send + Sync + 'static) -> Failure {
        Failure {
            kind: ErrorKind::Input,
            error: anyhow::Error::msg(message),
            hint: None,
            code: None,
        }
    }

    /// A result the work produced that fails its own check beyond a tolerance: exit code 4, as
    /// `map --check` (the work was done; its result is not what it should be).
    pub fn beyond_tolerance(
        message: impl Display + std::fmt::Debug + Send + Sync + 'static,
    ) -> Failure {
        Failure {
            code: Some(4),
            ..Failure::work(anyhow::Error::msg(message))
        }
    }

    /// A failure while working that the command line itself meets (writing to standard output).
    pub fn work(error: impl Into<anyhow::Error>) -> Failure {
        Failure {
            kind: ErrorKind::Work,
            error: error.into(),
            hint: None,
            code: None,
        }
    }

    /// The same failure, said to come from a flag (`--grid`) or to have happened while doing
    /// something (`mapping … into …`).
    pub fn context(self, context: impl Display + Send + Sync + 'static) -> Failure {
        Failure {
            error: self.error.context(context),
            ..self
        }
    }

    /// The same failure with a hint of what to do.
    pub fn hint(self, hint: impl Into<String>) -> Failure {
        Failure {
            hint: Some(hint.into()),
            ..self
        }
    }

    pub fn exit_code(&self) -> ExitCode {
        ExitCode::from(self.code.unwrap_or(match self.kind {
            ErrorKind::Input => 2,
            ErrorKind::Work => 1,
        }))
    }

    /// Writes the failure to standard error: the error and its causes on one line, each cause
    /// once (an error that already quotes its cause does not repeat it), then the hint.
    pub fn report(&self) {
        let mut message = String::new();
        for cause in self.error.chain() {
            let text = cause.to_string();
            if message.contains(&text) {
                continue;
            }
            if !message.is_empty() {
                message.push_str(": ");
            }
            message.push_str(&text);
        }
        // Whatever a message quotes of the input, it shows a few characters of it.
        // A closed standard error has nobody to tell: no panic over it.
        let mut err = std::io::stderr().lock();
        let safe = volmap::error::terminal_safe;
        let _ = writeln!(err, "error: {}", safe(&volmap::error::capped(&message)));
        if let Some(hint) = &self.hint {
            let _ = writeln!(err, "  hint: {}", safe(&volmap::error::capped(hint)));
        }
    }
}

/// `result.flag("--grid")`: a library error said to come from a flag.
pub trait FlagContext<T> {
    fn flag(self, flag: &str) -> Result<T, Failure>;
}

impl<T, E: Into<Failure>> FlagContext<T> for Result<T, E> {
    fn flag(self, flag: &str) -> Result<T, Failure> {
        self.map_err(|e| e.into().context(flag.to_string()))
    }
}
