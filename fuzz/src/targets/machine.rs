//! The machine file with its CSV tables, and the tolerance file.

use std::path::{Path, PathBuf};

use volmap::io::tolerance_file::ToleranceFile;
use volmap::model::grid::Grid;
use volmap::model::inputs::{Approach, Inputs};
use volmap::model::{AxisLetter, Command, Machine};
use volmap::reference::Twin;

use super::{read, Context, Outcome, Target, Verdict};
use crate::material::Grammar;

/// Keys and values of machine files, beyond those the corpus holds.
const MACHINE_WORDS: &[&str] = &[
    "name",
    "description",
    "chain",
    "tool",
    "offset",
    "axes",
    "range",
    "direction",
    "spindle",
    "thermal",
    "reference_C",
    "inputs",
    "poly",
    "table",
    "interp",
    "linear",
    "quadratic",
    "cubic",
    "periodic",
    "csv",
    "column",
    "of",
    "table2d",
    "x",
    "y",
    "values",
    "sum",
    "value",
    "reverse",
    "per_kelvin",
    "EXX",
    "EYX",
    "EZX",
    "EAX",
    "EBX",
    "ECX",
    "EXY",
    "EYY",
    "EZY",
    "ECY",
    "EXZ",
    "EYZ",
    "EZZ",
    "EAZ",
    "EBZ",
    "EXC",
    "EYC",
    "ECC",
    "EAC",
    "EXB",
    "EBB",
    "EC0Y",
    "EA0Z",
    "EB0Z",
    "EX0C",
    "EY0C",
    "EA0C",
    "EB0C",
    "EX0B",
    "EZ0B",
    "EXS",
    "EYS",
    "EZS",
    "EAS",
    "EBS",
    "FYXFZ",
    "FYXCFZB",
    "FXYFZ",
    "FZXYFC",
    "FCFYXZB",
    "X",
    "Y",
    "Z",
    "A",
    "B",
    "C",
    "position_mm",
    "position_deg",
];

pub const MACHINE: Target = Target {
    name: "machine",
    about: "machine files (TOML) with their CSV tables: `Machine::from_path`, then the GPU packing of a grid over the travel and the f64 reference at its points, at both approach directions and 30 K off the reference temperature",
    grammar: Grammar::Toml,
    words: MACHINE_WORDS,
    run: machine,
};

/// The file names of `paths`, as messages name them, each once.
pub(super) fn names(paths: &[PathBuf]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for path in paths {
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

pub(super) fn as_strs(names: &[String]) -> Vec<&str> {
    names.iter().map(String::as_str).collect()
}

fn machine(cx: &mut Context, input: &[u8]) -> Verdict {
    let paths = cx.write("machine.toml", input)?;
    let names = names(&paths);
    let machine = read!(Machine::from_path(&paths[0]), &as_strs(&names));
    evaluate(&machine);
    let opposite = Inputs {
        approach: [Approach::Negative; 6],
        temperatures_c: machine.thermal.as_ref().map_or(Vec::new(), |t| {
            t.inputs
                .iter()
                .map(|i| (i.clone(), t.reference_c + 30.0))
                .collect()
        }),
    };
    evaluate(&machine.at(&opposite));
    Ok(Outcome::Accepted)
}

/// The GPU packing (host side) of a 3×3×3 grid over the travel with every rotary axis in the
/// middle of its travel, and the f64 reference at every point of it: whatever they return, they
/// must not panic.
pub(super) fn evaluate(machine: &Machine) {
    let mut pose: Command = [0.0; 6];
    for axis in &machine.axes {
        if !axis.letter.is_linear() {
            pose[axis.letter.index()] = 0.5 * (axis.range[0] + axis.range[1]);
        }
    }
    let dims = [AxisLetter::X, AxisLetter::Y, AxisLetter::Z].map(|l| {
        if machine.axis(l).is_some() {
            3
        } else {
            1
        }
    });
    let Ok(grid) = Grid::full_travel(machine, dims, pose) else {
        return;
    };
    std::hint::black_box(volmap::gpu::chain::pack(machine, &grid));
    let twin = Twin::of(machine);
    for p in 0..grid.points() {
        std::hint::black_box(twin.deviation(&grid.command(grid.indices(p))));
    }
}

/// Keys and values of tolerance files.
const TOLERANCE_WORDS: &[&str] = &[
    "axes", "spindle", "uniform", "normal", "shape", "constant", "line", "bow", "EC0Y", "EXX",
    "EZY", "EXS", "EZS", "EAS", "EBS", "EA0Z", "EB0Z", "EX0C", "EY0C", "EA0C", "EB0C", "ECC", "X",
    "Y", "Z", "A", "B", "C",
];

pub const TOLERANCE: Target = Target {
    name: "tolerance",
    about: "tolerance files (TOML): `ToleranceFile::parse` against the embedded machine a seed names (`# machine:`, else every one), then the machine sampled with every term at its limit and the reference evaluated on it",
    grammar: Grammar::Toml,
    words: TOLERANCE_WORDS,
    run: tolerance,
};

fn tolerance(cx: &mut Context, input: &[u8]) -> Verdict {
    let paths = cx.write("tolerances.toml", input)?;
    let text = read!(volmap::io::read_text(&paths[0]), &["tolerances.toml"]);
    // Against the machine the seed names (`# machine:`), else every machine; accepted where one
    // of them takes it (a file is written for one machine).
    let named = super::directive(input, "machine");
    let mut outcome = None;
    for (_, machine) in cx
        .machines()
        .iter()
        .filter(|(n, _)| named.is_none_or(|m| m == *n))
    {
        match ToleranceFile::parse(&text, Path::new(&paths[0]), machine) {
            Ok(file) => {
                outcome = Some(Outcome::Accepted);
                let perturbations: Vec<_> =
                    file.tolerances.iter().map(|t| t.perturbation).collect();
                let limits: Vec<f64> = file
                    .tolerances
                    .iter()
                    .map(|t| t.distribution.limit())
                    .collect();
                evaluate(&machine.perturbed(&perturbations, &limits));
            }
            Err(error) => {
                let refused = super::refused(error, &["tolerances.toml"])?;
                outcome.get_or_insert(refused);
            }
        }
    }
    Ok(outcome.unwrap_or(Outcome::Accepted))
}
