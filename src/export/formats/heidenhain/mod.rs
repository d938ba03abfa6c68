//! `heidenhain`: HEIDENHAIN nonlinear axis error compensation in the MANUALplus 620 layout (not
//! the iTNC 530 / TNC 430 column-number layout)
//! (HEIDENHAIN technical manuals, "Nonlinear axis error compensation"): compensation-value
//! tables `*.COM` and the assignment table `*.CMA` that says which `*.COM` is read along which
//! axis.
//!
//! - `x.com`, `y.com`, `z.com`: one table per input axis (the axis of its `config.cma` column),
//!   `AXISPOS` the positions of its points (machine datum, mm) and a column per compensated axis
//!   (`X`, `Y`, `Z`): `[column axis] = F(input axis)`, so `y.com` holds the pitch error of Y
//!   along Y, the straightness of Y in X and Z, the squareness of Y to X and Z;
//!   `BACKLASH`, where the input axis has reversal terms, the own column's values for the
//!   negative direction of traverse (empty otherwise);
//! - `config.cma`: one row, active (`*`), naming the three tables in the columns X, Y, Z;
//! - `volmap.txt`: what was written from what, the sign and the loading steps (for people; the
//!   control reads only the tables).
//!
//! The control interpolates linearly between points; the points are free (volmap chooses them,
//! [`free_nodes`](crate::export::nodes::free_nodes), shared by the columns of a table) and cover the
//! travel, so nothing is read beyond the ends (where the end values are taken to hold).
//! **Sign**: the tables hold the error, actual − commanded position ("The error is positive if
//! the table travel is too long"), so the values are the negated command correction, `−d`.
//! The frame of the file (`BEGIN` line, fixed-width columns, `[END]`) is the general form of the
//! TNC's tables; the column widths are volmap's.
//!
//! The tables as the control holds them are in [`tables`], the files written by [`write`] and
//! read back by [`read`].

mod read;
mod tables;
mod write;

use crate::export::error::ExportError;
use crate::export::fitting::{Fitting, Structure, Term};
use crate::export::format::{Control, Format, Layout, Limits, Nodes, Spec, WrittenFile};
use tables::MIN_SPACING_MM;
use write::write_files;

pub struct Heidenhain;

const SPEC: Spec = Spec {
    name: "heidenhain",
    title: "HEIDENHAIN (nonlinear axis error compensation, *.COM and *.CMA, the MANUALplus 620 layout)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Free,
        min_points: 2,
        max_points: 256,
        min_spacing_mm: MIN_SPACING_MM,
        default_points: 64,
        source:
            "HEIDENHAIN: 256 entries per .COM table (TNC 407 technical manual, PLC module 9095)",
    },
    structure: Structure::Additive([[Term::Curve; 3]; 3]),
    holds: "one table per axis holds the error of X, Y and Z as a function of that axis (pitch, straightness, squareness, sag), summed over the axes, and the reversal of each axis along itself (BACKLASH); no table holds an error that varies with two axes at once (the Abbe offset of an angular error, a sag that grows as the ram extends) or an orientation error",
    uses_direction: true,
};

impl Format for Heidenhain {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([SPEC.limits.default_points; 3]);
        write_files(fitting, points, spacing_mm)
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(read::read(files)?))
    }
}
