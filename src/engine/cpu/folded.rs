//! The CPU engine for a machine whose errors read other axes' positions (`of`, `table2d`,
//! `sum`; docs/model.md): every axis transform is tabulated over exactly the grid dimensions it
//! depends on (its own, and those of the axes its errors read), one or two, or evaluated point
//! by point for an axis that depends on all three. Per grid line, the axes that do not vary along
//! X are composed once into the constant factors between those that do, so each point costs a
//! product per varying axis and per constant run, real and ideal.

use nalgebra::Matrix4;

use crate::model::grid::Grid;
use crate::model::{AxisLetter, Machine};
use crate::reference::{self, Twin};

type Transform = Matrix4<f64>;

/// The most entries of one axis's table (real and ideal, 256 bytes an entry).
const MAX_TABLE_ENTRIES: u64 = crate::engine::CPU_CHUNK_POINTS;

/// One axis's transforms, real and ideal.
enum AxisTable {
    /// Over the grid dimensions `dims` (none, one or two, in increasing order): entry
    /// `Σ ijk[dims[n]] · stride[n]`.
    Folded {
        dims: Vec<usize>,
        stride: Vec<usize>,
        real: Vec<Transform>,
        ideal: Vec<Transform>,
    },
    /// Depends on X, Y and Z: evaluated at each point.
    PerPoint(AxisLetter),
}

impl AxisTable {
    fn new(twin: &Twin, letter: AxisLetter, grid: &Grid) -> AxisTable {
        let axis = twin.real().axis(letter).expect("an axis of the machine");
        let ideal_axis = twin.ideal().axis(letter).expect("same axes");
        let dims = axis.grid_dims();
        let sizes: Vec<usize> = dims.iter().map(|&d| grid.dims[d]).collect();
        // A table over two dimensions larger than a chunk (2^18 entries, 64 MiB) is evaluated
        // point by point instead: memory bounded whatever the grid.
        let too_large = sizes.iter().map(|&n| n as u64).product::<u64>() > MAX_TABLE_ENTRIES;
        if dims.len() > 2 || too_large {
            return AxisTable::PerPoint(letter);
        }
        // Row-major over `dims`: the last varies fastest.
        let stride: Vec<usize> = (0..dims.len())
            .map(|n| sizes[n + 1..].iter().product())
            .collect();
        let entries: usize = sizes.iter().product();
        let (mut real, mut ideal) = (Vec::with_capacity(entries), Vec::with_capacity(entries));
        for e in 0..entries {
            let mut ijk = [0; 3];
            for (n, &d) in dims.iter().enumerate() {
                ijk[d] = (e / stride[n]) % sizes[n];
            }
            let command = grid.command(ijk);
            let q = command[letter.index()];
            real.push(reference::axis_transform_at(axis, q, &command));
            ideal.push(reference::axis_transform(ideal_axis, q));
        }
        AxisTable::Folded {
            dims,
            stride,
            real,
            ideal,
        }
    }

    /// Whether the transform changes along a grid line (with X).
    fn varies_along_x(&self) -> bool {
        match self {
            AxisTable::Folded { dims, .. } => dims.contains(&0),
            AxisTable::PerPoint(_) => true,
        }
    }

    fn at(&self, twin: &Twin, grid: &Grid, ijk: [usize; 3]) -> (Transform, Transform) {
        match self {
            AxisTable::Folded {
                dims,
                stride,
                real,
                ideal,
            } => {
                let e: usize = dims.iter().zip(stride).map(|(&d, s)| ijk[d] * s).sum();
                (real[e], ideal[e])
            }
            AxisTable::PerPoint(letter) => {
                let command = grid.command(ijk);
                let q = command[letter.index()];
                let axis = twin.real().axis(*letter).expect("an axis of the machine");
                let ideal = twin.ideal().axis(*letter).expect("same axes");
                (
                    reference::axis_transform_at(axis, q, &command),
                    reference::axis_transform(ideal, q),
                )
            }
        }
    }
}

/// A factor of a line's product: constant along the line, or an axis that varies along it.
enum Factor<'a> {
    Constant(Transform),
    Varying(&'a AxisTable),
}

/// A line's product as factors, constant runs composed once; a run left empty is left out.
struct Factors<'a> {
    factors: Vec<Factor<'a>>,
    run: Option<Transform>,
}

impl<'a> Factors<'a> {
    fn new() -> Self {
        Factors {
            factors: Vec::new(),
            run: None,
        }
    }

    fn constant(&mut self, t: &Transform) {
        self.run = Some(self.run.map_or(*t, |r| r * t));
    }

    fn varying(&mut self, table: &'a AxisTable) {
        if let Some(run) = self.run.take() {
            self.factors.push(Factor::Constant(run));
        }
        self.factors.push(Factor::Varying(table));
    }

    fn finish(mut self) -> Vec<Factor<'a>> {
        if let Some(run) = self.run.take() {
            self.factors.push(Factor::Constant(run));
        }
        self.factors
    }
}

/// The product of `factors` at point `i` of line `(j, k)`; `real` picks the real or the ideal
/// transforms.
fn product(plan: &FoldedPlan, factors: &[Factor], ijk: [usize; 3], real: bool) -> Transform {
    let pick = |(r, i): (Transform, Transform)| if real { r } else { i };
    let mut out: Option<Transform> = None;
    for factor in factors {
        let t = match factor {
            Factor::Constant(t) => *t,
            Factor::Varying(table) => pick(table.at(&plan.twin, &plan.grid, ijk)),
        };
        out = Some(out.map_or(t, |o| o * t));
    }
    out.unwrap_or_else(Transform::identity)
}

/// The plan of a machine with errors of other axes' positions.
pub(super) struct FoldedPlan {
    twin: Twin,
    grid: Grid,
    /// The axes in product order.
    axes: Vec<AxisTable>,
    /// Where X stands in the product order.
    x_position: Option<usize>,
    tail_real: Transform,
    tail_ideal: Transform,
}

impl FoldedPlan {
    pub(super) fn new(machine: &Machine, grid: &Grid) -> FoldedPlan {
        let twin = Twin::of(machine);
        let order = machine.axes_in_product_order();
        let x_position = order.iter().position(|a| a.letter == AxisLetter::X);
        let axes = order
            .into_iter()
            .map(|axis| AxisTable::new(&twin, axis.letter, grid))
            .collect();
        FoldedPlan {
            grid: grid.clone(),
            axes,
            x_position,
            tail_real: reference::spindle_and_tool(machine),
            tail_ideal: reference::spindle_and_tool(twin.ideal()),
            twin,
        }
    }

    /// The real and ideal transforms of every point of line `(j, k)`, handed to `point(i, real,
    /// ideal)`. The ideal machine's axes depend on their own position only: along a line only
    /// its X varies.
    pub(super) fn line(
        &self,
        [j, k]: [usize; 2],
        mut point: impl FnMut(usize, &Transform, &Transform),
    ) {
        let (mut real, mut ideal) = (Factors::new(), Factors::new());
        for (n, table) in self.axes.iter().enumerate() {
            if table.varies_along_x() {
                real.varying(table);
            } else {
                real.constant(&table.at(&self.twin, &self.grid, [0, j, k]).0);
            }
            if Some(n) == self.x_position {
                ideal.varying(table);
            } else {
                ideal.constant(&table.at(&self.twin, &self.grid, [0, j, k]).1);
            }
        }
        real.constant(&self.tail_real);
        ideal.constant(&self.tail_ideal);
        let (real, ideal) = (real.finish(), ideal.finish());
        for i in 0..self.grid.dims[0] {
            let r = product(self, &real, [i, j, k], true);
            let id = product(self, &ideal, [i, j, k], false);
            point(i, &r, &id);
        }
    }
}
