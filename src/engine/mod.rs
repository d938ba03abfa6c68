//! The engines and the choice between them: the GPU (`crate::gpu`), the CPU engine ([`cpu`], the
//! GPU's passes in f64 on all cores) and the reference over a grid. Each computes a map chunk by
//! chunk of whole grid lines in the layout of [`crate::model::channels`]; [`map`] streams the
//! chunks into a field file with the statistics and the spot check.

pub mod cpu;
pub mod map;

use crate::gpu::{GpuError, GpuMapper};
use crate::model::grid::Grid;
use crate::model::Machine;
use map::MapError;

/// `--device`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The GPU when an adapter exists, else the CPU.
    Auto,
    Gpu,
    Cpu,
}

/// Where the map is computed.
pub enum Engine {
    Gpu(Box<GpuMapper>),
    Cpu,
}

impl Engine {
    /// Opens the engine `choice` asks for. With `Auto` and no adapter, falls back to the CPU and
    /// returns a note saying so.
    pub fn select(choice: DeviceChoice) -> Result<(Engine, Option<String>), MapError> {
        if choice == DeviceChoice::Cpu {
            return Ok((Engine::Cpu, None));
        }
        match GpuMapper::open()? {
            Some(gpu) => Ok((Engine::Gpu(Box::new(gpu)), None)),
            None if choice == DeviceChoice::Auto => Ok((
                Engine::Cpu,
                Some("no GPU adapter found: computing on the CPU (f64, all cores)".into()),
            )),
            None => Err(MapError::NoAdapter),
        }
    }

    pub fn name(&self) -> String {
        match self {
            Engine::Gpu(g) => g.adapter_name().to_string(),
            Engine::Cpu => format!("CPU, f64 ({} threads)", rayon::current_num_threads()),
        }
    }

    /// Computes the map, handing chunks of whole lines to `on_chunk(first_line, lines, data)`.
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
        }
    }
}
