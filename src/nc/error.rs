//! What is wrong with a program or the options of its compensation: one error for the reader
//! and the compensation alike, naming the program's line where there is one.

use crate::io::FileError;

/// Which option of a compensation an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcOption {
    ToolLengths,
    WorkOffsets,
    ChordTolerance,
    Orientation,
    AngularTolerance,
    /// The bound on the rotary correction of the orientation compensation.
    MaxRotaryCorrection,
    Decimals,
    /// The distance between the samples of a trace.
    TraceStep,
}

impl std::fmt::Display for NcOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NcOption::ToolLengths => "tool lengths",
            NcOption::WorkOffsets => "work offset",
            NcOption::ChordTolerance => "chord tolerance",
            NcOption::Orientation => "orientation compensation",
            NcOption::AngularTolerance => "angular tolerance",
            NcOption::MaxRotaryCorrection => "largest rotary correction",
            NcOption::Decimals => "decimals",
            NcOption::TraceStep => "sampling step",
        })
    }
}

/// What is wrong with a program or the options of its compensation.
#[derive(Debug, thiserror::Error)]
pub enum NcError {
    #[error("{path}: line {line}: {message}")]
    Line {
        path: String,
        line: usize,
        message: String,
    },
    /// The program needs a value of `option` here that was not given.
    #[error("{path}: line {line}: {message}")]
    Missing {
        path: String,
        line: usize,
        option: NcOption,
        message: String,
    },
    /// A block with a code volmap does not follow.
    #[error("{path}: line {line}: {code} is not supported (volmap follows G0 G1 G2 G3 G4 G10 L2/L20 G17 G18 G19 G20 G21 G28 G40 G43 G43.4 G43.5 G49 G52 G53 G54–G59 G61 G64 G68 G69 G73 G80–G83 G85 G89 G90 G91 G92 G92.1 G92.2 G94 G95 G98 G99 G234, M98 and G65 with their body in the file)")]
    Unsupported {
        path: String,
        line: usize,
        code: String,
    },
    #[error(transparent)]
    File(#[from] FileError),
    /// A work offset file that does not hold work offsets.
    #[error("{path}: {message}")]
    OffsetFile { path: String, message: String },
    /// A work offset turns a rotary axis the machine lacks: the turn would be dropped unseen.
    #[error(
        "G{number} turns {axis} by {turn}°, but the machine (chain {chain}) has no {axis} axis"
    )]
    WorkOffsetAxis {
        number: u32,
        axis: crate::model::AxisLetter,
        /// The turn as shown (degrees).
        turn: String,
        chain: String,
    },
    /// The whole program is beyond a limit (its blocks).
    #[error("{path}: {message}")]
    Program { path: String, message: String },
    /// An option's value is wrong.
    #[error("{option} `{value}`: {message}")]
    Option {
        option: NcOption,
        value: String,
        message: String,
    },
}

crate::error::input_errors!(NcError);

impl NcError {
    pub fn line(path: &str, line: usize, message: String) -> NcError {
        NcError::Line {
            path: path.to_string(),
            line,
            message,
        }
    }
}
