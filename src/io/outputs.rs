//! The outputs of a run: what volmap may write to (checked before any work, [`check_writable`]),
//! where a file is written when its name is a symbolic link ([`target_of`]), and, for a run that
//! asks it ([`hold_commits`]: the command line does), every output held complete under its
//! temporary name until the run ends, then put in place together ([`commit_held`]) or removed
//! together ([`discard_held`]): a run that fails on its last output has replaced none of the
//! earlier ones.
//!
//! What volmap does with an existing output:
//! - a regular file the user could write is replaced whole (written beside it, then renamed);
//! - a regular file the user could not write (`chmod 400`, another user's) is refused, as a
//!   shell's redirection refuses it: volmap never replaces a file its user could not write;
//! - a symbolic link is followed: the file it points to is replaced and the link stays, as a
//!   shell's redirection writes through it; a link to nothing is refused;
//! - a device or a pipe (`/dev/null`, `/dev/stdout`) is written directly, never replaced;
//! - a folder is refused.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use super::FileError;

/// An output refused before anything is written (bad input: exit code 2).
fn refused(path: &Path, why: String) -> FileError {
    FileError::write(
        path,
        std::io::Error::new(std::io::ErrorKind::InvalidInput, why),
    )
}

/// The folder a file at `path` lies in (`.` for a bare file name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The file a write to `path` replaces: `path` itself, or where the symbolic link `path` leads
/// (links of links followed). A link to nothing is refused.
pub fn target_of(path: &Path) -> Result<PathBuf, FileError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path).map_err(|_| {
            let to = std::fs::read_link(path).unwrap_or_default();
            refused(
                path,
                format!(
                    "a symbolic link to `{}`, which does not exist: volmap writes through a link only to a file that is there",
                    super::shown_path(&to)
                ),
            )
        }),
        _ => Ok(path.to_path_buf()),
    }
}

/// Checks, before any work, that `path` can be written as an output: its folder exists, it is not
/// a folder, a link to nothing, or a file the user could not write. The file a write replaces
/// ([`target_of`]).
pub fn check_writable(path: &Path) -> Result<PathBuf, FileError> {
    let target = target_of(path)?;
    if let Ok(metadata) = std::fs::metadata(&target) {
        if metadata.is_dir() {
            return Err(FileError::write(
                path,
                std::io::Error::new(std::io::ErrorKind::IsADirectory, "it is a folder"),
            ));
        }
        if metadata.is_file() && !user_may_write(&target, &metadata) {
            return Err(refused(
                path,
                "it is write-protected: volmap replaces only a file its user could write (make it writable, or name another)"
                    .to_string(),
            ));
        }
        if !metadata.is_file() {
            return Ok(target);
        }
    }
    let folder = folder_of(&target);
    if !folder.is_dir() {
        return Err(refused(
            path,
            format!("its folder `{}` does not exist", super::shown_path(folder)),
        ));
    }
    Ok(target)
}

/// Whether the user could write the existing file `path`: it has a write permission for
/// someone (the administrator's account can write any file, but a file nobody may write is one
/// its owner protected), and the system grants this process writing it.
fn user_may_write(path: &Path, metadata: &std::fs::Metadata) -> bool {
    if metadata.permissions().readonly() {
        return false;
    }
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let Ok(name) = std::ffi::CString::new(path.as_os_str().as_bytes()) else {
            return true;
        };
        // SAFETY: `name` is a NUL-terminated path; access only reads it.
        unsafe { libc::access(name.as_ptr(), libc::W_OK) == 0 }
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        true
    }
}

/// Whether completed outputs are held until the run ends.
static HOLD: AtomicBool = AtomicBool::new(false);

/// The completed outputs held: (temporary file, the name it will have).
fn held() -> std::sync::MutexGuard<'static, Vec<(PathBuf, PathBuf)>> {
    static HELD: Mutex<Vec<(PathBuf, PathBuf)>> = Mutex::new(Vec::new());
    HELD.lock().unwrap_or_else(|p| p.into_inner())
}

/// From now on, every output completed is held under its temporary name until
/// [`commit_held`] or [`discard_held`].
pub fn hold_commits() {
    HOLD.store(true, Ordering::SeqCst);
}

/// Holds the completed `temp` (to become `path`) where outputs are held; `false` where they are
/// not (the caller renames it now).
pub(super) fn hold(temp: &Path, path: &Path) -> bool {
    if !HOLD.load(Ordering::SeqCst) || super::atomic::in_scratch(path) {
        return false;
    }
    let mut held = held();
    // A second output to one name (refused by the command line) replaces the first.
    if let Some(k) = held.iter().position(|(_, p)| p == path) {
        let (old, _) = held.remove(k);
        let _ = std::fs::remove_file(&old);
        super::atomic::forget(&old);
    }
    held.push((temp.to_path_buf(), path.to_path_buf()));
    true
}

/// The temporary file holding the output `path` completed by this run, if one is held: a run
/// that reads what it wrote (a machine file checked as every command will read it) reads it
/// there.
pub fn held_temporary(path: &Path) -> Option<PathBuf> {
    let held = held();
    if held.is_empty() {
        return None;
    }
    let identity = super::source::Identity::of_named(path);
    held.iter()
        .find(|(_, p)| super::source::Identity::of_named(p).is(&identity))
        .map(|(t, _)| t.clone())
}

/// Puts every held output in place, in the order they were completed; the names put in place.
/// A rename that fails (the disk gone) removes the outputs not yet in place and says which.
pub fn commit_held() -> Result<Vec<PathBuf>, FileError> {
    let outputs: Vec<(PathBuf, PathBuf)> = held().drain(..).collect();
    let mut done = Vec::new();
    for (k, (temp, path)) in outputs.iter().enumerate() {
        if let Err(e) = std::fs::rename(temp, path) {
            for (rest, _) in &outputs[k..] {
                let _ = std::fs::remove_file(rest);
                super::atomic::forget(rest);
            }
            return Err(FileError::write(path, e));
        }
        super::atomic::forget(temp);
        done.push(path.clone());
    }
    Ok(done)
}

/// Removes every held output: the run failed, and none of its outputs replaces anything.
pub fn discard_held() {
    for (temp, _) in held().drain(..) {
        let _ = std::fs::remove_file(&temp);
        super::atomic::forget(&temp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_lead_to_their_file_and_a_link_to_nothing_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("real.csv");
        std::fs::write(&file, "old").unwrap();
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&file, &link).unwrap();
            assert_eq!(
                target_of(&link).unwrap(),
                std::fs::canonicalize(&file).unwrap()
            );
            let dangling = dir.path().join("dangling.csv");
            std::os::unix::fs::symlink(dir.path().join("none"), &dangling).unwrap();
            let message = target_of(&dangling).unwrap_err().to_string();
            assert!(message.contains("which does not exist"), "{message}");
            assert!(check_writable(&dangling).is_err());
        }
        assert_eq!(target_of(&file).unwrap(), file);
        assert_eq!(check_writable(&file).unwrap(), file);
        let message = check_writable(&dir.path().join("no/x.csv"))
            .unwrap_err()
            .to_string();
        assert!(message.contains("does not exist"), "{message}");
        let mut permissions = std::fs::metadata(&file).unwrap().permissions();
        permissions.set_readonly(true);
        std::fs::set_permissions(&file, permissions).unwrap();
        let message = check_writable(&file).unwrap_err().to_string();
        assert!(message.contains("write-protected"), "{message}");
    }
}
