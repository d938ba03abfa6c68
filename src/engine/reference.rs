//! The f64 reference at every point of a grid, in the engines' chunk layout: ground truth for the
//! tests, the spot check of a map and the benchmarks' baseline.

use super::CPU_CHUNK_POINTS;
use crate::model::grid::Grid;
use crate::model::Machine;
use crate::reference::Twin;

/// The six output values of one point, in [`CHANNELS`](crate::model::channels::CHANNELS) order: OE.X OE.Y OE.Z VE.X VE.Y VE.Z.
pub fn point_values(twin: &Twin, grid: &Grid, ijk: [usize; 3]) -> [f64; 6] {
    let d = twin.deviation(&grid.command(ijk));
    let (oe, ve) = (d.orientation_rad, d.volumetric_mm);
    [oe.x, oe.y, oe.z, ve.x, ve.y, ve.z]
}

/// Computes lines `first_line .. first_line + lines` into `out` (`lines · 6 · nx` values) with
/// the reference at every point.
pub fn reference_lines(twin: &Twin, grid: &Grid, first_line: u64, lines: u64, out: &mut [f32]) {
    let nx = grid.dims[0];
    super::par_lines(grid, first_line, lines, out, |[j, k], line_out| {
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
    on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
) -> Result<(), E> {
    let twin = Twin::of(machine);
    super::run_in_chunks(
        grid,
        chunk_points.unwrap_or(CPU_CHUNK_POINTS),
        |first_line, lines, buffer| reference_lines(&twin, grid, first_line, lines, buffer),
        on_chunk,
    )
}
