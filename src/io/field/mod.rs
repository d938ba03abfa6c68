//! Field files: OpenEXR, one part, scanlines, six channels `OE.X OE.Y OE.Z VE.X VE.Y VE.Z`,
//! FLOAT (or HALF where a picture is wanted), uncompressed or compressed with OpenEXR's ZIP or
//! PXR24. The image is `nx` wide and `ny·nz` tall; pixel `(i, j + k·ny)` holds grid point
//! `(i, j, k)`. A five-axis map over the rotary axes is one multi-part file: one such field per
//! pose of the sweep, each part named by its pose (`B=-90,C=0`) and carrying every attribute a
//! single-pose field has. A map with its uncertainty adds, after each part of errors, a part of
//! the same grid and pose holding the standard uncertainty of each channel, its method in
//! `volmap.uncertainty`; readers find the parts of errors by pose and each one's uncertainty
//! beside it.
//!
//! The writers stream lines as they arrive through a pipeline that compresses and writes them
//! behind the computation, with a fixed number of pieces in memory whatever the grid or the
//! sweep. They write to a temporary file in the target's folder and rename it only when every
//! line is written and synced, so an interrupted run never leaves a truncated field. The readers
//! read any scanline compression the `exr` crate decodes, block by block, with the offset tables
//! read a window at a time: memory does not grow with the grid.
//!
//! What is the `exr` crate's and what is volmap's:
//! - The crate encodes the container: the magic number and version flags, every header
//!   attribute (its `AttributeValue`s; volmap's own as custom attributes, `v3d` among them), the
//!   end of the headers, the chunks' numbers and the offsets (`encode`); it decodes every
//!   number volmap reads, and decompresses the blocks (`blocks`).
//! - volmap puts the attributes in its order itself: the crate's `Header::write` writes its own
//!   attributes in its own order and the custom ones in a `HashMap`'s, which differs from run to
//!   run (the same field would not be the same file twice).
//! - volmap keeps the offset tables and the chunks' placement (`pipeline`): the crate's
//!   `ChunkWriter` writes the headers through `Header::write` and holds every offset table in
//!   memory until the end (8 bytes a block, growing with the grid and the sweep), where volmap
//!   writes the tables first as zeros and fills each piece's offsets in as its blocks land. The
//!   chunks are laid out as `Chunk::write` lays them out, but that function writes a part number
//!   only in a file of several headers (a sweep of one pose is multi-part too) and takes each
//!   block as an owned copy.
//! - The readers stay volmap's (`header`, `read`): the crate's `MetaData` and
//!   `block::reader` read every header and offset table whole before anything is checked against
//!   the file's length (a table of a chunk per line is as large as the grid), offer no block
//!   read at random, and refuse damaged files with their own messages, or accept some that volmap
//!   refuses (a data window with its corners swapped), where volmap names what is wrong: the
//!   channels found, an unknown compression's code, the chunk header that does not match.

mod blocks;
mod encode;
mod header;
mod inputs;
mod loaded;
mod merge;
mod pipeline;
mod prepare;
mod read;
mod write;

pub use blocks::{compress_on_one_thread, Compression, Storage, HALF_MAX};
pub use loaded::{field_memory_bytes, GridCell, LoadedField, FIELD_MEMORY_BYTES};
pub use merge::merge_parts;
pub use pipeline::WriteTimes;
pub use read::{FieldFile, FieldReader, SINGLE_MAP_PART};
pub use write::{FieldWriter, PartsWriter};

use super::FileError;
use crate::error::{Classify, ErrorKind};
use crate::model::grid::Grid;
use crate::model::inputs::InputsRecord;
use crate::model::{poses, AxisLetter};

/// The bytes of a field's container besides its values: each part's header (the machine file
/// and its CSV tables among its attributes, `header_text_bytes` of them, and about a kilobyte of
/// others) and its offset table (8 bytes a block of lines), for `parts` parts of a grid `dims`.
pub fn container_bytes(
    dims: [usize; 3],
    storage: Storage,
    parts: u64,
    header_text_bytes: u64,
) -> u64 {
    let lines = dims[1] as u64 * dims[2] as u64;
    let codec = blocks::BlockCodec::for_writing(dims[0], lines, storage);
    let table = 8 * lines.div_ceil(codec.lines_per_block());
    parts.saturating_mul(table.saturating_add(header_text_bytes).saturating_add(1024))
}

#[derive(Debug, thiserror::Error)]
pub enum FieldError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{path}: not a volmap field: {what}")]
    Format { path: String, what: String },
    /// Fields that are not the shards of one sweep, to merge.
    #[error("{path}: {what}")]
    NotOneSweep { path: String, what: String },
    #[error("{path}: lines must arrive in order: expected line {expected}, got {got}")]
    OutOfOrder {
        path: String,
        expected: u64,
        got: u64,
    },
    #[error("{path}: only {written} of {total} lines were written; the field was not saved")]
    Incomplete {
        path: String,
        written: u64,
        total: u64,
    },
    #[error("{path}: parts must arrive in order: expected part {expected}, got {got}")]
    PartOutOfOrder {
        path: String,
        expected: usize,
        got: usize,
    },
    #[error("{path} holds {count} poses, one field each ({poses}): say which one")]
    Poses {
        path: String,
        count: usize,
        poses: String,
    },
    #[error("{path} holds no field at the pose {pose}; its poses: {poses}")]
    NoPose {
        path: String,
        pose: String,
        poses: String,
    },
    /// A reader of the standard uncertainties of a field that holds none.
    #[error("{path} holds no standard uncertainties (u) of its values{at}")]
    NoUncertainty { path: String, at: String },
    #[error("{path} holds the field computed at {held}, not at the inputs asked ({asked})")]
    Inputs {
        path: String,
        held: String,
        asked: String,
    },
    #[error("{path}: {channel} = {value:e} at grid point ({}, {}, {}) is beyond the range of HALF values (±{max}); the field was not saved", point[0], point[1], point[2])]
    HalfRange {
        path: String,
        channel: &'static str,
        point: [usize; 3],
        value: f32,
        max: f32,
    },
    #[error("{path}: {what}; the field was not saved")]
    Compress { path: String, what: String },
    #[error("{path}: {what} needs {bytes} bytes of memory at once, more than the {limit} bytes volmap reads a field in")]
    TooLarge {
        path: String,
        what: String,
        bytes: u64,
        limit: u64,
    },
}

impl Classify for FieldError {
    /// A field that cannot be read or is not volmap's is bad input; a field that could not be
    /// written whole is the work's failure.
    fn kind(&self) -> ErrorKind {
        match self {
            FieldError::File(e) => e.kind(),
            FieldError::Format { .. }
            | FieldError::NotOneSweep { .. }
            | FieldError::Poses { .. }
            | FieldError::NoPose { .. }
            | FieldError::NoUncertainty { .. }
            | FieldError::Inputs { .. }
            | FieldError::HalfRange { .. }
            | FieldError::TooLarge { .. } => ErrorKind::Input,
            FieldError::OutOfOrder { .. }
            | FieldError::Incomplete { .. }
            | FieldError::PartOutOfOrder { .. }
            | FieldError::Compress { .. } => ErrorKind::Work,
        }
    }
}

/// What a field file says about itself, stored as header attributes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FieldInfo {
    /// Grid points along X, Y, Z (`volmap.dims`, v3i).
    pub dims: [usize; 3],
    /// Commanded X, Y, Z of pixel (0, 0), mm (`volmap.origin`, v3d).
    pub origin_mm: [f64; 3],
    /// Grid step along X, Y, Z, mm (`volmap.spacing`, v3d).
    pub spacing_mm: [f64; 3],
    /// Commanded A, B, C, degrees (`volmap.pose`, v3d); axes the machine lacks are 0.
    pub pose_deg: [f64; 3],
    /// The rotary axes the machine has, e.g. `BC` (`volmap.poseAxes`).
    pub pose_axes: String,
    /// The machine's `name` (`volmap.machine`).
    pub machine_name: String,
    /// The chain in Hwang's notation (`volmap.chain`).
    pub chain: String,
    /// The machine file, verbatim (`volmap.machineToml`).
    pub machine_toml: String,
    /// CSV tables the machine file reads: `(path as written, text)` (`volmap.csvPath.N` and
    /// `volmap.csvText.N` for the `N`-th; `volmap.csv.<path>` in fields written before).
    pub csv_files: Vec<(String, String)>,
    /// The device that computed the field (`volmap.device`).
    pub device: String,
    /// The evaluation inputs the field was computed for: every axis's approach direction and
    /// every declared input's temperature (`volmap.approach`, `volmap.temperatures`,
    /// `volmap.referenceTemperature`); the default inputs in a field written before fields
    /// recorded them.
    pub inputs: InputsRecord,
    /// Where the part holds the standard uncertainties of the channels rather than their
    /// values: the method that computed them (`volmap.uncertainty`). Such a part follows the
    /// part of the errors at the same pose.
    pub uncertainty: Option<String>,
}

impl FieldInfo {
    /// The header without the machine's file and CSV tables (never copied).
    pub fn without_machine(&self) -> FieldInfo {
        FieldInfo {
            dims: self.dims,
            origin_mm: self.origin_mm,
            spacing_mm: self.spacing_mm,
            pose_deg: self.pose_deg,
            pose_axes: self.pose_axes.clone(),
            machine_name: self.machine_name.clone(),
            chain: self.chain.clone(),
            machine_toml: String::new(),
            csv_files: Vec::new(),
            device: self.device.clone(),
            inputs: self.inputs.clone(),
            uncertainty: self.uncertainty.clone(),
        }
    }

    /// The name of the field's pose: every rotary axis of the machine in the order A, B, C
    /// (`B=-90,C=0`), as the parts of a multi-part file are named.
    pub fn pose_name(&self) -> String {
        let axes: Vec<AxisLetter> = self
            .pose_axes
            .chars()
            .filter_map(AxisLetter::from_char)
            .collect();
        poses::name_of(self.pose_deg, &axes)
    }

    /// The grid of commanded positions the field covers.
    pub fn grid(&self) -> Grid {
        let mut pose = [0.0; 6];
        pose[3..].copy_from_slice(&self.pose_deg);
        Grid {
            dims: self.dims,
            origin_mm: self.origin_mm,
            spacing_mm: self.spacing_mm,
            pose,
        }
    }
}

/// `volmap.units`, written into every field.
pub const UNITS: &str = "VE.X VE.Y VE.Z: mm, volumetric error p_real - p_ideal, workpiece frame; \
OE.X OE.Y OE.Z: rad, rotation vector of R_real R_ideal^T, workpiece frame; \
origin, spacing: mm (commanded X Y Z); pose: degrees (commanded A B C)";

/// How far a rotary position may lie from a part's pose and still pick that part, degrees.
pub const POSE_TOLERANCE_DEG: f64 = 1e-9;

/// The most poses a message lists before it says how many more there are.
const LISTED_POSES: usize = 16;

/// Poses in words for a message: their names separated by spaces, the first
/// few where there are many (`B=-90,C=0 B=-90,C=90 … and 10 more`); a pose of a machine without
/// rotary axes is `(no rotary axis)`.
pub fn pose_list(names: &[String]) -> String {
    let shown: Vec<&str> = names
        .iter()
        .take(LISTED_POSES)
        .map(|n| {
            if n.is_empty() {
                "(no rotary axis)"
            } else {
                n.as_str()
            }
        })
        .collect();
    let mut text = shown.join(" ");
    if names.len() > LISTED_POSES {
        text.push_str(&format!(" … and {} more", names.len() - LISTED_POSES));
    }
    text
}

/// The grid and pose in words, exact (shortest round-trip decimals).
pub fn grid_text(info: &FieldInfo) -> String {
    let mut parts: Vec<String> = (0..3)
        .map(|d| {
            let end = info.origin_mm[d] + (info.dims[d].max(1) - 1) as f64 * info.spacing_mm[d];
            format!(
                "{}: {} points from {:?} to {:?} mm, step {:?} mm",
                ["X", "Y", "Z"][d],
                info.dims[d],
                info.origin_mm[d],
                end,
                info.spacing_mm[d]
            )
        })
        .collect();
    for axis in info.pose_axes.chars() {
        let index = "ABC".find(axis).unwrap_or(0);
        parts.push(format!("{axis} at {:?} deg", info.pose_deg[index]));
    }
    parts.join("; ")
}
