//! FANUC's two compensations of the Series 30i family, one format each: `fanuc`, the pitch error
//! compensation of each linear axis ([`pitch`]: its tables in [`tables`], written by [`write`],
//! read back by [`read`]), and `fanuc-3d`, the lattice of the three-dimensional error
//! compensation ([`lattice`], one file).

pub mod lattice;
pub mod pitch;
mod read;
mod tables;
mod write;
