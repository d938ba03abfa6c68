//! Machine files written into another folder than their base: the CSV tables the base names
//! must still be found. A machine file's `csv = "PATH"` is relative to the file's own folder
//! (docs/model.md), so a file that `fit` or `build` writes elsewhere gets every relative PATH
//! rewritten relative to its own folder; absolute paths stay as they are.

use std::path::{Component, Path, PathBuf};

use toml_edit::visit_mut::{self, VisitMut};
use toml_edit::{DocumentMut, Item, KeyMut};

use super::CalibrateError;
use crate::model::Machine;

/// `text`, a machine file derived from `base`, with every relative CSV path rewritten for a file
/// in `out_folder`. A base read from text (an embedded machine) has inline tables only and is
/// returned as it is.
pub fn rebase_tables(
    text: &str,
    base: &Machine,
    out_folder: &Path,
) -> Result<String, CalibrateError> {
    let Some(from) = &base.source.folder else {
        return Ok(text.to_string());
    };
    let mut document: DocumentMut = text.parse().map_err(|e| {
        CalibrateError::Parameter(format!("the machine file does not parse again: {e}"))
    })?;
    let to = absolute(out_folder)?;
    let mut rebase = Rebase {
        from: absolute(from)?,
        to,
        failure: None,
    };
    rebase.visit_document_mut(&mut document);
    match rebase.failure {
        Some(failure) => Err(failure),
        None => Ok(document.to_string()),
    }
}

struct Rebase {
    from: PathBuf,
    to: PathBuf,
    failure: Option<CalibrateError>,
}

impl VisitMut for Rebase {
    fn visit_table_like_kv_mut(&mut self, key: KeyMut<'_>, node: &mut Item) {
        if key.get() == "csv" {
            if let Some(value) = node.as_value_mut() {
                if let Some(path) = value.as_str() {
                    let path = Path::new(path);
                    if path.is_relative() {
                        let moved = relative_path(&lexical(&self.from.join(path)), &self.to);
                        let decor = value.decor().clone();
                        *value = moved.to_string_lossy().replace('\\', "/").into();
                        *value.decor_mut() = decor;
                    }
                }
            }
            return;
        }
        visit_mut::visit_table_like_kv_mut(self, key, node);
    }
}

/// `path` made absolute against the working directory, with `.` and `..` resolved by name.
fn absolute(path: &Path) -> Result<PathBuf, CalibrateError> {
    let path = if path.as_os_str().is_empty() {
        Path::new(".")
    } else {
        path
    };
    std::path::absolute(path)
        .map(|p| lexical(&p))
        .map_err(|e| CalibrateError::Parameter(format!("{}: {e}", path.display())))
}

/// `path` with `.` and `..` components resolved by name (a `..` at the root stays at the root).
fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push(component);
                }
            }
            other => out.push(other),
        }
    }
    out
}

/// The path of `target` seen from `folder`, both absolute and lexical: `..` up to their common
/// ancestor, then down to `target`. Paths on different roots (Windows drives) stay absolute.
fn relative_path(target: &Path, folder: &Path) -> PathBuf {
    let target_parts: Vec<Component> = target.components().collect();
    let folder_parts: Vec<Component> = folder.components().collect();
    let common = target_parts
        .iter()
        .zip(&folder_parts)
        .take_while(|(a, b)| a == b)
        .count();
    if common == 0 {
        return target.to_path_buf();
    }
    let mut out = PathBuf::new();
    for _ in common..folder_parts.len() {
        out.push("..");
    }
    for part in &target_parts[common..] {
        out.push(part);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_to_the_common_folder() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(relative_path(&p("/a/b/t.csv"), &p("/a/b")), p("t.csv"));
        assert_eq!(
            relative_path(&p("/a/b/t.csv"), &p("/a/c/d")),
            p("../../b/t.csv")
        );
        assert_eq!(relative_path(&p("/a/t.csv"), &p("/a/b")), p("../t.csv"));
        assert_eq!(lexical(&p("/a/b/../c/./t.csv")), p("/a/c/t.csv"));
    }
}
