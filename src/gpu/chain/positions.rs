//! The positions pass of sampled machines (`positions_main` in `shaders/positions.wgsl`): VE and
//! OE of every sample at arbitrary commanded positions, batch by batch as in `sampled.rs`.

use super::mapper::{GpuMapper, SampledKernel};
use super::sampled::{workgroups, Base, Buffers};
use crate::gpu::device::{Pass, Readback};
use crate::gpu::layout::WORKGROUP_SIZE;
use crate::gpu::GpuError;
use crate::model::channels::Sample;
use crate::model::grid::Grid;
use crate::model::perturbation::Perturbation;
use crate::model::{Command, Machine};

/// The device's output per sample of the positions pass: six channels per position.
const POSITION_VALUES: u64 = 6;

impl GpuMapper {
    /// VE and OE (in [`crate::model::channels::SAMPLE_COLUMNS`] order) of each sampled machine
    /// (as [`GpuMapper::variant_stats`]) at each commanded position; every position stands at
    /// the rotary positions of the first. `on_batch(samples done)` is called after each batch.
    pub fn variant_values(
        &self,
        machine: &Machine,
        perturbations: &[Perturbation],
        rows: &[Vec<f64>],
        commands: &[Command],
        mut on_batch: impl FnMut(usize),
    ) -> Result<Vec<Vec<Sample>>, GpuError> {
        let mut pose = commands.first().copied().unwrap_or([0.0; 6]);
        pose[..3].fill(0.0);
        let grid = Grid {
            dims: [1, 1, 1],
            origin_mm: [0.0; 3],
            spacing_mm: [0.0; 3],
            pose,
        };
        let base = Base::new(machine, perturbations, &grid);
        let terms = perturbations.len().max(1);
        let positions: Vec<[f32; 4]> = commands
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let count = positions.len().max(1) as u64;
        let max_groups = self.gpu.max_workgroups_per_dimension() as u64;
        if count > max_groups * WORKGROUP_SIZE as u64 {
            return Err(self.error(format!(
                "{count} positions exceed one dispatch of the positions pass"
            )));
        }
        let value_bytes = count * POSITION_VALUES * 4;
        let per_sample = value_bytes + base.order.len() as u64 * 80 + 2 * 96 + terms as u64 * 4;
        let batch = self
            .batch_size(per_sample)
            .min(rows.len().max(1))
            .min((self.gpu.max_storage_binding_bytes() / value_bytes).max(1) as usize);
        let buffers = Buffers::new(self, &base, terms, batch, 1);
        let position_buffer = self.gpu.storage("positions", &positions);
        let output = self
            .gpu
            .output("position values", batch as u64 * value_bytes);
        let staging = self
            .gpu
            .staging("position values staging", batch as u64 * value_bytes);
        let params_buffer = self
            .gpu
            .uniform("positions params", bytemuck::bytes_of(&base.packed.params));
        let kernel = self.sampled_kernel(SampledKernel::Positions)?;
        let b = &buffers;
        let bindings = self.gpu.bind(
            &kernel,
            &[
                (0, &params_buffer),
                (1, &b.axes),
                (2, &b.functions),
                (3, &b.pieces),
                (4, &b.coefficients),
                (11, &b.constants),
                (12, &b.terms),
                (13, &b.amplitudes),
                (14, &b.locations),
                (17, &position_buffer),
                (18, &output),
            ],
        );
        let mut values = Vec::with_capacity(rows.len());
        for batch_rows in rows.chunks(batch) {
            let data = self.batch_data(machine, perturbations, &base, batch_rows, &grid)?;
            buffers.write(self, &data);
            let samples = batch_rows.len() as u32;
            let mut params = base.packed.params;
            params.counts[2] = terms as u32;
            params.counts[3] = samples;
            self.gpu.write(&params_buffer, bytemuck::bytes_of(&params));
            let bytes = samples as u64 * value_bytes;
            let submission = self.gpu.submit(
                &[Pass {
                    kernel: &kernel,
                    bindings: &bindings,
                    workgroups: [workgroups(count), samples, 1],
                }],
                Some(Readback {
                    from: &output,
                    to: &staging,
                    bytes,
                }),
            );
            self.gpu.read(submission, &staging, bytes, |bytes| {
                let all: &[f32] = bytemuck::cast_slice(bytes);
                for sample in all.chunks_exact((count * POSITION_VALUES) as usize) {
                    values.push(
                        sample
                            .chunks_exact(POSITION_VALUES as usize)
                            .take(commands.len())
                            .map(|v| [v[3], v[4], v[5], v[0], v[1], v[2]].map(f64::from))
                            .collect(),
                    );
                }
            })?;
            on_batch(values.len());
        }
        Ok(values)
    }
}
