//! The GPU twin of trilinear sampling ([`crate::io::field::LoadedField::sample`]): each position's
//! grid cell and fractions are found on the host in f64, the field goes to the device in slabs
//! of whole z planes that fit its binding limit, and `shaders/sample.wgsl` blends the eight
//! corners of every cell.

use super::device::{self, Gpu, Pass, Readback};
use super::layout::{SampleParams, SamplePoint, SAMPLE_VALUES, WORKGROUP_SIZE};
use super::GpuError;
use crate::io::field::GridCell;

/// The sampling kernel's WGSL source.
pub const SAMPLE_WGSL: &str = include_str!("../../shaders/sample.wgsl");
const VALUES: usize = SAMPLE_VALUES as usize;
const SAMPLE_BYTES: u64 = (VALUES * 4) as u64;
const WORKGROUP: u64 = WORKGROUP_SIZE as u64;

pub struct GpuSampler {
    gpu: Gpu,
    kernel: device::Kernel,
}

impl GpuSampler {
    /// `Ok(None)` when there is no adapter.
    pub fn open() -> Result<Option<GpuSampler>, GpuError> {
        let Some(gpu) = Gpu::open()? else {
            return Ok(None);
        };
        let kernel = gpu.kernel("sample.wgsl sample_main", SAMPLE_WGSL, "sample_main")?;
        Ok(Some(GpuSampler { gpu, kernel }))
    }

    pub fn adapter_name(&self) -> &str {
        self.gpu.adapter_name()
    }

    /// Whether the adapter is a CPU implementation (lavapipe and the like).
    pub fn is_software(&self) -> bool {
        self.gpu.is_software()
    }

    /// Samples the field of grid `dims` in `cells` (found on the host, see [`GridCell`]).
    /// `field[p]` holds the six values of grid point `p = i + nx·(j + ny·k)`; every point's cell must lie in the grid (the host checks
    /// positions before it builds them). `max_slab_bytes` caps the field bytes held on the
    /// device at once, below the device's own limit.
    pub fn sample(
        &self,
        dims: [usize; 3],
        field: &[[f32; VALUES]],
        cells: &[GridCell],
        max_slab_bytes: Option<u64>,
    ) -> Result<Vec<[f32; VALUES]>, GpuError> {
        let points: Vec<SamplePoint> = cells.iter().map(sample_point).collect();
        let [nx, ny, nz] = dims.map(|n| n as u64);
        let error = |message: String| GpuError::Runtime {
            adapter: self.adapter_name().to_string(),
            message,
        };
        if field.len() as u64 != nx * ny * nz {
            return Err(error(format!(
                "the field holds {} grid points, not {nx}×{ny}×{nz}",
                field.len()
            )));
        }
        let binding = self.gpu.max_storage_binding_bytes();
        let limit = max_slab_bytes.map_or(binding, |m| m.min(binding));
        let plane_bytes = nx * ny * SAMPLE_BYTES;
        let planes = (limit / plane_bytes).min(nz);
        if planes < nz && planes < 2 {
            return Err(error(format!(
                "two z planes of the field ({} bytes) exceed the {limit} bytes one binding holds; \
                 the CPU samples any field",
                2 * plane_bytes
            )));
        }
        // Slab s holds planes s·step ..= s·step + step: every cell with its lower corner at
        // k in s·step .. s·step + step has both its planes there.
        let step = if planes == nz { nz.max(1) } else { planes - 1 };
        let slab_of = |p: &SamplePoint| p.cell[2] as u64 / step;
        let slabs = nz.div_ceil(step).max(1) as usize;
        let mut by_slab: Vec<Vec<usize>> = vec![Vec::new(); slabs];
        for (n, p) in points.iter().enumerate() {
            let slab = slab_of(p) as usize;
            if slab >= slabs || p.cell[0] as u64 >= nx || p.cell[1] as u64 >= ny {
                return Err(error(format!("sample point {n} lies outside the grid")));
            }
            by_slab[slab].push(n);
        }
        let per_dispatch = (self.gpu.max_workgroups_per_dimension() as u64 * WORKGROUP)
            .min(binding / std::mem::size_of::<SamplePoint>() as u64)
            .min(binding / SAMPLE_BYTES)
            .max(1) as usize;
        let mut samples = vec![[0.0f32; VALUES]; points.len()];
        for (slab, members) in by_slab.iter().enumerate() {
            if members.is_empty() {
                continue;
            }
            let first_plane = slab as u64 * step;
            let last_plane = (first_plane + step).min(nz - 1);
            let slab_points =
                &field[(first_plane * nx * ny) as usize..((last_plane + 1) * nx * ny) as usize];
            let field_buffer = self.gpu.storage("field slab", slab_points);
            for batch in members.chunks(per_dispatch) {
                let batch_points: Vec<SamplePoint> = batch.iter().map(|&n| points[n]).collect();
                let params = SampleParams {
                    dims: [nx as u32, ny as u32, nz as u32, 0],
                    range: [first_plane as u32, 0, batch.len() as u32, 0],
                };
                let values = self.dispatch(&params, &field_buffer, &batch_points)?;
                for (&n, v) in batch.iter().zip(values) {
                    samples[n] = v;
                }
            }
        }
        Ok(samples)
    }

    /// One dispatch of the kernel over `points`, all in the slab `field` holds.
    fn dispatch(
        &self,
        params: &SampleParams,
        field: &device::Buffer,
        points: &[SamplePoint],
    ) -> Result<Vec<[f32; VALUES]>, GpuError> {
        let bytes = points.len() as u64 * SAMPLE_BYTES;
        let params = self
            .gpu
            .uniform("sample params", bytemuck::bytes_of(params));
        let point_buffer = self.gpu.storage("sample points", points);
        let output = self.gpu.output("samples", bytes);
        let staging = self.gpu.staging("samples staging", bytes);
        let bindings = self.gpu.bind(
            &self.kernel,
            &[(0, &params), (1, field), (2, &point_buffer), (3, &output)],
        );
        let submission = self.gpu.submit(
            &[Pass {
                kernel: &self.kernel,
                bindings: &bindings,
                workgroups: [(points.len() as u64).div_ceil(WORKGROUP) as u32, 1, 1],
            }],
            Some(Readback {
                from: &output,
                to: &staging,
                bytes,
            }),
        );
        self.gpu.read(submission, &staging, bytes, |data| {
            bytemuck::cast_slice::<u8, [f32; VALUES]>(data).to_vec()
        })
    }
}

/// A cell as the sampling kernel takes it.
fn sample_point(cell: &GridCell) -> SamplePoint {
    let [i, j, k] = cell.lower.map(|n| n as u32);
    let [tx, ty, tz] = cell.fraction.map(|t| t as f32);
    SamplePoint {
        cell: [i, j, k, 0],
        t: [tx, ty, tz, 0.0],
    }
}
