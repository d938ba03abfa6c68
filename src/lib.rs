//! volmap: the volumetric error of multi-axis machine tools, mapped over their workspace.
//!
//! The mathematics is docs/model.md's: every axis contributes a relative transform with its ISO
//! 230-1 errors, the chain `E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)` is multiplied
//! at every commanded position, and the tool tip's deviation from the ideal machine is the
//! volumetric error.
//!
//! The crate is laid out in layers, each using only those below it:
//! - [`error`]: what kind of failure an error is (bad input, or the work failed); [`limits`]: the
//!   documented limits on the counts an input implies; [`report`]: numbers in what volmap
//!   prints for people, one rule for every command;
//! - [`model`]: what a machine is (chain, axes, error functions), the grid of commanded positions,
//!   the channels of a field; no files, no devices;
//! - [`reference`](mod@reference): the f64 truth (nalgebra), and a machine with its ideal twin;
//! - [`io`]: files: machine files and the embedded machines, field files (OpenEXR), points CSV,
//!   meshes;
//! - [`gpu`]: every wgpu call, the chain kernel's packing and mapper, the sampler;
//! - [`engine`]: the GPU, the CPU engine and the reference over a grid, one map run into a field;
//! - [`query`]: answers at arbitrary positions, field slices, the deformed grid;
//! - [`part`]: part files, feature errors, minimum zones, machine capability;
//! - [`design`]: machine design from tolerances: the error budget, Monte Carlo over sampled
//!   machines, tolerance allocation, the probability that a part conforms;
//! - [`standards`]: the standard tests (one file per ISO part) from the model, against measured
//!   data;
//! - [`calibrate`]: location errors fitted to tests, machine files built from measurements;
//! - [`nc`]: offline NC program compensation;
//! - [`export`](mod@export): the correction as controllers' compensation tables, with the residual
//!   each control leaves;
//! - [`plot`]: one drawing written as SVG or PNG, and the charts built from it;
//! - [`bench`](mod@bench): `volmap bench`.

pub mod bench;
pub mod calibrate;
pub mod design;
pub mod engine;
pub mod error;
pub mod export;
pub mod gpu;
pub mod io;
pub mod limits;
pub mod model;
pub mod nc;
pub mod part;
pub mod plot;
pub mod query;
pub mod reference;
pub mod report;
pub mod standards;
pub mod view;
