//! The map of a machine whose error values read other axes' positions (`of`, `table2d`, `sum`),
//! and the statistics of batches of such sampled machines (`shaders/folded.wgsl`). Each term of
//! an error value reads one or two grid indices (its axis's own, the axes it names), so each
//! axis's errors are a sum of parts, one per set of grid dimensions its terms read, each
//! tabulated on the device over exactly those dimensions. The axes that do not vary along a grid
//! line are composed once per line, and per point only the parts that read i are added. A map is
//! a batch of one machine without deviations; a batch's fields are reduced on the device.
//!
//! The tables of one machine hold, per part, one entry per value of the one or two dimensions it
//! reads: at most the grid's largest face (NX·NY, NY·NZ or NX·NZ) per part, 32 bytes an entry
//! (their layout: [`super::fold_layout`]).

use super::fold_layout::FoldedLayout;
use super::mapper::{GpuMapper, LineTiles, SampledKernel};
use super::sampled::{add_partials, finish_stats, workgroups, Base};
use super::{check_error_angles, Tiling, BYTES_PER_POINT};
use crate::gpu::device::{Buffer, Pass, Readback};
use crate::gpu::layout::{DevData, Location, Partial, CONSTANTS_PER_SAMPLE};
use crate::gpu::GpuError;
use crate::model::grid::Grid;
use crate::model::perturbation::Perturbation;
use crate::model::statistics::FieldStats;
use crate::model::Machine;

/// A machine and its perturbations on the device, with the buffers of one batch.
struct Folded {
    base: Base,
    layout: FoldedLayout,
    batch: usize,
    /// Perturbation terms (at least one: the amplitudes' stride).
    terms: u32,
    params: Buffer,
    values_bindings: crate::gpu::device::Bindings,
    /// The chunks in flight at once: each its parameters, results and their bindings.
    slots: Vec<Slot>,
    values_kernel: std::sync::Arc<crate::gpu::device::Kernel>,
    folded_kernel: std::sync::Arc<crate::gpu::device::Kernel>,
    amplitudes: Buffer,
    locations: Buffer,
    constants: Buffer,
}

/// One chunk in flight: its parameters, what `folded_main` writes (the chunk's field, or the
/// batch's partials) and where it is read back.
struct Slot {
    params: Buffer,
    results: Buffer,
    staging: Buffer,
    bindings: crate::gpu::device::Bindings,
}

/// How one chunk of lines is dispatched: the point pass's tiling with one line per invocation.
struct ChunkDispatch {
    tiles: LineTiles,
    /// Workgroups along a line, line groups.
    workgroups: [u32; 2],
}

impl ChunkDispatch {
    fn of(
        mapper: &GpuMapper,
        lines: u64,
        nx: u64,
        x_alone: bool,
    ) -> Result<ChunkDispatch, GpuError> {
        let tiling = mapper.tiling_of_folded(nx, x_alone);
        let max_groups = mapper.gpu.max_workgroups_per_dimension() as u64;
        let tiles = LineTiles::of(tiling, nx, max_groups)
            .filter(|t| t.line_groups(lines) as u64 <= max_groups)
            .ok_or_else(|| {
                mapper.error(format!(
                    "{lines} lines of {nx} points need more workgroups than one dispatch holds"
                ))
            })?;
        Ok(ChunkDispatch {
            workgroups: [tiles.x_groups, tiles.line_groups(lines)],
            tiles,
        })
    }

    fn groups(&self) -> u64 {
        self.workgroups[0] as u64 * self.workgroups[1] as u64
    }

    /// The most lines of `nx` points one dispatch takes.
    fn max_lines(mapper: &GpuMapper, nx: u64, x_alone: bool) -> u64 {
        let max_groups = mapper.gpu.max_workgroups_per_dimension() as u64;
        ChunkDispatch::of(mapper, 1, nx, x_alone)
            .map_or(1, |d| max_groups * d.tiles.lines_per_workgroup)
    }
}

impl GpuMapper {
    /// Refuses, before any work (a field file created, a kernel compiled), a grid whose error
    /// tables for `machine` (of errors that read other axes' positions) exceed one buffer of
    /// this adapter.
    pub fn check_grid_tables(&self, machine: &Machine, grid: &Grid) -> Result<(), GpuError> {
        self.check_tables(machine, grid, &FoldedLayout::new(machine, grid))
    }

    fn check_tables(
        &self,
        machine: &Machine,
        grid: &Grid,
        layout: &FoldedLayout,
    ) -> Result<(), GpuError> {
        let binding = self.gpu.max_storage_binding_bytes();
        if layout.bytes() > binding {
            return Err(GpuError::GridTables {
                machine: machine.name.clone(),
                grid: crate::model::grid::dims_text(grid.dims),
                adapter: self.adapter_name().to_string(),
                bytes: layout.bytes(),
                limit: binding,
            });
        }
        Ok(())
    }

    /// Uploads `machine` with its tables' `layout` over `grid`, compiles the kernels and sizes
    /// the buffers for batches of up to `samples` machines whose chunks' results take
    /// `result_bytes(batch)`: the field of one chunk, or with `reduce` the partials of a batch
    /// (`result_bytes(1)` per machine).
    fn prepare_folded(
        &self,
        (machine, perturbations): (&Machine, &[Perturbation]),
        (grid, layout): (&Grid, FoldedLayout),
        (samples, slots): (usize, usize),
        reduce: bool,
        result_bytes: impl Fn(u64) -> u64,
    ) -> Result<Folded, GpuError> {
        let base = Base::new(machine, perturbations, grid);
        self.check_tables(machine, grid, &layout)?;
        let terms = perturbations.len().max(1) as u64;
        let order = base.order.len() as u64;
        let per_sample = layout.bytes()
            + order * std::mem::size_of::<Location>() as u64
            + CONSTANTS_PER_SAMPLE as u64 * std::mem::size_of::<DevData>() as u64
            + terms * 4
            + if reduce { result_bytes(1) } else { 0 };
        let batch = self.batch_size(per_sample).min(samples.max(1));
        let b = batch as u64;
        let gpu = &self.gpu;
        let packed = &base.packed;
        let params = gpu.uniform("folded params", bytemuck::bytes_of(&packed.params));
        let axes = gpu.storage("axes", &packed.axes);
        let functions = gpu.storage("functions", &packed.functions);
        let pieces = gpu.storage("pieces", &packed.pieces);
        let coefficients = gpu.storage("coefficients", &packed.coefficients);
        let terms_buffer = gpu.storage("terms", &base.terms);
        let folded_parts = gpu.storage("folded parts", &layout.parts);
        let folded_axes = gpu.storage("folded axes", &layout.axes);
        let amplitudes = gpu.writable("amplitudes", b * terms * 4);
        let locations = gpu.writable(
            "locations",
            (b * order).max(1) * std::mem::size_of::<Location>() as u64,
        );
        let constants = gpu.writable(
            "constants",
            b * CONSTANTS_PER_SAMPLE as u64 * std::mem::size_of::<DevData>() as u64,
        );
        let x_errors = gpu.output("folded parts' values", (b * layout.bytes()).max(32));
        // The buffer `folded_main` does not write in this mode.
        let unused = gpu.output("unused", 48);
        let values_kernel = self.sampled_kernel(SampledKernel::FoldedValues)?;
        let folded_kernel = self.sampled_kernel(SampledKernel::Folded {
            x_alone: layout.x_alone,
            reduce,
            lines_per_lane: self
                .tiling_of_folded(grid.dims[0] as u64, layout.x_alone)
                .lines_per_lane,
        })?;
        let values_bindings = gpu.bind(
            &values_kernel,
            &[
                (0, &params),
                (1, &axes),
                (2, &functions),
                (3, &pieces),
                (4, &coefficients),
                (8, &x_errors),
                (12, &terms_buffer),
                (13, &amplitudes),
                (19, &folded_parts),
            ],
        );
        let slots = (0..slots.max(1))
            .map(|_| {
                let params = gpu.uniform("folded chunk params", bytemuck::bytes_of(&packed.params));
                let results = gpu.output("folded results", result_bytes(b).max(16));
                let staging = gpu.staging("folded staging", result_bytes(b).max(16));
                let (out, partials) = if reduce {
                    (&unused, &results)
                } else {
                    (&results, &unused)
                };
                let bindings = gpu.bind(
                    &folded_kernel,
                    &[
                        (0, &params),
                        (1, &axes),
                        (7, out),
                        (21, &x_errors),
                        (11, &constants),
                        (14, &locations),
                        (16, partials),
                        (19, &folded_parts),
                        (20, &folded_axes),
                    ],
                );
                Slot {
                    params,
                    results,
                    staging,
                    bindings,
                }
            })
            .collect();
        Ok(Folded {
            base,
            layout,
            batch,
            terms: terms as u32,
            params,
            values_bindings,
            slots,
            values_kernel,
            folded_kernel,
            amplitudes,
            locations,
            constants,
        })
    }

    /// Uploads the batch `rows` and fills its tables.
    fn fold_batch(
        &self,
        folded: &Folded,
        machine: &Machine,
        perturbations: &[Perturbation],
        rows: &[Vec<f64>],
        grid: &Grid,
    ) -> Result<(), GpuError> {
        let data = self.batch_data(machine, perturbations, &folded.base, rows, grid)?;
        let gpu = &self.gpu;
        gpu.write(&folded.amplitudes, bytemuck::cast_slice(&data.amplitudes));
        gpu.write(&folded.locations, bytemuck::cast_slice(&data.locations));
        gpu.write(&folded.constants, bytemuck::cast_slice(&data.constants));
        let samples = rows.len() as u32;
        let mut params = folded.base.packed.params;
        let layout = &folded.layout;
        params.counts = [layout.entries, 0, folded.terms, samples];
        params.group_starts = [layout.span.0, layout.span.1, 0, 0];
        gpu.write(&folded.params, bytemuck::bytes_of(&params));
        // Workgroups for `count` invocations of each sample, in rows of at most the device's
        // limit.
        let rows_of = |count: u64| {
            let groups = workgroups(count) as u64;
            let rows = groups.div_ceil(gpu.max_workgroups_per_dimension() as u64);
            [groups.div_ceil(rows) as u32, rows as u32, samples]
        };
        gpu.submit(
            &[Pass {
                kernel: &folded.values_kernel,
                bindings: &folded.values_bindings,
                workgroups: rows_of(layout.entries as u64),
            }],
            None,
        );
        Ok(())
    }

    /// Writes the parameters of chunk `(first_line, lines)` of `samples` machines into `slot`
    /// and returns how it is dispatched.
    fn set_chunk(
        &self,
        folded: &Folded,
        slot: &Slot,
        (first_line, lines): (u64, u64),
        samples: u32,
        grid: &Grid,
    ) -> Result<ChunkDispatch, GpuError> {
        let dispatch = ChunkDispatch::of(self, lines, grid.dims[0] as u64, folded.layout.x_alone)?;
        let mut params = folded.base.packed.params;
        params.counts = [folded.layout.entries, 0, folded.terms, samples];
        params.chunk = [
            first_line as u32,
            lines as u32,
            dispatch.tiles.points_per_invocation,
            dispatch.tiles.invocations_per_line_group,
        ];
        params.group_starts = [folded.layout.span.0, folded.layout.span.1, 0, 0];
        self.gpu.write(&slot.params, bytemuck::bytes_of(&params));
        Ok(dispatch)
    }

    /// Sets the chunk `(first_line, lines)` of `samples` machines and dispatches `folded_main`
    /// over it in slot `slot`, its results copied to the slot's staging buffer.
    fn submit_folded_chunk(
        &self,
        folded: &Folded,
        slot: &Slot,
        (first_line, lines): (u64, u64),
        samples: u32,
        result_bytes: u64,
        grid: &Grid,
    ) -> Result<crate::gpu::device::Submission, GpuError> {
        let dispatch = self.set_chunk(folded, slot, (first_line, lines), samples, grid)?;
        let submission = self.gpu.submit(
            &[Pass {
                kernel: &folded.folded_kernel,
                bindings: &slot.bindings,
                workgroups: [dispatch.workgroups[0], dispatch.workgroups[1], samples],
            }],
            Some(Readback {
                from: &slot.results,
                to: &slot.staging,
                bytes: result_bytes,
            }),
        );
        Ok(submission)
    }
}

impl GpuMapper {
    /// [`GpuMapper::run`] for a machine with errors of other axes' positions: its tables filled
    /// once, then chunk after chunk, each read back while the next computes.
    pub(super) fn run_folded<E: From<GpuError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        check_error_angles(machine, grid)?;
        let nx = grid.dims[0] as u64;
        // A chunk holds whole lines: at least one, whatever is asked, as on the CPU.
        let device_limit = self.max_chunk_points();
        let limit = chunk_points.map_or(device_limit, |c| c.max(nx).min(device_limit));
        if nx > limit {
            return Err(self
                .error(format!(
                    "a line of {nx} points does not fit in one chunk of at most {limit} points"
                ))
                .into());
        }
        let layout = FoldedLayout::new(machine, grid);
        let x_alone = layout.x_alone;
        let lines = (limit / nx).clamp(1, ChunkDispatch::max_lines(self, nx, x_alone));
        let chunks = grid.chunks(lines * nx);
        let chunk_lines = chunks.most_lines().max(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let folded = self.prepare_folded((machine, &[]), (grid, layout), (1, 2), false, |_| {
            chunk_bytes
        })?;
        self.fold_batch(&folded, machine, &[], &[Vec::new()], grid)?;
        let mut deliver = |submission, slot: &Slot, (first, lines): (u64, u64)| {
            let bytes = lines * nx * BYTES_PER_POINT;
            self.gpu.read(submission, &slot.staging, bytes, |data| {
                on_chunk(first, lines, bytemuck::cast_slice(data))
            })?
        };
        let mut pending = None;
        for (n, chunk) in chunks.iter().enumerate() {
            let slot = &folded.slots[n % folded.slots.len()];
            let bytes = chunk.1 * nx * BYTES_PER_POINT;
            let submission = self.submit_folded_chunk(&folded, slot, chunk, 1, bytes, grid)?;
            if let Some((previous, slot, chunk)) = pending.replace((submission, slot, chunk)) {
                deliver(previous, slot, chunk)?;
            }
        }
        if let Some((previous, slot, chunk)) = pending {
            deliver(previous, slot, chunk)?;
        }
        Ok(())
    }

    /// [`GpuMapper::variant_stats`] for a machine with errors of other axes' positions: batch
    /// after batch, each sample's tables filled on the device and its field reduced there to
    /// the partials of its workgroups; nothing per point is read back.
    pub(super) fn variant_stats_folded(
        &self,
        machine: &Machine,
        perturbations: &[Perturbation],
        rows: &[Vec<f64>],
        grid: &Grid,
        mut on_batch: impl FnMut(usize),
    ) -> Result<Vec<FieldStats>, GpuError> {
        let nx = grid.dims[0] as u64;
        let layout = FoldedLayout::new(machine, grid);
        let x_alone = layout.x_alone;
        let chunks = grid.chunks(ChunkDispatch::max_lines(self, nx, x_alone) * nx);
        let mut most_groups = 1;
        for (_, lines) in chunks.iter() {
            most_groups = most_groups.max(ChunkDispatch::of(self, lines, nx, x_alone)?.groups());
        }
        let partial = std::mem::size_of::<Partial>() as u64;
        let folded = self.prepare_folded(
            (machine, perturbations),
            (grid, layout),
            (rows.len(), 1),
            true,
            |batch| batch * most_groups * partial,
        )?;
        let mut stats = vec![FieldStats::default(); rows.len()];
        let mut done = 0;
        for batch_rows in rows.chunks(folded.batch) {
            self.fold_batch(&folded, machine, perturbations, batch_rows, grid)?;
            let samples = batch_rows.len();
            let batch_stats = &mut stats[done..done + samples];
            let mut best: Vec<(f64, u64)> = vec![(-1.0, u64::MAX); samples];
            for chunk in chunks.iter() {
                let groups = ChunkDispatch::of(self, chunk.1, nx, x_alone)?.groups();
                let bytes = samples as u64 * groups * partial;
                let slot = &folded.slots[0];
                let submission =
                    self.submit_folded_chunk(&folded, slot, chunk, samples as u32, bytes, grid)?;
                self.gpu.read(submission, &slot.staging, bytes, |data| {
                    add_partials(
                        bytemuck::cast_slice(data),
                        groups,
                        nx,
                        batch_stats,
                        &mut best,
                    )
                })?;
            }
            finish_stats(batch_stats, best, grid);
            done += samples;
            on_batch(done);
        }
        Ok(stats)
    }
}

impl GpuMapper {
    /// How `folded_main` divides the lines of `machine` over `grid` among its invocations.
    pub fn folded_tiling(&self, machine: &Machine, grid: &Grid) -> Tiling {
        self.tiling_of_folded(
            grid.dims[0] as u64,
            FoldedLayout::new(machine, grid).x_alone,
        )
    }

    /// Where X alone varies along a line, the point pass's tiling (a point reads X's part of i
    /// once for all of an invocation's lines); otherwise one line an invocation. On a CPU
    /// adapter, which runs an invocation's points one after another, each invocation takes
    /// whole lines, so that their other axes are composed once (measured on lavapipe: about
    /// 4.7 µs an invocation, 0.11 µs a point, with the span's axes composed per point). A
    /// tiling set by hand ([`GpuMapper::set_tiling`]) is taken as it is.
    fn tiling_of_folded(&self, nx: u64, x_alone: bool) -> Tiling {
        let own = self.tiling();
        let points_per_lane = if self.gpu.is_software() && own == super::SOFTWARE_TILING {
            own.points_per_lane.max(nx)
        } else {
            own.points_per_lane
        };
        Tiling {
            lines_per_lane: if x_alone { own.lines_per_lane } else { 1 },
            points_per_lane,
        }
    }

    /// The seconds `folded_main` takes over the whole grid of a machine with errors of other
    /// axes' positions (its tables filled before, nothing read back), and the write-only kernel
    /// with the same dispatch and output (its ceiling), taking turns `runs` times after warming
    /// up for `warm_up_s` seconds; and whether timestamp queries timed them.
    pub fn time_folded(
        &self,
        machine: &Machine,
        grid: &Grid,
        runs: usize,
        warm_up_s: f64,
    ) -> Result<([Vec<f64>; 2], bool), GpuError> {
        check_error_angles(machine, grid)?;
        let nx = grid.dims[0] as u64;
        let layout = FoldedLayout::new(machine, grid);
        let lines = (self.max_chunk_points() / nx)
            .clamp(1, ChunkDispatch::max_lines(self, nx, layout.x_alone));
        let chunks = grid.chunks(lines * nx);
        let chunk_lines = chunks.most_lines().max(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let slots = chunks.len().min(2);
        let folded =
            self.prepare_folded((machine, &[]), (grid, layout), (1, slots), false, |_| {
                chunk_bytes
            })?;
        self.fold_batch(&folded, machine, &[], &[Vec::new()], grid)?;
        let write_only = self.write_only_kernel(1)?;
        let ceiling_bindings: Vec<_> = folded
            .slots
            .iter()
            .map(|s| {
                self.gpu
                    .bind(&write_only, &[(0, &s.params), (7, &s.results)])
            })
            .collect();
        let pass = |ceiling: bool, timer: Option<&crate::gpu::device::Timer>| {
            let mut last = None;
            for (n, (first_line, lines)) in chunks.iter().enumerate() {
                let slot = &folded.slots[n % folded.slots.len()];
                let dispatch = self.set_chunk(&folded, slot, (first_line, lines), 1, grid)?;
                let (kernel, bindings) = if ceiling {
                    (&*write_only, &ceiling_bindings[n % folded.slots.len()])
                } else {
                    (&*folded.folded_kernel, &slot.bindings)
                };
                let pass = Pass {
                    kernel,
                    bindings,
                    workgroups: [dispatch.workgroups[0], dispatch.workgroups[1], 1],
                };
                let submission = self
                    .gpu
                    .submit_timed(&[pass], None, timer.map(|t| (t, n as u32)));
                // A slot's parameters are rewritten two chunks later: wait for it first.
                if slots < chunks.len() {
                    self.gpu.wait(submission)?;
                } else {
                    last = Some(submission);
                }
            }
            match last {
                Some(last) => self.gpu.wait(last),
                None => Ok(()),
            }
        };
        let (mut seconds, timestamps) =
            self.take_turns(2, chunks.len(), (runs, warm_up_s), |k, timer| {
                pass(k == 1, timer)
            })?;
        let ceiling = seconds.pop().expect("the ceiling's runs");
        let kernel = seconds.pop().expect("the kernel's runs");
        Ok(([kernel, ceiling], timestamps))
    }
}
