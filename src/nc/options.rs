//! What a compensation needs besides the machine and the program: work offsets, tool lengths,
//! tolerances, decimals, the evaluation inputs; read from the command line's values and files and
//! checked against the machine.

use std::collections::HashMap;

use super::error::{NcError, NcOption};
use crate::io::read_text;
use crate::model::inputs::Inputs;
use crate::model::Machine;

/// Tool lengths: one for every tool, or per tool number.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolLengths {
    pub all: Option<f64>,
    pub per_tool: HashMap<u32, f64>,
}

impl ToolLengths {
    /// One length for every tool, `120`, or lengths per tool, `T1=80,T2=120.5` (mm, along the spindle axis).
    pub fn parse(text: &str) -> Result<ToolLengths, NcError> {
        let mut lengths = ToolLengths::default();
        let bad = |message: &str| NcError::Option {
            option: NcOption::ToolLengths,
            value: crate::error::excerpt(text).into_owned(),
            message: format!("{message}: a length in mm, or T1=80,T2=120 per tool"),
        };
        if text.trim().is_empty() {
            return Ok(lengths);
        }
        let most = crate::io::machine_file::MAX_PLAUSIBLE_LENGTH_MM;
        let length = |value: &str| {
            value
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.abs() <= most)
                .ok_or_else(|| {
                    bad(&format!(
                        "`{}` is not a length of at most {most} mm",
                        crate::error::excerpt(value.trim())
                    ))
                })
        };
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        for part in &parts {
            match part.split_once('=') {
                None if part.is_empty() => return Err(bad("an empty item")),
                None if parts.len() > 1 => {
                    return Err(bad("one length for every tool stands alone"))
                }
                None => lengths.all = Some(length(part)?),
                Some((tool, value)) => {
                    let number = tool.trim().trim_start_matches(['T', 't']);
                    let number = number.parse().map_err(|_| {
                        bad(&format!("`{}` is not a tool", crate::error::excerpt(tool)))
                    })?;
                    if lengths.per_tool.insert(number, length(value)?).is_some() {
                        return Err(bad(&format!("T{number} is given twice")));
                    }
                }
            }
        }
        Ok(lengths)
    }
}

/// What the compensation needs besides the machine and the program.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Work offsets by number (54–59): machine X, Y, Z (mm) and A, B, C (degrees) of the work
    /// zero. G54 is zero unless given.
    pub work_offsets: HashMap<u32, [f64; 6]>,
    /// Tool lengths; without any, the machine file's tool offset stands.
    pub tool_lengths: ToolLengths,
    /// Largest distance of the real tool tip from the intended path, mm.
    pub chord_tolerance_mm: f64,
    /// Decimals written (default 4 in mm, 5 in inch).
    pub decimals: Option<usize>,
    /// Pass blocks volmap does not understand through unchanged instead of failing.
    pub pass_unknown: bool,
    /// The temperatures of the machine's thermal inputs for the whole program, and the approach
    /// direction of every axis at its start (before the axis first moves).
    pub inputs: Inputs,
    /// Where given, the tool orientation is compensated too (five-axis machines): the largest
    /// angle between the real and the intended tool axis along the path, rad.
    pub orientation_tolerance_rad: Option<f64>,
    /// Where the orientation is compensated: the largest turn of the rotary axes from their
    /// programmed positions (the two as a vector), degrees. Near a singular pose the full
    /// correction would turn them by far more; what it leaves of the axis error is reported.
    pub max_rotary_correction_deg: f64,
}

/// The largest chord tolerance, mm: a kilometre, the largest length a machine file holds.
pub const MAX_CHORD_TOLERANCE_MM: f64 = 1e6;

/// The default angular tolerance of the orientation compensation, rad.
pub const DEFAULT_ANGULAR_TOLERANCE_RAD: f64 = 1e-5;

/// The default bound on the rotary correction of the orientation compensation, degrees: at
/// B = 0.3° a 4e-5 rad axis error needs C to turn 0.44°.
pub const DEFAULT_MAX_ROTARY_CORRECTION_DEG: f64 = 1.0;

/// The largest bound on the rotary correction, degrees: beyond it the rotary words would no
/// longer be a correction of the programmed ones.
pub const MAX_ROTARY_CORRECTION_DEG: f64 = 10.0;

impl Default for Options {
    fn default() -> Options {
        Options {
            work_offsets: HashMap::new(),
            tool_lengths: ToolLengths::default(),
            chord_tolerance_mm: 0.001,
            decimals: None,
            pass_unknown: false,
            inputs: Inputs::default(),
            orientation_tolerance_rad: None,
            max_rotary_correction_deg: DEFAULT_MAX_ROTARY_CORRECTION_DEG,
        }
    }
}

/// Refuses a work offset that turns A, B or C on a machine without that axis (zeros are taken),
/// lowest offset number first.
pub fn check_work_offsets(
    machine: &Machine,
    work_offsets: &HashMap<u32, [f64; 6]>,
) -> Result<(), NcError> {
    let mut numbers: Vec<u32> = work_offsets.keys().copied().collect();
    numbers.sort_unstable();
    for number in numbers {
        let offset = work_offsets[&number];
        for axis in crate::model::AxisLetter::ALL
            .into_iter()
            .filter(|l| !l.is_linear())
        {
            let turn = offset[axis.index()];
            if turn != 0.0 && machine.axis(axis).is_none() {
                return Err(NcError::WorkOffsetAxis {
                    number,
                    axis,
                    turn: crate::error::shown(turn),
                    chain: machine.chain.hwang_notation(),
                });
            }
        }
    }
    Ok(())
}

/// `G54=100,50,-200` (X, Y, Z mm, then optionally A, B, C degrees).
pub fn parse_work_offset(text: &str) -> Result<(u32, [f64; 6]), NcError> {
    let bad = || NcError::Option {
        option: NcOption::WorkOffsets,
        value: crate::error::excerpt(text).into_owned(),
        message: "expected G54=X,Y,Z (mm), e.g. G54=100,50,-200".into(),
    };
    let (name, values) = text.split_once('=').ok_or_else(bad)?;
    let number: u32 = name
        .trim()
        .trim_start_matches(['G', 'g'])
        .parse()
        .map_err(|_| bad())?;
    if !(54..=59).contains(&number) {
        return Err(bad());
    }
    let values: Vec<f64> = values
        .split(',')
        .map(|v| v.trim().parse())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    if values.len() != 3 && values.len() != 6 {
        return Err(bad());
    }
    if let Some(n) = values.iter().position(|v| !v.is_finite()) {
        return Err(NcError::Option {
            option: NcOption::WorkOffsets,
            value: crate::error::excerpt(text).into_owned(),
            message: format!(
                "G{number}: its {} value is not a finite number",
                ["X", "Y", "Z", "A", "B", "C"][n]
            ),
        });
    }
    let mut offset = [0.0; 6];
    offset[..values.len()].copy_from_slice(&values);
    Ok((number, offset))
}

/// Work offsets from a TOML file: `G54 = [X, Y, Z]` (mm, then optionally A, B, C degrees) per
/// offset.
pub fn read_work_offsets(path: &std::path::Path) -> Result<Vec<(u32, [f64; 6])>, NcError> {
    let name = path.display().to_string();
    let file_error = |message: String| NcError::OffsetFile {
        path: name.clone(),
        message,
    };
    let text = read_text(path)?;
    if let Some(message) = crate::error::toml_beyond_limits(&text) {
        return Err(file_error(message));
    }
    let table: std::collections::BTreeMap<String, Vec<f64>> =
        toml::from_str(&text).map_err(|e| file_error(crate::error::toml_message(&e, &text)))?;
    table
        .into_iter()
        .map(|(key, values)| {
            let text = format!(
                "{key}={}",
                values
                    .iter()
                    .map(f64::to_string)
                    .collect::<Vec<_>>()
                    .join(",")
            );
            parse_work_offset(&text).map_err(|e| file_error(e.to_string()))
        })
        .collect()
}
