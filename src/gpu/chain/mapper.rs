//! The chain kernel on an open device: the per-map passes, the chunks planned per tiling, the
//! point pass dispatched chunk by chunk with the readback of one overlapping the compute of the
//! next (the kernels timed for `volmap bench`: [`super::timing`]).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::pack::{pack, MachineShape, Packed, PointVariant};
use super::{
    check_error_angles, KernelChoice, Tiling, BYTES_PER_POINT, CHAIN_WGSL, DEFAULT_CHUNK_POINTS,
    DEFAULT_CHUNK_POINTS_HARDWARE, HARDWARE_TILING, SOFTWARE_TILING,
};
use crate::gpu::device::{self, Buffer, Gpu, Pass, Readback};
use crate::gpu::layout::{DevData, Params, WORKGROUP_SIZE};
use crate::gpu::GpuError;
use crate::model::grid::{Chunks, Grid};
use crate::model::Machine;

/// The buffers of one chunk in flight.
struct InFlight {
    params: Buffer,
    output: Buffer,
    staging: Buffer,
}

/// How one tiling dispatches a chunk: its pipelines, their bindings to each chunk's buffers,
/// how the invocations divide the lines.
pub(super) struct Plan {
    pub tiling: Tiling,
    /// Points per invocation (`Params::chunk[2]`).
    points_per_invocation: u32,
    /// Invocations that share a group of lines (`Params::chunk[3]`).
    invocations_per_line_group: u32,
    x_groups: u32,
    lines_per_workgroup: u64,
    points: Arc<device::Kernel>,
    write_only: Arc<device::Kernel>,
    /// Per chunk in flight: the point pass's bindings, the write-only kernel's.
    bindings: Vec<(device::Bindings, device::Bindings)>,
}

/// A map ready to run: the machine on the device, its axis values and groups computed, the
/// chunks planned for one or more tilings.
pub(super) struct Prepared {
    params: Params,
    nx: u64,
    pub chunks: Chunks,
    in_flight: Vec<InFlight>,
    pub plans: Vec<Plan>,
}

/// What the per-map passes leave on the device for the point pass.
pub(super) struct MapTables {
    pub group_values: Buffer,
    pub x_errors: Buffer,
}

/// A cache of pipelines compiled on first use, one per key.
type Pipelines<K> = Mutex<HashMap<K, Arc<device::Kernel>>>;

/// The chain kernels on an open device.
pub struct GpuMapper {
    pub(super) gpu: Gpu,
    axis_values: device::Kernel,
    groups: device::Kernel,
    /// The point pass per variant (its override constants).
    pub(super) points: Pipelines<PointVariant>,
    /// The sums of the uncertainty of a map (`shaders/uncertainty.wgsl`), compiled when first
    /// asked for.
    pub(super) accumulate: Pipelines<()>,
    /// The write-only ceiling per lines per invocation.
    write_only: Pipelines<u32>,
    /// The kernels of sampled machines, compiled when first asked for.
    pub(super) sampled: Pipelines<SampledKernel>,
    tiling: Tiling,
}

/// A kernel of batches of sampled machines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum SampledKernel {
    AxisValues,
    Groups,
    Positions,
    /// The tables of the errors of a machine with errors of other axes' positions
    /// (`folded_values_main`).
    FoldedValues,
    /// Its map (`folded_main`): X alone varying along a line or not, the field stored or
    /// reduced, lines per invocation.
    Folded {
        x_alone: bool,
        reduce: bool,
        lines_per_lane: u32,
    },
    /// The reduce pass of a shape of machine and a tiling.
    Reduce(PointVariant),
}

/// How a tiling divides a chunk of lines `nx` long among the point pass's invocations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct LineTiles {
    /// Points per invocation (`Params::chunk[2]`).
    pub points_per_invocation: u32,
    /// Invocations that share a group of lines (`Params::chunk[3]`).
    pub invocations_per_line_group: u32,
    /// Workgroups along a line.
    pub x_groups: u32,
    pub lines_per_workgroup: u64,
}

impl LineTiles {
    pub(super) fn of(tiling: Tiling, nx: u64, max_groups: u64) -> Option<LineTiles> {
        let workgroup = WORKGROUP_SIZE as u64;
        // Up to points_per_lane points per invocation; lines shorter than a workgroup's worth
        // share it (invocations per group of lines a power of two).
        let lanes_per_line = nx
            .div_ceil(tiling.points_per_lane)
            .next_power_of_two()
            .min(workgroup);
        let x_groups = nx.div_ceil(lanes_per_line * tiling.points_per_lane);
        (x_groups <= max_groups).then(|| LineTiles {
            points_per_invocation: nx.div_ceil(lanes_per_line * x_groups) as u32,
            invocations_per_line_group: lanes_per_line as u32,
            x_groups: x_groups as u32,
            lines_per_workgroup: workgroup / lanes_per_line * tiling.lines_per_lane as u64,
        })
    }

    /// Workgroups along the lines for `lines` lines.
    pub(super) fn line_groups(&self, lines: u64) -> u32 {
        lines.div_ceil(self.lines_per_workgroup) as u32
    }
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
            sampled: Mutex::new(HashMap::new()),
            accumulate: Mutex::new(HashMap::new()),
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
    pub(super) fn pipeline<K: Copy + Eq + std::hash::Hash + std::fmt::Debug>(
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

    /// The write-only kernel with `lines_per_lane` lines per invocation.
    pub(super) fn write_only_kernel(
        &self,
        lines_per_lane: u32,
    ) -> Result<Arc<device::Kernel>, GpuError> {
        self.pipeline(
            &self.write_only,
            lines_per_lane,
            "write_only_main",
            &[("LINES_PER_LANE", lines_per_lane as f64)],
        )
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

    pub(super) fn error(&self, message: String) -> GpuError {
        GpuError::Runtime {
            adapter: self.adapter_name().to_string(),
            message,
        }
    }

    /// The chunks of whole lines a map of `grid` is computed in on this device, at most
    /// `chunk_points` points each where asked (a chunk holds at least one line, whatever is
    /// asked, as on the CPU).
    pub(super) fn chunks_of(
        &self,
        grid: &Grid,
        chunk_points: Option<u64>,
    ) -> Result<Chunks, GpuError> {
        let nx = grid.dims[0] as u64;
        let device_limit = self.max_chunk_points();
        let limit = chunk_points.map_or(device_limit, |c| c.max(nx).min(device_limit));
        if nx > limit {
            return Err(self.error(format!(
                "a line of {nx} points does not fit in one chunk of at most {limit} points"
            )));
        }
        let lines_per_chunk = (limit / nx).min(self.max_chunk_lines()).max(1);
        Ok(grid.chunks(lines_per_chunk * nx))
    }

    /// Uploads the machine, computes its axis values and groups, and plans the chunks for each
    /// of `tilings`.
    pub(super) fn prepare(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        tilings: &[Tiling],
    ) -> Result<Prepared, GpuError> {
        check_error_angles(machine, grid)?;
        super::check_own_axis_errors(machine)?;
        let packed = pack(machine, grid);
        let nx = grid.dims[0] as u64;
        let chunks = self.chunks_of(grid, chunk_points)?;
        let chunk_lines = chunks.most_lines().max(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let tables = self.per_map_passes(&packed, nx)?;
        let in_flight: Vec<InFlight> = (0..2.min(chunks.len()))
            .map(|_| InFlight {
                params: self
                    .gpu
                    .uniform("chunk params", bytemuck::bytes_of(&packed.params)),
                output: self.gpu.output("output", chunk_bytes),
                staging: self.gpu.staging("staging", chunk_bytes),
            })
            .collect();
        let plans = tilings
            .iter()
            .map(|&tiling| self.plan(tiling, packed.shape, nx, &tables, &in_flight))
            .collect::<Result<Vec<Plan>, GpuError>>()?;
        Ok(Prepared {
            params: packed.params,
            nx,
            chunks,
            in_flight,
            plans,
        })
    }

    /// Uploads the packed machine and runs the per-map passes: every axis at every grid value it
    /// takes, then the group tables. Returns what the point pass reads of them.
    pub(super) fn per_map_passes(&self, packed: &Packed, nx: u64) -> Result<MapTables, GpuError> {
        let gpu = &self.gpu;
        let [entries, group_entries, _, _] = packed.params.counts.map(u64::from);
        let params = gpu.uniform("params", bytemuck::bytes_of(&packed.params));
        let axes = gpu.storage("axes", &packed.axes);
        let functions = gpu.storage("functions", &packed.functions);
        let pieces = gpu.storage("pieces", &packed.pieces);
        let coefficients = gpu.storage("coefficients", &packed.coefficients);
        let groups = gpu.storage("groups", &packed.groups);
        let factors = gpu.storage("factors", &packed.factors);
        let constants = gpu.storage("constants", &packed.constants);
        let entry_bytes = std::mem::size_of::<DevData>() as u64;
        let axis_values = gpu.output("axis values", entries.max(1) * entry_bytes);
        let group_values = gpu.output("group values", group_entries.max(1) * entry_bytes);
        let x_errors = gpu.output("x errors", 2 * 16 * nx);
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
                (11, &constants),
            ],
        );
        let workgroup = WORKGROUP_SIZE as u64;
        let dispatch = |count: u64, what: &str| -> Result<u32, GpuError> {
            let groups = count.div_ceil(workgroup).max(1);
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
        Ok(MapTables {
            group_values,
            x_errors,
        })
    }

    /// How `tiling` dispatches a chunk of lines `nx` long, with its pipelines bound to each
    /// chunk's buffers.
    fn plan(
        &self,
        tiling: Tiling,
        shape: MachineShape,
        nx: u64,
        tables: &MapTables,
        in_flight: &[InFlight],
    ) -> Result<Plan, GpuError> {
        let tiles = LineTiles::of(tiling, nx, self.gpu.max_workgroups_per_dimension() as u64)
            .ok_or_else(|| {
                self.error(format!(
                    "a line of {nx} points needs more workgroups than one dispatch holds"
                ))
            })?;
        let variant = PointVariant {
            shape,
            lines_per_lane: tiling.lines_per_lane,
        };
        let points = self.pipeline(&self.points, variant, "points_main", &variant.constants())?;
        let write_only = self.pipeline(
            &self.write_only,
            tiling.lines_per_lane,
            "write_only_main",
            &[("LINES_PER_LANE", tiling.lines_per_lane as f64)],
        )?;
        let bindings = in_flight
            .iter()
            .map(|chunk| {
                (
                    self.gpu.bind(
                        &points,
                        &[
                            (0, &chunk.params),
                            (6, &tables.group_values),
                            (7, &chunk.output),
                            (8, &tables.x_errors),
                        ],
                    ),
                    self.gpu
                        .bind(&write_only, &[(0, &chunk.params), (7, &chunk.output)]),
                )
            })
            .collect();
        Ok(Plan {
            tiling,
            points_per_invocation: tiles.points_per_invocation,
            invocations_per_line_group: tiles.invocations_per_line_group,
            x_groups: tiles.x_groups,
            lines_per_workgroup: tiles.lines_per_workgroup,
            points,
            write_only,
            bindings,
        })
    }

    /// Submits chunk `n` of `prepared` with plan `plan` into its buffers, with or without the copy
    /// to the host.
    pub(super) fn submit_chunk(
        &self,
        prepared: &Prepared,
        plan: usize,
        n: usize,
        choice: KernelChoice,
        readback: bool,
        timed: Option<(&device::Timer, u32)>,
    ) -> device::Submission {
        let (first_line, lines) = prepared.chunks.get(n);
        let buffers = n % prepared.in_flight.len();
        let chunk = &prepared.in_flight[buffers];
        let plan = &prepared.plans[plan];
        let mut params = prepared.params;
        params.chunk = [
            first_line as u32,
            lines as u32,
            plan.points_per_invocation,
            plan.invocations_per_line_group,
        ];
        self.gpu.write(&chunk.params, bytemuck::bytes_of(&params));
        let (point_bindings, write_only_bindings) = &plan.bindings[buffers];
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
            from: &chunk.output,
            to: &chunk.staging,
            bytes: lines * prepared.nx * BYTES_PER_POINT,
        });
        self.gpu.submit_timed(&[pass], copy, timed)
    }

    /// Computes the map chunk by chunk. `on_chunk(first_line, lines, data)` receives each chunk's
    /// output in line order: for each line, `nx` values of each channel of [`CHANNELS`](crate::model::channels::CHANNELS).
    /// `chunk_points` caps the points per chunk below the device's own limit.
    pub fn run<E: From<GpuError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        if machine.has_cross_axis_errors() {
            return self.run_folded(machine, grid, chunk_points, on_chunk);
        }
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
        let (first_line, lines) = prepared.chunks.get(n);
        let chunk = &prepared.in_flight[n % prepared.in_flight.len()];
        let bytes = lines * prepared.nx * BYTES_PER_POINT;
        self.gpu.read(submission, &chunk.staging, bytes, |data| {
            on_chunk(first_line, lines, bytemuck::cast_slice(data))
        })?
    }
}
