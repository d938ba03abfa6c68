//! Writing a file whole or not at all: every output goes to a temporary file in the target's
//! folder (`.NAME.PID.part`, so two runs never share one) and is renamed into place only when it
//! is complete and on disk. Until then dropping it removes the temporary file, so a failed or
//! interrupted run never leaves half a file under the name asked for.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::FileError;

/// A file being written under a temporary name; [`AtomicFile::commit`] puts it in place.
pub struct AtomicFile {
    out: BufWriter<File>,
    temp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl AtomicFile {
    /// Starts writing `path` (through a buffer of `buffer_bytes`).
    pub fn create(path: &Path, buffer_bytes: usize) -> Result<AtomicFile, FileError> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temp = path.with_file_name(format!(".{name}.{}.part", std::process::id()));
        let file = File::create(&temp).map_err(|e| FileError::write(path, e))?;
        Ok(AtomicFile {
            out: BufWriter::with_capacity(buffer_bytes, file),
            temp,
            path: path.to_path_buf(),
            committed: false,
        })
    }

    /// The name the file will have.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A write error on this file.
    pub fn error(&self, source: std::io::Error) -> FileError {
        FileError::write(&self.path, source)
    }

    /// Flushes, syncs and renames the file into place.
    pub fn commit(mut self) -> Result<(), FileError> {
        let result = (|| -> std::io::Result<()> {
            self.out.flush()?;
            self.out.get_ref().sync_all()?;
            std::fs::rename(&self.temp, &self.path)
        })();
        result.map_err(|e| self.error(e))?;
        self.committed = true;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.out.write(bytes)
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.out.write_all(bytes)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Seeking flushes the buffer first: writers that fill in a file out of order (VTK's appended
/// arrays) seek to where each piece belongs.
impl Seek for AtomicFile {
    fn seek(&mut self, position: SeekFrom) -> std::io::Result<u64> {
        self.out.seek(position)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `path` whole with `write`, or leaves nothing of it.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let mut file = AtomicFile::create(path, 1 << 16)?;
    write(&mut file).map_err(|e| file.error(e))?;
    file.commit()
}
