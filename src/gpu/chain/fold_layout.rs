//! Where each part of a machine's errors stands in the tables of `shaders/folded.wgsl`: each
//! axis's six errors split by the grid dimensions their terms read (a term reads at most two),
//! each part tabulated over exactly those dimensions. Pure host arithmetic, no device.

use crate::gpu::layout::FoldedPart;
use crate::model::errorfn::ErrorFunction;
use crate::model::grid::Grid;
use crate::model::{AxisLetter, Machine};

/// Bytes of one part's entry of one machine: its six errors in two vec4.
const ENTRY_BYTES: u64 = 32;

/// The bit of the grid dimension that drives axis `letter`; none for a rotary axis (at its pose).
fn dim_bit(letter: AxisLetter) -> u32 {
    if letter.is_linear() {
        1 << letter.direction_index()
    } else {
        0
    }
}

/// The grid dimensions term `term` of an error of axis `own` reads (the shader's `term_dims`).
fn term_dims(term: &ErrorFunction, own: AxisLetter) -> u32 {
    match term {
        ErrorFunction::Of { axis, .. } => dim_bit(*axis),
        ErrorFunction::Table2d(t) => dim_bit(t.axes[0]) | dim_bit(t.axes[1]),
        _ => dim_bit(own),
    }
}

/// The entry steps per i, j, k of a table over the grid dimensions of `mask` (0 for the others),
/// i fastest so that the entries a line reads stand together, and its entries.
fn strides(mask: u32, grid: &Grid) -> ([u32; 4], u64) {
    let mut stride = [0u32; 4];
    let mut step = 1u64;
    for d in (0..3).filter(|d| mask & 1 << d != 0) {
        stride[d] = step as u32;
        step *= grid.dims[d] as u64;
    }
    (stride, step)
}

/// Where each part of each axis of a machine stands, and which axes vary along a line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct FoldedLayout {
    pub parts: Vec<FoldedPart>,
    /// Per axis (product order): first part, parts constant along a line, parts varying (the
    /// part of i alone first), -.
    pub axes: Vec<[u32; 4]>,
    /// Table entries of one machine, every part's together.
    pub entries: u32,
    /// The axes `[first, end)` (product order) from the first to the last that varies along a
    /// grid line: composed at every point; those before and after once per line.
    pub span: (u32, u32),
    /// X alone varies along a line: the point pass's formula.
    pub x_alone: bool,
}

impl FoldedLayout {
    pub fn new(machine: &Machine, grid: &Grid) -> FoldedLayout {
        let order = machine.axes_in_product_order();
        let mut parts = Vec::new();
        let mut axes = Vec::new();
        let mut entries = 0u64;
        for (n, axis) in order.iter().enumerate() {
            // The part of the own dimension always: the tolerances' deviations go there.
            let mut masks = vec![dim_bit(axis.letter)];
            for f in axis.components.iter().flatten() {
                for term in f.terms().into_iter().filter(|t| !t.is_zero()) {
                    masks.push(term_dims(term, axis.letter));
                }
            }
            // Those constant along a line first.
            masks.sort_unstable_by_key(|m| (m & 1, *m));
            masks.dedup();
            let constant = masks.iter().filter(|m| *m & 1 == 0).count() as u32;
            axes.push([
                parts.len() as u32,
                constant,
                masks.len() as u32 - constant,
                0,
            ]);
            for mask in masks {
                let (stride, step) = strides(mask, grid);
                parts.push(FoldedPart {
                    table: [entries as u32, step as u32, n as u32, mask],
                    stride,
                });
                entries += step;
            }
        }
        let varies = |n: &usize| axes[*n][2] > 0;
        let count = order.len();
        let first = (0..count).find(varies).unwrap_or(count);
        let end = (0..count).rfind(varies).map_or(first, |last| last + 1);
        let x_alone = end == first + 1 && order[first].letter == AxisLetter::X;
        FoldedLayout {
            parts,
            axes,
            entries: entries as u32,
            span: (first as u32, end as u32),
            x_alone,
        }
    }

    /// Bytes of the tables of one machine.
    pub fn bytes(&self) -> u64 {
        self.entries as u64 * ENTRY_BYTES
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::embedded;
    use crate::model::Machine;

    #[test]
    fn the_gantrys_errors_fold_into_parts_of_the_dimensions_they_read() {
        // FFXYZ: EAX reads Y, every other error of X its own position; EZY sums a table of Y
        // and a table of Y and Z; Z reads only Z.
        let machine = embedded::load("gantry-2m").unwrap();
        let grid = Grid::full_travel(&machine, [5, 7, 3], [0.0; 6]).unwrap();
        let layout = FoldedLayout::new(&machine, &grid);
        let masks: Vec<u32> = layout.parts.iter().map(|p| p.table[3]).collect();
        assert_eq!(masks, [0b010, 0b001, 0b010, 0b110, 0b100]);
        assert_eq!(layout.axes, [[0, 1, 1, 0], [2, 2, 0, 0], [4, 1, 0, 0]]);
        let entries: Vec<u32> = layout.parts.iter().map(|p| p.table[1]).collect();
        assert_eq!(entries, [7, 5, 7, 21, 3]);
        assert_eq!(layout.parts[3].stride, [0, 1, 7, 0]);
        assert_eq!(layout.parts[1].stride, [1, 0, 0, 0]);
        assert_eq!(layout.entries, 43);
        assert_eq!((layout.span, layout.x_alone), ((0, 1), true));
        // A sag of Y with X makes Y vary along a line too: X and Y are composed per point.
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/machines/gantry-2m.toml"
        ))
        .unwrap()
        .replace("of = [\"Y\", \"Z\"]", "of = [\"X\", \"Y\"]");
        let sagging = Machine::from_toml(&text, "gantry.toml", None).unwrap();
        let layout = FoldedLayout::new(&sagging, &grid);
        assert_eq!((layout.span, layout.x_alone), ((0, 2), false));
        assert_eq!(layout.axes[1], [2, 1, 1, 0]);
    }
}
