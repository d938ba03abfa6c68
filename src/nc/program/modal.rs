//! A program's modal state as the control keeps it from block to block: motion, plane, distance,
//! units, work offset and tool, where the tool is (in the program and in the output), which axes
//! have a value, and the direction each axis last moved in. The compensation reads and updates
//! the same state, so it lies below both the reader and the compensation.

use std::collections::HashMap;

use crate::model::inputs::Approach;
use crate::nc::options::ToolLengths;

/// The approach direction of every axis, by program axis (X Y Z A B C).
pub(in crate::nc) type Directions = [Approach; 6];

/// The motion mode: G0, G1, G2, G3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::nc) enum Motion {
    Rapid,
    Linear,
    Clockwise,
    CounterClockwise,
}

impl Motion {
    pub(in crate::nc) fn code(self) -> u32 {
        match self {
            Motion::Rapid => 0,
            Motion::Linear => 1,
            Motion::Clockwise => 2,
            Motion::CounterClockwise => 3,
        }
    }
}

/// The arc plane: the program axes (indices into X Y Z) of its first and second coordinates and
/// of the helix, and the letters of the centre offsets along the first and second.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::nc) struct Plane {
    pub(in crate::nc) u: usize,
    pub(in crate::nc) v: usize,
    pub(in crate::nc) w: usize,
    pub(in crate::nc) centre: [char; 2],
}

pub(in crate::nc) const XY: Plane = Plane {
    u: 0,
    v: 1,
    w: 2,
    centre: ['I', 'J'],
};

pub(in crate::nc) const ZX: Plane = Plane {
    u: 2,
    v: 0,
    w: 1,
    centre: ['K', 'I'],
};

pub(in crate::nc) const YZ: Plane = Plane {
    u: 1,
    v: 2,
    w: 0,
    centre: ['J', 'K'],
};

/// The program axes' letters, in the order of positions and directions.
pub(in crate::nc) const AXIS_LETTERS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

pub(in crate::nc) const MM_PER_INCH: f64 = 25.4;

/// A program's modal state.
#[derive(Debug, Clone)]
pub(in crate::nc) struct State {
    pub(in crate::nc) motion: Motion,
    pub(in crate::nc) plane: Plane,
    pub(in crate::nc) absolute: bool,
    pub(in crate::nc) inch: bool,
    pub(in crate::nc) offset: u32,
    pub(in crate::nc) tool: Option<u32>,
    /// Tool length compensation (G43) in force, until G49: the control then stands the axes at
    /// the program position plus the tool length along the spindle axis (Z).
    pub(in crate::nc) tool_length_on: bool,
    /// Tool-centre-point control in force (G43.4, G43.5, G234), until G49 or G43: X Y Z are the
    /// tool tip in the workpiece frame (`nc::tcpm`).
    pub(in crate::nc) tcpm: Option<super::tcpm::Tcpm>,
    /// The options' tool lengths, for the scans ahead.
    pub(in crate::nc) tool_lengths: ToolLengths,
    pub(in crate::nc) pending_tool: Option<u32>,
    /// Where the program has the tool (program coordinates, mm and degrees).
    pub(in crate::nc) position: [f64; 6],
    /// Where the output program has the tool, as written (mm and degrees).
    pub(in crate::nc) written: [f64; 6],
    /// The motion mode the output program is in.
    pub(in crate::nc) written_motion: Motion,
    /// The direction each axis last moved in, in the output (the options' initial directions
    /// before it moves).
    pub(in crate::nc) approach: Directions,
    /// The same in the program as it was.
    pub(in crate::nc) programmed: Directions,
    /// Which axes the program has given a value (by a block naming them) since its start or
    /// their last reference return: an arc needs its start, so both axes of its plane.
    pub(in crate::nc) set: [AxisSet; 6],
    /// Axes whose position volmap cannot know (a block it does not model may have moved them):
    /// the line that made each so, until a block sets it absolutely again (see `unknown`).
    pub(in crate::nc) unknown: [Option<usize>; 6],
    /// The axes the program names anywhere: a block that may move any axis makes these unknown.
    pub(in crate::nc) named: [bool; 6],
    /// The work offsets as the program has them (the options', then as G10 sets them), machine
    /// mm and degrees; and those a block volmap does not follow has changed (by line). A change
    /// of offset carries where the tool is over (`offsets`).
    pub(in crate::nc) work_offsets: super::offsets::WorkOffsets,
    pub(in crate::nc) offsets_unknown: HashMap<u32, usize>,
    /// The line of a block that set tool data volmap does not follow (G10 L1, L10, L11): moves
    /// under G43 are not compensated after it.
    pub(in crate::nc) tool_data_unknown: Option<usize>,
    /// The shift of the coordinates by G52 and by G92 (machine mm and degrees, added to the work
    /// offset).
    pub(in crate::nc) local_shift: [f64; 6],
    pub(in crate::nc) g92_shift: [f64; 6],
    /// Set by the reader for a move it leaves uncompensated: its line, the unknown axes and the
    /// line that made the first of them unknown.
    pub(in crate::nc) left_alone: Option<LeftAlone>,
}

/// A move volmap leaves as it is because it depends on an axis it cannot know.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(in crate::nc) struct LeftAlone {
    pub(in crate::nc) line: usize,
    pub(in crate::nc) axes: String,
    pub(in crate::nc) since: usize,
}

/// Whether the program has given an axis a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::nc) enum AxisSet {
    /// Named by a block.
    Yes,
    /// Not named by any block yet.
    Never,
    /// Sent to the reference point (G28) or moved in machine coordinates (G53) by the block on
    /// this line, and not named since.
    Reference(usize),
}
