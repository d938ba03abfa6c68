//! NC programs at the size bound: an input is a fragment of G-code, repeated into a program of
//! 5 MB (within the 256 MiB limit), so that wherever its lines are short the program has more
//! blocks than `volmap::limits::MAX_PROGRAM_BLOCKS`. Such a program must be refused before it is
//! parsed (counted, not read into blocks: within the harness's bounds on heap and time), naming
//! the program and the bound; one within the bound is left to the `gcode` target (parsing a
//! million blocks is its work, and slow in a test build).

use volmap::limits::MAX_PROGRAM_BLOCKS;
use volmap::nc;

use super::{Context, Outcome, Target, Verdict};
use crate::material::Grammar;

/// The size of the program a fragment is repeated into.
const PROGRAM_BYTES: usize = 5 << 20;

pub const NC_SIZE: Target = Target {
    name: "nc-size",
    about: "NC programs at the size bound: a fragment repeated into 5 MB; beyond 1,000,000 blocks (`limits::MAX_PROGRAM_BLOCKS`), `nc::blocks_as_run` refuses it, naming the program and the bound, before it is parsed",
    grammar: Grammar::Gcode,
    words: &["\n", "\r\n", "G1 X1\n", "N1", "%", "(", ")", ";"],
    run: nc_size,
};

fn nc_size(_cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "big.nc";
    if input.is_empty() {
        return Ok(Outcome::Accepted);
    }
    let program = input.repeat(PROGRAM_BYTES.div_ceil(input.len()));
    // Blocks as the reader counts them: lines, the last without its line end counted too.
    let blocks = program.split_inclusive(|&b| b == b'\n').count() as u64;
    if blocks <= MAX_PROGRAM_BLOCKS {
        return Ok(Outcome::Accepted);
    }
    match nc::blocks_as_run(&program, FILE, false) {
        Ok(_) => Err(format!(
            "a program of {blocks} blocks, more than the limit of {MAX_PROGRAM_BLOCKS}, was read"
        )),
        Err(error) => {
            let message = error.to_string();
            // A program that is not text is refused for that first, at its first line.
            let bound = format!("more than the limit of {MAX_PROGRAM_BLOCKS}");
            if !(message.contains(&bound) || message.contains("not a text file")) {
                return Err(format!(
                    "a program of {blocks} blocks refused for another reason than the bound: {}",
                    volmap::error::capped(&message)
                ));
            }
            super::refused(error, &[FILE])
        }
    }
}
