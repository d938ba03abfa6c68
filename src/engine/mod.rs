//! The engines and the choice between them. The GPU ([`crate::gpu`]), the CPU engine ([`cpu`]:
//! the GPU's passes in f64 on all cores) and the reference over a grid ([`reference`](mod@reference): the f64
//! truth at every point) each compute a map chunk by chunk of whole grid lines, in the layout of
//! [`crate::model::channels`], and hand the chunks to a callback; [`map`] is the one map run,
//! streaming them into a field file with the statistics and the spot check; [`sweep`] runs it at
//! every pose of a sweep of the rotary axes into one multi-part file.

pub mod cpu;
pub mod map;
pub mod map_uncertainty;
pub mod reference;
pub mod sweep;
pub mod uncertainty;
pub mod variants;

use crate::error::{Classify, ErrorKind};
use crate::gpu::{GpuError, GpuMapper};
use crate::io::field::FieldError;
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;

/// Why a map could not be computed or stored.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error("no GPU adapter found")]
    NoAdapter,
    /// A value computed is not a finite number: the machine's errors at its inputs are beyond
    /// any number there (bad input; a machine file's values are bounded as it is read).
    #[error("{what} is not a finite number: the machine's errors are beyond any number there ({inputs})")]
    NotFinite { what: String, inputs: String },
    /// The machine's uncertainties cannot be propagated (a covariance that is no covariance:
    /// the machine file's reader refuses those first).
    #[error("the uncertainties of the error values cannot be propagated: {0}")]
    Uncertainty(String),
}

impl Classify for EngineError {
    fn kind(&self) -> ErrorKind {
        match self {
            EngineError::Gpu(e) => e.kind(),
            EngineError::Field(e) => e.kind(),
            EngineError::NoAdapter => ErrorKind::Work,
            EngineError::NotFinite { .. } | EngineError::Uncertainty(_) => ErrorKind::Input,
        }
    }
}

/// Which engine to compute on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The GPU when an adapter exists, else the CPU engine.
    Auto,
    Gpu,
    Cpu,
}

/// Where a map is computed.
pub enum Engine {
    Gpu(Box<GpuMapper>),
    /// The CPU engine ([`cpu::CpuPlan`]).
    Cpu,
    /// The f64 reference at every point: the truth, and the slowest.
    Reference,
}

impl Engine {
    /// Opens the engine `choice` asks for. With `Auto` and no adapter, falls back to the CPU and
    /// returns a note saying so.
    pub fn select(choice: DeviceChoice) -> Result<(Engine, Option<String>), EngineError> {
        if choice == DeviceChoice::Cpu {
            return Ok((Engine::Cpu, None));
        }
        match GpuMapper::open()? {
            Some(gpu) => Ok((Engine::Gpu(Box::new(gpu)), None)),
            None if choice == DeviceChoice::Auto => Ok((
                Engine::Cpu,
                Some("no GPU adapter found: computing on the CPU (f64, all cores)".into()),
            )),
            None => Err(EngineError::NoAdapter),
        }
    }

    pub fn name(&self) -> String {
        match self {
            Engine::Gpu(g) => g.adapter_name().to_string(),
            Engine::Cpu => format!("CPU, f64 ({} threads)", rayon::current_num_threads()),
            Engine::Reference => {
                format!("f64 reference ({} threads)", rayon::current_num_threads())
            }
        }
    }

    /// The most points one chunk of a map holds on this engine.
    pub fn chunk_points(&self) -> u64 {
        match self {
            Engine::Gpu(g) => g.max_chunk_points(),
            Engine::Cpu | Engine::Reference => CPU_CHUNK_POINTS,
        }
    }

    /// Computes the map, handing chunks of whole lines to `on_chunk(first_line, lines, data)` in
    /// line order. `chunk_points` caps the points per chunk below the engine's own limit; a chunk
    /// holds at least one line, whatever the cap.
    pub fn run<E: From<GpuError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        chunk_points: Option<u64>,
        on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        match self {
            Engine::Gpu(g) => g.run(machine, grid, chunk_points, on_chunk),
            Engine::Cpu => cpu::run(machine, grid, chunk_points, on_chunk),
            Engine::Reference => reference::run(machine, grid, chunk_points, on_chunk),
        }
    }
}

/// Lines per chunk of the engines that compute on the host (the CPU engine, the reference) are
/// chosen so a chunk holds about this many points.
pub const CPU_CHUNK_POINTS: u64 = 1 << 18;

/// Fills the lines `first_line .. first_line + lines` of `out` in parallel, in the chunk layout
/// (per line, `nx` values of each channel in turn): `line([j, k], values)` writes line `(j, k)`.
pub(crate) fn par_lines(
    grid: &Grid,
    first_line: u64,
    lines: u64,
    out: &mut [f32],
    line: impl Fn([usize; 2], &mut [f32]) + Sync,
) {
    use rayon::prelude::*;
    let ny = grid.dims[1] as u64;
    out.par_chunks_mut(CHANNELS.len() * grid.dims[0])
        .take(lines as usize)
        .enumerate()
        .for_each(|(n, values)| {
            let l = first_line + n as u64;
            line([(l % ny) as usize, (l / ny) as usize], values)
        });
}

/// The whole grid in chunks of at most `chunk_points` points: `compute(first_line, lines,
/// buffer)` fills each, `on_chunk` takes it. The loop of the engines that compute on the host.
pub(crate) fn run_in_chunks<E>(
    grid: &Grid,
    chunk_points: u64,
    compute: impl Fn(u64, u64, &mut [f32]),
    mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
) -> Result<(), E> {
    let mut buffer = Vec::new();
    for (first_line, lines) in grid.chunks(chunk_points).iter() {
        buffer.resize(lines as usize * grid.dims[0] * CHANNELS.len(), 0.0f32);
        compute(first_line, lines, &mut buffer);
        on_chunk(first_line, lines, &buffer)?;
    }
    Ok(())
}
