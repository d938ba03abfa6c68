//! `volmap machines`: the embedded machines, and the machine file of one.

use std::process::ExitCode;

use volmap::io::embedded;

use serde_json::json;
use volmap::io::digest;

use super::args::JsonArg;
use super::envelope::Envelope;
use super::failure::Failure;

#[derive(clap::Args)]
pub struct MachinesArgs {
    /// Print the machine file of this embedded machine (TOML, with its comments): a starting
    /// point for a machine file of one's own.
    #[arg(long, value_name = "NAME")]
    show: Option<String>,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: MachinesArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[("--json", args.json.json.as_deref())])?;
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
        if let Some(path) = &args.json.json {
            Envelope::new("machines")
                .machine(&embedded::load(name)?)
                .write(path, "--json", &json!({ "toml": text }))?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    outln!("{:<18} {:<9} {:<6} description", "name", "chain", "axes");
    let mut list = Vec::new();
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::load(name)?;
        let axes = machine.chain.axes().count();
        outln!(
            "{name:<18} {:<9} {axes:<6} {}",
            machine.chain.hwang_notation(),
            machine.description
        );
        list.push(json!({
            "name": name,
            "chain": machine.chain.hwang_notation(),
            "axes": axes,
            "description": machine.description,
            "sha256": digest::of_machine(&machine),
        }));
    }
    if let Some(path) = &args.json.json {
        Envelope::new("machines").write(path, "--json", &json!({ "machines": list }))?;
    }
    Ok(ExitCode::SUCCESS)
}
