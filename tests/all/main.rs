//! volmap's integration tests, one binary. GPU tests skip only where no adapter exists; with
//! `VOLMAP_REQUIRE_GPU=1` (set by CI) a missing adapter is a failure.

/// The fuzzing harness counts the heap of the campaigns' threads (`fuzz`); other threads only
/// pass through it.
#[global_allocator]
static ALLOCATOR: fuzz::harness::watch::CountingAllocator = fuzz::harness::watch::CountingAllocator;

mod ballbar;
mod calibrate;
mod citations;
mod cli;
mod common;
mod cpu;
mod design;
mod docs;
mod export;
mod export_fanuc;
mod export_figure;
mod export_formats;
mod export_heidenhain;
mod export_isg;
mod export_isg_axis;
mod export_siemens;
mod features;
mod field;
mod field_inputs;
mod field_storage;
mod fuzz;
mod fuzz_findings;
mod fuzz_findings_nc;
mod golden;
mod gpu;
mod gpu_sparse;
mod identifiability;
mod machine_file;
mod mesh;
mod min_zone;
mod model_check;
mod model_forms;
mod nc;
mod nc_arcs;
mod nc_inputs;
mod nc_orientation;
mod nc_posts;
mod plot;
mod plot_extremes;
mod plot_looks;
mod profile_datums;
mod query;
mod reference;
mod shaders;
mod standards;
mod standards_frames;
mod standards_inputs;
mod standards_rotary;
mod variants;
mod vtk;
