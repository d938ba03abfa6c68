//! Host mirrors of the WGSL structs in `shaders/chain.wgsl`, `shaders/sample.wgsl` and
//! `shaders/uncertainty.wgsl`, and the
//! constants both sides share: one `#[repr(C)]` Pod struct per WGSL struct, vec4/mat4 fields
//! only (no vec3 in buffers), explicit padding, a compile-time size check for each. A test reads
//! the shaders with naga and holds every name in [`SHARED_CONSTANTS`] and [`STRUCT_SIZES`] to the
//! WGSL side.

use bytemuck::{Pod, Zeroable};

use crate::model::errorfn::PERIOD_DEG;

/// Invocations per workgroup of every kernel (`@workgroup_size`).
pub const WORKGROUP_SIZE: u32 = 64;
/// Function index meaning "this error is zero": the shader skips it.
pub const NO_FUNCTION: u32 = u32::MAX;
/// The domain bound of functions without one (constants and polynomials).
pub const UNBOUNDED: f32 = f32::MAX;
/// The kind of an axis, [`AxisData::kind`].
pub const KIND_LINEAR: u32 = 0;
pub const KIND_ROTARY: u32 = 1;
/// The driver of an axis held at a fixed position (the pose), [`AxisData::driver`]; 0, 1, 2
/// name the grid dimension that drives it.
pub const SOURCE_FIXED: u32 = 3;
/// What a factor is (`Factor::info[0]`): an entry of the axis-value table or a constant.
pub const FACTOR_AXIS_ENTRY: u32 = 0;
pub const FACTOR_CONSTANT: u32 = 1;
/// How the entries of a table are indexed along a chunk's lines: one entry for every line, one
/// per j or one per k. A group table may also be absent (the identity).
pub const INDEX_ONE: u32 = 0;
pub const INDEX_J: u32 = 1;
pub const INDEX_K: u32 = 2;
pub const TABLE_ABSENT: u32 = 3;
/// The group tables: PA, PB (Pre) and QA, QB (Post).
pub const GROUP_TABLES: u32 = 4;
/// Values per grid point and per sample in the sampling kernel: VE.X VE.Y VE.Z OE.X OE.Y OE.Z.
pub const SAMPLE_VALUES: u32 = 6;
/// The shapes of a tolerance's deviation over its axis's travel, [`Term::info`]`[2]`.
pub const SHAPE_CONSTANT: u32 = 0;
pub const SHAPE_LINE: u32 = 1;
pub const SHAPE_BOW: u32 = 2;
/// The most axes `folded_main` composes at every point (a machine's axes).
pub const SPAN_AXES: u32 = 6;
/// Flags of a [`Function`] (`pieces[2]`): periodic, a two-axis table, and where the argument
/// axes stand (4 bits each: 0 the error's own axis, else the commanded axis's index + 1).
pub const FUNCTION_PERIODIC: u32 = 1;
pub const FUNCTION_TABLE2D: u32 = 2;
pub const FUNCTION_ARG_SHIFT: u32 = 4;
pub const FUNCTION_ARG2_SHIFT: u32 = 8;
/// [`Term::info`]`[0]` of a term that deviates no component error (a location or the spindle).
pub const TERM_NO_AXIS: u32 = u32::MAX;
/// `which` of `component_terms_at`: every term (else a mask of the grid dimensions read).
pub const TERMS_ALL: u32 = u32::MAX;
/// The constant factors of each machine in the `constants` buffer: X's location, S·Trans(tool).
pub const CONSTANT_X_LOCATION: u32 = 0;
pub const CONSTANT_TAIL: u32 = 1;
pub const CONSTANTS_PER_SAMPLE: u32 = 2;

/// A value WGSL declares as a `const` of the same name.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shared {
    U32(u32),
    F32(f32),
}

/// Every constant the shaders share with this file, by its WGSL name.
pub const SHARED_CONSTANTS: [(&str, Shared); 27] = [
    ("WORKGROUP_SIZE", Shared::U32(WORKGROUP_SIZE)),
    ("NO_FUNCTION", Shared::U32(NO_FUNCTION)),
    ("KIND_LINEAR", Shared::U32(KIND_LINEAR)),
    ("KIND_ROTARY", Shared::U32(KIND_ROTARY)),
    ("SOURCE_FIXED", Shared::U32(SOURCE_FIXED)),
    ("FACTOR_AXIS_ENTRY", Shared::U32(FACTOR_AXIS_ENTRY)),
    ("FACTOR_CONSTANT", Shared::U32(FACTOR_CONSTANT)),
    ("INDEX_ONE", Shared::U32(INDEX_ONE)),
    ("INDEX_J", Shared::U32(INDEX_J)),
    ("INDEX_K", Shared::U32(INDEX_K)),
    ("TABLE_ABSENT", Shared::U32(TABLE_ABSENT)),
    ("SAMPLE_VALUES", Shared::U32(SAMPLE_VALUES)),
    ("PERIOD_DEG", Shared::F32(PERIOD_DEG as f32)),
    ("GROUP_TABLES", Shared::U32(GROUP_TABLES)),
    ("SHAPE_CONSTANT", Shared::U32(SHAPE_CONSTANT)),
    ("SHAPE_LINE", Shared::U32(SHAPE_LINE)),
    ("SHAPE_BOW", Shared::U32(SHAPE_BOW)),
    ("TERM_NO_AXIS", Shared::U32(TERM_NO_AXIS)),
    ("FUNCTION_PERIODIC", Shared::U32(FUNCTION_PERIODIC)),
    ("FUNCTION_TABLE2D", Shared::U32(FUNCTION_TABLE2D)),
    ("FUNCTION_ARG_SHIFT", Shared::U32(FUNCTION_ARG_SHIFT)),
    ("FUNCTION_ARG2_SHIFT", Shared::U32(FUNCTION_ARG2_SHIFT)),
    ("CONSTANT_X_LOCATION", Shared::U32(CONSTANT_X_LOCATION)),
    ("CONSTANT_TAIL", Shared::U32(CONSTANT_TAIL)),
    ("CONSTANTS_PER_SAMPLE", Shared::U32(CONSTANTS_PER_SAMPLE)),
    ("SPAN_AXES", Shared::U32(SPAN_AXES)),
    ("TERMS_ALL", Shared::U32(TERMS_ALL)),
];

/// The size of every struct a shader reads or writes through a buffer, by its WGSL name.
pub const STRUCT_SIZES: [(&str, usize); 15] = [
    ("Params", std::mem::size_of::<Params>()),
    ("AxisData", std::mem::size_of::<AxisData>()),
    ("Function", std::mem::size_of::<Function>()),
    ("Piece", std::mem::size_of::<Piece>()),
    ("DevData", std::mem::size_of::<DevData>()),
    ("Factor", std::mem::size_of::<Factor>()),
    ("Group", std::mem::size_of::<Group>()),
    ("SampleParams", std::mem::size_of::<SampleParams>()),
    ("SamplePoint", std::mem::size_of::<SamplePoint>()),
    ("Term", std::mem::size_of::<Term>()),
    ("Location", std::mem::size_of::<Location>()),
    ("XPoly", std::mem::size_of::<XPoly>()),
    ("Partial", std::mem::size_of::<Partial>()),
    ("FoldedPart", std::mem::size_of::<FoldedPart>()),
    (
        "UncertaintyParams",
        std::mem::size_of::<UncertaintyParams>(),
    ),
];

/// A 3×3 matrix in the upper-left of a WGSL `mat4x4<f32>`, column-major.
pub type Mat4 = [[f32; 4]; 4];

/// `struct Params` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Params {
    /// Commanded X, Y, Z of grid point (0, 0, 0), mm; w unused.
    pub origin: [f32; 4],
    /// Grid step along X, Y, Z, mm; w unused.
    pub spacing: [f32; 4],
    /// nx, ny, nz, number of axes.
    pub grid: [u32; 4],
    /// Axis-value entries and group entries (each per machine), perturbation terms, machines in
    /// the batch (1 for a map).
    pub counts: [u32; 4],
    /// First line of this chunk, lines in this chunk, points per invocation of the point pass,
    /// invocations per group of lines (the point pass's tiling, see `shaders/chain.wgsl`).
    pub chunk: [u32; 4],
    /// First entry of each group table in the group values: PA, PB (Pre), QA, QB (Post); for
    /// `folded_main`, the axes `[first, end)` composed at every point, then unused.
    pub group_starts: [u32; 4],
    /// X's nominal motion along x̂ (`q` times X's sense) at the centre index, its step per index,
    /// the centre index (X's polynomials are in `t = i − centre`); w unused.
    pub x_motion: [f32; 4],
    /// `EXX EYX EZX` as polynomials in `t`: `x_translation[k]` holds the three `c_k`.
    pub x_translation: [[f32; 4]; 4],
    /// `EAX EBX ECX` likewise.
    pub x_rotation: [[f32; 4]; 4],
}
const _: () = assert!(std::mem::size_of::<Params>() == 7 * 16 + 8 * 16);

/// One axis of the chain, in product order: `struct AxisData` in `shaders/chain.wgsl`.
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
    /// Kind (`KIND_*`), driver (grid dimension 0..3 or `SOURCE_FIXED`), rotation axis index
    /// (0 = x, 1 = y, 2 = z), index of the axis's first entry in the axis-value table.
    pub info: [u32; 4],
    /// x: the commanded position when the driver is fixed (mm or degrees).
    pub fixed_q: [f32; 4],
    /// Function indices of `EXk EYk EZk EAk`.
    pub functions_a: [u32; 4],
    /// Function indices of `EBk ECk`, the axis's letter index (X Y Z A B C: 0..5), unused.
    pub functions_b: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<AxisData>() == 176);

impl AxisData {
    /// `KIND_LINEAR` or `KIND_ROTARY`.
    pub fn kind(&self) -> u32 {
        self.info[0]
    }

    /// The grid dimension that drives the axis, or `SOURCE_FIXED`.
    pub fn driver(&self) -> u32 {
        self.info[1]
    }

    /// The axis's first entry in the axis-value table.
    pub fn first_entry(&self) -> u32 {
        self.info[3]
    }
}

/// One error function: `struct Function` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Function {
    /// First piece, number of pieces, flags (`FUNCTION_*`), the next function of a sum
    /// (`NO_FUNCTION`: none); a two-axis table: its first coefficient, `nx | ny << 16`, flags,
    /// next.
    pub pieces: [u32; 4],
    /// Domain `lo`, `hi` (positions clamp into it), unused, unused.
    pub domain: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<Function>() == 32);

/// One polynomial piece: `struct Piece` in `shaders/chain.wgsl`.
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
/// columns of `M` with `d` in w. Written by the `axis_values` pass: `struct DevData` in
/// `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct DevData {
    pub r0_t0: [[f32; 4]; 3],
    pub m_d: [[f32; 4]; 3],
}
const _: () = assert!(std::mem::size_of::<DevData>() == 96);

/// One factor of a group: an axis-value entry or a constant transform (X's location,
/// `S·Trans(tool)`) of the machine's row of the `constants` buffer: `struct Factor` in
/// `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Factor {
    /// Source (`FACTOR_AXIS_ENTRY` or `FACTOR_CONSTANT`), the axis's first axis-value entry or the
    /// constant (`CONSTANT_X_LOCATION`, `CONSTANT_TAIL`), how it is indexed (`INDEX_ONE`,
    /// `INDEX_J`, `INDEX_K`), unused.
    pub info: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<Factor>() == 16);

impl Factor {
    /// An axis's entries of the axis-value table from `first_entry` on, indexed by `index`.
    pub fn axis_entry(first_entry: u32, index: u32) -> Factor {
        Factor {
            info: [FACTOR_AXIS_ENTRY, first_entry, index, 0],
        }
    }

    /// A constant transform of the machine: `CONSTANT_X_LOCATION` or `CONSTANT_TAIL`.
    pub fn constant(which: u32) -> Factor {
        Factor {
            info: [FACTOR_CONSTANT, which, INDEX_ONE, 0],
        }
    }

    /// How the factor's entries are indexed: `INDEX_ONE`, `INDEX_J` or `INDEX_K`.
    pub fn index(&self) -> u32 {
        self.info[2]
    }
}

/// One of the four group tables PA, PB, QA, QB: the product of a run of factors, tabulated
/// over its index: `struct Group` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub struct Group {
    /// First factor, factor count (0: the table is unused), how it is indexed (`INDEX_*`), first
    /// entry in the group values.
    pub info: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<Group>() == 16);

impl Group {
    pub fn new(first_factor: u32, factors: u32, index: u32, first_entry: u32) -> Group {
        Group {
            info: [first_factor, factors, index, first_entry],
        }
    }

    /// An unused table whose entries (none) would start at `first_entry`.
    pub fn unused(first_entry: u32) -> Group {
        Group::new(0, 0, INDEX_ONE, first_entry)
    }

    pub fn first_factor(&self) -> u32 {
        self.info[0]
    }

    pub fn factors(&self) -> u32 {
        self.info[1]
    }

    pub fn index(&self) -> u32 {
        self.info[2]
    }

    pub fn first_entry(&self) -> u32 {
        self.info[3]
    }
}

/// What the sampling kernel needs to know of the field and the dispatch: `struct SampleParams`
/// in `shaders/sample.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct SampleParams {
    /// nx, ny, nz of the whole grid; w unused.
    pub dims: [u32; 4],
    /// First z plane held in the field buffer, unused, points in this dispatch, unused.
    pub range: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<SampleParams>() == 32);

/// One position to sample: its grid cell and the fractions within it, found on the host in f64:
/// `struct SamplePoint` in `shaders/sample.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct SamplePoint {
    /// i, j, k of the cell's lower corner (k in the whole grid); w unused.
    pub cell: [u32; 4],
    /// Fractions along x, y, z in [0, 1] (0 along a dimension one point deep); w unused.
    pub t: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<SamplePoint>() == 32);

/// A tolerance's deviation of a component error of a sampled machine: `struct Term` in
/// `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Term {
    /// Axis (product order), component (0..5), shape (`SHAPE_*`), index of its amplitude in a
    /// sample's row of amplitudes.
    pub info: [u32; 4],
    /// The axis's travel `a`, `b`; unused, unused.
    pub range: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<Term>() == 32);

/// An axis location of one sampled machine: `struct Location` in `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Location {
    /// `(EX0k, EY0k, EZ0k)`, mm.
    pub delta: [f32; 4],
    /// `Rot(EA0k, EB0k, EC0k) − I`, computed in f64.
    pub m: Mat4,
}
const _: () = assert!(std::mem::size_of::<Location>() == 80);

/// X's errors of one sampled machine as polynomials in `t = i − centre`: `struct XPoly` in
/// `shaders/chain.wgsl` (the layout of [`Params::x_translation`] and [`Params::x_rotation`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct XPoly {
    pub translation: [[f32; 4]; 4],
    pub rotation: [[f32; 4]; 4],
}
const _: () = assert!(std::mem::size_of::<XPoly>() == 128);

/// The statistics of one workgroup's points of one sampled machine: `struct Partial` in
/// `shaders/chain.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Partial {
    /// max |VE| (mm; −1 where the workgroup had no point), Σ |VE|², max |OE| (rad), unused.
    pub stats: [f32; 4],
    /// max |VE·x̂|, |VE·ŷ|, |VE·ẑ|, unused.
    pub axes: [f32; 4],
    /// The grid line and i of the max |VE|, unused, unused.
    pub at: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<Partial>() == 48);

/// One part of an axis's errors, the terms that read the same grid dimensions, tabulated over
/// them: `struct FoldedPart` in `shaders/folded.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct FoldedPart {
    /// First entry, entries, axis (product order), the grid dimensions it reads (bit d).
    pub table: [u32; 4],
    /// The entry's step per i, j, k (0 for a dimension the part does not read), unused.
    pub stride: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<FoldedPart>() == 32);

/// `struct UncertaintyParams` in `shaders/uncertainty.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct UncertaintyParams {
    /// Values in the chunk, 1 for the first term of the sums (it writes them), then unused.
    pub counts: [u32; 4],
    /// The factor of `a − b`; then unused.
    pub scale: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<UncertaintyParams>() == 32);
