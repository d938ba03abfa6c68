//! The GPU: every wgpu call behind [`device`], the Pod mirrors of the WGSL structs and the
//! constants shared with WGSL in [`layout`], and one module per shader beside its name:
//! [`chain`] (`shaders/deviation.wgsl` + `shaders/chain.wgsl`: the machine packed into buffers and
//! the map computed chunk by chunk) and [`sample`] (`shaders/sample.wgsl`: trilinear sampling of a
//! field); `shaders/uncertainty.wgsl`, the sums of a map's uncertainty, beside the chain's
//! mapper ([`chain::SumsPlan`]).

pub mod chain;
pub mod device;
pub mod layout;
pub mod sample;
pub mod slow;

pub use chain::{
    check_error_angles, pack, GpuMapper, KernelChoice, MachineShape, Packed, Tiling, TimedKernel,
    CHAIN_WGSL, MAX_ERROR_ANGLE_RAD,
};
pub use device::GpuError;
pub use sample::{GpuSampler, SAMPLE_WGSL};

/// A shader as volmap compiles it: its name, the files of `shaders/` it is joined from, in
/// order, and the joined source.
#[derive(Debug, Clone, Copy)]
pub struct Shader {
    pub name: &'static str,
    pub files: &'static [&'static str],
    pub source: &'static str,
}

/// Every shader volmap compiles.
pub const SHADERS: [Shader; 3] = [
    Shader {
        name: "chain",
        files: &chain::CHAIN_WGSL_FILES,
        source: CHAIN_WGSL,
    },
    Shader {
        name: "sample",
        files: &["sample.wgsl"],
        source: SAMPLE_WGSL,
    },
    Shader {
        name: "uncertainty",
        files: &["uncertainty.wgsl"],
        source: chain::UNCERTAINTY_WGSL,
    },
];
