//! TOML files at the size bounds: an input is a fragment of TOML, repeated into a file of a few
//! megabytes (within the 64 MiB text limit), so that its values, keys or dotted keys pass
//! `volmap::error`'s bounds wherever the fragment is dense in them. A file beyond a bound must be
//! refused by every reader of TOML before it is parsed, with the bound's own message (line and
//! column) naming the file; one within the bounds is left to the format targets (parsing
//! megabytes is their work, and slow in a test build).

use std::path::Path;

use volmap::calibrate::fit::FitFile;
use volmap::io::tolerance_file::ToleranceFile;
use volmap::model::Machine;
use volmap::part::PartFile;

use super::{Context, Outcome, Target, Verdict};
use crate::material::Grammar;

/// The size of the file a fragment is repeated into.
const FILE_BYTES: usize = 4 << 20;

pub const TOML_SIZE: Target = Target {
    name: "toml-size",
    about: "TOML files at the size bounds: a fragment repeated into 4 MB; beyond a bound (values, keys, dotted-key parts, nesting: `error::toml_beyond_limits`), the machine, tolerance, part, fit and work offset readers each refuse it with the bound's message before parsing",
    grammar: Grammar::Toml,
    words: &["=", ",", "[", "]", "{", "}", ".", "[[", "]]", "\"", "'''", "#"],
    run: toml_size,
};

fn toml_size(cx: &mut Context, input: &[u8]) -> Verdict {
    if input.is_empty() {
        return Ok(Outcome::Accepted);
    }
    let fragment = String::from_utf8_lossy(input);
    let text = fragment.repeat(FILE_BYTES.div_ceil(fragment.len()));
    let Some(bound) = volmap::error::toml_beyond_limits(&text) else {
        return Ok(Outcome::Accepted);
    };
    // The bound's message, as the readers must give it: its first line (`line L, column C: …`).
    let said = bound.lines().next().unwrap_or_default().to_string();
    let paths = cx.write("big.toml", text.as_bytes())?;
    let path = &paths[0];
    let machine = cx.machine("vmc-li2015").clone();
    let refusals: Vec<(&str, Option<String>)> = vec![
        (
            "machine",
            Machine::from_toml(&text, "big.toml", None)
                .err()
                .map(|e| e.to_string()),
        ),
        (
            "tolerance",
            ToleranceFile::parse(&text, Path::new(path), &machine)
                .err()
                .map(|e| e.to_string()),
        ),
        ("part", PartFile::read(path).err().map(|e| e.to_string())),
        ("fit", FitFile::read(path).err().map(|e| e.to_string())),
        (
            "work offset",
            volmap::nc::read_work_offsets(path)
                .err()
                .map(|e| e.to_string()),
        ),
    ];
    for (reader, refusal) in refusals {
        match refusal {
            None => {
                return Err(format!(
                    "the {reader} reader took a file beyond the bounds ({said})"
                ))
            }
            Some(message) if !(message.contains(&said) && message.contains("big.toml")) => {
                return Err(format!(
                    "the {reader} reader refused a file beyond the bounds ({said}) for another reason, after parsing it: {}",
                    volmap::error::capped(&message)
                ))
            }
            Some(_) => {}
        }
    }
    Ok(Outcome::Refused(said))
}
