//! Writing a file whole or not at all: every output goes to a temporary file in the target's
//! folder (`.NAME.PID.N.part`, created new: no two runs, and no two writers of one run, share
//! one) and is renamed into place only when it is complete and on disk, so the file a run
//! reports is the whole file it wrote. An output that is one of the run's inputs is refused
//! before anything is written ([`super::source::check_not_source`]). Until then dropping it removes the temporary file, so a failed or
//! interrupted run never leaves half a file under the name asked for.
//!
//! Every temporary file alive is registered here, and every scratch folder ([`ScratchDir`]: a
//! benchmark's fields), so that a signal handler (which runs no destructors) can remove them all
//! ([`remove_live_temporaries_and_exit`]); and a run that starts writing
//! `NAME` first removes the temporary files of `NAME` left by runs whose process is gone (killed
//! beyond any handler, or a power cut), keeping those of runs still alive.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use super::FileError;

/// A file being written under a temporary name; [`AtomicFile::commit`] puts it in place.
pub struct AtomicFile {
    out: BufWriter<File>,
    /// The temporary name; none where the target is a device or a pipe, written directly.
    temp: Option<PathBuf>,
    path: PathBuf,
    committed: bool,
}

impl AtomicFile {
    /// Starts writing `path` (through a buffer of `buffer_bytes`).
    pub fn create(path: &Path, buffer_bytes: usize) -> Result<AtomicFile, FileError> {
        super::source::check_not_source(path)?;
        // A link is written through: the file it leads to is replaced, the link stays.
        let target = super::outputs::check_writable(path)?;
        let path = target.as_path();
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            // A device or a pipe (`/dev/null`, `/dev/stdout`): renaming over it would
            // replace the device with a file, so it is written directly.
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| FileError::write(path, e))?;
            return Ok(AtomicFile {
                out: BufWriter::with_capacity(buffer_bytes, file),
                temp: None,
                path: path.to_path_buf(),
                committed: false,
            });
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        remove_stale_temporaries(path, &name);
        // Created and listed under the lock: a signal handler that takes the lock to remove
        // every temporary file either finds this one listed or stops the process before it
        // exists.
        let mut live = live();
        let (temp, file) = loop {
            let temp = path.with_file_name(temporary_name(&name, std::process::id()));
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&temp)
            {
                Ok(file) => break (temp, file),
                // Left by a process of the same number long gone: take the next name.
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(FileError::write(path, e)),
            }
        };
        live.push(temp.clone());
        drop(live);
        Ok(AtomicFile {
            out: BufWriter::with_capacity(buffer_bytes, file),
            temp: Some(temp),
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

    /// Flushes, syncs and renames the file into place (a device or pipe: flushes).
    pub fn commit(mut self) -> Result<(), FileError> {
        let result = (|| -> std::io::Result<()> {
            self.out.flush()?;
            match &self.temp {
                Some(temp) => {
                    self.out.get_ref().sync_all()?;
                    // Held complete until the run ends, where the run holds its outputs.
                    if super::outputs::hold(temp, &self.path) {
                        return Ok(());
                    }
                    std::fs::rename(temp, &self.path)?;
                    forget(temp);
                    Ok(())
                }
                None => Ok(()),
            }
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
        if let (false, Some(temp)) = (self.committed, &self.temp) {
            let _ = std::fs::remove_file(temp);
            forget(temp);
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

/// A new temporary name of `name` written by process `pid`: `.NAME.PID.N.part`, `N` counting
/// the temporary files of the process.
fn temporary_name(name: &str, pid: u32) -> String {
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let n = COUNT.fetch_add(1, Ordering::Relaxed);
    format!(".{name}.{pid}.{n}.part")
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

/// Whether `path` lies in a scratch folder alive now: a benchmark's scratch fields are put in
/// place at once, never held to the run's end (the folder is gone by then).
pub(super) fn in_scratch(path: &Path) -> bool {
    live_folders().iter().any(|folder| path.starts_with(folder))
}

/// Takes a temporary file off the list of live ones (committed or removed).
pub(super) fn forget(temp: &Path) {
    live().retain(|t| t != temp);
}

/// Removes every temporary file being written and every scratch folder, and exits with `code`:
/// for a signal handler, which runs no destructors. The lists stay locked until the process
/// ends, so no writer starts another temporary file or folder meanwhile.
pub fn remove_live_temporaries_and_exit(code: i32) -> ! {
    let mut live = live();
    for temp in live.drain(..) {
        let _ = std::fs::remove_file(temp);
    }
    let mut folders = live_folders();
    for folder in folders.drain(..) {
        let _ = std::fs::remove_dir_all(folder);
    }
    std::process::exit(code)
}

/// Removes the temporary files of `name` (beside `path`) whose writing process is gone.
fn remove_stale_temporaries(path: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(super::outputs::folder_of(path)) else {
        return;
    };
    for entry in entries.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|f| writer_of(f, name)) else {
            continue;
        };
        if pid != std::process::id() && process_is_gone(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// The process that wrote `file_name` if it is a temporary file of `name`: `.NAME.PID.N.part`
/// (or `.NAME.PID.part`, as runs before the count wrote). The temporary file of another output
/// whose name starts like this one's (`.NAME.99.PID.N.part`, of `NAME.99`) is not.
fn writer_of(file_name: &str, name: &str) -> Option<u32> {
    let rest = file_name
        .strip_prefix('.')?
        .strip_prefix(name)?
        .strip_prefix('.')?
        .strip_suffix(".part")?;
    let pid = match rest.split_once('.') {
        Some((pid, n)) if n.bytes().all(|b| b.is_ascii_digit()) => pid,
        Some(_) => return None,
        None => rest,
    };
    pid.parse().ok()
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

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn two_writers_of_one_file_write_under_names_of_their_own() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let mut first = AtomicFile::create(&path, 16).unwrap();
        let mut second = AtomicFile::create(&path, 16).unwrap();
        assert_ne!(first.temp, second.temp);
        first.write_all(b"first, whole\n").unwrap();
        second.write_all(b"second, whole\n").unwrap();
        first.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "first, whole\n");
        second.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second, whole\n");
        assert_eq!(names(dir.path()), ["out.csv"]);
    }

    /// A target that is not a regular file is never renamed over: a device is written
    /// directly (`/dev/null` stays a device), a socket refuses to be opened and stays, a folder
    /// is refused.
    #[cfg(unix)]
    #[test]
    fn devices_sockets_and_folders_are_not_replaced_by_a_file() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        let mut file = AtomicFile::create(null, 16).unwrap();
        file.write_all(b"discarded\n").unwrap();
        file.commit().unwrap();
        assert!(std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device());
        let dir = tempfile::tempdir().unwrap();
        let socket = dir.path().join("out.sock");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        assert!(AtomicFile::create(&socket, 16).is_err());
        assert!(std::fs::metadata(&socket).unwrap().file_type().is_socket());
        let error = AtomicFile::create(dir.path(), 16)
            .err()
            .unwrap()
            .to_string();
        assert!(error.ends_with("cannot write: it is a folder"), "{error}");
        assert_eq!(names(dir.path()), ["out.sock"]);
    }

    #[test]
    fn a_file_dropped_unfinished_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let mut file = AtomicFile::create(&path, 16).unwrap();
        file.write_all(&[b'x'; 100]).unwrap();
        drop(file);
        assert!(names(dir.path()).is_empty());
    }

    #[test]
    fn an_input_of_the_run_is_never_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.csv");
        std::fs::write(&path, "X,Y,Z\n").unwrap();
        super::super::source::read_text(&path).unwrap();
        let error = AtomicFile::create(&dir.path().join(".").join("in.csv"), 16)
            .err()
            .unwrap();
        assert!(
            error.to_string().contains("an input of this run"),
            "{error}"
        );
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "X,Y,Z\n");
        assert_eq!(names(dir.path()), ["in.csv"]);
    }

    #[test]
    fn stale_names_are_read_as_the_process_that_wrote_them() {
        let pid = |file_name: &str| writer_of(file_name, "out.csv");
        assert_eq!(pid(&temporary_name("out.csv", 4242)), Some(4242));
        assert_eq!(pid(".out.csv.4242.part"), Some(4242));
        // The temporary file of `out.csv.99` belongs to another output.
        assert_eq!(pid(".out.csv.99.4242.0.part"), None);
    }
}
