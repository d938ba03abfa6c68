//! The `volmap` binary as a user runs it, command by command.

mod compensate;
mod design;
mod inputs;
mod interrupt;
mod machines;
mod map;
mod plot;
mod query;
mod robust;
mod standards;
mod sweep;
mod sweep_readers;

use assert_cmd::Command;
use predicates::prelude::*;

fn volmap() -> Command {
    Command::cargo_bin("volmap").unwrap()
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
