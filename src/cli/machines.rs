//! `volmap machines`: the embedded machines.

use std::process::ExitCode;

use volmap::io::embedded;

use super::failure::Failure;

pub fn run() -> Result<ExitCode, Failure> {
    println!("{:<18} {:<9} {:<6} description", "name", "chain", "axes");
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::load(name)?;
        let axes = machine.chain.axes().count();
        println!(
            "{name:<18} {:<9} {axes:<6} {}",
            machine.chain.hwang_notation(),
            machine.description
        );
    }
    Ok(ExitCode::SUCCESS)
}
