//! The ISG kernel's two compensations (Beckhoff TwinCAT 3 CNC), one format each: `isg`, the
//! error parameters of the volumetric compensation ([`volumetric`]; the parameters and files
//! its writer and reader share in [`parameters`], read back by [`read`]), and `isg-axis`, the
//! axis compensation lists ([`axis`]; the lists in [`axis_lists`], read back by
//! [`axis_read`]).

pub mod axis;
mod axis_lists;
mod axis_read;
mod parameters;
mod read;
pub mod volumetric;
