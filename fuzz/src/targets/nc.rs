//! NC programs (G-code) and work offsets.

use volmap::nc::{self, Options, ToolLengths};

use super::directive;
use super::measured::machine_of;
use super::{read, Context, Outcome, Target, Verdict};
use crate::material::Grammar;

const GCODE_WORDS: &[&str] = &[
    "G0", "G00", "G1", "G01", "G2", "G3", "G4", "G17", "G18", "G19", "G20", "G21", "G28", "G40",
    "G43", "G49", "G53", "G54", "G55", "G56", "G57", "G58", "G59", "G61", "G64", "G65", "G68",
    "G69", "G73", "G80", "G81", "G82", "G83", "G85", "G89", "G90", "G91", "G94", "G95", "G98",
    "G99", "M3", "M5", "M6", "M30", "M98", "M99", "T1", "T2", "H1", "X", "Y", "Z", "A", "B", "C",
    "I", "J", "K", "R", "F", "P", "Q", "L", "O", "N", "S",
];

pub const GCODE: Target = Target {
    name: "gcode",
    about: "NC programs (`compensate --program`): `nc::compensate` on the embedded machine a seed names (`vmc-li2015` by default; tool orientation too where it says so), with work offsets G54–G59 and tool lengths T1–T3, and the compensated program traced back through the model (`nc::trace`)",
    grammar: Grammar::Gcode,
    words: GCODE_WORDS,
    run: gcode,
};

/// Work offsets of every G54–G59: a work zero inside the travels of every embedded machine.
fn options(orientation: bool, pass_unknown: bool) -> Options {
    Options {
        tool_lengths: ToolLengths::parse("T1=80,T2=100,T3=90").expect("tool lengths"),
        work_offsets: (54..=59)
            .map(|n| (n, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0]))
            .collect(),
        pass_unknown,
        orientation_tolerance_rad: orientation.then_some(nc::DEFAULT_ANGULAR_TOLERANCE_RAD),
        ..Options::default()
    }
}

/// The most blocks (as the control runs them) of a program compensated: five-axis moves with the
/// orientation compensated take up to a millisecond each.
const COMPENSATED_BLOCKS: usize = 500;

fn gcode(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "program.nc";
    let machine = machine_of(cx, input, "vmc-li2015");
    // The orientation is compensated on machines with two rotary axes only (elsewhere the option
    // is refused, which is not the program's doing).
    let options = options(
        directive(input, "orientation") == Some("on") && machine.rotary_axes().len() == 2,
        directive(input, "pass-unknown") == Some("on"),
    );
    let blocks = read!(
        nc::blocks_as_run(input, FILE, options.pass_unknown),
        &[FILE]
    );
    if blocks.len() > COMPENSATED_BLOCKS {
        // Read as the control runs it, within the documented bound: compensating it is work
        // that grows with its blocks (measured by the benchmarks), not the reading under test.
        return Ok(Outcome::Accepted);
    }
    let compensated = read!(nc::compensate(machine, input, FILE, &options), &[FILE]);
    // The compensated program is one volmap reads again.
    if let Err(e) = nc::trace(
        machine,
        compensated.text.as_bytes(),
        "compensated.nc",
        &options,
    ) {
        return Err(format!(
            "the compensated program does not read back: {}",
            volmap::error::excerpt(&e.to_string())
        ));
    }
    Ok(Outcome::Accepted)
}

pub const OFFSETS: Target = Target {
    name: "offsets",
    about: "work offset files (TOML, `--work-offset-file`): `nc::read_work_offsets`; each line of the file also as a `--work-offset` and a `--tool-length` value (`nc::parse_work_offset`, `ToolLengths::parse`)",
    grammar: Grammar::Toml,
    words: &["G54", "G55", "G56", "G57", "G58", "G59", "G53", "G54.1", "T1", "T2"],
    run: offsets,
};

fn offsets(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "offsets.toml";
    let paths = cx.write(FILE, input)?;
    let outcome = match nc::read_work_offsets(&paths[0]) {
        Ok(offsets) => {
            std::hint::black_box(offsets);
            Outcome::Accepted
        }
        Err(error) => super::refused(error, &[FILE])?,
    };
    // Each line as a flag's value: whatever they make of it, as the checks allow.
    for line in String::from_utf8_lossy(input).lines().take(64) {
        if let Err(error) = nc::parse_work_offset(line) {
            super::refused(error, &[])?;
        }
        if let Err(error) = ToolLengths::parse(line) {
            super::refused(error, &[])?;
        }
    }
    Ok(outcome)
}
