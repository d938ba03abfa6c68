//! volmap: the volumetric error of multi-axis machine tools, mapped over their workspace.
//!
//! The mathematics is MODEL.md's: every axis contributes a relative transform with its ISO 230-1
//! errors, the chain `E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)` is multiplied at every
//! commanded position, and the tool tip's deviation from the ideal machine is the volumetric error.
//!
//! The crate is laid out as the architecture:
//! - [`machine`]: the machine model, its TOML file and the embedded machines;
//! - [`reference`](mod@reference): the f64 CPU reference (nalgebra), ground truth of every test;
//! - [`gpu`]: the WGSL chain kernel (`shaders/chain.wgsl`) on wgpu, all wgpu calls in
//!   [`gpu::device`];
//! - [`cpu`]: the reference over a grid on all cores, the fallback where no adapter exists;
//! - [`grid`]: the grid of commanded positions a map covers;
//! - [`field`]: field files (OpenEXR) written as a stream and read back;
//! - [`map`]: a whole map run, its statistics and its spot check;
//! - [`query`]: VE and OE at arbitrary positions, from a field or exactly;
//! - [`features`]: part files, feature errors and machine capability, on [`tolerance`]
//!   (minimum zones) and [`mesh`] (STL in, PLY out);
//! - [`standards`]: standard accuracy tests from the model against measured data, `fit` and
//!   `build`;
//! - [`plot`]: charts, colour maps and the deformed grid as SVG and PNG;
//! - [`nc`]: offline NC program compensation;
//! - [`bench`](mod@bench): `volmap bench`.

pub mod bench;
pub mod cpu;
pub mod features;
pub mod field;
pub mod gpu;
pub mod grid;
pub mod machine;
pub mod map;
pub mod mesh;
pub mod nc;
pub mod plot;
pub mod query;
pub mod reference;
pub mod standards;
pub mod tolerance;
