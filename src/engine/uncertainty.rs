//! The uncertainty of a map (docs/model.md, "Uncertainty of the error values"): the standard
//! uncertainty of each channel at every grid point, chunk by chunk in the map's layout, by the
//! GUM's first-order propagation or by Monte Carlo (JCGM 101), on the engine at hand.
//!
//! Both are sums over machines ([`SumTerm`]): per chunk, each term's two fields differenced and
//! accumulated, `Σ d` and `Σ d²` per value. On the GPU the sums stay on the device and only they
//! are read back ([`crate::gpu::GpuMapper::chunk_sums`]); the CPU engine and the reference run
//! the same sums in f64 from their own fields (the CPU twin of the device's).
//! - First order: one term per direction of the covariance (an independent quantity `u_i` alone;
//!   the columns of the Cholesky factor of a correlated group), `d = (VE(+t·e) − VE(−t·e))/(2t)`
//!   the sensitivity along it, `u² = Σ d²`. The step `t·e` is large enough that f32 fields resolve
//!   the difference and small enough that the central difference is the derivative: angles of
//!   at most [`ANGLE_STEP_RAD`] (the truncation, `(t·e)²/6` relative, is below 1e-8), lengths of
//!   [`LENGTH_STEP_MM`] (VE is linear in a length error, so any step is exact).
//! - Monte Carlo: one term per draw ([`Draws`]), `d` the drawn machine's field less the nominal
//!   one; the sums are pooled in f64 on the host batch after batch (Chan's formula), `u` the
//!   standard deviation of the draws (divisor `N − 1`). The adaptive variant (JCGM 101 §7.9)
//!   runs batches of `M` draws until, at every point of the chunk and for every channel, twice
//!   the standard deviation of the batches' means and of their standard uncertainties (over
//!   `√h`) is within the numerical tolerance `δ` of the uncertainty to two significant digits.

use super::cpu::CpuPlan;
use super::reference::reference_lines;
use super::{Engine, EngineError};
use crate::gpu::chain::{SumTerm, SumsPlan};
use crate::gpu::{GpuError, MAX_ERROR_ANGLE_RAD};
use crate::model::channels::CHANNELS;
use crate::model::grid::{Chunks, Grid};
use crate::model::uncertainty::UncertainKind;
use crate::model::Machine;
use crate::reference::uncertainty::Draws;
use crate::reference::Twin;

/// The largest angle a first-order step moves any error value by, rad.
pub const ANGLE_STEP_RAD: f64 = 1e-4;
/// The largest length a first-order step moves any error value by, mm.
pub const LENGTH_STEP_MM: f64 = 1e-2;
/// The most points one chunk of an uncertainty run holds: its pooled sums are f64 on the host.
pub const UNCERTAINTY_CHUNK_POINTS: u64 = 1 << 20;
/// Draws summed on the device between two readbacks of a Monte Carlo run.
pub const DRAWS_PER_READBACK: usize = 1024;
/// The most batches an adaptive Monte Carlo run takes per chunk.
pub const MAX_ADAPTIVE_BATCHES: usize = 100;
/// The first order's terms the GPU holds mapped for every chunk at most (two machines' tables
/// each, kilobytes); beyond, each chunk maps them again in batches.
pub const MAX_MAPPED_TERMS: usize = 1024;

/// How the uncertainty of a map is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UncertaintyMethod {
    /// The GUM's first-order propagation (JCGM 100).
    FirstOrder,
    /// Monte Carlo (JCGM 101) with `draws` draws.
    MonteCarlo { draws: usize, seed: u64 },
    /// Monte Carlo with the adaptive stopping rule of JCGM 101 §7.9: batches of `batch` draws
    /// until the results are stable to two significant digits.
    Adaptive { batch: usize, seed: u64 },
}

impl UncertaintyMethod {
    /// The method in words, as a field's header records it.
    pub fn describe(&self) -> String {
        match self {
            UncertaintyMethod::FirstOrder => {
                "first order (GUM, JCGM 100): standard uncertainty of each channel".into()
            }
            UncertaintyMethod::MonteCarlo { draws, seed } => format!(
                "Monte Carlo (JCGM 101): {draws} draws, seed {seed}: standard deviation of each channel"
            ),
            UncertaintyMethod::Adaptive { batch, seed } => format!(
                "Monte Carlo (JCGM 101), adaptive (section 7.9): batches of {batch} draws until stable to 2 significant digits (at most {MAX_ADAPTIVE_BATCHES}), seed {seed}: standard deviation of each channel"
            ),
        }
    }
}

/// What an uncertainty run reports beside its values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UncertaintyRun {
    /// Machines summed per chunk (directions of first order, draws of Monte Carlo): the fewest
    /// and the most over the chunks.
    pub terms_min: usize,
    pub terms_max: usize,
    /// Chunks where the adaptive rule stopped at its bound before the results were stable.
    pub unstable_chunks: usize,
}

/// The directions of the first order: each a perturbation of every quantity (one standard
/// uncertainty along it), with the step `t` that moves it by at most the step sizes.
fn first_order_terms(machine: &Machine, grid: &Grid) -> Result<Vec<SumTerm>, EngineError> {
    let directions = machine
        .uncertainty
        .directions()
        .map_err(|e| EngineError::Uncertainty(format!("{e:?}")))?;
    // Room under the kernels' bound on error angles for the step.
    let room = MAX_ERROR_ANGLE_RAD - crate::gpu::chain::error_angles_rad(machine, grid);
    let angle_step = ANGLE_STEP_RAD.min(0.5 * room.max(0.0));
    let mut terms = Vec::with_capacity(directions.len());
    for e in directions {
        let (angle, length) = largest_moves(machine, &e);
        let t = match (angle > 0.0, length > 0.0) {
            (false, false) => continue,
            (true, false) => angle_step / angle,
            (false, true) => LENGTH_STEP_MM / length,
            (true, true) => (angle_step / angle).min(LENGTH_STEP_MM / length),
        };
        let step: Vec<f64> = e.iter().map(|x| x * t).collect();
        let minus: Vec<f64> = step.iter().map(|x| -x).collect();
        terms.push(SumTerm {
            plus: machine.with_deviations(&step),
            minus: Some(machine.with_deviations(&minus)),
            scale: 1.0 / (2.0 * t),
        });
    }
    Ok(terms)
}

/// The largest angle (rad) and length (mm) the perturbations `e` move any error value by at
/// the machine's inputs: a table's scale by the span of its nodes.
fn largest_moves(machine: &Machine, e: &[f64]) -> (f64, f64) {
    let (mut angle, mut length) = (0.0f64, 0.0f64);
    let mut first = 0;
    for value in &machine.uncertainty.values {
        let count = value.kind.count();
        let factor = value
            .factor(&machine.inputs, machine.thermal.as_ref())
            .abs();
        for (k, &x) in e[first..first + count].iter().enumerate() {
            let reach = match &value.kind {
                UncertainKind::Table { positions, .. } if k == positions.len() => positions
                    .iter()
                    .map(|q| (q - positions[0]).abs())
                    .fold(0.0, f64::max),
                _ => 1.0,
            };
            let moved = x.abs() * factor * reach;
            if value.target.is_angular() {
                angle = angle.max(moved);
            } else {
                length = length.max(moved);
            }
        }
        first += count;
    }
    (angle, length)
}

/// Per value of a chunk: draws pooled so far, their mean (of `d`) and sum of squared deviations.
#[derive(Default)]
struct Pooled {
    count: f64,
    mean: Vec<f64>,
    m2: Vec<f64>,
}

impl Pooled {
    /// A batch of `n` draws given by its sums `Σ d` and `Σ d²`.
    fn of_sums(n: f64, first: &[f32], second: &[f32]) -> Pooled {
        assert_eq!(first.len(), second.len(), "two sums per value");
        Pooled {
            count: n,
            mean: first.iter().map(|&s| s as f64 / n).collect(),
            m2: first
                .iter()
                .zip(second)
                .map(|(&s1, &s2)| (s2 as f64 - (s1 as f64).powi(2) / n).max(0.0))
                .collect(),
        }
    }

    /// Adds the draws of `other` (Chan's formula).
    fn merge(&mut self, other: &Pooled) {
        if self.count == 0.0 {
            *self = Pooled {
                count: other.count,
                mean: other.mean.clone(),
                m2: other.m2.clone(),
            };
            return;
        }
        assert_eq!(self.mean.len(), other.mean.len(), "one chunk's values");
        let (na, nb) = (self.count, other.count);
        let total = na + nb;
        for i in 0..self.mean.len() {
            let delta = other.mean[i] - self.mean[i];
            self.mean[i] += delta * nb / total;
            self.m2[i] += other.m2[i] + delta * delta * na * nb / total;
        }
        self.count = total;
    }

    fn std(&self) -> Vec<f64> {
        let divisor = (self.count - 1.0).max(1.0);
        self.m2.iter().map(|m| (m / divisor).sqrt()).collect()
    }
}

/// JCGM 101 §7.9.4's numerical tolerance of a standard uncertainty `u` to two significant
/// digits: half a unit of its second digit.
pub fn numerical_tolerance(u: f64) -> f64 {
    if u <= 0.0 || !u.is_finite() {
        return f64::INFINITY;
    }
    let l = u.log10().floor() - 1.0;
    0.5 * 10f64.powf(l)
}

/// Where the sums of a chunk are computed.
enum Summer<'a> {
    Gpu(&'a crate::gpu::GpuMapper, Box<SumsPlan>),
    Host {
        reference: bool,
        grid: &'a Grid,
        base: &'a Machine,
        chunks: Chunks,
    },
}

impl Summer<'_> {
    fn chunks(&self) -> &Chunks {
        match self {
            Summer::Gpu(_, plan) => &plan.chunks,
            Summer::Host { chunks, .. } => chunks,
        }
    }

    /// `(Σ d, Σ d²)` over `terms` for chunk `n`.
    fn sums(&self, n: usize, terms: &[SumTerm]) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
        match self {
            Summer::Gpu(gpu, plan) => {
                let sums = gpu.chunk_sums(plan, n, terms)?;
                Ok((sums.first, sums.second))
            }
            Summer::Host {
                reference,
                grid,
                base,
                chunks,
            } => {
                let (first_line, lines) = chunks.get(n);
                let values = lines as usize * grid.dims[0] * CHANNELS.len();
                let field = |machine: &Machine| {
                    let mut out = vec![0.0f32; values];
                    if *reference {
                        reference_lines(&Twin::of(machine), grid, first_line, lines, &mut out);
                    } else {
                        CpuPlan::new(machine, grid).compute_lines(first_line, lines, &mut out);
                    }
                    out
                };
                let nominal = terms.iter().any(|t| t.minus.is_none()).then(|| field(base));
                let mut first = vec![0.0f64; values];
                let mut second = vec![0.0f64; values];
                for term in terms {
                    let a = field(&term.plus);
                    let minus = term.minus.as_ref().map(field);
                    let b = minus
                        .as_deref()
                        .or(nominal.as_deref())
                        .expect("the nominal field");
                    for i in 0..values {
                        let d = term.scale * (a[i] as f64 - b[i] as f64);
                        first[i] += d;
                        second[i] += d * d;
                    }
                }
                let to_f32 = |v: Vec<f64>| v.into_iter().map(|x| x as f32).collect();
                Ok((to_f32(first), to_f32(second)))
            }
        }
    }
}

impl Engine {
    /// The standard uncertainty of every channel of `machine`'s map over `grid` by `method`,
    /// handed over chunk by chunk in the map's layout as `on_chunk(first_line, lines, values)`.
    pub fn run_uncertainty<E: From<EngineError>>(
        &self,
        machine: &Machine,
        grid: &Grid,
        method: UncertaintyMethod,
        chunk_points: Option<u64>,
        mut on_chunk: impl FnMut(u64, u64, &[f32]) -> Result<(), E>,
    ) -> Result<UncertaintyRun, E> {
        let chunk_points = chunk_points
            .unwrap_or(UNCERTAINTY_CHUNK_POINTS)
            .min(UNCERTAINTY_CHUNK_POINTS);
        let summer = match self {
            Engine::Gpu(gpu) => Summer::Gpu(
                gpu,
                Box::new(
                    gpu.plan_sums(machine, grid, Some(chunk_points))
                        .map_err(EngineError::from)?,
                ),
            ),
            Engine::Cpu | Engine::Reference => Summer::Host {
                reference: matches!(self, Engine::Reference),
                grid,
                base: machine,
                chunks: grid.chunks(
                    (chunk_points.max(grid.dims[0] as u64) / grid.dims[0] as u64)
                        * grid.dims[0] as u64,
                ),
            },
        };
        let first_order = match method {
            UncertaintyMethod::FirstOrder => Some(first_order_terms(machine, grid)?),
            _ => None,
        };
        // The first order's machines are the same in every chunk: on the GPU they are packed and
        // sent once, not once per chunk (that cost, not the passes, bounds a fast device).
        let mapped = match (&summer, first_order.as_deref()) {
            (Summer::Gpu(gpu, plan), Some(terms))
                if !terms.is_empty() && terms.len() <= MAX_MAPPED_TERMS =>
            {
                Some(gpu.map_terms(plan, terms).map_err(EngineError::from)?)
            }
            _ => None,
        };
        let draws = match method {
            UncertaintyMethod::MonteCarlo { seed, .. }
            | UncertaintyMethod::Adaptive { seed, .. } => Some(
                Draws::new(&machine.uncertainty, seed)
                    .map_err(|e| EngineError::Uncertainty(format!("{e:?}")))?,
            ),
            UncertaintyMethod::FirstOrder => None,
        };
        let drawn = |range: std::ops::Range<usize>| -> Vec<SumTerm> {
            let draws = draws.as_ref().expect("the draws of a Monte Carlo run");
            range
                .map(|d| SumTerm {
                    plus: machine.with_deviations(&draws.deviations(d as u64)),
                    minus: None,
                    scale: 1.0,
                })
                .collect()
        };
        let mut run = UncertaintyRun {
            terms_min: usize::MAX,
            ..Default::default()
        };
        let chunks = *summer.chunks();
        for n in 0..chunks.len() {
            let (first_line, lines) = chunks.get(n);
            let values = lines as usize * grid.dims[0] * CHANNELS.len();
            let (u, terms): (Vec<f32>, usize) = match method {
                UncertaintyMethod::FirstOrder => {
                    let terms = first_order.as_deref().unwrap_or_default();
                    if terms.is_empty() {
                        (vec![0.0; values], 0)
                    } else {
                        let (_, second) = match (&summer, &mapped) {
                            (Summer::Gpu(gpu, plan), Some(mapped)) => {
                                let sums = gpu
                                    .chunk_sums_mapped(plan, n, mapped)
                                    .map_err(EngineError::from)?;
                                (sums.first, sums.second)
                            }
                            _ => summer.sums(n, terms).map_err(EngineError::from)?,
                        };
                        (
                            second.iter().map(|s| s.max(0.0).sqrt()).collect(),
                            terms.len(),
                        )
                    }
                }
                UncertaintyMethod::MonteCarlo { draws, .. } => {
                    let mut pooled = Pooled::default();
                    let mut start = 0;
                    while start < draws {
                        let end = (start + DRAWS_PER_READBACK).min(draws);
                        let (first, second) = summer
                            .sums(n, &drawn(start..end))
                            .map_err(EngineError::from)?;
                        pooled.merge(&Pooled::of_sums((end - start) as f64, &first, &second));
                        start = end;
                    }
                    (pooled.std().into_iter().map(|x| x as f32).collect(), draws)
                }
                UncertaintyMethod::Adaptive { batch, .. } => {
                    let (u, batches, stable) = adaptive(&summer, n, batch, values, &drawn)?;
                    if !stable {
                        run.unstable_chunks += 1;
                    }
                    (u, batches * batch)
                }
            };
            run.terms_min = run.terms_min.min(terms);
            run.terms_max = run.terms_max.max(terms);
            on_chunk(first_line, lines, &u)?;
        }
        if run.terms_min == usize::MAX {
            run.terms_min = 0;
        }
        Ok(run)
    }
}

/// One chunk by the adaptive rule: the pooled standard deviations, the batches run, and whether
/// the results were stable within [`MAX_ADAPTIVE_BATCHES`].
fn adaptive(
    summer: &Summer,
    n: usize,
    batch: usize,
    values: usize,
    drawn: &dyn Fn(std::ops::Range<usize>) -> Vec<SumTerm>,
) -> Result<(Vec<f32>, usize, bool), EngineError> {
    let mut pooled = Pooled::default();
    // Per value: Σ and Σ² over the batches of each batch's mean and standard deviation.
    let mut y = (vec![0.0f64; values], vec![0.0f64; values]);
    let mut u = (vec![0.0f64; values], vec![0.0f64; values]);
    let mut h = 0usize;
    loop {
        let mut batch_pool = Pooled::default();
        let mut start = h * batch;
        let end = start + batch;
        while start < end {
            let stop = (start + DRAWS_PER_READBACK).min(end);
            let (first, second) = summer.sums(n, &drawn(start..stop))?;
            batch_pool.merge(&Pooled::of_sums((stop - start) as f64, &first, &second));
            start = stop;
        }
        let batch_u = batch_pool.std();
        assert_eq!(
            batch_u.len(),
            values,
            "a batch's value per value of the chunk"
        );
        for (i, (&mean, &bu)) in batch_pool.mean.iter().zip(&batch_u).enumerate() {
            y.0[i] += mean;
            y.1[i] += mean * mean;
            u.0[i] += bu;
            u.1[i] += bu * bu;
        }
        pooled.merge(&batch_pool);
        h += 1;
        if h >= 2 {
            let hf = h as f64;
            // The standard deviation of the mean of h batch results, s/√h.
            let spread =
                |(s1, s2): (&f64, &f64)| ((s2 - s1 * s1 / hf).max(0.0) / (hf - 1.0) / hf).sqrt();
            let total_u = pooled.std();
            let stable = (0..values).all(|i| {
                let delta = numerical_tolerance(total_u[i]);
                2.0 * spread((&y.0[i], &y.1[i])) <= delta
                    && 2.0 * spread((&u.0[i], &u.1[i])) <= delta
            });
            if stable || h >= MAX_ADAPTIVE_BATCHES {
                return Ok((total_u.into_iter().map(|x| x as f32).collect(), h, stable));
            }
        }
    }
}
