//! The map of a machine whose error values read other axes' positions (`of`, `table2d`): the
//! per-map tables of the chain kernel hold each axis at the grid values of its own dimension
//! only, so such a machine is mapped point by point, each axis's errors evaluated at the point's
//! commanded positions. Where some axes do not vary along a grid line in X, `grid_runs_main`
//! composes them once per run of points along the line and evaluates the terms that do not read
//! X once per run too; where every axis varies, `grid_points_main` composes every axis at every
//! point (one point per invocation keeps more of the device busy). Slower than the folded chain,
//! exact to the same tolerance; chunk after chunk, each read back before the next.

use super::mapper::{GpuMapper, SampledKernel};
use super::pack::pack;
use super::{check_error_angles, BYTES_PER_POINT};
use crate::gpu::device::{Pass, Readback};
use crate::gpu::layout::{GRID_RUN, WORKGROUP_SIZE};
use crate::gpu::GpuError;
use crate::model::grid::Grid;
use crate::model::perturbation::Perturbation;
use crate::model::statistics::FieldStats;
use crate::model::{AxisLetter, Machine};

impl GpuMapper {
    /// [`GpuMapper::run`] for a machine with errors of other axes' positions.
    pub(super) fn run_per_point<E: From<GpuError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        check_error_angles(machine, grid)?;
        let packed = pack(machine, grid);
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
        let chunks = grid.chunks((limit / nx).max(1) * nx);
        let (first_x, last_x) = x_dependent_axes(machine);
        // Sharing the axes outside [first_x, last_x] along a run pays only where there are some;
        // where there are none, one point per invocation keeps more of the device busy.
        let every_axis_varies = first_x == 0 && last_x as usize + 1 == machine.axes.len();
        let (kernel, run) = if every_axis_varies {
            (SampledKernel::GridPoints, 1)
        } else {
            (SampledKernel::GridRuns, GRID_RUN)
        };
        let runs_per_line = nx.div_ceil(u64::from(run));
        let chunk_lines = chunks.iter().map(|&(_, lines)| lines).max().unwrap_or(1);
        let chunk_bytes = chunk_lines * nx * BYTES_PER_POINT;
        let gpu = &self.gpu;
        let kernel = self.sampled_kernel(kernel)?;
        let params = gpu.uniform("per-point params", bytemuck::bytes_of(&packed.params));
        let axes = gpu.storage("axes", &packed.axes);
        let functions = gpu.storage("functions", &packed.functions);
        let pieces = gpu.storage("pieces", &packed.pieces);
        let coefficients = gpu.storage("coefficients", &packed.coefficients);
        let constants = gpu.storage("constants", &packed.constants);
        let output = gpu.output("per-point output", chunk_bytes);
        let staging = gpu.staging("per-point staging", chunk_bytes);
        let bindings = gpu.bind(
            &kernel,
            &[
                (0, &params),
                (1, &axes),
                (2, &functions),
                (3, &pieces),
                (4, &coefficients),
                (7, &output),
                (11, &constants),
            ],
        );
        let max_groups = gpu.max_workgroups_per_dimension() as u64;
        for (first_line, lines) in chunks {
            let groups = (lines * runs_per_line).div_ceil(WORKGROUP_SIZE as u64);
            let rows = groups.div_ceil(max_groups);
            let row_groups = groups.div_ceil(rows);
            // chunk.z: the invocations in one row of workgroups; chunk.w: the axes composed at
            // every point.
            let mut chunk_params = packed.params;
            chunk_params.chunk = [
                first_line as u32,
                lines as u32,
                (row_groups * WORKGROUP_SIZE as u64) as u32,
                first_x | last_x << 8,
            ];
            gpu.write(&params, bytemuck::bytes_of(&chunk_params));
            let bytes = lines * nx * BYTES_PER_POINT;
            let submission = gpu.submit(
                &[Pass {
                    kernel: &kernel,
                    bindings: &bindings,
                    workgroups: [row_groups as u32, rows as u32, 1],
                }],
                Some(Readback {
                    from: &output,
                    to: &staging,
                    bytes,
                }),
            );
            gpu.read(submission, &staging, bytes, |data| {
                on_chunk(first_line, lines, bytemuck::cast_slice(data))
            })??;
        }
        Ok(())
    }
}

/// The first and last axis, in product order, whose transform varies along a grid line: X, and
/// any axis with an error of X's position. `(n, 0)` where there is none (every axis per line).
fn x_dependent_axes(machine: &Machine) -> (u32, u32) {
    let depends = |axis: &crate::model::Axis| {
        axis.letter == AxisLetter::X
            || axis
                .components
                .iter()
                .flatten()
                .any(|f| f.other_axes().contains(&AxisLetter::X))
    };
    let order = machine.axes_in_product_order();
    let first = order.iter().position(|a| depends(a));
    let last = order.iter().rposition(|a| depends(a));
    match (first, last) {
        (Some(f), Some(l)) => (f as u32, l as u32),
        _ => (order.len() as u32, 0),
    }
}

impl GpuMapper {
    /// [`GpuMapper::variant_stats`] for a machine with errors of other axes' positions: each
    /// sampled machine is mapped point by point on the device and its statistics are reduced on
    /// the host as its chunks come back.
    pub(super) fn variant_stats_per_point(
        &self,
        machine: &Machine,
        perturbations: &[Perturbation],
        rows: &[Vec<f64>],
        grid: &Grid,
        mut on_batch: impl FnMut(usize),
    ) -> Result<Vec<FieldStats>, GpuError> {
        let nx = grid.dims[0];
        let mut all = Vec::with_capacity(rows.len());
        for (done, row) in rows.iter().enumerate() {
            let sample = machine.perturbed(perturbations, row);
            let mut stats = FieldStats::default();
            self.run(
                &sample,
                grid,
                None,
                |first, lines, data| -> Result<(), GpuError> {
                    stats.add_chunk(first, lines, nx, data);
                    Ok(())
                },
            )?;
            all.push(stats);
            on_batch(done + 1);
        }
        Ok(all)
    }
}
