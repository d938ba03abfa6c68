//! Host mirrors of the WGSL structs in `shaders/chain.wgsl` and `shaders/sample.wgsl`. Keep in
//! sync with those files: one `#[repr(C)]` Pod struct per WGSL struct, vec4/mat4 fields only (no
//! vec3 in buffers), explicit padding, and a compile-time size check for each.

use bytemuck::{Pod, Zeroable};

/// Function index meaning "this error is zero": the shader skips it.
pub const NO_FUNCTION: u32 = u32::MAX;
/// The domain bound of functions without one (constants and polynomials).
pub const UNBOUNDED: f32 = f32::MAX;
/// `AxisData::info[0]` values.
pub const KIND_LINEAR: u32 = 0;
pub const KIND_ROTARY: u32 = 1;
/// `AxisData::info[1]` for an axis held at a fixed position (the pose); 0..3 name a grid dimension.
pub const SOURCE_FIXED: u32 = 3;

/// A 3×3 matrix in the upper-left of a WGSL `mat4x4<f32>`, column-major.
pub type Mat4 = [[f32; 4]; 4];

/// Keep in sync with `struct Params` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Params {
    /// Commanded X, Y, Z of grid point (0, 0, 0), mm; w unused.
    pub origin: [f32; 4],
    /// Grid step along X, Y, Z, mm; w unused.
    pub spacing: [f32; 4],
    /// nx, ny, nz, number of axes.
    pub grid: [u32; 4],
    /// Axis-value entries, group entries, unused, unused.
    pub counts: [u32; 4],
    /// First line of this chunk, lines in this chunk, points per invocation of the point pass,
    /// invocations per group of lines (the point pass's tiling, see `shaders/chain.wgsl`).
    pub chunk: [u32; 4],
    /// First group entry of each slot: PA, PB (Pre), QA, QB (Post).
    pub slots: [u32; 4],
    /// X's nominal motion along x̂ (`q` times X's sense) at the centre index, its step per index,
    /// the centre index (X's polynomials are in `t = i − centre`); w unused.
    pub x_motion: [f32; 4],
    /// `EXX EYX EZX` as polynomials in `t`: `x_translation[k]` holds the three `c_k`.
    pub x_translation: [[f32; 4]; 4],
    /// `EAX EBX ECX` likewise.
    pub x_rotation: [[f32; 4]; 4],
}
const _: () = assert!(std::mem::size_of::<Params>() == 7 * 16 + 8 * 16);

/// One axis of the chain, in product order. Keep in sync with `struct AxisData` in
/// `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct AxisData {
    /// `o_k`, mm.
    pub offset: [f32; 4],
    /// Location position errors `(EX0k, EY0k, EZ0k)`, mm.
    pub location_delta: [f32; 4],
    /// `Rot(EA0k, EB0k, EC0k) − I`, computed in f64 on the host.
    pub location_m: Mat4,
    /// `u_k`: unit direction times sense.
    pub unit: [f32; 4],
    /// Kind (`KIND_*`), source (grid dimension 0..3 or `SOURCE_FIXED`), rotation axis index
    /// (0 = x, 1 = y, 2 = z), index of the axis's first entry in the axis-value table.
    pub info: [u32; 4],
    /// x: the commanded position when the source is fixed (mm or degrees).
    pub fixed_q: [f32; 4],
    /// Function indices of `EXk EYk EZk EAk`.
    pub functions_a: [u32; 4],
    /// Function indices of `EBk ECk`, unused, unused.
    pub functions_b: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<AxisData>() == 176);

/// One error function. Keep in sync with `struct Function` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Function {
    /// First piece, number of pieces, periodic (0/1), unused.
    pub pieces: [u32; 4],
    /// Domain `lo`, `hi` (positions clamp into it), unused, unused.
    pub domain: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<Function>() == 32);

/// One polynomial piece. Keep in sync with `struct Piece` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Piece {
    /// Where the piece starts; its polynomial is in `s = q − start`.
    pub start: f32,
    /// Polynomial degree.
    pub degree: u32,
    /// Index of coefficient `c0` in the flat coefficient array (scalar index; four per vec4).
    pub coefficient: u32,
    pub _pad: u32,
}
const _: () = assert!(std::mem::size_of::<Piece>() == 16);

/// A transform in deviation form `[(I + M)·R0, t0 + d]`: columns of `R0` with `t0` in w,
/// columns of `M` with `d` in w. Written by the `axis_values` pass. Keep in sync with
/// `struct DevData` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct DevData {
    pub r0_t0: [[f32; 4]; 3],
    pub m_d: [[f32; 4]; 3],
}
const _: () = assert!(std::mem::size_of::<DevData>() == 96);

/// One factor of a group: an axis-value entry or a constant transform (X's location,
/// `S·Trans(tool)`). Keep in sync with `struct Factor` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Factor {
    /// Source (`FACTOR_AXIS_ENTRY` or `FACTOR_CONSTANT`), the axis's first axis-value entry,
    /// the dimension that indexes it (0 fixed, 1 j, 2 k), unused.
    pub info: [u32; 4],
    /// The transform itself when the source is `FACTOR_CONSTANT`.
    pub value: DevData,
}
const _: () = assert!(std::mem::size_of::<Factor>() == 16 + 96);

/// `Factor::info[0]` values.
pub const FACTOR_AXIS_ENTRY: u32 = 0;
pub const FACTOR_CONSTANT: u32 = 1;

/// One of the four group tables PA, PB, QA, QB: the product of a run of factors, tabulated
/// over its dimension. Keep in sync with `struct Group` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub struct Group {
    /// First factor, factor count (0: the slot is unused), dimension (0: one entry, 1: one per
    /// j, 2: one per k), first entry in the group table.
    pub info: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<Group>() == 16);

/// What the sampling kernel needs to know of the field and the dispatch. Keep in sync with
/// `struct SampleParams` in `shaders/sample.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SampleParams {
    /// nx, ny, nz of the whole grid; w unused.
    pub dims: [u32; 4],
    /// First z plane held in the field buffer, unused, points in this dispatch, unused.
    pub range: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<SampleParams>() == 32);

/// One position to sample: its grid cell and the fractions within it, found on the host in f64.
/// Keep in sync with `struct SamplePoint` in `shaders/sample.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct SamplePoint {
    /// i, j, k of the cell's lower corner (k in the whole grid); w unused.
    pub cell: [u32; 4],
    /// Fractions along x, y, z in [0, 1] (0 along a dimension one point deep); w unused.
    pub t: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<SamplePoint>() == 32);
