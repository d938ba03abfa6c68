//! Writing a file whole or not at all: every output goes to a temporary file in the target's
//! folder (`.NAME.PID.part`, so two runs never share one) and is renamed into place only when it
//! is complete and on disk. Until then dropping it removes the temporary file, so a failed or
//! interrupted run never leaves half a file under the name asked for.
//!
//! Every temporary file alive is registered here, and every scratch folder ([`ScratchDir`]: a
//! benchmark's fields), so that a signal handler (which runs no destructors) can remove them all
//! ([`remove_live_temporaries`]); and a run that starts writing
//! `NAME` first removes the temporary files of `NAME` left by runs whose process is gone (killed
//! beyond any handler, or a power cut), keeping those of runs still alive.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

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
        remove_stale_temporaries(path, &name);
        let temp = path.with_file_name(temporary_name(&name, std::process::id()));
        let file = File::create(&temp).map_err(|e| FileError::write(path, e))?;
        live().push(temp.clone());
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

    /// Writes `bytes` at `offset` of the file, leaving the position that sequential writes
    /// continue from where it is: a table written ahead (flushed) and filled in as the data it
    /// points to is written.
    pub fn write_at(&mut self, bytes: &[u8], offset: u64) -> std::io::Result<()> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileExt;
            self.out.get_ref().write_all_at(bytes, offset)
        }
        #[cfg(not(unix))]
        {
            self.out.flush()?;
            let file = self.out.get_mut();
            let here = file.stream_position()?;
            file.seek(SeekFrom::Start(offset))?;
            file.write_all(bytes)?;
            file.seek(SeekFrom::Start(here))?;
            Ok(())
        }
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
        forget(&self.temp);
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
            forget(&self.temp);
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

/// The temporary name of `name` written by process `pid`.
fn temporary_name(name: &str, pid: u32) -> String {
    format!(".{name}.{pid}.part")
}

/// The temporary files being written now.
fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    // A writer that panicked holding the lock left the list whole: keep using it.
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// The scratch folders alive now.
fn live_folders() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// A folder of scratch files (a benchmark's fields), removed with everything in it when
/// dropped, and by [`remove_live_temporaries`] when a signal ends the process.
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// Creates `path` (and its parents).
    pub fn create(path: &Path) -> Result<ScratchDir, FileError> {
        std::fs::create_dir_all(path).map_err(|e| FileError::write(path, e))?;
        live_folders().push(path.to_path_buf());
        Ok(ScratchDir {
            path: path.to_path_buf(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
        live_folders().retain(|p| p != &self.path);
    }
}

/// Takes a temporary file off the list of live ones (committed or removed).
fn forget(temp: &Path) {
    live().retain(|t| t != temp);
}

/// Removes every temporary file being written and every scratch folder: for a signal handler,
/// before the process exits without running destructors.
pub fn remove_live_temporaries() {
    for temp in live().drain(..) {
        let _ = std::fs::remove_file(temp);
    }
    for folder in live_folders().drain(..) {
        let _ = std::fs::remove_dir_all(folder);
    }
}

/// Removes the temporary files of `name` (beside `path`) whose writing process is gone.
fn remove_stale_temporaries(path: &Path, name: &str) {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(pid) = file_name
            .to_str()
            .and_then(|f| f.strip_prefix(&prefix))
            .and_then(|rest| rest.strip_suffix(".part"))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && process_is_gone(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Whether no process `pid` exists (signal 0 checks without sending anything).
#[cfg(unix)]
fn process_is_gone(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: kill with signal 0 sends nothing; it only reports whether the process exists.
    let result = unsafe { libc::kill(pid, 0) };
    result == -1 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
}

/// Elsewhere no temporary file is taken for stale: each is left to its writer.
#[cfg(not(unix))]
fn process_is_gone(_pid: u32) -> bool {
    false
}
