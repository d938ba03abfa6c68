//! Files: every format volmap reads and writes that more than one part of it uses. The machine
//! file (TOML, with CSV tables) and the embedded machines, field files (OpenEXR), points CSV,
//! meshes (STL in, PLY and VTK PolyData out), VTK ImageData of fields; underneath them one CSV reader for every CSV input and one way of
//! writing a file whole or not at all.

pub mod atomic;
pub mod csv;
pub mod digest;
pub mod disk;
pub mod embedded;
pub mod field;
pub mod machine_file;
pub mod mesh;
pub mod outputs;
pub mod points;
pub mod source;
pub mod tolerance_file;
pub mod vtk;

use std::path::Path;

use crate::error::{Classify, ErrorKind};

/// A file that could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{path}: cannot read: {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: cannot write: {source}")]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: larger than {limit}, the most {kind} may hold")]
    TooLarge {
        path: String,
        limit: String,
        kind: &'static str,
    },
    #[error(
        "{path} is an input of this run{}: volmap never writes over its inputs",
        read_as(path, input)
    )]
    OverwritesInput { path: String, input: String },
    #[error(
        "{path} is an input of this run and one of its outputs{}: volmap never writes over its inputs",
        written_as(path, output)
    )]
    ReadsOutput { path: String, output: String },
    #[error("`{name}` lies outside the folder {folder}: files named in a file must be in its folder or below it")]
    OutsideFolder { name: String, folder: String },
}

impl FileError {
    pub fn read(path: &Path, source: std::io::Error) -> FileError {
        FileError::Read {
            path: shown_path(path),
            source,
        }
    }

    pub fn write(path: &Path, source: std::io::Error) -> FileError {
        FileError::Write {
            path: shown_path(path),
            source,
        }
    }

    pub fn too_large(path: &Path, kind: source::SourceKind) -> FileError {
        FileError::TooLarge {
            path: shown_path(path),
            limit: source::describe_bytes(kind.limit_bytes()),
            kind: kind.name(),
        }
    }

    /// Whether this is a file named outside the folder of the file that names it.
    pub fn is_outside_folder(&self) -> bool {
        matches!(self, FileError::OutsideFolder { .. })
    }
}

/// The most characters of a path a message shows: the start and the end of a longer one.
const SHOWN_PATH_CHARS: usize = 320;

/// `path` as a message shows it: control characters (a newline inside a name written in a file)
/// as `?`, and a path longer than [`SHOWN_PATH_CHARS`] cut in the middle, so that a name of 4 kB
/// from a file does not become a 4 kB message.
pub fn shown_path(path: &Path) -> String {
    let chars: Vec<char> = path
        .display()
        .to_string()
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    if chars.len() <= SHOWN_PATH_CHARS {
        return chars.into_iter().collect();
    }
    let half = SHOWN_PATH_CHARS / 2;
    let head: String = chars[..half].iter().collect();
    let tail: String = chars[chars.len() - half..].iter().collect();
    format!("{head}…{tail}")
}

/// How the output an input would be replaced by was named, where that differs from the input's
/// name.
fn written_as(path: &str, output: &str) -> String {
    if path == output {
        String::new()
    } else {
        format!(" (written as {output})")
    }
}

/// How the input an output would replace was named, where that differs from the output's name.
fn read_as(path: &str, input: &str) -> String {
    if path == input {
        String::new()
    } else {
        format!(" (read as {input})")
    }
}

impl Classify for FileError {
    /// A file that cannot be read is the input's fault; one that cannot be written, the work's,
    /// unless no file can have its name (a NUL byte in it, a folder's name, a folder that does not
    /// exist).
    fn kind(&self) -> ErrorKind {
        match self {
            FileError::Read { .. }
            | FileError::TooLarge { .. }
            | FileError::OverwritesInput { .. }
            | FileError::ReadsOutput { .. }
            | FileError::OutsideFolder { .. } => ErrorKind::Input,
            FileError::Write { source, .. }
                if matches!(
                    source.kind(),
                    std::io::ErrorKind::InvalidInput | std::io::ErrorKind::IsADirectory
                ) =>
            {
                ErrorKind::Input
            }
            FileError::Write { .. } => ErrorKind::Work,
        }
    }
}

pub use source::{read_bytes, read_text, SourceKind};
