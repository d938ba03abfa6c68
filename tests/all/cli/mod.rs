//! The `volmap` binary as a user runs it: command by command (`map`, `sample`, `features`,
//! `compensate`, …), then what holds across commands (`outputs`, `input_files`, `messages`,
//! `flag_values`, `machine_values`), and the inputs every command refuses as one table
//! (`refusals`).

mod compensate;
mod compensate_check;
mod compensate_orientation;
mod compensate_tcpm;
mod design;
mod evaluation_inputs;
mod export;
mod export_fanuc;
mod export_uncertainty;
mod features;
mod features_uncertainty;
mod field_files;
mod fit_uncertainty;
mod flag_values;
mod input_files;
mod interrupt;
mod json;
mod limits_budget;
mod limits_grid;
mod limits_nc;
mod limits_outputs;
mod limits_toml;
mod machine_files;
mod machine_files_tables;
mod machine_values;
mod machines;
mod map;
mod map_check;
mod map_uncertainty;
mod messages;
mod outputs;
mod plot;
mod profile_datums;
mod query;
mod refusals;
mod sample;
mod sample_uncertainty;
mod shards;
mod shell;
mod standards;
mod standards_frames;
mod sweep;
mod test_uncertainty;
mod trace;
mod uncertainty;
mod view;

use std::path::Path;

use assert_cmd::Command;
use predicates::prelude::*;

pub fn volmap() -> Command {
    Command::cargo_bin("volmap").unwrap()
}

/// volmap run under the shell's `ulimit LIMIT` (`-v KIB`: its address space, where an allocation
/// beyond it fails and the run aborts instead of succeeding; `-f BLOCKS`: the size of a file it
/// writes).
pub fn volmap_under(limit: &str) -> Command {
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("ulimit {limit} && exec \"$0\" \"$@\""))
        .arg(assert_cmd::cargo::cargo_bin("volmap"));
    command
}

/// Runs volmap with `args` in `dir`: exit code 2 with every one of `says` on stderr, which it
/// returns.
pub fn refused(args: &[&str], dir: &std::path::Path, says: &[&str]) -> String {
    let output = volmap().args(args).current_dir(dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    for s in says {
        assert!(stderr.contains(s), "{args:?}: `{s}` not in: {stderr}");
    }
    stderr
}

/// Runs volmap with `args` in `dir`: success with no error on stderr; its stdout.
pub fn succeeds(args: &[&str], dir: &std::path::Path) -> String {
    let output = volmap().args(args).current_dir(dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{args:?}: {stderr}");
    assert!(!stderr.contains("error"), "{args:?}: {stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// A path as the `&str` an argument list takes.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `base` then `extra`.
pub fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
    base.iter().chain(extra).copied().collect()
}

/// Arguments built as `String`s, as `volmap().args` takes them.
pub fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Exit code 2, the error naming each of `named`, and no panic.
pub fn assert_refused(cmd: &mut assert_cmd::Command, named: &[&str]) {
    let output = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    for n in named {
        assert!(stderr.contains(n), "`{n}` not named in {stderr}");
    }
}

/// The embedded example machine's file with the line of `key` replaced by `line`.
pub fn machine_with(
    dir: &std::path::Path,
    name: &str,
    key: &str,
    line: &str,
) -> std::path::PathBuf {
    let output = volmap()
        .args(["machines", "--show", "vmc-li2015"])
        .output()
        .unwrap();
    let text = String::from_utf8(output.stdout).unwrap();
    let prefix = format!("{key} = ");
    assert!(text.lines().any(|l| l.starts_with(&prefix)), "{key}");
    let changed: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with(&prefix) {
                line.to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    let path = dir.join(name);
    std::fs::write(&path, changed.join("\n")).unwrap();
    path
}

/// The temporary files (`.NAME.PID.part`) in `dir`.
pub fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".part"))
        .collect()
}

/// An SVG written by a command: no NaN or infinity anywhere, no label longer than 16 characters.
pub fn assert_finite_svg(path: &Path) {
    let svg = std::fs::read_to_string(path).unwrap();
    let words = svg.split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '.'));
    for word in words {
        let word = word.trim_start_matches('-');
        assert!(word != "NaN" && word != "inf", "{path:?}: {word}");
    }
    for label in svg.split("<text").skip(1) {
        let text = label.split('>').nth(1).unwrap().split('<').next().unwrap();
        if text.parse::<f64>().is_ok() {
            assert!(text.chars().count() <= 16, "label `{text}`");
        }
    }
}

#[test]
fn machines_lists_the_embedded_machines() {
    volmap().arg("machines").assert().success().stdout(
        predicate::str::contains("vmc-li2015")
            .and(predicate::str::contains("FYXCFZB"))
            .and(predicate::str::contains("4axis-hwang2014"))
            .and(predicate::str::contains("vmc-dobariya2015")),
    );
}

/// The `result` of a `--json` report (docs/json.md), its envelope's schema version checked.
pub fn json_result(path: impl AsRef<Path>) -> serde_json::Value {
    let text = std::fs::read_to_string(path.as_ref()).unwrap();
    let mut report: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(report["schema"], 1, "{}", path.as_ref().display());
    report["result"].take()
}
