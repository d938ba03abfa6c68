//! What a file system holds: the free space of the folder an output goes into, and whether an
//! output is a device or a pipe (written directly, whatever its name).

use std::path::Path;

/// The bytes an unprivileged process may still write in the file system of `folder` (`None`
/// where the system does not say, or off Unix).
pub fn free_bytes(folder: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let folder = if folder.as_os_str().is_empty() {
            Path::new(".")
        } else {
            folder
        };
        let name = std::ffi::CString::new(folder.as_os_str().as_bytes()).ok()?;
        let mut stats: libc::statvfs = unsafe { std::mem::zeroed() };
        // SAFETY: `name` is a NUL-terminated path and `stats` a writable statvfs.
        if unsafe { libc::statvfs(name.as_ptr(), &mut stats) } != 0 {
            return None;
        }
        Some((stats.f_bavail as u64).saturating_mul(stats.f_frsize as u64))
    }
    #[cfg(not(unix))]
    {
        let _ = folder;
        None
    }
}

/// Whether `path` names an existing device or pipe (not a regular file or a folder).
pub fn is_device(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_has_free_space_and_dev_null_is_a_device() {
        assert!(free_bytes(Path::new(".")).is_some_and(|b| b > 0));
        #[cfg(unix)]
        assert!(is_device(Path::new("/dev/null")));
        assert!(!is_device(Path::new(".")));
    }
}
