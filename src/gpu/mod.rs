//! The GPU engine: the machine packed into the buffers of `shaders/chain.wgsl`, and the map
//! computed chunk by chunk with the readback of one chunk overlapping the compute of the next.
//!
//! Per map, two passes evaluate every axis at its grid values (the machine's error tables on the
//! GPU) and fold the chain on either side of X into at most two tables each; per chunk, one pass
//! composes each line's products from those tables and evaluates its points.

pub mod device;
pub mod layout;
pub mod sample;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use nalgebra::Matrix3;

use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::{Axis, AxisLetter, Machine};
use crate::reference::{self, Twin};
pub use device::GpuError;
use device::{Buffer, Gpu, Pass, Readback};
use layout::{AxisData, DevData, Factor, Function, Group, Mat4, Params, Piece};
pub use sample::{GpuSampler, SAMPLE_WGSL};

/// The chain kernel's WGSL source.
pub const CHAIN_WGSL: &str = include_str!("../../shaders/chain.wgsl");
/// Invocations per workgroup; keep in sync with `@workgroup_size` in `shaders/chain.wgsl`.
pub const WORKGROUP_SIZE: u64 = 64;
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
/// tilings measured on lavapipe, see the README's performance section).
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

/// The machine and grid as the shader's buffers. Built on the host in f64, stored in f32.
#[derive(Debug, Clone)]
pub struct Packed {
    pub params: Params,
    pub axes: Vec<AxisData>,
    pub functions: Vec<Function>,
    pub pieces: Vec<Piece>,
    /// Flat coefficients, padded to whole vec4s.
    pub coefficients: Vec<[f32; 4]>,
    /// PA, PB, QA, QB: the group tables the group pass fills.
    pub groups: [Group; 4],
    /// The factors of the groups, group after group.
    pub factors: Vec<Factor>,
    /// The shape of the machine the point pass is compiled for.
    pub shape: MachineShape,
}

fn mat4_of(m: &Matrix3<f64>) -> Mat4 {
    let mut out = [[0.0f32; 4]; 4];
    for (c, column) in out.iter_mut().enumerate().take(3) {
        for (r, value) in column.iter_mut().enumerate().take(3) {
            *value = m[(r, c)] as f32;
        }
    }
    out
}

fn vec4_of(v: [f64; 3]) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, 0.0]
}

fn finite_or_unbounded(x: f64) -> f32 {
    if x.is_finite() {
        x as f32
    } else {
        x.signum() as f32 * layout::UNBOUNDED
    }
}

/// `Rot(a, b, c) − I` in f64, exact, then small enough to keep its precision in f32.
fn rot_deviation(a: f64, b: f64, c: f64) -> Matrix3<f64> {
    reference::rot(a, b, c)
        .fixed_view::<3, 3>(0, 0)
        .into_owned()
        - Matrix3::identity()
}

/// The kernels' series for small rotations are exact in f32 for angles below this, rad.
pub const MAX_ERROR_ANGLE_RAD: f64 = 0.1;

/// Checks that the machine's error rotations stay small over the grid: the sum of the magnitudes
/// of every angular error (component, location, spindle) below [`MAX_ERROR_ANGLE_RAD`]. Real
/// machines are below 1e-3 rad; larger values are a unit mistake (degrees or µrad for rad).
pub fn check_error_angles(machine: &Machine, grid: &Grid) -> Result<(), GpuError> {
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

/// The deviation form `[(I + M)·R0, t0 + d]` of the transform from `ideal` to `real`, both
/// computed in f64: `R0 = R_ideal`, `t0 = t_ideal`, `M = R_real·R_idealᵀ − I`, `d = t_real − t_ideal`.
fn deviation_form(real: &reference::Transform, ideal: &reference::Transform) -> DevData {
    let r_real = real.fixed_view::<3, 3>(0, 0);
    let r_ideal = ideal.fixed_view::<3, 3>(0, 0);
    let m = r_real * r_ideal.transpose() - Matrix3::identity();
    let t0 = ideal.fixed_view::<3, 1>(0, 3);
    let d = real.fixed_view::<3, 1>(0, 3) - t0;
    DevData {
        r0_t0: std::array::from_fn(|c| {
            [
                r_ideal[(0, c)] as f32,
                r_ideal[(1, c)] as f32,
                r_ideal[(2, c)] as f32,
                t0[c] as f32,
            ]
        }),
        m_d: std::array::from_fn(|c| {
            [
                m[(0, c)] as f32,
                m[(1, c)] as f32,
                m[(2, c)] as f32,
                d[c] as f32,
            ]
        }),
    }
}

fn constant_factor(value: DevData) -> Factor {
    Factor {
        info: [layout::FACTOR_CONSTANT, 0, 0, 0],
        value,
    }
}

/// Splits one side of X (its factors in product order) into at most two runs with at most one
/// factor each that varies along the grid (Y with j, Z with k): the second run starts at the
/// second varying factor. Returns each run with the dimension it varies along (0: none).
fn split_side(side: &[Factor]) -> Vec<(&[Factor], u32)> {
    let varying: Vec<usize> = (0..side.len()).filter(|&n| side[n].info[2] != 0).collect();
    debug_assert!(
        varying.len() <= 2,
        "only Y and Z vary along a line's neighbours"
    );
    match varying.as_slice() {
        [first, second, ..] => vec![
            (&side[..*second], side[*first].info[2]),
            (&side[*second..], side[*second].info[2]),
        ],
        [only] => vec![(side, side[*only].info[2])],
        [] => vec![(side, 0)],
    }
}

/// `Σ c_k s^k` with `s = a + b·t`, as coefficients in `t` (f64, then f32).
fn polynomial_in_t(coefficients: &[f64], a: f64, b: f64) -> [f64; 4] {
    let mut out = [0.0; 4];
    for (k, &c) in coefficients.iter().enumerate() {
        // c·(a + b·t)^k = c·Σ_m C(k, m)·a^(k−m)·b^m·t^m
        let mut binomial = 1.0;
        for (m, slot) in out.iter_mut().enumerate().take(k + 1) {
            *slot += c * binomial * a.powi((k - m) as i32) * b.powi(m as i32);
            binomial = binomial * (k - m) as f64 / (m + 1) as f64;
        }
    }
    out
}

/// X's six component errors as polynomials of degree 3 at most in `t = i − centre`, where each is
/// one polynomial piece over every X of the grid (so the point pass evaluates it exactly, without
/// clamping, from coefficients every invocation shares); `None` for those that are not.
fn x_polynomials(x: &Axis, grid: &Grid, centre: f64) -> [Option<[f64; 4]>; 6] {
    let (origin, spacing) = (grid.origin_mm[0], grid.spacing_mm[0]);
    let (q_low, q_high) = (origin, origin + spacing * (grid.dims[0] - 1) as f64);
    std::array::from_fn(
        |n| match x.components[n].as_ref().filter(|f| !f.is_zero()) {
            None => Some([0.0; 4]),
            Some(f) => {
                let form = f.pieces();
                match form.pieces.as_slice() {
                    [piece]
                        if !form.periodic
                            && piece.coefficients.len() <= 4
                            && form.lo <= q_low
                            && q_high <= form.hi =>
                    {
                        Some(polynomial_in_t(
                            &piece.coefficients,
                            origin + spacing * centre - piece.start,
                            spacing,
                        ))
                    }
                    _ => None,
                }
            }
        },
    )
}

/// Packs the machine and the grid for the chain kernel.
pub fn pack(machine: &Machine, grid: &Grid) -> Packed {
    let twin = Twin::of(machine);
    let mut functions = Vec::new();
    let mut pieces = Vec::new();
    let mut flat: Vec<f32> = Vec::new();
    let mut axes = Vec::new();
    let mut entries = 0u32;
    // Pre: the axes before X in product order, then X's location; Post: the axes after X, then
    // S·Trans(tool). Without X every axis stands in Pre (a chain has at least one axis).
    let mut pre = Vec::new();
    let mut post = Vec::new();
    let mut x_seen = false;
    for axis in machine.axes_in_product_order() {
        let mut indices = [layout::NO_FUNCTION; 6];
        for (n, component) in axis.components.iter().enumerate() {
            let Some(f) = component.as_ref().filter(|f| !f.is_zero()) else {
                continue;
            };
            let form = f.pieces();
            indices[n] = functions.len() as u32;
            functions.push(Function {
                pieces: [
                    pieces.len() as u32,
                    form.pieces.len() as u32,
                    form.periodic as u32,
                    0,
                ],
                domain: [
                    finite_or_unbounded(form.lo),
                    finite_or_unbounded(form.hi),
                    0.0,
                    0.0,
                ],
            });
            for piece in &form.pieces {
                pieces.push(Piece {
                    start: piece.start as f32,
                    degree: piece.coefficients.len() as u32 - 1,
                    coefficient: flat.len() as u32,
                    _pad: 0,
                });
                flat.extend(piece.coefficients.iter().map(|&c| c as f32));
            }
        }
        let [ex, ey, ez, ea, eb, ec] = axis.location;
        let letter = axis.letter;
        let (kind, source, fixed) = if letter.is_linear() {
            (layout::KIND_LINEAR, letter.direction_index() as u32, 0.0)
        } else {
            (
                layout::KIND_ROTARY,
                layout::SOURCE_FIXED,
                grid.pose[letter.index()] as f32,
            )
        };
        let first_entry = entries;
        entries += if source == layout::SOURCE_FIXED {
            1
        } else {
            grid.dims[source as usize] as u32
        };
        axes.push(AxisData {
            offset: vec4_of(axis.offset_mm),
            location_delta: vec4_of([ex, ey, ez]),
            location_m: mat4_of(&rot_deviation(ea, eb, ec)),
            unit: vec4_of(axis.unit_vector()),
            info: [kind, source, letter.direction_index() as u32, first_entry],
            fixed_q: [fixed, 0.0, 0.0, 0.0],
            functions_a: [indices[0], indices[1], indices[2], indices[3]],
            functions_b: [
                indices[4],
                indices[5],
                layout::NO_FUNCTION,
                layout::NO_FUNCTION,
            ],
        });
        if letter == AxisLetter::X {
            x_seen = true;
            let ideal_x = twin.ideal().axis(AxisLetter::X).expect("same axes");
            pre.push(constant_factor(deviation_form(
                &reference::location(axis),
                &reference::location(ideal_x),
            )));
            continue;
        }
        let dimension = if source == layout::SOURCE_FIXED {
            0
        } else {
            source
        };
        let factor = Factor {
            info: [layout::FACTOR_AXIS_ENTRY, first_entry, dimension, 0],
            value: bytemuck::Zeroable::zeroed(),
        };
        // X's location closes Pre; the axes after it belong to Post.
        if x_seen {
            post.push(factor);
        } else {
            pre.push(factor);
        }
    }
    while flat.len() % 4 != 0 {
        flat.push(0.0);
    }
    let coefficients = flat.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();

    post.push(constant_factor(deviation_form(
        &reference::spindle_and_tool(machine),
        &reference::spindle_and_tool(twin.ideal()),
    )));

    // PA, PB from Pre, QA, QB from Post; a side with one run leaves its second slot unused.
    let mut groups = [Group::default(); 4];
    let mut factors = Vec::new();
    let mut slots = [SLOT_ABSENT; 4];
    let mut first_entries = [0u32; 4];
    let mut group_entries = 0u32;
    for (side, first_slot) in [(&pre, 0usize), (&post, 2usize)] {
        let runs = split_side(side);
        for slot in first_slot..first_slot + 2 {
            first_entries[slot] = group_entries;
            groups[slot].info[3] = group_entries;
            let Some(&(run, dimension)) = runs.get(slot - first_slot) else {
                continue;
            };
            groups[slot].info = [
                factors.len() as u32,
                run.len() as u32,
                dimension,
                group_entries,
            ];
            factors.extend_from_slice(run);
            slots[slot] = dimension;
            group_entries += if dimension == 0 {
                1
            } else {
                grid.dims[dimension as usize] as u32
            };
        }
    }
    let pre_varies = slots[..2].iter().any(|&s| s == SLOT_J || s == SLOT_K);

    // X's errors as polynomials in t = i − centre where each is one piece, else its table.
    let nx = grid.dims[0];
    let centre = (nx - 1) as f64 / 2.0;
    let (polynomials, sense) = match machine.axis(AxisLetter::X) {
        Some(x) => (x_polynomials(x, grid, centre), x.unit_vector()[0]),
        None => ([Some([0.0; 4]); 6], 0.0),
    };
    let coefficients_of = |group: &[Option<[f64; 4]>]| -> [[f32; 4]; 4] {
        std::array::from_fn(|k| {
            let c = |n: usize| group[n].map_or(0.0, |p| p[k]) as f32;
            [c(0), c(1), c(2), 0.0]
        })
    };
    let (origin_x, spacing_x) = (grid.origin_mm[0], grid.spacing_mm[0]);
    let params = Params {
        origin: vec4_of(grid.origin_mm),
        spacing: vec4_of(grid.spacing_mm),
        grid: [
            grid.dims[0] as u32,
            grid.dims[1] as u32,
            grid.dims[2] as u32,
            axes.len() as u32,
        ],
        counts: [entries, group_entries, 0, 0],
        chunk: [0; 4],
        slots: first_entries,
        x_motion: [
            (sense * (origin_x + spacing_x * centre)) as f32,
            (sense * spacing_x) as f32,
            centre as f32,
            0.0,
        ],
        x_translation: coefficients_of(&polynomials[..3]),
        x_rotation: coefficients_of(&polynomials[3..]),
    };
    let shape = MachineShape {
        slots,
        pre_varies,
        x_translation_table: polynomials[..3].iter().any(Option::is_none),
        x_rotation_table: polynomials[3..].iter().any(Option::is_none),
    };
    Packed {
        params,
        axes,
        functions,
        pieces,
        coefficients,
        groups,
        factors,
        shape,
    }
}

/// Where each group slot of the point pass comes from: its one entry, the line's j or k, or
/// nowhere (keep in sync with `SLOT_*` in `shaders/chain.wgsl`).
pub const SLOT_ONE: u32 = 0;
pub const SLOT_J: u32 = 1;
pub const SLOT_K: u32 = 2;
pub const SLOT_ABSENT: u32 = 3;

/// The shape of a machine as the point pass sees it: where each group slot comes from and where
/// X's errors do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MachineShape {
    /// Where PA, PB, QA, QB come from: `SLOT_ONE`, `SLOT_J`, `SLOT_K` or `SLOT_ABSENT`.
    pub slots: [u32; 4],
    /// Pre changes from line to line (Y or Z stands before X in the product order).
    pub pre_varies: bool,
    /// X's translations (EXX EYX EZX) come from the axis pass's table, not from polynomials.
    pub x_translation_table: bool,
    /// X's rotations (EAX EBX ECX) likewise.
    pub x_rotation_table: bool,
}

/// A shape of machine with the lines per invocation of a tiling: the point pass's
/// pipeline-overridable constants (see `shaders/chain.wgsl`), one compiled pipeline each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PointVariant {
    pub shape: MachineShape,
    pub lines_per_lane: u32,
}

impl PointVariant {
    fn constants(&self) -> [(&'static str, f64); 8] {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let shape = &self.shape;
        [
            ("LINES_PER_LANE", self.lines_per_lane as f64),
            ("PRE_A", shape.slots[0] as f64),
            ("PRE_B", shape.slots[1] as f64),
            ("POST_A", shape.slots[2] as f64),
            ("POST_B", shape.slots[3] as f64),
            ("PRE_VARIES", flag(shape.pre_varies)),
            ("X_TRANSLATION_TABLE", flag(shape.x_translation_table)),
            ("X_ROTATION_TABLE", flag(shape.x_rotation_table)),
        ]
    }
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

/// The buffers of one chunk in flight.
struct Slot {
    params: Buffer,
    output: Buffer,
    staging: Buffer,
}

/// How one tiling dispatches a chunk: its pipelines, their bindings to each slot, the shape of
/// the dispatch.
struct Plan {
    tiling: Tiling,
    /// Points per invocation and invocations per group of lines (`Params::chunk[2..4]`).
    shape: [u32; 2],
    x_groups: u32,
    lines_per_workgroup: u64,
    points: Arc<device::Kernel>,
    write_only: Arc<device::Kernel>,
    /// Per slot: the point pass's bindings, the write-only kernel's.
    bindings: Vec<(device::Bindings, device::Bindings)>,
}

/// A map ready to run: the machine on the device, its axis values and groups computed, the
/// chunks planned for one or more tilings.
struct Prepared {
    params: Params,
    nx: u64,
    chunks: Vec<(u64, u64)>,
    slots: Vec<Slot>,
    plans: Vec<Plan>,
}

/// A cache of pipelines compiled on first use, one per key.
type Pipelines<K> = Mutex<HashMap<K, Arc<device::Kernel>>>;

/// The chain kernels on an open device.
pub struct GpuMapper {
    gpu: Gpu,
    axis_values: device::Kernel,
    groups: device::Kernel,
    /// The point pass per variant (its override constants).
    points: Pipelines<PointVariant>,
    /// The write-only ceiling per lines per invocation.
    write_only: Pipelines<u32>,
    tiling: Tiling,
}

impl GpuMapper {
    /// `Ok(None)` when there is no adapter.
    pub fn open() -> Result<Option<GpuMapper>, GpuError> {
        let Some(gpu) = Gpu::open()? else {
            return Ok(None);
        };
        let kernel = |entry: &str| gpu.kernel(&format!("chain.wgsl {entry}"), CHAIN_WGSL, entry);
        let axis_values = kernel("axis_values_main")?;
        let groups = kernel("groups_main")?;
        let tiling = if gpu.is_software() {
            SOFTWARE_TILING
        } else {
            HARDWARE_TILING
        };
        Ok(Some(GpuMapper {
            gpu,
            axis_values,
            groups,
            points: Mutex::new(HashMap::new()),
            write_only: Mutex::new(HashMap::new()),
            tiling,
        }))
    }

    pub fn adapter_name(&self) -> &str {
        self.gpu.adapter_name()
    }

    /// The tiling maps use on this device.
    pub fn tiling(&self) -> Tiling {
        self.tiling
    }

    /// Maps with `tiling` from now on (tests cover every tiling on one device with it). Returns
    /// an error for a tiling the shader has no variant for.
    pub fn set_tiling(&mut self, tiling: Tiling) -> Result<(), GpuError> {
        if ![1, 2, 4].contains(&tiling.lines_per_lane) || tiling.points_per_lane == 0 {
            return Err(self.error(format!(
                "no point pass takes {} lines of {} points per invocation",
                tiling.lines_per_lane, tiling.points_per_lane
            )));
        }
        self.tiling = tiling;
        Ok(())
    }

    /// The tilings a write-only ceiling is measured with: the device's own, one line per
    /// invocation, and the defaults of both kinds of adapter. How fast the same values can be
    /// written depends on who writes which (by up to 2× on lavapipe), so the ceiling is the
    /// fastest of these, never only the chain's own.
    pub fn ceiling_tilings(&self) -> Vec<Tiling> {
        let mut tilings = Vec::new();
        for t in [
            self.tiling,
            Tiling {
                lines_per_lane: 1,
                ..self.tiling
            },
            SOFTWARE_TILING,
            HARDWARE_TILING,
        ] {
            if !tilings.contains(&t) {
                tilings.push(t);
            }
        }
        tilings
    }

    /// The pipeline for `key` from `cache`, compiled the first time it is asked for.
    fn pipeline<K: Copy + Eq + std::hash::Hash + std::fmt::Debug>(
        &self,
        cache: &Pipelines<K>,
        key: K,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> Result<Arc<device::Kernel>, GpuError> {
        let mut cache = cache.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(kernel) = cache.get(&key) {
            return Ok(kernel.clone());
        }
        let kernel = Arc::new(self.gpu.kernel_with_constants(
            &format!("chain.wgsl {entry} {key:?}"),
            CHAIN_WGSL,
            entry,
            constants,
        )?);
        cache.insert(key, kernel.clone());
        Ok(kernel)
    }

    /// The most points one chunk may hold on this device.
    pub fn max_chunk_points(&self) -> u64 {
        let default = if self.gpu.is_software() {
            DEFAULT_CHUNK_POINTS
        } else {
            DEFAULT_CHUNK_POINTS_HARDWARE
        };
        (self.gpu.max_storage_binding_bytes() / BYTES_PER_POINT).min(default)
    }

    /// The most lines one chunk may hold: as many as workgroups fit in one dispatch dimension,
    /// so the point pass's rows of workgroups fit whatever its tiling.
    pub fn max_chunk_lines(&self) -> u64 {
        self.gpu.max_workgroups_per_dimension() as u64
    }

    fn error(&self, message: String) -> GpuError {
        GpuError::Runtime {
            adapter: self.adapter_name().to_string(),
            message,
        }
    }

    /// Uploads the machine, computes its axis values and groups, and plans the chunks for each
    /// of `tilings`.
    fn prepare(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        tilings: &[Tiling],
    ) -> Result<Prepared, GpuError> {
        check_error_angles(machine, grid)?;
        let packed = pack(machine, grid);
        let nx = grid.dims[0] as u64;
        let gpu = &self.gpu;
        let limit =
            chunk_points.map_or(self.max_chunk_points(), |c| c.min(self.max_chunk_points()));
        if nx > limit {
            return Err(self.error(format!(
                "a line of {nx} points does not fit in one chunk of at most {limit} points"
            )));
        }
        let lines_per_chunk = (limit / nx).min(self.max_chunk_lines()).max(1);
        let chunks = grid.chunks(lines_per_chunk * nx);
        let chunk_lines = chunks.iter().map(|&(_, lines)| lines).max().unwrap_or(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let [entries, group_entries, _, _] = packed.params.counts.map(u64::from);

        let params = gpu.uniform("params", bytemuck::bytes_of(&packed.params));
        let axes = gpu.storage("axes", bytemuck::cast_slice(&packed.axes));
        let functions = gpu.storage("functions", bytemuck::cast_slice(&packed.functions));
        let pieces = gpu.storage("pieces", bytemuck::cast_slice(&packed.pieces));
        let coefficients = gpu.storage("coefficients", bytemuck::cast_slice(&packed.coefficients));
        let groups = gpu.storage("groups", bytemuck::cast_slice(&packed.groups));
        let factors = gpu.storage("factors", bytemuck::cast_slice(&packed.factors));
        let entry_bytes = std::mem::size_of::<DevData>() as u64;
        let axis_values = gpu.output("axis values", entries.max(1) * entry_bytes);
        let group_values = gpu.output("group values", group_entries.max(1) * entry_bytes);
        let x_errors = gpu.output("x errors", 2 * 16 * nx);

        // Every axis at every grid value it takes, then the groups of factors, once per map.
        let axis_bindings = gpu.bind(
            &self.axis_values,
            &[
                (0, &params),
                (1, &axes),
                (2, &functions),
                (3, &pieces),
                (4, &coefficients),
                (5, &axis_values),
                (8, &x_errors),
            ],
        );
        let group_bindings = gpu.bind(
            &self.groups,
            &[
                (0, &params),
                (5, &axis_values),
                (6, &group_values),
                (9, &groups),
                (10, &factors),
            ],
        );
        let dispatch = |count: u64, what: &str| -> Result<u32, GpuError> {
            let groups = count.div_ceil(WORKGROUP_SIZE).max(1);
            if groups > gpu.max_workgroups_per_dimension() as u64 {
                return Err(self.error(format!("{count} {what} exceed one dispatch")));
            }
            Ok(groups as u32)
        };
        gpu.submit(
            &[
                Pass {
                    kernel: &self.axis_values,
                    bindings: &axis_bindings,
                    workgroups: [dispatch(entries, "axis values")?, 1, 1],
                },
                Pass {
                    kernel: &self.groups,
                    bindings: &group_bindings,
                    workgroups: [dispatch(group_entries, "group entries")?, 1, 1],
                },
            ],
            None,
        );

        let slots: Vec<Slot> = (0..2.min(chunks.len()))
            .map(|_| Slot {
                params: gpu.uniform("chunk params", bytemuck::bytes_of(&packed.params)),
                output: gpu.output("output", chunk_bytes),
                staging: gpu.staging("staging", chunk_bytes),
            })
            .collect();
        let plans = tilings
            .iter()
            .map(|&tiling| {
                // Up to points_per_lane points per invocation; lines shorter than a workgroup's
                // worth share it (invocations per group of lines a power of two).
                let lanes_per_line = nx
                    .div_ceil(tiling.points_per_lane)
                    .next_power_of_two()
                    .min(WORKGROUP_SIZE);
                let x_groups = nx.div_ceil(lanes_per_line * tiling.points_per_lane);
                if x_groups > gpu.max_workgroups_per_dimension() as u64 {
                    return Err(self.error(format!(
                        "a line of {nx} points needs more workgroups than one dispatch holds"
                    )));
                }
                let variant = PointVariant {
                    shape: packed.shape,
                    lines_per_lane: tiling.lines_per_lane,
                };
                let points =
                    self.pipeline(&self.points, variant, "points_main", &variant.constants())?;
                let write_only = self.pipeline(
                    &self.write_only,
                    tiling.lines_per_lane,
                    "write_only_main",
                    &[("LINES_PER_LANE", tiling.lines_per_lane as f64)],
                )?;
                let bindings = slots
                    .iter()
                    .map(|slot| {
                        (
                            gpu.bind(
                                &points,
                                &[
                                    (0, &slot.params),
                                    (6, &group_values),
                                    (7, &slot.output),
                                    (8, &x_errors),
                                ],
                            ),
                            gpu.bind(&write_only, &[(0, &slot.params), (7, &slot.output)]),
                        )
                    })
                    .collect();
                Ok(Plan {
                    tiling,
                    shape: [
                        nx.div_ceil(lanes_per_line * x_groups) as u32,
                        lanes_per_line as u32,
                    ],
                    x_groups: x_groups as u32,
                    lines_per_workgroup: WORKGROUP_SIZE / lanes_per_line
                        * tiling.lines_per_lane as u64,
                    points,
                    write_only,
                    bindings,
                })
            })
            .collect::<Result<Vec<Plan>, GpuError>>()?;
        Ok(Prepared {
            params: packed.params,
            nx,
            chunks,
            slots,
            plans,
        })
    }

    /// Submits chunk `n` of `prepared` with plan `plan` into its slot, with or without the copy
    /// to the host.
    fn submit_chunk(
        &self,
        prepared: &Prepared,
        plan: usize,
        n: usize,
        choice: KernelChoice,
        readback: bool,
        timed: Option<(&device::Timer, u32)>,
    ) -> device::Submission {
        let (first_line, lines) = prepared.chunks[n];
        let slot_index = n % prepared.slots.len();
        let slot = &prepared.slots[slot_index];
        let plan = &prepared.plans[plan];
        let mut params = prepared.params;
        params.chunk = [
            first_line as u32,
            lines as u32,
            plan.shape[0],
            plan.shape[1],
        ];
        self.gpu.write(&slot.params, bytemuck::bytes_of(&params));
        let (point_bindings, write_only_bindings) = &plan.bindings[slot_index];
        let (kernel, bindings) = match choice {
            KernelChoice::Chain => (&plan.points, point_bindings),
            KernelChoice::WriteOnly => (&plan.write_only, write_only_bindings),
        };
        let pass = Pass {
            kernel,
            bindings,
            workgroups: [
                plan.x_groups,
                lines.div_ceil(plan.lines_per_workgroup) as u32,
                1,
            ],
        };
        let copy = readback.then(|| Readback {
            from: &slot.output,
            to: &slot.staging,
            bytes: lines * prepared.nx * BYTES_PER_POINT,
        });
        self.gpu.submit_timed(&[pass], copy, timed)
    }

    /// Computes the map chunk by chunk. `on_chunk(first_line, lines, data)` receives each chunk's
    /// output in line order: for each line, `nx` values of each channel of [`CHANNELS`].
    /// `chunk_points` caps the points per chunk below the device's own limit.
    pub fn run<E: From<GpuError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        let prepared = self.prepare(machine, grid, chunk_points, &[self.tiling])?;
        let mut pending: Option<(device::Submission, usize)> = None;
        for n in 0..prepared.chunks.len() {
            let submission = self.submit_chunk(&prepared, 0, n, KernelChoice::Chain, true, None);
            // Read the previous chunk while this one computes.
            if let Some((previous, p)) = pending.replace((submission, n)) {
                self.deliver(&prepared, previous, p, &mut on_chunk)?;
            }
        }
        if let Some((previous, p)) = pending {
            self.deliver(&prepared, previous, p, &mut on_chunk)?;
        }
        Ok(())
    }

    fn deliver<E: From<GpuError>>(
        &self,
        prepared: &Prepared,
        submission: device::Submission,
        n: usize,
        on_chunk: &mut impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        let (first_line, lines) = prepared.chunks[n];
        let slot = &prepared.slots[n % prepared.slots.len()];
        let bytes = lines * prepared.nx * BYTES_PER_POINT;
        self.gpu.read(submission, &slot.staging, bytes, |data| {
            on_chunk(first_line, lines, bytemuck::cast_slice(data))
        })?
    }

    /// The seconds one pass over the whole grid takes on the device (best of `runs`) for each of
    /// `kernels`, and whether timestamp queries timed them. The kernels take turns, run after
    /// run, so a ceiling and the kernel it bounds are measured under the same conditions.
    pub fn time_kernels(
        &self,
        machine: &Machine,
        grid: &Grid,
        kernels: &[TimedKernel],
        runs: usize,
    ) -> Result<(Vec<f64>, bool), GpuError> {
        let mut tilings: Vec<Tiling> = Vec::new();
        for kernel in kernels {
            if !tilings.contains(&kernel.tiling) {
                tilings.push(kernel.tiling);
            }
        }
        let prepared = self.prepare(machine, grid, None, &tilings)?;
        let plan_of = |kernel: &TimedKernel| {
            prepared
                .plans
                .iter()
                .position(|p| p.tiling == kernel.tiling)
                .expect("a plan per tiling")
        };
        // Let the per-map passes and any lazy driver work finish before the clock starts.
        for kernel in kernels {
            let warm_up =
                self.submit_chunk(&prepared, plan_of(kernel), 0, kernel.choice, false, None);
            self.gpu.wait(warm_up)?;
        }
        let timer = self.gpu.timer(prepared.chunks.len());
        let mut best = vec![f64::INFINITY; kernels.len()];
        for _ in 0..runs.max(1) {
            for (k, kernel) in kernels.iter().enumerate() {
                let plan = plan_of(kernel);
                let start = std::time::Instant::now();
                let mut last = None;
                for n in 0..prepared.chunks.len() {
                    let timed = timer.as_ref().map(|t| (t, n as u32));
                    last = Some(self.submit_chunk(&prepared, plan, n, kernel.choice, false, timed));
                }
                if let Some(last) = last {
                    self.gpu.wait(last)?;
                }
                let seconds = match &timer {
                    Some(t) => self.gpu.timed_seconds(t, prepared.chunks.len() as u32)?,
                    None => start.elapsed().as_secs_f64(),
                };
                best[k] = best[k].min(seconds);
            }
        }
        Ok((best, timer.is_some()))
    }

    /// [`GpuMapper::time_kernels`] for one kernel with this device's tiling.
    pub fn time_kernel(
        &self,
        machine: &Machine,
        grid: &Grid,
        choice: KernelChoice,
        runs: usize,
    ) -> Result<(f64, bool), GpuError> {
        let kernel = TimedKernel {
            choice,
            tiling: self.tiling,
        };
        let (seconds, timestamps) = self.time_kernels(machine, grid, &[kernel], runs)?;
        Ok((seconds[0], timestamps))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::embedded;

    #[test]
    fn polynomials_in_the_grid_index_equal_the_pieces() {
        let coefficients = [0.02, -3e-5, 4e-8, -2e-11];
        let (a, b) = (-137.5, 12.5);
        let in_t = polynomial_in_t(&coefficients, a, b);
        for t in [-40.0, -3.5, 0.0, 1.0, 17.25, 40.0] {
            let s = a + b * t;
            let want: f64 = coefficients.iter().rev().fold(0.0, |acc, c| acc * s + c);
            let got: f64 = in_t.iter().rev().fold(0.0, |acc, c| acc * t + c);
            assert!((want - got).abs() < 1e-15, "t = {t}: {want} vs {got}");
        }
        assert_eq!(polynomial_in_t(&[0.5], 3.0, 2.0), [0.5, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn each_side_folds_into_at_most_two_tables_by_j_or_k() {
        let grid = |m: &Machine, pose| Grid::full_travel(m, [5, 6, 7], pose).unwrap();
        // Li (FFXYZ): Pre is X's location alone, Post runs through Y then Z.
        let li = embedded::load("vmc-li2015").unwrap();
        let packed = pack(&li, &grid(&li, [0.0; 6]));
        assert_eq!(packed.shape.slots, [SLOT_ONE, SLOT_ABSENT, SLOT_J, SLOT_K]);
        assert!(!packed.shape.pre_varies);
        let entries: Vec<u32> = packed.groups.iter().map(|g| g.info[3]).collect();
        assert_eq!(entries, [0, 1, 1, 7]);
        assert_eq!(packed.params.counts[1], 1 + 6 + 7);
        // Hwang's 4-axis FYCFXZ (product order C Y X Z): Pre = C·Y(j)·L_X, Post = Z(k)·S·tool.
        let four = embedded::load("4axis-hwang2014").unwrap();
        let packed = pack(&four, &grid(&four, [0.0, 0.0, 0.0, 0.0, 0.0, 40.0]));
        assert_eq!(
            packed.shape.slots,
            [SLOT_J, SLOT_ABSENT, SLOT_K, SLOT_ABSENT]
        );
        assert!(packed.shape.pre_varies);
        assert_eq!(packed.groups[0].info[..3], [0, 3, 1]);
        assert_eq!(packed.groups[2].info[..3], [3, 2, 2]);
        // Without X every axis stands in Pre: Y(j) then Z(k).
        let travels = [(AxisLetter::Y, [0.0, 100.0]), (AxisLetter::Z, [0.0, 50.0])];
        let no_x = Machine::nominal("no X", "FYFZ", &travels).unwrap();
        let packed = pack(
            &no_x,
            &Grid::full_travel(&no_x, [1, 6, 7], [0.0; 6]).unwrap(),
        );
        assert_eq!(packed.shape.slots, [SLOT_J, SLOT_K, SLOT_ONE, SLOT_ABSENT]);
        assert!(packed.shape.pre_varies);
    }

    #[test]
    fn x_errors_are_polynomials_only_where_one_piece_covers_the_grid() {
        // The 5-axis machine's EXX is a cubic spline of four pieces; its other X errors are
        // polynomials or three-node tables over the whole travel.
        let five = embedded::load("5axis-hwang2014").unwrap();
        let packed = pack(
            &five,
            &Grid::full_travel(&five, [9, 4, 3], [0.0, 0.0, 0.0, 0.0, 30.0, 60.0]).unwrap(),
        );
        assert!(packed.shape.x_translation_table);
        assert!(!packed.shape.x_rotation_table);
        let li = embedded::load("vmc-li2015").unwrap();
        let grid = Grid::full_travel(&li, [9, 4, 3], [0.0; 6]).unwrap();
        let packed = pack(&li, &grid);
        assert!(!packed.shape.x_translation_table && !packed.shape.x_rotation_table);
        // EXX of Li is 2e-5·q: in t = i − 4 with 125 mm steps, 0.01 + 2.5e-3·t.
        let [c0, c1, c2, c3] = packed.params.x_translation.map(|c| c[0] as f64);
        assert!(
            (c0 - 0.01).abs() < 1e-9 && (c1 - 2.5e-3).abs() < 1e-9,
            "{c0} {c1}"
        );
        assert_eq!([c2, c3], [0.0, 0.0]);
        assert_eq!(packed.params.x_motion[..3], [500.0, 125.0, 4.0]);
    }
}
