//! The CPU engine: the f64 reference at every grid point, in parallel (rayon), producing chunks
//! in the same layout as the GPU engine. Used where no adapter exists, with `--device cpu`, and
//! by `--check`.

use rayon::prelude::*;

use crate::gpu::layout::CHANNELS;
use crate::grid::Grid;
use crate::machine::Machine;
use crate::reference;

/// Lines per CPU chunk are chosen so a chunk holds about this many points.
pub const CPU_CHUNK_POINTS: u64 = 1 << 18;

/// The six output values of one point, in [`CHANNELS`] order: OE.X OE.Y OE.Z VE.X VE.Y VE.Z.
pub fn point_values(machine: &Machine, ideal: &Machine, grid: &Grid, ijk: [usize; 3]) -> [f64; 6] {
    let d = reference::deviation_against(machine, ideal, &grid.command(ijk));
    let (oe, ve) = (d.orientation_rad, d.volumetric_mm);
    [oe.x, oe.y, oe.z, ve.x, ve.y, ve.z]
}

/// Computes lines `first_line .. first_line + lines` into `out` (`lines · 6 · nx` values).
pub fn compute_lines(
    machine: &Machine,
    ideal: &Machine,
    grid: &Grid,
    first_line: u64,
    lines: u64,
    out: &mut [f32],
) {
    let nx = grid.dims[0];
    let ny = grid.dims[1] as u64;
    out.par_chunks_mut(CHANNELS.len() * nx)
        .take(lines as usize)
        .enumerate()
        .for_each(|(n, line_out)| {
            let line = first_line + n as u64;
            let (j, k) = ((line % ny) as usize, (line / ny) as usize);
            for i in 0..nx {
                let values = point_values(machine, ideal, grid, [i, j, k]);
                for (c, v) in values.iter().enumerate() {
                    line_out[c * nx + i] = *v as f32;
                }
            }
        });
}

/// The whole map, chunk by chunk, with the same callback as the GPU engine.
pub fn run<E>(
    machine: &Machine,
    grid: &Grid,
    chunk_points: Option<u64>,
    mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
) -> Result<(), E> {
    let ideal = machine.without_errors();
    let chunks = grid.chunks(chunk_points.unwrap_or(CPU_CHUNK_POINTS));
    let nx = grid.dims[0];
    let mut buffer = Vec::new();
    for (first_line, lines) in chunks {
        buffer.resize(lines as usize * nx * CHANNELS.len(), 0.0f32);
        compute_lines(machine, &ideal, grid, first_line, lines, &mut buffer);
        on_chunk(first_line, lines, &buffer)?;
    }
    Ok(())
}
