//! The channels of a field: the six values volmap computes at every commanded position.
//!
//! Engines hand over chunks of whole grid lines, and the field file stores them, in one layout:
//! for each line, `nx` values of each channel of [`CHANNELS`] in turn (OpenEXR orders channels
//! alphabetically, so OE comes before VE). Point queries answer in [`SAMPLE_COLUMNS`] order, VE
//! first, as people read them.

/// The field's channels in engine and file order: the orientation error OE (rad, rotation vector
/// of `R_real · R_idealᵀ`) and the volumetric error VE (mm, `p_real − p_ideal`), both in the
/// workpiece frame.
pub const CHANNELS: [&str; 6] = ["OE.X", "OE.Y", "OE.Z", "VE.X", "VE.Y", "VE.Z"];

/// The columns of a point query's answer, VE first: `VE.X VE.Y VE.Z` (mm) `OE.X OE.Y OE.Z` (rad).
pub const SAMPLE_COLUMNS: [&str; 6] = ["VE.X", "VE.Y", "VE.Z", "OE.X", "OE.Y", "OE.Z"];

/// The six values at a point, in [`SAMPLE_COLUMNS`] order.
pub type Sample = [f64; 6];

/// The columns `sample --exact --uncertainty` adds: the standard uncertainty of each VE
/// component (mm), first order or by Monte Carlo.
pub const UNCERTAINTY_COLUMNS: [&str; 3] = ["u(VE.X)", "u(VE.Y)", "u(VE.Z)"];
