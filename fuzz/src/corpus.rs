//! The seed corpus of each target (`tests/fuzz-corpus/<target>/`, small files from `examples/`,
//! `machines/` and the tests), and inputs that are several files at once.
//!
//! A target that reads a file naming other files (a machine file and its CSV tables, a fit file
//! and its measured CSV files, a part file and its mesh) takes them in one input: the main file
//! first, then each other file after a line `#=== NAME` (a comment to TOML), so that mutations
//! reach every file and splices move lines between them.

use std::path::{Path, PathBuf};

/// The line that starts another file of an input.
pub const FILE_MARK: &[u8] = b"#=== ";

/// The folder of `target`'s seed corpus.
pub fn folder(target: &str) -> PathBuf {
    crate::checkout()
        .join("tests")
        .join("fuzz-corpus")
        .join(target)
}

/// Every file of `target`'s corpus, in the order of their names.
pub fn load(target: &str) -> std::io::Result<Vec<Vec<u8>>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(folder(target))?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    paths.retain(|p| p.is_file());
    paths.sort();
    paths.iter().map(std::fs::read).collect()
}

/// Whether `name` may name a file of an input: a plain name, no folder, no leading dot.
fn plain_name(name: &[u8]) -> bool {
    (1..=40).contains(&name.len())
        && name[0] != b'.'
        && name
            .iter()
            .all(|&b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
}

/// An input's files: the main file, then `(name, bytes)` of each other file in order.
pub fn split(input: &[u8]) -> (&[u8], Vec<(&str, &[u8])>) {
    let mut starts: Vec<(usize, usize, &str)> = Vec::new(); // (mark start, content start, name)
    let mut at = 0;
    while at < input.len() {
        let end = input[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(input.len(), |p| at + p + 1);
        let line = &input[at..end];
        if let Some(rest) = line.strip_prefix(FILE_MARK) {
            let name = rest.strip_suffix(b"\n").unwrap_or(rest);
            let name = name.strip_suffix(b"\r").unwrap_or(name);
            if plain_name(name) {
                // SAFETY of the unwrap: a plain name is ASCII.
                starts.push((at, end, std::str::from_utf8(name).unwrap()));
            }
        }
        at = end;
    }
    let main_end = starts.first().map_or(input.len(), |s| s.0);
    let files = starts
        .iter()
        .enumerate()
        .map(|(n, &(_, content, name))| {
            let end = starts.get(n + 1).map_or(input.len(), |s| s.0);
            (name, &input[content..end])
        })
        .collect();
    (&input[..main_end], files)
}

/// A folder the targets write their files in, cleared of the last execution's files before
/// each execution writes its own.
pub struct Scratch {
    dir: tempfile::TempDir,
    written: Vec<PathBuf>,
}

impl Scratch {
    pub fn new() -> std::io::Result<Scratch> {
        Ok(Scratch {
            dir: tempfile::Builder::new().prefix("volmap-fuzz-").tempdir()?,
            written: Vec::new(),
        })
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Writes `files` (`(name, bytes)`), after removing those of the last execution; the path of
    /// each, in order. A name given twice is written once, with its last bytes.
    pub fn write(&mut self, files: &[(&str, &[u8])]) -> std::io::Result<Vec<PathBuf>> {
        for path in self.written.drain(..) {
            let _ = std::fs::remove_file(path);
        }
        let mut paths = Vec::with_capacity(files.len());
        for (name, bytes) in files {
            let path = self.dir.path().join(name);
            std::fs::write(&path, bytes)?;
            self.written.push(path.clone());
            paths.push(path);
        }
        Ok(paths)
    }
}
