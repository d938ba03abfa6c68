//! The GPU engine: the machine packed into the buffers of `shaders/chain.wgsl`, and the map
//! computed chunk by chunk with the readback of one chunk overlapping the compute of the next.

pub mod device;
pub mod layout;
pub mod sample;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use nalgebra::{Matrix3, Vector3};

use crate::grid::Grid;
use crate::machine::{AxisLetter, Machine};
use crate::reference;
pub use device::GpuError;
use device::{Buffer, Gpu, Pass, Readback};
use layout::{AxisData, DevData, Function, LineData, Mat4, Params, Piece, CHANNELS};
pub use sample::{GpuSampler, SAMPLE_WGSL};

/// The chain kernel's WGSL source.
pub const CHAIN_WGSL: &str = include_str!("../../shaders/chain.wgsl");
/// Invocations per workgroup; keep in sync with `@workgroup_size` in `shaders/chain.wgsl`.
pub const WORKGROUP_SIZE: u64 = 64;
/// The most points each invocation of the point pass computes along its line, sharing the line's
/// values among them (on lavapipe 8, 16 and 32 gave about 62, 77 and 85 Mpts/s).
pub const MAX_POINTS_PER_LANE: u64 = 32;
/// Bytes of output per grid point: six f32 channels.
pub const BYTES_PER_POINT: u64 = (CHANNELS.len() * 4) as u64;
/// The default upper bound of points per chunk on a CPU adapter: two chunks in flight hold about
/// 100 MB (measured on lavapipe, larger chunks are no faster).
pub const DEFAULT_CHUNK_POINTS: u64 = 1 << 20;
/// The same on a hardware GPU, where a chunk of 1 Mi points takes well under a millisecond and the
/// host's work per chunk would cap the rate: two chunks in flight hold about 800 MB (output and
/// staging), still bounded whatever the grid.
pub const DEFAULT_CHUNK_POINTS_HARDWARE: u64 = 1 << 23;

/// The machine and grid as the shader's buffers. Built on the host in f64, stored in f32.
#[derive(Debug, Clone)]
pub struct Packed {
    pub params: Params,
    pub axes: Vec<AxisData>,
    pub functions: Vec<Function>,
    pub pieces: Vec<Piece>,
    /// Flat coefficients, padded to whole vec4s.
    pub coefficients: Vec<[f32; 4]>,
    /// The shape of the machine the point pass is compiled for.
    pub variant: PointVariant,
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
pub fn check_error_angles(machine: &Machine, grid: &Grid) -> Result<(), String> {
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
        Err(format!(
            "the angular errors of {} add up to {total:.3} rad over this grid; the GPU kernels take error rotations below {MAX_ERROR_ANGLE_RAD} rad (angular errors are in rad: check the units), --device cpu has no such limit",
            machine.name
        ))
    }
}

/// Packs the machine and the grid for the chain kernel.
pub fn pack(machine: &Machine, grid: &Grid) -> Packed {
    let mut functions = Vec::new();
    let mut pieces = Vec::new();
    let mut flat: Vec<f32> = Vec::new();
    let mut axes = Vec::new();
    let mut entries = 0u32;
    let mut x_position = None;
    let mut rotary_before_x = false;
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
        if letter == AxisLetter::X {
            x_position = Some(axes.len() as u32);
        }
        rotary_before_x |= !letter.is_linear() && x_position.is_none();
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
    }
    while flat.len() % 4 != 0 {
        flat.push(0.0);
    }
    let coefficients = flat.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();

    // X's errors that are one polynomial piece of degree ≤ 3 are evaluated by the point pass
    // from workgroup-uniform coefficients instead of gathered per point from the x_errors table.
    let mut x_poly = [[0.0f32; 4]; 6];
    let mut x_poly_span = [[0.0f32; 4]; 6];
    let mut inline = [true; 6];
    if let Some(x) = machine.axis(AxisLetter::X) {
        for (n, component) in x.components.iter().enumerate() {
            let Some(f) = component.as_ref().filter(|f| !f.is_zero()) else {
                continue;
            };
            let form = f.pieces();
            match form.pieces.as_slice() {
                [piece] if !form.periodic && piece.coefficients.len() <= 4 => {
                    for (c, &value) in piece.coefficients.iter().enumerate() {
                        x_poly[n][c] = value as f32;
                    }
                    x_poly_span[n] = [
                        piece.start as f32,
                        finite_or_unbounded(form.lo),
                        finite_or_unbounded(form.hi),
                        0.0,
                    ];
                }
                _ => inline[n] = false,
            }
        }
    }
    // S · Trans(tool) = [(I + M_S), tool + e_S + M_S·tool].
    let [exs, eys, ezs, eas, ebs] = machine.spindle;
    let spindle_m = rot_deviation(eas, ebs, 0.0);
    let tool = Vector3::from(machine.tool_offset_mm);
    let tail_delta = Vector3::new(exs, eys, ezs) + spindle_m * tool;
    let params = Params {
        origin: vec4_of(grid.origin_mm),
        spacing: vec4_of(grid.spacing_mm),
        grid: [
            grid.dims[0] as u32,
            grid.dims[1] as u32,
            grid.dims[2] as u32,
            axes.len() as u32,
        ],
        chunk: [0, 0, x_position.unwrap_or(axes.len() as u32), entries],
        tail_offset: vec4_of(machine.tool_offset_mm),
        tail_delta: vec4_of(tail_delta.into()),
        tail_m: mat4_of(&spindle_m),
        options: [0; 4],
        x_poly,
        x_poly_span,
    };
    let variant = PointVariant {
        rotary_before_x,
        has_x: x_position.is_some(),
        x_translations_inline: inline[..3].iter().all(|&b| b),
        x_rotations_inline: inline[3..].iter().all(|&b| b),
    };
    Packed {
        params,
        axes,
        functions,
        pieces,
        coefficients,
        variant,
    }
}

/// The chain kernels on an open device.
pub struct GpuMapper {
    gpu: Gpu,
    axis_values: device::Kernel,
    line_values: device::Kernel,
    /// The point pass per shape of machine (its override constants), compiled when first used.
    points: Mutex<HashMap<PointVariant, Arc<device::Kernel>>>,
    write_only: device::Kernel,
}

/// The shape of a machine as the point pass sees it: its pipeline-overridable constants (see
/// `shaders/chain.wgsl`), one compiled pipeline per shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PointVariant {
    /// A rotary axis stands before X in the product order (Pre has a nominal rotation).
    pub rotary_before_x: bool,
    /// The chain has an X axis.
    pub has_x: bool,
    /// X's translations (EXX EYX EZX) are single polynomial pieces, in `Params::x_poly`.
    pub x_translations_inline: bool,
    /// X's rotations (EAX EBX ECX) are single polynomial pieces, in `Params::x_poly`.
    pub x_rotations_inline: bool,
}

impl PointVariant {
    fn constants(&self) -> [(&'static str, f64); 4] {
        let value = |b: bool| if b { 1.0 } else { 0.0 };
        [
            ("ROTARY_BEFORE_X", value(self.rotary_before_x)),
            ("HAS_X", value(self.has_x)),
            ("X_TRANSLATIONS_INLINE", value(self.x_translations_inline)),
            ("X_ROTATIONS_INLINE", value(self.x_rotations_inline)),
        ]
    }
}

/// Which per-chunk work [`GpuMapper::time_kernel`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KernelChoice {
    /// The line and point passes of the chain.
    Chain,
    /// A kernel with the same dispatch and output that computes nothing: the ceiling.
    WriteOnly,
}

/// The buffers of one chunk in flight.
struct Slot {
    params: Buffer,
    output: Buffer,
    staging: Buffer,
    line_bindings: device::Bindings,
    point_bindings: device::Bindings,
    write_only_bindings: device::Bindings,
}

/// A map ready to run: the machine on the device, its axis values computed, the chunks planned.
struct Prepared {
    params: Params,
    nx: u64,
    x_groups: u32,
    lines_per_group: u64,
    chunks: Vec<(u64, u64)>,
    slots: Vec<Slot>,
    points: Arc<device::Kernel>,
}

impl GpuMapper {
    /// `Ok(None)` when there is no adapter.
    pub fn open() -> Result<Option<GpuMapper>, GpuError> {
        let Some(gpu) = Gpu::open()? else {
            return Ok(None);
        };
        let kernel = |entry: &str| gpu.kernel(&format!("chain.wgsl {entry}"), CHAIN_WGSL, entry);
        let axis_values = kernel("axis_values_main")?;
        let line_values = kernel("line_values_main")?;
        let write_only = kernel("write_only_main")?;
        Ok(Some(GpuMapper {
            gpu,
            axis_values,
            line_values,
            points: Mutex::new(HashMap::new()),
            write_only,
        }))
    }

    pub fn adapter_name(&self) -> &str {
        self.gpu.adapter_name()
    }

    /// The point pass for this shape of machine, compiled the first time it is asked for.
    fn points_kernel(&self, variant: PointVariant) -> Result<Arc<device::Kernel>, GpuError> {
        let mut cache = self.points.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(kernel) = cache.get(&variant) {
            return Ok(kernel.clone());
        }
        let kernel = Arc::new(self.gpu.kernel_with_constants(
            &format!("chain.wgsl points_main {variant:?}"),
            CHAIN_WGSL,
            "points_main",
            &variant.constants(),
        )?);
        cache.insert(variant, kernel.clone());
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

    /// The most lines one chunk may hold: one workgroup row per line.
    pub fn max_chunk_lines(&self) -> u64 {
        let by_binding =
            self.gpu.max_storage_binding_bytes() / std::mem::size_of::<LineData>() as u64;
        (self.gpu.max_workgroups_per_dimension() as u64).min(by_binding)
    }

    fn error(&self, message: String) -> GpuError {
        GpuError::Runtime {
            adapter: self.adapter_name().to_string(),
            message,
        }
    }

    /// Uploads the machine, computes its axis values and plans the chunks.
    fn prepare(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
    ) -> Result<Prepared, GpuError> {
        check_error_angles(machine, grid).map_err(|message| self.error(message))?;
        let packed = pack(machine, grid);
        let nx = grid.dims[0] as u64;
        let gpu = &self.gpu;
        let limit =
            chunk_points.map_or(self.max_chunk_points(), |c| c.min(self.max_chunk_points()));
        // Up to MAX_POINTS_PER_LANE points per invocation; lines shorter than a workgroup's
        // worth share it (lanes per line a power of two).
        let lanes_per_line = nx
            .div_ceil(MAX_POINTS_PER_LANE)
            .next_power_of_two()
            .min(WORKGROUP_SIZE);
        let lines_per_group = WORKGROUP_SIZE / lanes_per_line;
        let x_groups = nx.div_ceil(lanes_per_line * MAX_POINTS_PER_LANE);
        if nx > limit || x_groups > gpu.max_workgroups_per_dimension() as u64 {
            return Err(self.error(format!(
                "a line of {nx} points does not fit in one chunk of at most {limit} points"
            )));
        }
        let lines_per_chunk = (limit / nx).min(self.max_chunk_lines()).max(1);
        let chunks = grid.chunks(lines_per_chunk * nx);
        let chunk_lines = chunks.iter().map(|&(_, lines)| lines).max().unwrap_or(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let entries = packed.params.chunk[3] as u64;

        let params = gpu.uniform("params", bytemuck::bytes_of(&packed.params));
        let axes = gpu.storage("axes", bytemuck::cast_slice(&packed.axes));
        let functions = gpu.storage("functions", bytemuck::cast_slice(&packed.functions));
        let pieces = gpu.storage("pieces", bytemuck::cast_slice(&packed.pieces));
        let coefficients = gpu.storage("coefficients", bytemuck::cast_slice(&packed.coefficients));
        let axis_values = gpu.output(
            "axis values",
            entries.max(1) * std::mem::size_of::<DevData>() as u64,
        );
        let x_errors = gpu.output("x errors", 2 * 16 * nx);

        // Every axis at every grid value it takes, once per map.
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
        let groups = entries.div_ceil(WORKGROUP_SIZE);
        if groups > gpu.max_workgroups_per_dimension() as u64 {
            return Err(self.error(format!("{entries} axis values exceed one dispatch")));
        }
        gpu.submit(
            &[Pass {
                kernel: &self.axis_values,
                bindings: &axis_bindings,
                workgroups: [groups as u32, 1, 1],
            }],
            None,
        );

        let points = self.points_kernel(packed.variant)?;
        let slots = (0..2.min(chunks.len()))
            .map(|_| {
                let params = gpu.uniform("chunk params", bytemuck::bytes_of(&packed.params));
                let lines = gpu.output(
                    "line values",
                    chunk_lines * std::mem::size_of::<LineData>() as u64,
                );
                let output = gpu.output("output", chunk_bytes);
                let staging = gpu.staging("staging", chunk_bytes);
                let line_bindings = gpu.bind(
                    &self.line_values,
                    &[(0, &params), (1, &axes), (5, &axis_values), (6, &lines)],
                );
                let point_bindings = gpu.bind(
                    &points,
                    &[
                        (0, &params),
                        (1, &axes),
                        (6, &lines),
                        (7, &output),
                        (8, &x_errors),
                    ],
                );
                let write_only_bindings = gpu.bind(&self.write_only, &[(0, &params), (7, &output)]);
                Slot {
                    params,
                    output,
                    staging,
                    line_bindings,
                    point_bindings,
                    write_only_bindings,
                }
            })
            .collect();
        let mut params = packed.params;
        params.options[1] = nx.div_ceil(lanes_per_line * x_groups) as u32;
        params.options[2] = lanes_per_line as u32;
        Ok(Prepared {
            points,
            params,
            nx,
            x_groups: x_groups as u32,
            lines_per_group,
            chunks,
            slots,
        })
    }

    /// Submits chunk `n` of `prepared` into its slot, with or without the copy to the host.
    fn submit_chunk(
        &self,
        prepared: &Prepared,
        n: usize,
        choice: KernelChoice,
        readback: bool,
        timed: Option<(&device::Timer, u32)>,
    ) -> device::Submission {
        let (first_line, lines) = prepared.chunks[n];
        let slot = &prepared.slots[n % prepared.slots.len()];
        let mut params = prepared.params;
        params.chunk[0] = first_line as u32;
        params.chunk[1] = lines as u32;
        self.gpu.write(&slot.params, bytemuck::bytes_of(&params));
        let point_grid = [
            prepared.x_groups,
            lines.div_ceil(prepared.lines_per_group) as u32,
            1,
        ];
        let chain = [
            Pass {
                kernel: &self.line_values,
                bindings: &slot.line_bindings,
                workgroups: [lines.div_ceil(WORKGROUP_SIZE) as u32, 1, 1],
            },
            Pass {
                kernel: &prepared.points,
                bindings: &slot.point_bindings,
                workgroups: point_grid,
            },
        ];
        let write_only = [Pass {
            kernel: &self.write_only,
            bindings: &slot.write_only_bindings,
            workgroups: point_grid,
        }];
        let passes: &[Pass] = match choice {
            KernelChoice::Chain => &chain,
            KernelChoice::WriteOnly => &write_only,
        };
        let copy = readback.then(|| Readback {
            from: &slot.output,
            to: &slot.staging,
            bytes: lines * prepared.nx * BYTES_PER_POINT,
        });
        self.gpu.submit_timed(passes, copy, timed)
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
        let prepared = self.prepare(machine, grid, chunk_points)?;
        let mut pending: Option<(device::Submission, usize)> = None;
        for n in 0..prepared.chunks.len() {
            let submission = self.submit_chunk(&prepared, n, KernelChoice::Chain, true, None);
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

    /// The seconds one pass over the whole grid takes on the device (best of `runs`) for each
    /// kernel of `choices`, and whether timestamp queries timed them. The kernels take turns, run
    /// after run, so a ceiling and the kernel it bounds are measured under the same conditions.
    pub fn time_kernels(
        &self,
        machine: &Machine,
        grid: &Grid,
        choices: &[KernelChoice],
        runs: usize,
    ) -> Result<(Vec<f64>, bool), GpuError> {
        let prepared = self.prepare(machine, grid, None)?;
        // Let the axis pass and any lazy driver work finish before the clock starts.
        for &choice in choices {
            let warm_up = self.submit_chunk(&prepared, 0, choice, false, None);
            self.gpu.wait(warm_up)?;
        }
        let timer = self.gpu.timer(prepared.chunks.len());
        let mut best = vec![f64::INFINITY; choices.len()];
        for _ in 0..runs.max(1) {
            for (k, &choice) in choices.iter().enumerate() {
                let start = std::time::Instant::now();
                let mut last = None;
                for n in 0..prepared.chunks.len() {
                    let timed = timer.as_ref().map(|t| (t, n as u32));
                    last = Some(self.submit_chunk(&prepared, n, choice, false, timed));
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

    /// [`GpuMapper::time_kernels`] for one kernel.
    pub fn time_kernel(
        &self,
        machine: &Machine,
        grid: &Grid,
        choice: KernelChoice,
        runs: usize,
    ) -> Result<(f64, bool), GpuError> {
        let (seconds, timestamps) = self.time_kernels(machine, grid, &[choice], runs)?;
        Ok((seconds[0], timestamps))
    }
}
