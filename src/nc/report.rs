//! What a compensation run gives back: the compensated program, where each of its lines comes
//! from, and the report of what was done.

use std::collections::BTreeMap;

use crate::model::inputs::Inputs;
use crate::model::Machine;

/// A compensated program.
#[derive(Debug, Clone, PartialEq)]
pub struct Compensated {
    pub text: String,
    pub report: Report,
    /// For each line of `text`, the input line (1-based) it comes from: the line itself, or the
    /// move it adds a piece to.
    pub origins: Vec<usize>,
}

/// What a compensation run did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Report {
    /// Programmed points compensated (block end points and added pieces).
    pub points: usize,
    pub largest_correction_mm: f64,
    pub blocks_changed: usize,
    pub blocks_added: usize,
    /// Largest distance of the real tool tip from the intended path along the feed moves,
    /// with the program as it was and as compensated, mm; the compensated figure is that of the
    /// program as written (its numbers rounded, arcs about the centres their words give).
    pub largest_error_before_mm: f64,
    pub largest_error_after_mm: f64,
    /// The moves the two figures above cover (the feed moves), in words; `trace --compensate`
    /// gives the same figures over the same moves.
    pub errors_cover: String,
    /// Where the orientation is compensated: the largest angle between the real and the intended
    /// tool axis along the feed moves, with the program as it was and as compensated (rotary
    /// words as written), rad.
    pub largest_orientation_error_before_rad: f64,
    pub largest_orientation_error_after_rad: f64,
    /// Where the orientation is compensated: the largest turn of the rotary axes from their
    /// programmed positions (the two as a vector), degrees.
    pub largest_rotary_correction_deg: f64,
    /// The lines where the bound on the rotary correction left part of the tool axis's error
    /// (near a singular pose, where the rotary axes hardly turn the tool axis), in order.
    pub orientation_left: Vec<OrientationLeft>,
    /// Take-up pieces added where an axis with a reversal error reverses (at the start of a
    /// move or at an arc's turning point).
    pub take_ups: usize,
    /// Pieces whose compensated motion runs against the programmed direction of an axis with a
    /// reversal error: the machine approaches them the other way than they were compensated for
    /// (only where a reversal error makes a reversing move shorter than the programmed one).
    pub against_direction: usize,
    /// Canned cycle blocks (holes, modal repeats included) expanded into their rapid and feed
    /// moves, each compensated like any move.
    pub cycle_holes_expanded: usize,
    /// Blocks passed as they are with `pass_unknown` (codes volmap does not follow): not
    /// compensated, and outside the error figures above, which cover compensated moves only.
    pub not_compensated: Vec<PassedBlock>,
    /// Moves passed as they are because they depend on an axis (or a work offset, or tool data)
    /// a block above left unknown: volmap adds no word to them and they are outside the error
    /// figures too.
    pub moves_not_compensated: Vec<LeftMove>,
    /// The evaluation inputs the program was compensated for.
    pub inputs: ReportInputs,
}

/// A block passed uncompensated: its line and the code volmap does not follow.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassedBlock {
    pub line: usize,
    pub code: String,
}

/// A move left as it is: its line, what it depends on that is not known (`X Y`, `G55 work
/// offset`, `tool length`), and the line of the block that first made it so.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LeftMove {
    pub line: usize,
    pub unknown: String,
    pub since_line: usize,
}

/// As the summaries list it: `6 (X Y not known since line 5)`.
impl std::fmt::Display for LeftMove {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({} not known since line {})",
            self.line, self.unknown, self.since_line
        )
    }
}

/// A line where the bound on the rotary correction left part of the tool axis's error: the
/// largest angle left between the real and the intended tool axis at its compensated points.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OrientationLeft {
    pub line: usize,
    pub left_rad: f64,
}

impl Report {
    /// The line where the bound left the largest orientation error, with it.
    pub fn largest_orientation_left(&self) -> Option<&OrientationLeft> {
        self.orientation_left
            .iter()
            .max_by(|a, b| a.left_rad.total_cmp(&b.left_rad))
    }
}

/// The evaluation inputs of a compensation as a report records them.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ReportInputs {
    /// The direction of every axis of the chain before it first moves (`+` or `-`); after that
    /// each axis approaches in the direction of its programmed motion.
    pub approach_at_start: BTreeMap<char, char>,
    /// The temperature of every declared thermal input for the whole program, °C.
    pub temperatures_c: BTreeMap<String, f64>,
    /// The machine's reference temperature, where it declares thermal inputs.
    pub reference_c: Option<f64>,
    /// The same in words.
    pub description: String,
}

impl ReportInputs {
    pub fn of(inputs: &Inputs, machine: &Machine) -> ReportInputs {
        let thermal = machine.thermal.as_ref();
        ReportInputs {
            approach_at_start: machine
                .chain
                .axes()
                .map(|l| (l.as_char(), inputs.approach[l.index()].sign()))
                .collect(),
            temperatures_c: thermal.map_or_else(BTreeMap::new, |t| {
                t.inputs
                    .iter()
                    .map(|i| (i.clone(), inputs.temperature_c(i, t.reference_c)))
                    .collect()
            }),
            reference_c: thermal.map(|t| t.reference_c),
            description: inputs.describe(machine),
        }
    }
}
