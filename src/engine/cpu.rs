//! The CPU engine, [`CpuPlan`]: the CPU twin of the GPU's passes in f64, producing chunks in the
//! same layout. Every axis transform once per grid value, the products before and after X once
//! per line, two 4×4 products per point, and the ideal machine alongside. Used where no adapter
//! exists and when the CPU is asked for.

mod folded;

use nalgebra::Matrix4;

use super::CPU_CHUNK_POINTS;
use crate::model::grid::Grid;
use crate::model::Machine;
use crate::reference::{self, Twin};

type Transform = Matrix4<f64>;

/// One axis's transforms, real and ideal, at every value of the grid coordinate that drives it.
struct AxisTable {
    /// The grid dimension (0 X, 1 Y, 2 Z), or `None` for an axis held at the pose.
    dimension: Option<usize>,
    real: Vec<Transform>,
    ideal: Vec<Transform>,
}

impl AxisTable {
    fn at(&self, ijk: [usize; 3]) -> (&Transform, &Transform) {
        let n = self.dimension.map_or(0, |d| ijk[d]);
        (&self.real[n], &self.ideal[n])
    }
}

/// The CPU twin of the GPU passes, in f64: `E_rel = Pre(j, k) · A_X(i) · Post(j, k)`.
pub struct CpuPlan {
    grid: Grid,
    /// The axes in product order.
    axes: Vec<AxisTable>,
    /// Where X stands in the product order (`axes.len()` when there is no X).
    x_position: usize,
    tail_real: Transform,
    tail_ideal: Transform,
    /// A machine with errors of other axes' positions, whose axes cannot be tabulated per grid
    /// value of their own: tabulated over the dimensions each reads instead ([`folded`]).
    folded: Option<Box<folded::FoldedPlan>>,
}

impl CpuPlan {
    pub fn new(machine: &Machine, grid: &Grid) -> CpuPlan {
        let twin = Twin::of(machine);
        let mut x_position = None;
        let axes: Vec<AxisTable> = machine
            .axes_in_product_order()
            .into_iter()
            .enumerate()
            .map(|(n, axis)| {
                let ideal_axis = twin.ideal().axis(axis.letter).expect("same axes");
                let dimension = axis
                    .letter
                    .is_linear()
                    .then(|| axis.letter.direction_index());
                if dimension == Some(0) {
                    x_position = Some(n);
                }
                let positions = grid.axis_positions(axis.letter);
                AxisTable {
                    dimension,
                    real: positions
                        .iter()
                        .map(|&q| reference::axis_transform(axis, q))
                        .collect(),
                    ideal: positions
                        .iter()
                        .map(|&q| reference::axis_transform(ideal_axis, q))
                        .collect(),
                }
            })
            .collect();
        CpuPlan {
            grid: grid.clone(),
            x_position: x_position.unwrap_or(axes.len()),
            axes,
            tail_real: reference::spindle_and_tool(machine),
            tail_ideal: reference::spindle_and_tool(twin.ideal()),
            folded: machine
                .has_cross_axis_errors()
                .then(|| Box::new(folded::FoldedPlan::new(machine, grid))),
        }
    }

    /// Computes lines `first_line .. first_line + lines` into `out` (`lines · 6 · nx` values).
    pub fn compute_lines(&self, first_line: u64, lines: u64, out: &mut [f32]) {
        let nx = self.grid.dims[0];
        if let Some(plan) = &self.folded {
            return super::par_lines(&self.grid, first_line, lines, out, |jk, line_out| {
                plan.line(jk, |i, real, ideal| {
                    write_point(line_out, nx, i, real, ideal)
                })
            });
        }
        super::par_lines(&self.grid, first_line, lines, out, |[j, k], line_out| {
            let ijk = [0, j, k];
            let (mut pre_r, mut pre_i) = (Transform::identity(), Transform::identity());
            let (mut post_r, mut post_i) = (Transform::identity(), Transform::identity());
            for (a, table) in self.axes.iter().enumerate() {
                let (r, i) = table.at(ijk);
                if a < self.x_position {
                    pre_r *= r;
                    pre_i *= i;
                } else if a > self.x_position {
                    post_r *= r;
                    post_i *= i;
                }
            }
            post_r *= self.tail_real;
            post_i *= self.tail_ideal;
            for i in 0..nx {
                let (real, ideal) = match self.axes.get(self.x_position) {
                    Some(x) => {
                        let (xr, xi) = x.at([i, 0, 0]);
                        (pre_r * xr * post_r, pre_i * xi * post_i)
                    }
                    None => (pre_r * post_r, pre_i * post_i),
                };
                write_point(line_out, nx, i, &real, &ideal);
            }
        });
    }
}

/// Point `i`'s OE and VE, from its real and ideal transforms, into a line of the chunk layout.
fn write_point(line_out: &mut [f32], nx: usize, i: usize, real: &Transform, ideal: &Transform) {
    let ve = real.fixed_view::<3, 1>(0, 3) - ideal.fixed_view::<3, 1>(0, 3);
    let r = real.fixed_view::<3, 3>(0, 0) * ideal.fixed_view::<3, 3>(0, 0).transpose();
    let oe = reference::rotation_vector(&r);
    for (c, v) in [oe.x, oe.y, oe.z, ve.x, ve.y, ve.z].iter().enumerate() {
        line_out[c * nx + i] = *v as f32;
    }
}

/// The whole map with [`CpuPlan`], chunk by chunk, with the same callback as the GPU engine.
pub fn run<E>(
    machine: &Machine,
    grid: &Grid,
    chunk_points: Option<u64>,
    on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
) -> Result<(), E> {
    let plan = CpuPlan::new(machine, grid);
    super::run_in_chunks(
        grid,
        chunk_points.unwrap_or(CPU_CHUNK_POINTS),
        |first_line, lines, buffer| plan.compute_lines(first_line, lines, buffer),
        on_chunk,
    )
}
