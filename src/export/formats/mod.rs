//! The formats: one file or folder each, and [`FORMATS`], the one registry of them the core
//! reads. A format's file (a folder's `mod.rs`, or for a folder of two formats one file each)
//! holds its `SPEC` and its [`Format`]; a folder's other files are its tables, its writer and
//! its reader. The formats import the core's files (`error`, `fitting`, `format`, `nodes`) and
//! files shared among themselves (`skew`, `axis_tables`, `grid_csv`'s grid), never this
//! registry.

mod axis_tables;
mod fanuc;
mod grid_csv;
mod heidenhain;
mod isg;
mod klipper;
mod klipper_twist;
mod linuxcnc;
mod marlin;
mod rrf;
mod rrf_heightmap;
mod siemens;
mod skew;

use crate::export::format::Format;

/// Every format volmap writes, in the order `--format` lists them.
pub static FORMATS: &[&dyn Format] = &[
    &grid_csv::GridCsv,
    &linuxcnc::LinuxCnc,
    &klipper::Klipper,
    &klipper_twist::KlipperTwist,
    &marlin::Marlin,
    &rrf::Rrf,
    &rrf_heightmap::RrfHeightMap,
    &siemens::Siemens,
    &heidenhain::Heidenhain,
    &fanuc::pitch::FanucPitch,
    &fanuc::lattice::FanucLattice,
    &isg::volumetric::Isg,
    &isg::axis::IsgAxis,
];
