//! Machine files written into another folder than their base: the CSV tables the base names
//! must still be found, with no flag. A machine file's `csv = "PATH"` is relative to the file's
//! own folder and must lie in it or below (docs/model.md), so a file that `fit` or `build` writes
//! elsewhere names each table the base names from its own folder where the table lies there or
//! below, and otherwise names a copy in the folder `NAME.tables/` beside it (`NAME` the file's
//! stem), which the command line writes: the written file stands alone, the base untouched.

use std::path::{Component, Path, PathBuf};

use toml_edit::visit_mut::{self, VisitMut};
use toml_edit::{DocumentMut, Item, KeyMut};

use super::CalibrateError;
use crate::model::Machine;

/// A machine file derived from a base, with its tables named for its own folder.
#[derive(Debug, Clone, PartialEq)]
pub struct Rebased {
    pub text: String,
    /// The tables to copy: the base's file, and the path of its copy relative to the new
    /// file's folder (`NAME.tables/FILE.csv`).
    pub copies: Vec<(PathBuf, String)>,
}

/// `text`, a machine file derived from `base`, written as `out` (a file in its folder): every
/// relative CSV path rewritten for `out`'s folder where the table lies in it or below, and
/// every other table (relative or absolute) named as a copy in `NAME.tables/`. A base read from
/// text (an embedded machine) has inline tables only and is returned as it is.
pub fn rebase_tables(text: &str, base: &Machine, out: &Path) -> Result<Rebased, CalibrateError> {
    let Some(from) = &base.source.folder else {
        return Ok(Rebased {
            text: text.to_string(),
            copies: Vec::new(),
        });
    };
    let mut document: DocumentMut = text.parse().map_err(|e| {
        CalibrateError::Parameter(format!("the machine file does not parse again: {e}"))
    })?;
    let folder = out.parent().unwrap_or(Path::new(""));
    let stem = out
        .file_stem()
        .map_or("machine".to_string(), |s| s.to_string_lossy().into_owned());
    let mut rebase = Rebase {
        from: absolute(from)?,
        to: absolute(folder)?,
        tables_folder: format!("{stem}.tables"),
        copies: Vec::new(),
    };
    rebase.visit_document_mut(&mut document);
    Ok(Rebased {
        text: document.to_string(),
        copies: rebase.copies,
    })
}

struct Rebase {
    from: PathBuf,
    to: PathBuf,
    tables_folder: String,
    copies: Vec<(PathBuf, String)>,
}

impl Rebase {
    /// The name the new file gives the table at `source` (absolute): its path from the new
    /// folder where it lies there or below, else its copy's (one copy per table, names kept
    /// apart by a number where two tables share a file name).
    fn name_for(&mut self, source: PathBuf) -> String {
        let moved = relative_path(&source, &self.to);
        let below = moved.is_relative()
            && !moved
                .components()
                .any(|c| matches!(c, Component::ParentDir));
        if below {
            return moved.to_string_lossy().replace('\\', "/");
        }
        if let Some((_, name)) = self.copies.iter().find(|(s, _)| *s == source) {
            return name.clone();
        }
        let file = source.file_name().map_or("table.csv".to_string(), |f| {
            f.to_string_lossy().into_owned()
        });
        let mut name = format!("{}/{file}", self.tables_folder);
        let mut n = 2;
        while self.copies.iter().any(|(_, taken)| *taken == name) {
            name = format!("{}/{n}-{file}", self.tables_folder);
            n += 1;
        }
        self.copies.push((source, name.clone()));
        name
    }
}

impl VisitMut for Rebase {
    fn visit_table_like_kv_mut(&mut self, key: KeyMut<'_>, node: &mut Item) {
        if key.get() == "csv" {
            if let Some(value) = node.as_value_mut() {
                if let Some(path) = value.as_str() {
                    let source = lexical(&self.from.join(Path::new(path)));
                    let named = self.name_for(source);
                    let decor = value.decor().clone();
                    *value = named.into();
                    *value.decor_mut() = decor;
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
