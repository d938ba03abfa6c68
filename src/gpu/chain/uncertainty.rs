//! Sums over machines for the uncertainty of a map (`shaders/uncertainty.wgsl`): chunk by chunk,
//! each term's two machines mapped by the point pass into two fields on the device and their
//! scaled difference added to the chunk's running sums there; only the sums are read back, once
//! per batch of terms, whatever the number of machines.
//!
//! The first-order propagation (GUM) gives one term per direction of the quantities'
//! covariance: the machine moved by `±t` times the direction, the difference scaled by
//! `1/(2t)` (a central difference); Monte Carlo (JCGM 101) one term per draw: the drawn
//! machine against the nominal one, mapped once per chunk.

use std::sync::Arc;

use super::mapper::{LineTiles, MapTables};
use super::pack::{pack, PointVariant};
use super::{check_error_angles, check_own_axis_errors, GpuMapper, BYTES_PER_POINT};
use crate::gpu::device::{self, Buffer, Pass, Readback};
use crate::gpu::layout::{Params, UncertaintyParams, WORKGROUP_SIZE};
use crate::gpu::GpuError;
use crate::model::channels::CHANNELS;
use crate::model::grid::{Chunks, Grid};
use crate::model::Machine;

/// The shader of the sums.
pub const UNCERTAINTY_WGSL: &str = include_str!("../../../shaders/uncertainty.wgsl");

/// One term of the sums: `scale · (field(plus) − field(minus))`, `minus` the nominal machine
/// where `None`.
pub struct SumTerm {
    pub plus: Machine,
    pub minus: Option<Machine>,
    pub scale: f64,
}

/// What the sums of a chunk hold, per value of the chunk (its layout: for each line, `nx`
/// values of each channel): `Σ d` and `Σ d²` over the terms, `d` each term's scaled difference.
pub struct ChunkSums {
    pub first: Vec<f32>,
    pub second: Vec<f32>,
}

/// A machine's tables on the device, bound to the point pass writing into one field buffer.
struct Mapped {
    _tables: MapTables,
    params: Params,
    params_buffer: Buffer,
    kernel: Arc<device::Kernel>,
    bindings: device::Bindings,
    tiles: LineTiles,
}

/// The buffers of the sums of a map: two fields of a chunk, the nominal field, the sums and
/// their staging buffer, and the nominal machine mapped into its field.
pub struct SumsPlan {
    nx: u64,
    pub chunks: Chunks,
    a: Buffer,
    b: Buffer,
    nominal: Buffer,
    sums: Buffer,
    staging: Buffer,
    accumulate_params: Buffer,
    accumulate: Arc<device::Kernel>,
    grid: Grid,
    base: Mapped,
}

/// Terms whose machines are on the device at once (their tables are small; the fields are
/// shared).
pub const TERMS_PER_BATCH: usize = 64;

impl GpuMapper {
    /// Plans the sums of `base`'s map over `grid`, the chunks as a map of it would have them.
    pub fn plan_sums(
        &self,
        base: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
    ) -> Result<SumsPlan, GpuError> {
        let nx = grid.dims[0] as u64;
        let chunks = self.chunks_of(grid, chunk_points)?;
        let chunk_bytes = chunks.most_lines().max(1) * nx * BYTES_PER_POINT;
        let gpu = &self.gpu;
        let accumulate = {
            let mut cache = self.accumulate.lock().unwrap_or_else(|p| p.into_inner());
            match cache.get(&()) {
                Some(kernel) => kernel.clone(),
                None => {
                    let kernel = Arc::new(gpu.kernel(
                        "uncertainty.wgsl accumulate_main",
                        UNCERTAINTY_WGSL,
                        "accumulate_main",
                    )?);
                    cache.insert((), kernel.clone());
                    kernel
                }
            }
        };
        let nominal = gpu.output("nominal field", chunk_bytes);
        let base = self.mapped(base, grid, &nominal)?;
        Ok(SumsPlan {
            nx,
            chunks,
            a: gpu.output("field a", chunk_bytes),
            b: gpu.output("field b", chunk_bytes),
            nominal,
            sums: gpu.output("sums", 2 * chunk_bytes),
            staging: gpu.staging("sums staging", 2 * chunk_bytes),
            accumulate_params: gpu.uniform(
                "uncertainty params",
                bytemuck::bytes_of(&UncertaintyParams {
                    counts: [0; 4],
                    scale: [0.0; 4],
                }),
            ),
            accumulate,
            grid: grid.clone(),
            base,
        })
    }

    /// `machine`'s tables on the device, the point pass bound to write into `output`.
    fn mapped(&self, machine: &Machine, grid: &Grid, output: &Buffer) -> Result<Mapped, GpuError> {
        check_error_angles(machine, grid)?;
        check_own_axis_errors(machine)?;
        let packed = pack(machine, grid);
        let nx = grid.dims[0] as u64;
        let tables = self.per_map_passes(&packed, nx)?;
        let tiling = self.tiling();
        let tiles = LineTiles::of(tiling, nx, self.gpu.max_workgroups_per_dimension() as u64)
            .ok_or_else(|| {
                self.error(format!(
                    "a line of {nx} points needs more workgroups than one dispatch holds"
                ))
            })?;
        let variant = PointVariant {
            shape: packed.shape,
            lines_per_lane: tiling.lines_per_lane,
        };
        let kernel = self.pipeline(&self.points, variant, "points_main", &variant.constants())?;
        let params_buffer = self
            .gpu
            .uniform("term params", bytemuck::bytes_of(&packed.params));
        let bindings = self.gpu.bind(
            &kernel,
            &[
                (0, &params_buffer),
                (6, &tables.group_values),
                (7, output),
                (8, &tables.x_errors),
            ],
        );
        Ok(Mapped {
            _tables: tables,
            params: packed.params,
            params_buffer,
            kernel,
            bindings,
            tiles,
        })
    }

    /// The point pass of `mapped` over lines `first_line .. first_line + lines`, its chunk
    /// parameters written first.
    fn point_pass<'a>(&self, mapped: &'a Mapped, first_line: u64, lines: u64) -> Pass<'a> {
        let mut params = mapped.params;
        params.chunk = [
            first_line as u32,
            lines as u32,
            mapped.tiles.points_per_invocation,
            mapped.tiles.invocations_per_line_group,
        ];
        self.gpu
            .write(&mapped.params_buffer, bytemuck::bytes_of(&params));
        Pass {
            kernel: &mapped.kernel,
            bindings: &mapped.bindings,
            workgroups: [mapped.tiles.x_groups, mapped.tiles.line_groups(lines), 1],
        }
    }

    /// Every term's machines on the device, bound to `plan`'s fields: mapped once, they serve
    /// every chunk of the plan (the first order's terms are the same in every chunk).
    pub fn map_terms(&self, plan: &SumsPlan, terms: &[SumTerm]) -> Result<MappedTerms, GpuError> {
        let terms = terms
            .iter()
            .map(|t| {
                let plus = self.mapped(&t.plus, &plan.grid, &plan.a)?;
                let minus = match &t.minus {
                    Some(m) => Some(self.mapped(m, &plan.grid, &plan.b)?),
                    None => None,
                };
                Ok((plus, minus, t.scale))
            })
            .collect::<Result<Vec<_>, GpuError>>()?;
        Ok(MappedTerms { terms })
    }

    /// The sums of chunk `n` of `plan` over `terms`: every term's machines mapped on the device,
    /// their scaled difference added there, the sums read back once. `terms` must not be empty.
    pub fn chunk_sums(
        &self,
        plan: &SumsPlan,
        n: usize,
        terms: &[SumTerm],
    ) -> Result<ChunkSums, GpuError> {
        assert!(!terms.is_empty(), "a sum of no terms");
        let mut sums = Accumulation::new(
            self,
            plan,
            n,
            terms.len(),
            terms.iter().any(|t| t.minus.is_none()),
        );
        for batch in terms.chunks(TERMS_PER_BATCH) {
            let mapped = self.map_terms(plan, batch)?;
            sums.add(&mapped);
        }
        sums.read()
    }

    /// [`GpuMapper::chunk_sums`] over terms mapped beforehand ([`GpuMapper::map_terms`]).
    pub fn chunk_sums_mapped(
        &self,
        plan: &SumsPlan,
        n: usize,
        mapped: &MappedTerms,
    ) -> Result<ChunkSums, GpuError> {
        assert!(!mapped.terms.is_empty(), "a sum of no terms");
        let nominal = mapped.terms.iter().any(|t| t.1.is_none());
        let mut sums = Accumulation::new(self, plan, n, mapped.terms.len(), nominal);
        sums.add(mapped);
        sums.read()
    }
}

/// Terms whose machines are on the device ([`GpuMapper::map_terms`]): each term's `plus` and
/// `minus` (`None`: the nominal field) and its scale.
pub struct MappedTerms {
    terms: Vec<(Mapped, Option<Mapped>, f64)>,
}

impl MappedTerms {
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

/// The sums of one chunk as its terms are added: the passes submitted so far, the last read
/// back.
struct Accumulation<'a> {
    gpu_mapper: &'a GpuMapper,
    plan: &'a SumsPlan,
    first_line: u64,
    lines: u64,
    values: u64,
    against_b: device::Bindings,
    against_nominal: device::Bindings,
    workgroups: [u32; 3],
    total: usize,
    written: usize,
    last: Option<device::Submission>,
}

impl<'a> Accumulation<'a> {
    /// The sums of chunk `n` over `total` terms, the nominal field mapped first where a term
    /// differs from it.
    fn new(
        gpu_mapper: &'a GpuMapper,
        plan: &'a SumsPlan,
        n: usize,
        total: usize,
        nominal: bool,
    ) -> Accumulation<'a> {
        let (first_line, lines) = plan.chunks.get(n);
        let values = lines * plan.nx * CHANNELS.len() as u64;
        let gpu = &gpu_mapper.gpu;
        if nominal {
            let pass = gpu_mapper.point_pass(&plan.base, first_line, lines);
            gpu.submit(&[pass], None);
        }
        let bindings = |b: &Buffer| {
            gpu.bind(
                &plan.accumulate,
                &[
                    (0, &plan.accumulate_params),
                    (1, &plan.a),
                    (2, b),
                    (3, &plan.sums),
                ],
            )
        };
        let groups = values.div_ceil(WORKGROUP_SIZE as u64).max(1);
        let width = (gpu.max_workgroups_per_dimension() as u64).min(groups);
        Accumulation {
            gpu_mapper,
            plan,
            first_line,
            lines,
            values,
            against_b: bindings(&plan.b),
            against_nominal: bindings(&plan.nominal),
            workgroups: [width as u32, groups.div_ceil(width) as u32, 1],
            total,
            written: 0,
            last: None,
        }
    }

    /// Adds `mapped`'s terms: each term's fields mapped and their scaled difference summed.
    fn add(&mut self, mapped: &MappedTerms) {
        let gpu = &self.gpu_mapper.gpu;
        for (plus, minus, scale) in &mapped.terms {
            gpu.write(
                &self.plan.accumulate_params,
                bytemuck::bytes_of(&UncertaintyParams {
                    counts: [self.values as u32, u32::from(self.written == 0), 0, 0],
                    scale: [*scale as f32, 0.0, 0.0, 0.0],
                }),
            );
            self.written += 1;
            let mut passes = vec![self
                .gpu_mapper
                .point_pass(plus, self.first_line, self.lines)];
            if let Some(minus) = minus {
                passes.push(
                    self.gpu_mapper
                        .point_pass(minus, self.first_line, self.lines),
                );
            }
            passes.push(Pass {
                kernel: &self.plan.accumulate,
                bindings: if minus.is_some() {
                    &self.against_b
                } else {
                    &self.against_nominal
                },
                workgroups: self.workgroups,
            });
            let copy = (self.written == self.total).then_some(Readback {
                from: &self.plan.sums,
                to: &self.plan.staging,
                bytes: 2 * self.values * 4,
            });
            self.last = Some(gpu.submit(&passes, copy));
        }
    }

    /// Reads the sums back, once every term was added.
    fn read(self) -> Result<ChunkSums, GpuError> {
        assert_eq!(self.written, self.total, "every term added");
        let submission = self.last.expect("at least one term");
        let n = self.values as usize;
        self.gpu_mapper.gpu.read(
            submission,
            &self.plan.staging,
            2 * self.values * 4,
            |data| {
                let all: &[f32] = bytemuck::cast_slice(data);
                ChunkSums {
                    first: all[..n].to_vec(),
                    second: all[n..2 * n].to_vec(),
                }
            },
        )
    }
}
