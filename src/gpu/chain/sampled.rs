//! Batches of sampled machines on the device (machine design): the base machine packed once,
//! each sample's deviations uploaded as its row of amplitudes with its axis locations, constant
//! factors and X polynomials computed on the host in f64. The per-map passes run once per batch
//! with a sample index; the point pass reduces each sample's field to its statistics
//! (`points_reduce_main`), so nothing per point leaves the device; the positions pass
//! (`positions_main`, in `positions.rs`) gives VE and OE at arbitrary positions for every sample.

use std::sync::Arc;

use super::mapper::{GpuMapper, LineTiles, SampledKernel};
use super::pack::{
    deviation_form, machine_constants, mat4_of, pack, polynomial_in_t, rot_deviation, vec4_of,
    x_polynomials, Packed, PointVariant,
};
use super::MAX_ERROR_ANGLE_RAD;
use crate::gpu::device::{Buffer, Pass, Readback};
use crate::gpu::layout::{
    DevData, Location, Partial, Term, XPoly, CONSTANTS_PER_SAMPLE, SHAPE_BOW, SHAPE_CONSTANT,
    SHAPE_LINE, TERM_NO_AXIS, WORKGROUP_SIZE,
};
use crate::gpu::GpuError;
use crate::model::grid::Grid;
use crate::model::perturbation::{ErrorTarget, Perturbation, Shape};
use crate::model::statistics::FieldStats;
use crate::model::{AxisLetter, Machine};
use crate::reference::{self, Twin};

/// What the kernels take of a base machine and its perturbations, the same for every batch.
pub(super) struct Base {
    pub(super) packed: Packed,
    /// The axes in product order, with the index of each in `machine.axes`.
    pub(super) order: Vec<usize>,
    /// X's six errors of the base machine as polynomials in the grid index (f64), where each is
    /// one; [0; 4] for the others (their table is used).
    x_polynomials: [[f64; 4]; 6],
    pub(super) terms: Vec<Term>,
    /// The sum of the base machine's angular errors over the grid (see
    /// [`super::check_error_angles`]), and for each perturbation the most it adds per unit of
    /// amplitude.
    angles_rad: f64,
    angle_weights: Vec<f64>,
}

impl Base {
    pub(super) fn new(machine: &Machine, perturbations: &[Perturbation], grid: &Grid) -> Base {
        let packed = pack(machine, grid);
        let product = machine.chain.product_order();
        let order: Vec<usize> = product
            .iter()
            .filter_map(|&l| machine.axes.iter().position(|a| a.letter == l))
            .collect();
        let centre = (grid.dims[0] - 1) as f64 / 2.0;
        let x_polynomials = match machine.axis(AxisLetter::X) {
            Some(x) => x_polynomials(x, grid, centre).map(|p| p.unwrap_or([0.0; 4])),
            None => [[0.0; 4]; 6],
        };
        // One term per perturbation, so that the amplitudes' stride is the term count; terms
        // that are not component errors name no axis and never match one.
        let mut terms = perturbations
            .iter()
            .enumerate()
            .map(|(t, p)| {
                let component = match p.target {
                    ErrorTarget::Component { axis, index } => order
                        .iter()
                        .position(|&a| machine.axes[a].letter == axis)
                        .map(|n| (n, index)),
                    _ => None,
                };
                let shape = match p.shape {
                    Shape::Constant => SHAPE_CONSTANT,
                    Shape::Line => SHAPE_LINE,
                    Shape::Bow => SHAPE_BOW,
                };
                match component {
                    Some((n, index)) => {
                        let range = machine.axes[order[n]].range;
                        Term {
                            info: [n as u32, index as u32, shape, t as u32],
                            range: [range[0] as f32, range[1] as f32, 0.0, 0.0],
                        }
                    }
                    None => Term {
                        info: [TERM_NO_AXIS, 0, shape, t as u32],
                        range: [0.0, 1.0, 0.0, 0.0],
                    },
                }
            })
            .collect::<Vec<_>>();
        if terms.is_empty() {
            // A buffer holds at least one element; the kernels read none past `counts.z`.
            terms.push(Term {
                info: [TERM_NO_AXIS, 0, SHAPE_CONSTANT, 0],
                range: [0.0, 1.0, 0.0, 0.0],
            });
        }
        let angles_rad = super::error_angles_rad(machine, grid);
        let angle_weights = perturbations
            .iter()
            .map(|p| if p.target.is_angular() { 1.0 } else { 0.0 })
            .collect();
        Base {
            packed,
            order,
            x_polynomials,
            terms,
            angles_rad,
            angle_weights,
        }
    }
}

/// The per-sample data of one batch.
pub(super) struct BatchData {
    pub(super) amplitudes: Vec<f32>,
    pub(super) locations: Vec<Location>,
    pub(super) constants: Vec<DevData>,
    x_polys: Vec<XPoly>,
}

impl GpuMapper {
    pub(super) fn sampled_kernel(
        &self,
        kernel: SampledKernel,
    ) -> Result<Arc<crate::gpu::device::Kernel>, GpuError> {
        let (entry, constants) = match kernel {
            SampledKernel::AxisValues => ("axis_values_sampled_main", Vec::new()),
            SampledKernel::Groups => ("groups_sampled_main", Vec::new()),
            SampledKernel::Positions => ("positions_main", Vec::new()),
            SampledKernel::FoldedValues => ("folded_values_main", Vec::new()),
            SampledKernel::Folded {
                x_alone,
                reduce,
                lines_per_lane,
            } => (
                "folded_main",
                vec![
                    ("FOLD_X_ALONE", f64::from(u8::from(x_alone))),
                    ("FOLD_REDUCE", f64::from(u8::from(reduce))),
                    ("LINES_PER_LANE", f64::from(lines_per_lane)),
                ],
            ),
            SampledKernel::Reduce(variant) => ("points_reduce_main", variant.constants().to_vec()),
        };
        self.pipeline(&self.sampled, kernel, entry, &constants)
    }

    /// The rows of one batch: each sample's amplitudes, axis locations, constant factors and X
    /// polynomials, in f64 on the host and stored in f32.
    pub(super) fn batch_data(
        &self,
        machine: &Machine,
        perturbations: &[Perturbation],
        base: &Base,
        rows: &[Vec<f64>],
        grid: &Grid,
    ) -> Result<BatchData, GpuError> {
        let terms = perturbations.len().max(1);
        let mut data = BatchData {
            amplitudes: vec![0.0; rows.len() * terms],
            locations: Vec::with_capacity(rows.len() * base.order.len()),
            constants: Vec::with_capacity(rows.len() * CONSTANTS_PER_SAMPLE as usize),
            x_polys: Vec::with_capacity(rows.len()),
        };
        let centre = (grid.dims[0] - 1) as f64 / 2.0;
        let (origin, spacing) = (grid.origin_mm[0], grid.spacing_mm[0]);
        let ideal = Twin::of(machine);
        for (b, row) in rows.iter().enumerate() {
            let added: f64 = row
                .iter()
                .zip(&base.angle_weights)
                .map(|(s, w)| s.abs() * w)
                .sum();
            if base.angles_rad + added >= MAX_ERROR_ANGLE_RAD {
                return Err(GpuError::ErrorAngles {
                    machine: machine.name.clone(),
                    total_rad: base.angles_rad + added,
                    limit_rad: MAX_ERROR_ANGLE_RAD,
                });
            }
            for (t, &s) in row.iter().enumerate() {
                data.amplitudes[b * terms + t] = s as f32;
            }
            let (locations, spindle) = machine.perturbed_constants(perturbations, row);
            for &a in &base.order {
                let [ex, ey, ez, ea, eb, ec] = locations[a];
                data.locations.push(Location {
                    delta: vec4_of([ex, ey, ez]),
                    m: mat4_of(&rot_deviation(ea, eb, ec)),
                });
            }
            let mut constants = machine_constants(&ideal);
            if let Some(x) = machine.axes.iter().position(|a| a.letter == AxisLetter::X) {
                let offset = machine.axes[x].offset_mm;
                constants[0] = deviation_form(
                    &reference::location_at(offset, locations[x]),
                    &reference::location_at(offset, [0.0; 6]),
                );
            }
            constants[1] = deviation_form(
                &reference::spindle_and_tool_at(spindle, machine.tool_offset_mm),
                &reference::spindle_and_tool_at([0.0; 5], machine.tool_offset_mm),
            );
            data.constants.extend(constants);
            // X's polynomials: the base machine's with the samples' deviations of X added.
            let mut x = base.x_polynomials;
            for (p, &s) in perturbations.iter().zip(row) {
                if let ErrorTarget::Component {
                    axis: AxisLetter::X,
                    index,
                } = p.target
                {
                    let range = machine.axis(AxisLetter::X).map_or([0.0, 1.0], |a| a.range);
                    let delta = polynomial_in_t(
                        &p.shape.polynomial(s, range),
                        origin + spacing * centre,
                        spacing,
                    );
                    for (c, d) in x[index].iter_mut().zip(delta) {
                        *c += d;
                    }
                }
            }
            let group = |first: usize| -> [[f32; 4]; 4] {
                std::array::from_fn(|k| {
                    [
                        x[first][k] as f32,
                        x[first + 1][k] as f32,
                        x[first + 2][k] as f32,
                        0.0,
                    ]
                })
            };
            data.x_polys.push(XPoly {
                translation: group(0),
                rotation: group(3),
            });
        }
        Ok(data)
    }

    /// The largest batch of samples the device holds at once for a grid whose per-sample tables
    /// and statistics take `bytes_per_sample`.
    pub(super) fn batch_size(&self, bytes_per_sample: u64) -> usize {
        let binding = self.gpu.max_storage_binding_bytes();
        let budget = if self.gpu.is_software() {
            1 << 26
        } else {
            1 << 28
        };
        let by_memory = (budget.min(binding) / bytes_per_sample.max(1)).max(1);
        by_memory.min(self.gpu.max_workgroups_per_dimension() as u64) as usize
    }
}

/// The machine's buffers on the device, and those of one batch sized for the largest batch.
pub(super) struct Buffers {
    pub(super) axes: Buffer,
    pub(super) functions: Buffer,
    pub(super) pieces: Buffer,
    pub(super) coefficients: Buffer,
    groups: Buffer,
    factors: Buffer,
    pub(super) terms: Buffer,
    pub(super) amplitudes: Buffer,
    pub(super) locations: Buffer,
    pub(super) constants: Buffer,
    x_polys: Buffer,
    axis_values: Buffer,
    group_values: Buffer,
    x_errors: Buffer,
}

impl Buffers {
    pub(super) fn new(
        mapper: &GpuMapper,
        base: &Base,
        terms: usize,
        batch: usize,
        nx: u64,
    ) -> Buffers {
        let gpu = &mapper.gpu;
        let packed = &base.packed;
        let [entries, group_entries, _, _] = packed.params.counts.map(u64::from);
        let entry_bytes = std::mem::size_of::<DevData>() as u64;
        let batch64 = batch as u64;
        let zeros = |label: &str, bytes: u64| gpu.writable(label, bytes.max(16));
        Buffers {
            axes: gpu.storage("axes", &packed.axes),
            functions: gpu.storage("functions", &packed.functions),
            pieces: gpu.storage("pieces", &packed.pieces),
            coefficients: gpu.storage("coefficients", &packed.coefficients),
            groups: gpu.storage("groups", &packed.groups),
            factors: gpu.storage("factors", &packed.factors),
            terms: gpu.storage("terms", &base.terms),
            amplitudes: zeros("amplitudes", batch64 * terms as u64 * 4),
            locations: zeros(
                "locations",
                batch64 * base.order.len() as u64 * std::mem::size_of::<Location>() as u64,
            ),
            constants: zeros(
                "constants",
                batch64 * CONSTANTS_PER_SAMPLE as u64 * entry_bytes,
            ),
            x_polys: zeros("x polys", batch64 * std::mem::size_of::<XPoly>() as u64),
            axis_values: gpu.output("axis values", (batch64 * entries).max(1) * entry_bytes),
            group_values: gpu.output(
                "group values",
                (batch64 * group_entries).max(1) * entry_bytes,
            ),
            x_errors: gpu.output("x errors", batch64 * 2 * 16 * nx.max(1)),
        }
    }

    pub(super) fn write(&self, mapper: &GpuMapper, data: &BatchData) {
        let gpu = &mapper.gpu;
        gpu.write(&self.amplitudes, bytemuck::cast_slice(&data.amplitudes));
        gpu.write(&self.locations, bytemuck::cast_slice(&data.locations));
        gpu.write(&self.constants, bytemuck::cast_slice(&data.constants));
        gpu.write(&self.x_polys, bytemuck::cast_slice(&data.x_polys));
    }
}

/// Workgroups for `count` invocations in one dispatch dimension.
pub(super) fn workgroups(count: u64) -> u32 {
    count.div_ceil(WORKGROUP_SIZE as u64).max(1) as u32
}

/// `a` (max |VE| at point `pa`) comes before `b` (at `pb`): larger, or as large and earlier.
fn comes_first(a: f64, pa: u64, b: f64, pb: u64) -> bool {
    a > b || (a == b && pa < pb)
}

impl GpuMapper {
    /// The statistics of the field over `grid` of each sampled machine: `machine` with row `b` of
    /// `rows` as the amplitudes of `perturbations` (see [`Machine::perturbed`]). The fields are
    /// reduced on the device; `on_batch(samples done)` is called after each batch.
    pub fn variant_stats(
        &self,
        machine: &Machine,
        perturbations: &[Perturbation],
        rows: &[Vec<f64>],
        grid: &Grid,
        mut on_batch: impl FnMut(usize),
    ) -> Result<Vec<FieldStats>, GpuError> {
        if machine.has_cross_axis_errors() {
            return self.variant_stats_folded(machine, perturbations, rows, grid, on_batch);
        }
        let base = Base::new(machine, perturbations, grid);
        let nx = grid.dims[0] as u64;
        let max_groups = self.gpu.max_workgroups_per_dimension() as u64;
        let tiles = LineTiles::of(self.tiling(), nx, max_groups).ok_or_else(|| {
            self.error(format!(
                "a line of {nx} points needs more workgroups than one dispatch holds"
            ))
        })?;
        let chunks = grid.chunks(max_groups * tiles.lines_per_workgroup * nx);
        let chunk_groups = |lines: u64| tiles.x_groups as u64 * tiles.line_groups(lines) as u64;
        let most_groups = chunk_groups(chunks.most_lines().max(1));
        let packed = &base.packed;
        let [entries, group_entries, _, _] = packed.params.counts.map(u64::from);
        let terms = perturbations.len().max(1);
        let per_sample = (entries + group_entries) * 96
            + 32 * nx
            + base.order.len() as u64 * 80
            + 2 * 96
            + 128
            + terms as u64 * 4
            + most_groups * 48;
        let batch = self.batch_size(per_sample).min(rows.len().max(1));
        let buffers = Buffers::new(self, &base, terms, batch, nx);
        let partial_bytes = batch as u64 * most_groups * std::mem::size_of::<Partial>() as u64;
        let partials = self.gpu.output("partials", partial_bytes);
        let staging = self.gpu.staging("partials staging", partial_bytes);
        let map_params = self
            .gpu
            .uniform("sampled params", bytemuck::bytes_of(&packed.params));
        let chunk_params = self
            .gpu
            .uniform("sampled chunk params", bytemuck::bytes_of(&packed.params));
        let axis_kernel = self.sampled_kernel(SampledKernel::AxisValues)?;
        let groups_kernel = self.sampled_kernel(SampledKernel::Groups)?;
        let reduce_kernel = self.sampled_kernel(SampledKernel::Reduce(PointVariant {
            shape: packed.shape,
            lines_per_lane: self.tiling().lines_per_lane,
        }))?;
        let b = &buffers;
        let axis_bindings = self.gpu.bind(
            &axis_kernel,
            &[
                (0, &map_params),
                (1, &b.axes),
                (2, &b.functions),
                (3, &b.pieces),
                (4, &b.coefficients),
                (5, &b.axis_values),
                (8, &b.x_errors),
                (12, &b.terms),
                (13, &b.amplitudes),
                (14, &b.locations),
            ],
        );
        let group_bindings = self.gpu.bind(
            &groups_kernel,
            &[
                (0, &map_params),
                (5, &b.axis_values),
                (6, &b.group_values),
                (9, &b.groups),
                (10, &b.factors),
                (11, &b.constants),
            ],
        );
        let reduce_bindings = self.gpu.bind(
            &reduce_kernel,
            &[
                (0, &chunk_params),
                (6, &b.group_values),
                (8, &b.x_errors),
                (15, &b.x_polys),
                (16, &partials),
            ],
        );
        let mut stats = vec![FieldStats::default(); rows.len()];
        let mut done = 0;
        for batch_rows in rows.chunks(batch) {
            let data = self.batch_data(machine, perturbations, &base, batch_rows, grid)?;
            buffers.write(self, &data);
            let samples = batch_rows.len() as u32;
            let mut params = packed.params;
            params.counts = [entries as u32, group_entries as u32, terms as u32, samples];
            self.gpu.write(&map_params, bytemuck::bytes_of(&params));
            self.gpu.submit(
                &[
                    Pass {
                        kernel: &axis_kernel,
                        bindings: &axis_bindings,
                        workgroups: [workgroups(entries), samples, 1],
                    },
                    Pass {
                        kernel: &groups_kernel,
                        bindings: &group_bindings,
                        workgroups: [workgroups(group_entries), samples, 1],
                    },
                ],
                None,
            );
            let batch_stats = &mut stats[done..done + batch_rows.len()];
            let mut best: Vec<(f64, u64)> = vec![(-1.0, u64::MAX); batch_rows.len()];
            for (first_line, lines) in chunks.iter() {
                params.chunk = [
                    first_line as u32,
                    lines as u32,
                    tiles.points_per_invocation,
                    tiles.invocations_per_line_group,
                ];
                self.gpu.write(&chunk_params, bytemuck::bytes_of(&params));
                let groups = chunk_groups(lines);
                let bytes = samples as u64 * groups * std::mem::size_of::<Partial>() as u64;
                let submission = self.gpu.submit(
                    &[Pass {
                        kernel: &reduce_kernel,
                        bindings: &reduce_bindings,
                        workgroups: [tiles.x_groups, tiles.line_groups(lines), samples],
                    }],
                    Some(Readback {
                        from: &partials,
                        to: &staging,
                        bytes,
                    }),
                );
                self.gpu.read(submission, &staging, bytes, |bytes| {
                    add_partials(
                        bytemuck::cast_slice(bytes),
                        groups,
                        nx,
                        batch_stats,
                        &mut best,
                    )
                })?;
            }
            finish_stats(batch_stats, best, grid);
            done += batch_rows.len();
            on_batch(done);
        }
        Ok(stats)
    }
}

/// Adds the partials of one chunk, `groups` per sample of the batch, to each sample's
/// statistics; `best` holds each sample's max |VE| so far and its point.
pub(super) fn add_partials(
    all: &[Partial],
    groups: u64,
    nx: u64,
    stats: &mut [FieldStats],
    best: &mut [(f64, u64)],
) {
    for ((per_sample, sample), best) in all.chunks_exact(groups as usize).zip(stats).zip(best) {
        for p in per_sample {
            if p.stats[0] < 0.0 {
                continue;
            }
            let ve = p.stats[0] as f64;
            let point = p.at[0] as u64 * nx + p.at[1] as u64;
            if comes_first(ve, point, best.0, best.1) {
                *best = (ve, point);
            }
            sample.sum_sq_ve += p.stats[1] as f64;
            sample.max_oe_rad = sample.max_oe_rad.max(p.stats[2] as f64);
            for (m, v) in sample.max_axis_mm.iter_mut().zip(p.axes) {
                *m = m.max(v as f64);
            }
        }
    }
}

/// Completes each sample's statistics once every chunk is added: its points, its max |VE| and
/// where.
pub(super) fn finish_stats(stats: &mut [FieldStats], best: Vec<(f64, u64)>, grid: &Grid) {
    for (sample, (ve, point)) in stats.iter_mut().zip(best) {
        sample.points = grid.points();
        sample.max_ve_mm = ve.max(0.0);
        sample.max_ve_point = if point == u64::MAX { 0 } else { point };
    }
}
