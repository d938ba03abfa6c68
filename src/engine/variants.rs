//! Many machines built from one (machine design): the base machine with each sample's deviations
//! added ([`Machine::perturbed`]), each reduced to the statistics of its field, or evaluated at a
//! set of positions, on the engine at hand. The GPU reduces on the device and reads back a few
//! numbers per sample; the CPU engine computes each sample's field in f64 as a map would.

use std::convert::Infallible;

use rayon::prelude::*;

use super::cpu::CpuPlan;
use super::reference::reference_lines;
use super::{run_in_chunks, Engine, EngineError, CPU_CHUNK_POINTS};
use crate::model::channels::Sample;
use crate::model::grid::Grid;
use crate::model::perturbation::Perturbation;
use crate::model::statistics::FieldStats;
use crate::model::{Command, Machine};
use crate::reference::Twin;

/// A base machine and the deviations its samples add: row `b` of an amplitude table holds the
/// amplitudes of `perturbations` for sample `b`.
#[derive(Debug, Clone, Copy)]
pub struct Variants<'a> {
    pub base: &'a Machine,
    pub perturbations: &'a [Perturbation],
}

impl Variants<'_> {
    /// Sample `row` as a machine.
    pub fn machine(&self, row: &[f64]) -> Machine {
        self.base.perturbed(self.perturbations, row)
    }
}

impl Engine {
    /// The statistics of each sample's field over `grids` (a sweep of poses: the statistics run
    /// over every grid, the pose of the largest |VE| is its index). `on_progress(samples done)`
    /// is called as samples finish.
    pub fn variant_stats(
        &self,
        variants: &Variants,
        rows: &[Vec<f64>],
        grids: &[Grid],
        on_progress: impl Fn(usize) + Sync,
    ) -> Result<Vec<FieldStats>, EngineError> {
        let mut total = vec![FieldStats::default(); rows.len()];
        match self {
            Engine::Gpu(gpu) => {
                for (pose, grid) in grids.iter().enumerate() {
                    let stats = gpu.variant_stats(
                        variants.base,
                        variants.perturbations,
                        rows,
                        grid,
                        |done| on_progress((pose * rows.len() + done) / grids.len()),
                    )?;
                    for (t, s) in total.iter_mut().zip(&stats) {
                        t.merge(s, pose);
                    }
                }
            }
            Engine::Cpu | Engine::Reference => {
                let done = std::sync::atomic::AtomicUsize::new(0);
                total = rows
                    .par_iter()
                    .map(|row| {
                        let machine = variants.machine(row);
                        let mut total = FieldStats::default();
                        for (pose, grid) in grids.iter().enumerate() {
                            total.merge(&self.host_stats(&machine, grid), pose);
                        }
                        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        on_progress(n + 1);
                        total
                    })
                    .collect();
            }
        }
        for (n, stats) in total.iter().enumerate() {
            let values = [stats.sum_sq_ve, stats.max_ve_mm, stats.max_oe_rad];
            if values
                .iter()
                .chain(&stats.max_axis_mm)
                .any(|v| !v.is_finite())
            {
                return Err(not_finite(variants, n, "the statistics"));
            }
        }
        Ok(total)
    }

    /// The statistics of one machine's field over a grid, computed on the host.
    fn host_stats(&self, machine: &Machine, grid: &Grid) -> FieldStats {
        let mut stats = FieldStats::default();
        let nx = grid.dims[0];
        let mut add = |first: u64, lines: u64, data: &[f32]| -> Result<(), Infallible> {
            stats.add_chunk(first, lines, nx, data);
            Ok(())
        };
        let result = match self {
            Engine::Reference => {
                let twin = Twin::of(machine);
                run_in_chunks(
                    grid,
                    CPU_CHUNK_POINTS,
                    |first, lines, buffer| reference_lines(&twin, grid, first, lines, buffer),
                    &mut add,
                )
            }
            _ => {
                let plan = CpuPlan::new(machine, grid);
                run_in_chunks(
                    grid,
                    CPU_CHUNK_POINTS,
                    |first, lines, buffer| plan.compute_lines(first, lines, buffer),
                    &mut add,
                )
            }
        };
        let Ok(()) = result;
        stats
    }

    /// VE and OE (in [`crate::model::channels::SAMPLE_COLUMNS`] order) of each sample at each
    /// commanded position; every position stands at the rotary positions of the first.
    pub fn variant_values(
        &self,
        variants: &Variants,
        rows: &[Vec<f64>],
        commands: &[Command],
        on_progress: impl Fn(usize) + Sync,
    ) -> Result<Vec<Vec<Sample>>, EngineError> {
        let values = self.values_of(variants, rows, commands, on_progress)?;
        for (n, sample) in values.iter().enumerate() {
            if let Some(p) = sample.iter().position(|v| v.iter().any(|x| !x.is_finite())) {
                let [x, y, z] = [0, 1, 2].map(|d| commands[p][d]);
                let at = format!("the error at X={x:.3} Y={y:.3} Z={z:.3} mm");
                return Err(not_finite(variants, n, &at));
            }
        }
        Ok(values)
    }

    fn values_of(
        &self,
        variants: &Variants,
        rows: &[Vec<f64>],
        commands: &[Command],
        on_progress: impl Fn(usize) + Sync,
    ) -> Result<Vec<Vec<Sample>>, EngineError> {
        if let Engine::Gpu(gpu) = self {
            return Ok(gpu.variant_values(
                variants.base,
                variants.perturbations,
                rows,
                commands,
                on_progress,
            )?);
        }
        let pose = commands.first().copied().unwrap_or([0.0; 6]);
        let done = std::sync::atomic::AtomicUsize::new(0);
        Ok(rows
            .par_iter()
            .map(|row| {
                let twin = Twin::new(variants.machine(row));
                let values = commands
                    .iter()
                    .map(|c| {
                        let mut command = pose;
                        command[..3].copy_from_slice(&c[..3]);
                        let d = twin.deviation(&command);
                        let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
                        [ve.x, ve.y, ve.z, oe.x, oe.y, oe.z]
                    })
                    .collect();
                on_progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
                values
            })
            .collect())
    }
}

/// `what` of sampled machine `n` is not a finite number.
fn not_finite(variants: &Variants, n: usize, what: &str) -> EngineError {
    EngineError::NotFinite {
        what: format!("{what} of sampled machine {}", n + 1),
        inputs: format!(
            "drawn around {} at {}",
            variants.base.name,
            variants.base.inputs.describe(variants.base)
        ),
    }
}
