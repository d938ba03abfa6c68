//! Machines built into the binary, chosen by name (`vmc-li2015`). Each is an ordinary
//! machine file in `machines/`, so what the binary embeds is what a user can copy and edit.

use std::path::Path;

use super::machine_file::MachineError;
use super::source::Reach;
use crate::model::Machine;

/// `(name, file text)` of every embedded machine; the first is the default.
pub const EMBEDDED: [(&str, &str); 5] = [
    ("vmc-li2015", include_str!("../../machines/vmc-li2015.toml")),
    (
        "vmc-dobariya2015",
        include_str!("../../machines/vmc-dobariya2015.toml"),
    ),
    (
        "4axis-hwang2014",
        include_str!("../../machines/4axis-hwang2014.toml"),
    ),
    (
        "5axis-hwang2014",
        include_str!("../../machines/5axis-hwang2014.toml"),
    ),
    ("gantry-2m", include_str!("../../machines/gantry-2m.toml")),
];

/// The machine `volmap map` uses when none is named.
pub const DEFAULT_MACHINE: &str = EMBEDDED[0].0;

/// The embedded machine called `name`, parsed.
pub fn embedded(name: &str) -> Option<Result<Machine, MachineError>> {
    EMBEDDED
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(n, text)| Machine::from_toml(text, &format!("<embedded {n}>"), None))
}

/// A machine by name or path: an embedded name first, then a path to a machine file (whose CSV
/// tables lie in its folder or below it).
pub fn load(name_or_path: &str) -> Result<Machine, MachineError> {
    load_reaching(name_or_path, Reach::Folder)
}

/// [`load`] with a machine file's CSV tables allowed where `reach` says.
pub fn load_reaching(name_or_path: &str, reach: Reach) -> Result<Machine, MachineError> {
    if let Some(machine) = embedded(name_or_path) {
        return machine;
    }
    let path = Path::new(name_or_path);
    // A machine file this run wrote is there, held until the run ends.
    if path.exists() || crate::io::outputs::held_temporary(path).is_some() {
        return Machine::from_path_reaching(path, reach);
    }
    Err(MachineError::UnknownMachine {
        name: name_or_path.to_string(),
        suggestion: nearest(name_or_path).map(str::to_string),
    })
}

/// The embedded machine whose name is nearest to `name` (Jaro-Winkler above 0.8, as a
/// misspelled subcommand is matched), if any.
pub fn nearest(name: &str) -> Option<&'static str> {
    EMBEDDED
        .iter()
        .map(|(n, _)| (*n, strsim::jaro_winkler(name, n)))
        .filter(|(_, score)| *score > 0.8)
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n)
}
