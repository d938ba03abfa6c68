//! Files: every format volmap reads and writes that more than one part of it uses. The machine
//! file (TOML, with CSV tables) and the embedded machines, field files (OpenEXR), points CSV,
//! meshes (STL in, PLY and VTK PolyData out), VTK ImageData of fields; underneath them one CSV reader for every CSV input and one way of
//! writing a file whole or not at all.

pub mod atomic;
pub mod csv;
pub mod embedded;
pub mod field;
pub mod machine_file;
pub mod mesh;
pub mod points;
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
}

impl FileError {
    pub fn read(path: &Path, source: std::io::Error) -> FileError {
        FileError::Read {
            path: path.display().to_string(),
            source,
        }
    }

    pub fn write(path: &Path, source: std::io::Error) -> FileError {
        FileError::Write {
            path: path.display().to_string(),
            source,
        }
    }
}

impl Classify for FileError {
    /// A file that cannot be read is the input's fault; one that cannot be written, the work's.
    fn kind(&self) -> ErrorKind {
        match self {
            FileError::Read { .. } => ErrorKind::Input,
            FileError::Write { .. } => ErrorKind::Work,
        }
    }
}

/// Reads a whole text file.
pub fn read_text(path: &Path) -> Result<String, FileError> {
    std::fs::read_to_string(path).map_err(|e| FileError::read(path, e))
}

/// Reads a whole file.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, FileError> {
    std::fs::read(path).map_err(|e| FileError::read(path, e))
}
