//! `siemens`: SINUMERIK 840D sl / 828D interpolatory compensation (Siemens, *Extended
//! Functions* function manual, K3 "Compensations"), written as the initialisation programs the
//! control runs to load it:
//!
//! - `AX_EEC.INI` (`%_N_AX_EEC_INI`): the measuring-system error compensation (MSEC, which
//!   includes leadscrew error compensation), one table per axis, input and output that axis:
//!   `$AA_ENC_COMP[0,N,X1]` with `$AA_ENC_COMP_STEP/_MIN/_MAX/_IS_MODULO[0,X1]`;
//! - `NC_CEC.INI` (`%_N_NC_CEC_INI`, only where there is something to hold): the sag/cross
//!   compensation (CEC), one table per (basic axis → compensated axis) pair the correction
//!   needs: `$AN_CEC[t,N]` with `$AN_CEC_INPUT_AXIS/_OUTPUT_AXIS/_STEP/_MIN/_MAX/_DIRECTION/
//!   _MULT_BY_TABLE/_IS_MODULO[t]`; and, for an axis with reversal terms, tables read only
//!   while that axis moves in the negative direction (`_DIRECTION = -1`) holding what the
//!   correction gains then.
//!
//! Every table is equidistant: point `N` at `MIN + N·STEP`, `(MAX − MIN)/STEP + 1` points;
//! linear between points; the first and last values hold outside `[MIN, MAX]`. The tables of
//! all axes sum. A CEC table reads the setpoint of its basic axis; an MSEC table the actual
//! position of its axis (the encoder's), so its values are the error as a function of where
//! the axis is, as a laser measures it. **Sign**: a table holds the error, actual − commanded position ("A positive
//! compensation value causes the corresponding machine axis to move in the negative
//! direction."), so the value written is the negated command correction, `−d`.
//!
//! Machine axis names: `X1`, `Y1`, `Z1` for X, Y, Z, the names of Siemens' examples.
//!
//! The tables as the control holds them are in [`tables`], the programs written by [`write`]
//! and read back by [`read`].

mod read;
mod tables;
mod write;

use crate::export::error::ExportError;
use crate::export::fitting::{Fitting, Structure, Term};
use crate::export::format::{Control, Format, Layout, Limits, Nodes, Spec, WrittenFile};
use write::write_files;

pub struct Siemens;

/// The most points volmap writes to one table.
const MAX_POINTS: usize = 2000;

const SPEC: Spec = Spec {
    name: "siemens",
    title: "SINUMERIK 840D sl / 828D (measuring-system error and sag/cross compensation tables)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        // MD38000 / MD18342 size the tables (their upper limits are to be checked in the
        // control's lists manual); an 828D holds 200 points per CEC table, fixed.
        max_points: MAX_POINTS,
        // Ten increments of the default 1 µm position resolution.
        min_spacing_mm: 0.01,
        default_points: 200,
        source:
            "SINUMERIK MD38000/MD18342 table sizes as volmap bounds them; an 828D holds 200",
    },
    structure: Structure::Additive([[Term::Curve; 3]; 3]),
    holds: "per-axis tables (MSEC) hold each axis's error along itself, sag/cross tables (CEC) the error of one axis as a function of another (straightness, squareness, sag), summed, and reversal as negative-direction tables; no table holds an error that varies with two axes at once (the Abbe offset of an angular error, a sag that grows as the ram extends) or an orientation error",
    uses_direction: true,
};

impl Format for Siemens {
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
