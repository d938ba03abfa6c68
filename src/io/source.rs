//! The files a run reads, its sources (not a machine's evaluation inputs, which are
//! [`crate::model::inputs`]): every file volmap reads goes through here, whole with a size bound
//! per kind ([`read_text`], [`read_bytes`]) or streamed a line at a time with a bound on each line
//! ([`open_stream`]), so that no source (a device such as `/dev/zero`, a file of one endless line)
//! reads until memory runs out.
//!
//! Every file read is also noted as a source of the run: [`check_not_source`] (which every
//! writer of `io::atomic` asks before it starts) refuses to write over any of them, so no output
//! of a run replaces one of its own sources.
//!
//! Files a source names (the CSV tables of a machine file or a fit file) are confined to the
//! folder of the file that names them, and below it, unless the caller allows more
//! ([`Reach`], [`confined`]).

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::FileError;

/// The most bytes a text input may hold: machine files and their CSV tables, part files, fit
/// files and their measured CSV files, tolerance files, work offset files.
pub const TEXT_LIMIT_BYTES: u64 = 64 << 20;

/// The most bytes an NC program may hold.
pub const PROGRAM_LIMIT_BYTES: u64 = 256 << 20;

/// The most bytes an STL mesh may hold (about 10 million triangles in binary STL).
pub const MESH_LIMIT_BYTES: u64 = 512 << 20;

/// The most bytes one line of a streamed input (a points CSV) may hold.
pub const LINE_LIMIT_BYTES: usize = 64 << 10;

/// The kind of a file read whole, which sets its size bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceKind {
    /// A text file: [`TEXT_LIMIT_BYTES`].
    Text,
    /// An NC program: [`PROGRAM_LIMIT_BYTES`].
    Program,
    /// An STL mesh: [`MESH_LIMIT_BYTES`].
    Mesh,
}

impl SourceKind {
    /// The most bytes a file of this kind may hold.
    pub const fn limit_bytes(self) -> u64 {
        match self {
            SourceKind::Text => TEXT_LIMIT_BYTES,
            SourceKind::Program => PROGRAM_LIMIT_BYTES,
            SourceKind::Mesh => MESH_LIMIT_BYTES,
        }
    }

    /// What the limit is for, in messages.
    pub const fn name(self) -> &'static str {
        match self {
            SourceKind::Text => "a text input",
            SourceKind::Program => "an NC program",
            SourceKind::Mesh => "an STL mesh",
        }
    }
}

/// A byte count as people read it: `64 MiB`, `64 KiB`.
pub fn describe_bytes(bytes: u64) -> String {
    match bytes {
        b if b >= 1 << 20 && b % (1 << 20) == 0 => format!("{} MiB", b >> 20),
        b if b >= 1 << 10 && b % (1 << 10) == 0 => format!("{} KiB", b >> 10),
        b => format!("{b} bytes"),
    }
}

/// The UTF-8 byte-order mark some editors on Windows put first in a text file.
const BYTE_ORDER_MARK: &[u8] = b"\xEF\xBB\xBF";

/// `bytes` without a leading UTF-8 byte-order mark.
pub fn without_byte_order_mark(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(BYTE_ORDER_MARK).unwrap_or(bytes)
}

/// Reads a whole file of `kind`, at most its limit; a leading byte-order mark is kept (binary
/// files have none to drop; text readers drop it).
pub fn read_bytes(path: &Path, kind: SourceKind) -> Result<Vec<u8>, FileError> {
    refuse_special(path)?;
    let file = open(path)?;
    let limit = kind.limit_bytes();
    if file
        .metadata()
        .is_ok_and(|m| m.is_file() && m.len() > limit)
    {
        return Err(FileError::too_large(path, kind));
    }
    read_rest(file, path, kind, Vec::new())
}

/// The rest of `file` after `bytes` (read from it already), within the limit of `kind`.
pub fn read_rest(
    file: File,
    path: &Path,
    kind: SourceKind,
    mut bytes: Vec<u8>,
) -> Result<Vec<u8>, FileError> {
    let limit = kind.limit_bytes();
    // Read in pieces and stop before the limit is passed: `read_to_end` of `limit + 1` bytes
    // doubles its buffer to twice the limit at the last byte (a device that never ends, such
    // as /dev/zero, made a mesh's 512 MiB limit a 1 GiB allocation).
    let mut file = file;
    let mut piece = vec![0u8; 1 << 16];
    loop {
        let n = match file.read(&mut piece) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(FileError::read(path, e)),
        };
        if (bytes.len() + n) as u64 > limit {
            return Err(FileError::too_large(path, kind));
        }
        bytes.extend_from_slice(&piece[..n]);
    }
    Ok(bytes)
}

/// Reads a whole text file ([`SourceKind::Text`]) as UTF-8, without a leading byte-order mark.
pub fn read_text(path: &Path) -> Result<String, FileError> {
    let mut bytes = read_bytes(path, SourceKind::Text)?;
    if bytes.starts_with(BYTE_ORDER_MARK) {
        bytes.drain(..BYTE_ORDER_MARK.len());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = before
            .rsplit(|&b| b == b'\n')
            .next()
            .map_or(0, |l| String::from_utf8_lossy(l).chars().count())
            + 1;
        FileError::read(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("line {line}, column {column}: not UTF-8 text (byte {at} of the file)"),
            ),
        )
    })
}

/// Opens a file to be read a line at a time (lines of at most [`LINE_LIMIT_BYTES`]: the
/// reader's to check), noting it as an input of the run.
pub fn open_stream(path: &Path) -> Result<File, FileError> {
    open(path)
}

/// Opens `path` for reading and notes it as an input.
fn open(path: &Path) -> Result<File, FileError> {
    let file = open_file(path)?;
    note_source(path);
    Ok(file)
}

/// Opens `path` for reading, a folder refused as one, without noting it as an input (field
/// files, which their readers note where a run writes beside them).
pub fn open_file(path: &Path) -> Result<File, FileError> {
    // What this run wrote and holds until it ends is read where it is held.
    if let Some(temp) = super::outputs::held_temporary(path) {
        return File::open(&temp).map_err(|e| FileError::read(path, e));
    }
    check_not_output(path)?;
    let file = File::open(path).map_err(|e| FileError::read(path, e))?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(FileError::read(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "a folder, not a file"),
        ));
    }
    Ok(file)
}

/// What identifies a file whatever path names it: its canonical path, and on Unix its device
/// and inode (a hard link has another path but the same inode).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Identity {
    canonical: PathBuf,
    inode: Option<(u64, u64)>,
}

impl Identity {
    /// The identity of an existing file, `None` for a path that names nothing.
    pub fn of(path: &Path) -> Option<Identity> {
        let canonical = std::fs::canonicalize(path).ok()?;
        Some(Identity {
            inode: inode(&canonical),
            canonical,
        })
    }

    /// The identity of a file that may not exist yet (an output): where it does not, its
    /// folder's canonical path joined to its name, without an inode.
    pub fn of_named(path: &Path) -> Identity {
        Identity::of(path).unwrap_or_else(|| {
            let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
            let canonical = match (absolute.parent(), absolute.file_name()) {
                (Some(folder), Some(name)) => std::fs::canonicalize(folder)
                    .map(|f| f.join(name))
                    .unwrap_or_else(|_| absolute.clone()),
                _ => absolute.clone(),
            };
            Identity {
                canonical,
                inode: None,
            }
        })
    }

    /// Whether both name one file: one canonical path, or one inode.
    pub fn is(&self, other: &Identity) -> bool {
        self.canonical == other.canonical || (self.inode.is_some() && self.inode == other.inode)
    }

    /// Whether the file read is still where it was read: a file deleted since may have left
    /// its inode to another.
    fn still_there(&self) -> bool {
        inode(&self.canonical) == self.inode
    }
}

/// The device and inode of the file at `path` (a hard link shares them); `None` where it does not
/// exist, or off Unix.
#[cfg(unix)]
fn inode(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn inode(_path: &Path) -> Option<(u64, u64)> {
    None
}

/// The files read so far by this process: the path as named and what it is.
fn inputs() -> std::sync::MutexGuard<'static, Vec<(PathBuf, Identity)>> {
    static INPUTS: Mutex<Vec<(PathBuf, Identity)>> = Mutex::new(Vec::new());
    INPUTS.lock().unwrap_or_else(|p| p.into_inner())
}

/// Notes `path` as an input of this run (for readers outside this module, such as field files).
pub fn note_source(path: &Path) {
    if let Some(identity) = Identity::of(path) {
        let mut inputs = inputs();
        inputs.retain(|(_, i)| i.still_there());
        if !inputs.iter().any(|(_, i)| i.is(&identity)) {
            inputs.push((path.to_path_buf(), identity));
        }
    }
}

/// The outputs this run will write, as the command line declared them before any work.
fn outputs() -> std::sync::MutexGuard<'static, Vec<(PathBuf, Identity)>> {
    static OUTPUTS: Mutex<Vec<(PathBuf, Identity)>> = Mutex::new(Vec::new());
    OUTPUTS.lock().unwrap_or_else(|p| p.into_inner())
}

/// Notes `path` as an output this run will write: reading it as an input later is refused
/// ([`check_not_output`]), before the work rather than when the output is written.
pub fn note_output(path: &Path) {
    outputs().push((path.to_path_buf(), Identity::of_named(path)));
}

/// Refuses to read `path` when it is an existing file this run is to write.
fn check_not_output(path: &Path) -> Result<(), FileError> {
    let Some(identity) = Identity::of(path) else {
        return Ok(());
    };
    if let Some((output, _)) = outputs().iter().find(|(_, o)| o.is(&identity)) {
        return Err(FileError::ReadsOutput {
            path: super::shown_path(path),
            output: super::shown_path(output),
        });
    }
    Ok(())
}

/// Refuses a pipe, a socket or a block device where a file is read whole or by seeking (every
/// input but the streamed ones: points, meshes): opening a pipe nobody writes (a FIFO named as a
/// machine's table) waits for ever, and a field is read by seeking. A shell's `<(…)` is a pipe
/// too: save the data to a file first. Character devices are read up to the size bound
/// (`/dev/zero` is refused when it passes it).
pub fn refuse_special(path: &Path) -> Result<(), FileError> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if let Ok(metadata) = std::fs::metadata(path) {
            let kind = metadata.file_type();
            let what = if kind.is_fifo() {
                "a pipe (FIFO)"
            } else if kind.is_socket() {
                "a socket"
            } else if kind.is_block_device() {
                "a block device"
            } else {
                return Ok(());
            };
            return Err(FileError::read(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("{what}, not a file: volmap reads inputs from regular files"),
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses `path` as an output when it is a file this run has read: an output never replaces
/// one of the run's inputs.
pub fn check_not_source(path: &Path) -> Result<(), FileError> {
    let Some(identity) = Identity::of(path) else {
        return Ok(());
    };
    match inputs()
        .iter()
        .find(|(_, i)| i.still_there() && i.is(&identity))
    {
        Some((input, _)) => Err(FileError::OverwritesInput {
            path: path.display().to_string(),
            input: input.display().to_string(),
        }),
        None => Ok(()),
    }
}

/// Where the files an input names may lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Reach {
    /// In the folder of the file that names them, or below it.
    #[default]
    Folder,
    /// Anywhere the user can read.
    Anywhere,
}

/// `name` (as written in the file at `folder`) joined to `folder`, refused where it lies outside
/// `folder` and `reach` does not allow that. Links are followed: a link in the folder to a file
/// outside it lies outside.
pub fn confined(folder: &Path, name: &Path, reach: Reach) -> Result<PathBuf, FileError> {
    let path = folder.join(name);
    if reach == Reach::Anywhere {
        return Ok(path);
    }
    let folder_for_canonical = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let inside = match (
        std::fs::canonicalize(folder_for_canonical),
        std::fs::canonicalize(&path),
    ) {
        (Ok(f), Ok(p)) => p.starts_with(f),
        // A file that does not exist is reported missing by its reader; judge it by its name.
        (_, Err(_)) => lexically_inside(name),
        (Err(_), Ok(_)) => false,
    };
    if inside {
        refuse_special(&path)?;
        Ok(path)
    } else {
        Err(FileError::OutsideFolder {
            name: crate::error::excerpt(&name.display().to_string()).into_owned(),
            folder: folder_for_canonical.display().to_string(),
        })
    }
}

/// Whether a relative name stays in its folder by its components alone (`a/../b` does,
/// `../b` and `/b` do not).
fn lexically_inside(name: &Path) -> bool {
    use std::path::Component;
    let mut depth = 0usize;
    for component in name.components() {
        match component {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir => match depth.checked_sub(1) {
                Some(d) => depth = d,
                None => return false,
            },
            Component::RootDir | Component::Prefix(_) => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_as_people_write_them() {
        assert_eq!(describe_bytes(TEXT_LIMIT_BYTES), "64 MiB");
        assert_eq!(describe_bytes(LINE_LIMIT_BYTES as u64), "64 KiB");
        assert_eq!(describe_bytes(1000), "1000 bytes");
    }

    #[test]
    fn names_stay_inside_by_their_components() {
        assert!(lexically_inside(Path::new("t.csv")));
        assert!(lexically_inside(Path::new("a/../t.csv")));
        assert!(lexically_inside(Path::new("./a/t.csv")));
        assert!(!lexically_inside(Path::new("../t.csv")));
        assert!(!lexically_inside(Path::new("a/../../t.csv")));
        assert!(!lexically_inside(Path::new("/etc/passwd")));
    }
}
