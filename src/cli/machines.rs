//! `volmap machines`: the embedded machines, and the machine file of one.

use std::process::ExitCode;

use volmap::io::embedded;

use super::failure::Failure;

#[derive(clap::Args)]
pub struct MachinesArgs {
    /// Print the machine file of this embedded machine (TOML, with its comments): a starting
    /// point for a machine file of one's own.
    #[arg(long, value_name = "NAME")]
    show: Option<String>,
}

pub fn run(args: MachinesArgs) -> Result<ExitCode, Failure> {
    if let Some(name) = &args.show {
        let (_, text) = embedded::EMBEDDED
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| {
                let names: Vec<&str> = embedded::EMBEDDED.iter().map(|(n, _)| *n).collect();
                let hint = embedded::nearest(name)
                    .map_or(String::new(), |n| format!("; did you mean `{n}`?"));
                Failure::input(format!(
                    "--show: `{}` is not an embedded machine{hint} (they are {})",
                    volmap::error::excerpt(name),
                    names.join(", ")
                ))
            })?;
        out!("{text}");
        return Ok(ExitCode::SUCCESS);
    }
    outln!("{:<18} {:<9} {:<6} description", "name", "chain", "axes");
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::load(name)?;
        let axes = machine.chain.axes().count();
        outln!(
            "{name:<18} {:<9} {axes:<6} {}",
            machine.chain.hwang_notation(),
            machine.description
        );
    }
    Ok(ExitCode::SUCCESS)
}
