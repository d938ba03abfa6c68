//! The kernels timed for `volmap bench`: passes over the whole grid taking turns, timed by the
//! device's timestamp queries where it has them and by the wall clock otherwise.

use super::mapper::GpuMapper;
use super::{KernelChoice, Tiling, TimedKernel};
use crate::gpu::device;
use crate::gpu::GpuError;
use crate::model::grid::Grid;
use crate::model::Machine;

impl GpuMapper {
    /// Runs `pass(k, timer)` (one pass over the grid in `chunks` chunks with kernel `k` of
    /// `kernels`, each chunk timed by `timer` where given) for every kernel in turn: first for at
    /// least `warm_up_s` seconds (once at least), the driver's lazy work done and the device's
    /// clocks up, then `runs` times. Returns each kernel's seconds per run and whether timestamp
    /// queries timed them.
    pub(super) fn take_turns(
        &self,
        kernels: usize,
        chunks: usize,
        (runs, warm_up_s): (usize, f64),
        pass: impl Fn(usize, Option<&device::Timer>) -> Result<(), GpuError>,
    ) -> Result<(Vec<Vec<f64>>, bool), GpuError> {
        let warming = std::time::Instant::now();
        loop {
            for k in 0..kernels {
                pass(k, None)?;
            }
            if warming.elapsed().as_secs_f64() >= warm_up_s {
                break;
            }
        }
        let timer = self.gpu.timer(chunks);
        let mut seconds = vec![Vec::with_capacity(runs); kernels];
        for _ in 0..runs.max(1) {
            for (k, runs_of_k) in seconds.iter_mut().enumerate() {
                let start = std::time::Instant::now();
                pass(k, timer.as_ref())?;
                runs_of_k.push(match &timer {
                    Some(t) => self.gpu.timed_seconds(t, chunks as u32)?,
                    None => start.elapsed().as_secs_f64(),
                });
            }
        }
        Ok((seconds, timer.is_some()))
    }

    /// The seconds one pass over the whole grid takes on the device, every run of `runs`, for
    /// each of `kernels`, and whether timestamp queries timed them. The kernels take turns, run
    /// after run, so a ceiling and the kernel it bounds are measured under the same conditions.
    /// Before the clock starts every kernel passes over the grid for at least `warm_up_s`
    /// seconds (once at least): the driver's lazy work done and the device's clocks up, whatever
    /// ran before.
    pub fn time_kernels(
        &self,
        machine: &Machine,
        grid: &Grid,
        kernels: &[TimedKernel],
        runs: usize,
        warm_up_s: f64,
    ) -> Result<(Vec<Vec<f64>>, bool), GpuError> {
        let mut tilings: Vec<Tiling> = Vec::new();
        for kernel in kernels {
            if !tilings.contains(&kernel.tiling) {
                tilings.push(kernel.tiling);
            }
        }
        let prepared = self.prepare(machine, grid, None, &tilings)?;
        let plan_of = |kernel: &TimedKernel| {
            prepared
                .plans
                .iter()
                .position(|p| p.tiling == kernel.tiling)
                .expect("a plan per tiling")
        };
        let pass = |kernel: &TimedKernel, timer: Option<&device::Timer>| {
            let plan = plan_of(kernel);
            let mut last = None;
            for n in 0..prepared.chunks.len() {
                let timed = timer.map(|t| (t, n as u32));
                last = Some(self.submit_chunk(&prepared, plan, n, kernel.choice, false, timed));
            }
            match last {
                Some(last) => self.gpu.wait(last),
                None => Ok(()),
            }
        };
        self.take_turns(
            kernels.len(),
            prepared.chunks.len(),
            (runs, warm_up_s),
            |k, timer| pass(&kernels[k], timer),
        )
    }

    /// [`GpuMapper::time_kernels`] for one kernel with this device's tiling: the fastest of
    /// `runs`, after one pass.
    pub fn time_kernel(
        &self,
        machine: &Machine,
        grid: &Grid,
        choice: KernelChoice,
        runs: usize,
    ) -> Result<(f64, bool), GpuError> {
        let kernel = TimedKernel {
            choice,
            tiling: self.tiling(),
        };
        let (seconds, timestamps) = self.time_kernels(machine, grid, &[kernel], runs, 0.0)?;
        Ok((
            seconds[0].iter().copied().fold(f64::INFINITY, f64::min),
            timestamps,
        ))
    }
}
