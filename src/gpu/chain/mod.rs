//! The chain kernel (`shaders/deviation.wgsl` + `shaders/chain.wgsl`): the machine packed into
//! its buffers ([`pack()`]), and the map computed chunk by chunk with the readback of one chunk
//! overlapping the compute of the next ([`GpuMapper`]).
//!
//! Per map, two passes evaluate every axis at its grid values (the machine's error tables on the
//! GPU) and fold the chain on either side of X into at most two tables each; per chunk, one pass
//! composes each line's products from those tables and evaluates its points.

mod fold_layout;
mod folded;
mod mapper;
pub mod pack;
mod positions;
mod sampled;
mod timing;
mod uncertainty;

pub use mapper::GpuMapper;
pub use pack::{pack, MachineShape, Packed, PointVariant};
pub use uncertainty::{
    ChunkSums, MappedTerms, SumTerm, SumsPlan, TERMS_PER_BATCH, UNCERTAINTY_WGSL,
};

use super::GpuError;
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;

/// The chain kernel's WGSL source: `shaders/deviation.wgsl` (transforms in deviation form),
/// `shaders/chain.wgsl` (buffers, the axis and group passes), `shaders/errors.wgsl` (error values
/// and the deviations of sampled machines), `shaders/points.wgsl` (the point
/// pass, its reduce variant, the write-only kernel), `shaders/positions.wgsl` (the chain at
/// arbitrary positions) and `shaders/folded.wgsl` (machines whose errors read other axes),
/// joined in that order.
pub const CHAIN_WGSL: &str = concat!(
    include_str!("../../../shaders/deviation.wgsl"),
    "\n",
    include_str!("../../../shaders/chain.wgsl"),
    "\n",
    include_str!("../../../shaders/errors.wgsl"),
    "\n",
    include_str!("../../../shaders/points.wgsl"),
    "\n",
    include_str!("../../../shaders/positions.wgsl"),
    "\n",
    include_str!("../../../shaders/folded.wgsl")
);
/// The files [`CHAIN_WGSL`] is joined from, in order, in `shaders/`.
pub const CHAIN_WGSL_FILES: [&str; 6] = [
    "deviation.wgsl",
    "chain.wgsl",
    "errors.wgsl",
    "points.wgsl",
    "positions.wgsl",
    "folded.wgsl",
];
/// Bytes of output per grid point: six f32 channels.
pub const BYTES_PER_POINT: u64 = (CHANNELS.len() * 4) as u64;
/// The default upper bound of points per chunk on a CPU adapter: two chunks in flight hold about
/// 100 MB (measured on lavapipe, larger chunks are no faster).
pub const DEFAULT_CHUNK_POINTS: u64 = 1 << 20;
/// The same on a hardware GPU, where a chunk of 1 Mi points takes well under a millisecond and the
/// host's work per chunk would cap the rate: two chunks in flight hold about 800 MB (output and
/// staging), still bounded whatever the grid.
pub const DEFAULT_CHUNK_POINTS_HARDWARE: u64 = 1 << 23;

/// How the point pass divides a chunk among its invocations: each takes `lines_per_lane`
/// neighbouring lines and up to `points_per_lane` points along them. Line terms are computed once
/// per invocation and line, X's errors once per invocation and point, so more of either shares
/// more work; the write-only ceiling uses the same tiling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Tiling {
    pub points_per_lane: u64,
    /// 1, 2 or 4 (the shader's `LINES_PER_LANE`).
    pub lines_per_lane: u32,
}

/// The tiling on a CPU adapter, which runs an invocation's points one after another and every
/// store and gather lane by lane: long runs and four lines per invocation (the fastest of the
/// tilings measured on lavapipe, see docs/performance.md).
pub const SOFTWARE_TILING: Tiling = Tiling {
    points_per_lane: 64,
    lines_per_lane: 4,
};
/// The tiling on a hardware GPU: one line per invocation and shorter runs, so that neighbouring
/// invocations write neighbouring values.
pub const HARDWARE_TILING: Tiling = Tiling {
    points_per_lane: 32,
    lines_per_lane: 1,
};

/// The kernels' series for small rotations are exact in f32 for angles below this, rad.
pub const MAX_ERROR_ANGLE_RAD: f64 = 0.1;

/// Checks that the machine's error rotations stay small over the grid: the sum of the magnitudes
/// of every angular error (component, location, spindle) below [`MAX_ERROR_ANGLE_RAD`]. Real
/// machines are below 1e-3 rad; larger values are a unit mistake (degrees or µrad for rad).
pub fn check_error_angles(machine: &Machine, grid: &Grid) -> Result<(), GpuError> {
    let total = error_angles_rad(machine, grid);
    if total < MAX_ERROR_ANGLE_RAD {
        Ok(())
    } else {
        Err(GpuError::ErrorAngles {
            machine: machine.name.clone(),
            total_rad: total,
            limit_rad: MAX_ERROR_ANGLE_RAD,
        })
    }
}

/// The sum of the magnitudes of every angular error of the machine over the grid: the spindle's,
/// every location's, and each axis's largest sum of component angles at its grid values.
pub fn error_angles_rad(machine: &Machine, grid: &Grid) -> f64 {
    let mut total = machine.spindle[3].abs() + machine.spindle[4].abs();
    for axis in &machine.axes {
        total += axis.location[3..].iter().map(|a| a.abs()).sum::<f64>();
        let positions = grid.axis_positions(axis.letter);
        let largest = positions
            .iter()
            .map(|&q| {
                axis.component_values(q)[3..]
                    .iter()
                    .map(|a| a.abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        total += largest;
    }
    total
}

/// Which per-chunk work [`GpuMapper::time_kernels`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KernelChoice {
    /// The point pass of the chain.
    Chain,
    /// A kernel with the same dispatch and output that computes nothing: the ceiling.
    WriteOnly,
}

/// One kernel to time: what it computes and how the chunk is divided among its invocations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimedKernel {
    pub choice: KernelChoice,
    pub tiling: Tiling,
}

/// Refuses a machine with an error value of another axis's position: the kernels evaluate each
/// axis's errors from its own position.
pub(crate) fn check_own_axis_errors(machine: &Machine) -> Result<(), GpuError> {
    for axis in &machine.axes {
        for (n, f) in axis.components.iter().enumerate() {
            if f.as_ref().is_some_and(|f| !f.other_axes().is_empty()) {
                return Err(GpuError::CrossAxis {
                    machine: machine.name.clone(),
                    key: format!("axes.{}.{}", axis.letter, axis.component_key(n)),
                });
            }
        }
    }
    Ok(())
}
