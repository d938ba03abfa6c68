//! The `volmap` binary as a user runs it, command by command.

mod compensate;
mod compensate_orientation;
mod design;
mod evaluation_inputs;
mod export;
mod export_fanuc;
mod field_files;
mod finite;
mod hardening_inputs;
mod hardening_messages;
mod hardening_outputs;
mod interrupt;
mod limits;
mod machine_files;
mod machine_files_tables;
mod machines;
mod map;
mod plot;
mod profile_datums;
mod query;
mod robust;
mod sample;
mod standards;
mod standards_frames;
mod sweep;
mod sweep_findings;
mod sweep_messages;
mod sweep_readers;
mod trace;

use assert_cmd::Command;
use predicates::prelude::*;

pub fn volmap() -> Command {
    Command::cargo_bin("volmap").unwrap()
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

#[test]
fn machines_lists_the_embedded_machines() {
    volmap().arg("machines").assert().success().stdout(
        predicate::str::contains("vmc-li2015")
            .and(predicate::str::contains("FYXCFZB"))
            .and(predicate::str::contains("4axis-hwang2014"))
            .and(predicate::str::contains("vmc-dobariya2015")),
    );
}
