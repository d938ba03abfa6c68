//! The f64 reference at every point of a grid, in the engines' chunk layout: ground truth for the
//! tests, the spot check of a map and the benchmarks' baseline.

use rayon::prelude::*;

use super::cpu::CPU_CHUNK_POINTS;
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;
use crate::reference::Twin;

/// The six output values of one point, in [`CHANNELS`] order: OE.X OE.Y OE.Z VE.X VE.Y VE.Z.
pub fn point_values(twin: &Twin, grid: &Grid, ijk: [usize; 3]) -> [f64; 6] {
    let d = twin.deviation(&grid.command(ijk));
    let (oe, ve) = (d.orientation_rad, d.volumetric_mm);
    [oe.x, oe.y, oe.z, ve.x, ve.y, ve.z]
}

/// Computes lines `first_line .. first_line + lines` into `out` (`lines · 6 · nx` values) with
/// the reference at every point.
pub fn reference_lines(twin: &Twin, grid: &Grid, first_line: u64, lines: u64, out: &mut [f32]) {
    let nx = grid.dims[0];
    let ny = grid.dims[1] as u64;
    out.par_chunks_mut(CHANNELS.len() * nx)
        .take(lines as usize)
        .enumerate()
        .for_each(|(n, line_out)| {
            let line = first_line + n as u64;
            let (j, k) = ((line % ny) as usize, (line / ny) as usize);
            for i in 0..nx {
                let values = point_values(twin, grid, [i, j, k]);
                for (c, v) in values.iter().enumerate() {
                    line_out[c * nx + i] = *v as f32;
                }
            }
        });
}

/// The whole map with the reference at every point, chunk by chunk, with the same callback as
/// the other engines.
pub fn run<E>(
    machine: &Machine,
    grid: &Grid,
    chunk_points: Option<u64>,
    mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
) -> Result<(), E> {
    let twin = Twin::of(machine);
    let mut buffer = Vec::new();
    for (first_line, lines) in grid.chunks(chunk_points.unwrap_or(CPU_CHUNK_POINTS)) {
        buffer.resize(lines as usize * grid.dims[0] * CHANNELS.len(), 0.0f32);
        reference_lines(&twin, grid, first_line, lines, &mut buffer);
        on_chunk(first_line, lines, &buffer)?;
    }
    Ok(())
}
