//! The fuzz targets: one per parser and reader of volmap, each calling the library as the
//! command line does (files written to a scratch folder where a reader takes a path), and what
//! each execution must hold: any error is the library's, of the kind bad input is, with a
//! message that names the file and quotes no more than a few characters of it; the checks of
//! each target beyond that (a file volmap writes reads back).

mod field;
mod machine;
mod measured;
mod nc;
mod nc_size;
mod parts;
mod toml_size;

use std::path::PathBuf;

use volmap::error::{Classify, ErrorKind};
use volmap::model::Machine;

use super::corpus::Scratch;
use super::material::Grammar;

/// What an execution came to, when it held every check.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// The input was read (and whatever the target does with it done).
    Accepted,
    /// The library refused it with this message.
    Refused(String),
}

/// An execution's outcome, or what it broke (a finding).
pub type Verdict = Result<Outcome, String>;

/// One parser or reader under test.
pub struct Target {
    pub name: &'static str,
    /// What it reads and how, for `--list` and docs/testing.md.
    pub about: &'static str,
    pub grammar: Grammar,
    /// Words of the format beyond those of its corpus.
    pub words: &'static [&'static str],
    pub run: fn(&mut Context, &[u8]) -> Verdict,
}

/// What targets share across executions: the scratch folder, the embedded machines.
pub struct Context {
    pub scratch: Scratch,
    machines: Vec<(&'static str, Machine)>,
}

impl Context {
    pub fn new() -> std::io::Result<Context> {
        let machines = volmap::io::embedded::EMBEDDED
            .iter()
            .map(|(name, _)| {
                let machine = volmap::io::embedded::embedded(name)
                    .expect("listed")
                    .expect("an embedded machine parses");
                (*name, machine)
            })
            .collect();
        Ok(Context {
            scratch: Scratch::new()?,
            machines,
        })
    }

    /// The embedded machine `name`.
    pub fn machine(&self, name: &str) -> &Machine {
        &self
            .machines
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("no embedded machine {name}"))
            .1
    }

    pub fn machines(&self) -> &[(&'static str, Machine)] {
        &self.machines
    }

    /// Writes an input's files: the main one as `main`, the others under their names (a name
    /// equal to `main` is left out); their paths, the main file's first.
    pub fn write(&mut self, main: &str, input: &[u8]) -> Result<Vec<PathBuf>, String> {
        let (first, others) = super::corpus::split(input);
        let mut files = vec![(main, first)];
        files.extend(others.into_iter().filter(|(name, _)| *name != main));
        self.scratch
            .write(&files)
            .map_err(|e| format!("the harness could not write the input's files: {e}"))
    }
}

/// The most bytes a message may have: messages quote at most 80 characters of any input, so
/// a longer one echoes input (or a list no reader needs).
pub const MAX_MESSAGE_BYTES: usize = 1200;

/// The value of the first comment line `# KEY: VALUE` (or `(KEY: VALUE)`) of an input: what a
/// seed says the target should run it with.
pub(crate) fn directive<'a>(input: &'a [u8], key: &str) -> Option<&'a str> {
    let text = std::str::from_utf8(&input[..input.len().min(4096)]).ok()?;
    text.lines().find_map(|line| {
        let line = line.trim();
        let inner = line
            .strip_prefix('#')
            .or_else(|| line.strip_prefix('(').and_then(|l| l.strip_suffix(')')))?;
        let (k, v) = inner.split_once(':')?;
        (k.trim() == key).then(|| v.trim())
    })
}

/// Judges an error of the library: bad input is [`ErrorKind::Input`], and its message as the
/// command line shows it (through [`volmap::error::capped`], which cuts what it quotes) names
/// one of `files` (the file at fault, or the one naming it) and stays short.
pub fn refused<E: Classify>(error: E, files: &[&str]) -> Verdict {
    let message = volmap::error::capped(&error.to_string());
    if error.kind() != ErrorKind::Input {
        return Err(format!(
            "bad input reported as a failure of the work (exit code 1, not 2): {}",
            quoted(&message)
        ));
    }
    if message.trim().is_empty() {
        return Err("an error with an empty message".into());
    }
    if message.len() > MAX_MESSAGE_BYTES {
        return Err(format!(
            "a message of {} bytes (at most {MAX_MESSAGE_BYTES}): {}",
            message.len(),
            quoted(&message)
        ));
    }
    let digits = longest_digit_run(&message);
    if digits > MAX_NUMBER_DIGITS {
        return Err(format!(
            "a message with a number of {digits} digits outside a quote (numbers with many digits are shown in exponent form): {}",
            quoted(&message)
        ));
    }
    if !files.is_empty() && !files.iter().any(|f| message.contains(f)) {
        return Err(format!(
            "a message that names none of the files {files:?}: {}",
            quoted(&message)
        ));
    }
    Ok(Outcome::Refused(message))
}

/// The start of a message in a finding.
fn quoted(message: &str) -> String {
    match message.char_indices().nth(400) {
        None => message.to_string(),
        Some((end, _)) => format!("{}…", &message[..end]),
    }
}

/// The most digits in a row a message may have outside its quotes (between backticks, which
/// [`volmap::error::excerpt`] cuts): a number volmap writes with more is one it should have
/// shown in exponent form (`volmap::error::shown` writes at most 24 characters).
const MAX_NUMBER_DIGITS: usize = volmap::error::EXCERPT_CHARS;

/// The most digits in a row in `text` outside its quotes (between backticks, or a line of input
/// quoted after `  | `).
fn longest_digit_run(text: &str) -> usize {
    let unquoted: Vec<&str> = text.lines().filter(|l| !l.starts_with("  | ")).collect();
    unquoted
        .join("\n")
        .split('`')
        .step_by(2)
        .flat_map(|part| {
            part.split(|c: char| !c.is_ascii_digit())
                .map(str::len)
                .collect::<Vec<_>>()
        })
        .max()
        .unwrap_or(0)
}

/// The value of a `Result` of the library, or the verdict on its error (see [`refused`]).
macro_rules! read {
    ($result:expr, $files:expr) => {
        match $result {
            Ok(value) => value,
            Err(error) => return super::refused(error, $files),
        }
    };
}
pub(crate) use read;

/// Every target, in the order of docs/testing.md.
pub const TARGETS: &[Target] = &[
    machine::MACHINE,
    machine::TOLERANCE,
    parts::PART,
    parts::STL,
    parts::POINTS,
    measured::MEASURED,
    measured::FIT,
    measured::INTERFEROMETER,
    nc::GCODE,
    nc::OFFSETS,
    field::FIELD,
    toml_size::TOML_SIZE,
    nc_size::NC_SIZE,
];

/// The target called `name`.
pub fn find(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}
