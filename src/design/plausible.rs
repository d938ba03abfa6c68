//! What the machines of a study can reach, checked before any device is chosen, so that every
//! engine refuses the same studies and answers the same others.
//!
//! The GPU's kernels take error rotations below [`MAX_ERROR_ANGLE_RAD`] (the sum of a machine's
//! angular errors over the grid, `gpu::chain::check_error_angles`); the CPU engine has no such
//! limit. A study whose drawn machines could pass it is refused here, as bad input, on every
//! device: the machine's own angular errors over each grid plus each angular tolerance at the
//! farthest its draws reach (`h` for a uniform one, [`MAX_STANDARD_DRAW`]`·σ` for a normal one).
//! An allocation grows its tolerances only up to that bound and up to the widths the tolerance
//! file's reader accepts ([`most_width`]), so it never asks a device for what another refuses,
//! nor writes a file volmap would not read.

use super::monte_carlo::Study;
use crate::gpu::chain::error_angles_rad;
use crate::gpu::MAX_ERROR_ANGLE_RAD;
use crate::io::tolerance_file::most_width;
use crate::model::perturbation::{Distribution, Tolerance};

/// The largest |z| a normal draw can take: Box–Muller from uniforms of 53 bits in (0, 1), the
/// smallest `2⁻⁵⁴`, gives at most `√(−2 ln 2⁻⁵⁴) = √(108 ln 2) = 8.652`; rounded up.
pub const MAX_STANDARD_DRAW: f64 = 8.7;

/// The study bound is kept this far below the kernels' limit, so that sums taken in another
/// order on a device never reach it.
const MARGIN: f64 = 1e-9;

/// The farthest a draw of `distribution` reaches from the nominal, per unit of scale.
pub fn reach(distribution: Distribution) -> f64 {
    match distribution {
        Distribution::Uniform { half_width } => half_width,
        Distribution::Normal { sigma } => MAX_STANDARD_DRAW * sigma,
    }
}

/// The study's machines' angular errors can add up to more than the kernels take.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "the machines drawn can have angular errors adding up to {total_rad:.4} rad over the grid \
     (the machine's own {own_rad:.4} rad, and each angular tolerance at its farthest draw: h of \
     a uniform one, {MAX_STANDARD_DRAW}σ of a normal one); volmap takes error rotations below \
     {limit_rad} rad on every device: angular widths are in rad, check the units"
)]
pub struct TooMuchAngle {
    pub total_rad: f64,
    pub own_rad: f64,
    pub limit_rad: f64,
}

crate::error::input_errors!(TooMuchAngle);

/// The largest sum of angular errors any machine of `study` can have over one of its grids, rad,
/// with each tolerance's width times `scale[t]`; and the machine's own part of it.
pub fn angles_bound_rad(study: &Study, scale: &[f64]) -> (f64, f64) {
    let own = study
        .grids
        .iter()
        .map(|grid| error_angles_rad(study.machine, grid))
        .fold(0.0, f64::max);
    let drawn: f64 = study
        .tolerances
        .iter()
        .zip(scale)
        .filter(|(t, _)| t.perturbation.target.is_angular())
        .map(|(t, k)| reach(t.distribution) * k.abs())
        .sum();
    (own + drawn, own)
}

/// Refuses a study whose machines (each width times `scale[t]`) could reach the kernels' limit.
pub fn check_angles(study: &Study, scale: &[f64]) -> Result<(), TooMuchAngle> {
    let (total_rad, own_rad) = angles_bound_rad(study, scale);
    // NaN compares false: a bound that is not a number is refused too.
    if total_rad < MAX_ERROR_ANGLE_RAD * (1.0 - MARGIN) {
        Ok(())
    } else {
        Err(TooMuchAngle {
            total_rad,
            own_rad,
            limit_rad: MAX_ERROR_ANGLE_RAD,
        })
    }
}

/// How far an allocation's common factor may take its chosen tolerances.
#[derive(Debug, Clone, PartialEq)]
pub struct Ceiling {
    /// For each tolerance, the factor at which it reaches the widest the file may give
    /// (infinite for a zero width, or a tolerance not chosen).
    pub term_factor: Vec<f64>,
    /// The factor at which the machines drawn would reach the kernels' limit on angles
    /// (infinite where every chosen term stops at its width first).
    pub angle_factor: f64,
}

impl Ceiling {
    /// The ceiling of the tolerances `chosen` of `study`.
    pub fn of(study: &Study, chosen: &[bool]) -> Ceiling {
        let term_factor: Vec<f64> = study
            .tolerances
            .iter()
            .zip(chosen)
            .map(|(t, &c)| term_ceiling(t, c))
            .collect();
        let mut ceiling = Ceiling {
            term_factor,
            angle_factor: f64::INFINITY,
        };
        let all_stopped = ceiling
            .term_factor
            .iter()
            .copied()
            .filter(|f| f.is_finite())
            .fold(1.0, f64::max);
        let fits = |factor: f64| check_angles(study, &ceiling.scale(chosen, factor)).is_ok();
        if !fits(all_stopped) {
            // The bound grows with the factor: bisect between a factor that fits and one that
            // does not (at 0 only the other tolerances and the machine count).
            let (mut low, mut high) = (0.0, all_stopped);
            for _ in 0..200 {
                let middle = 0.5 * (low + high);
                if middle <= low || middle >= high {
                    break;
                }
                if fits(middle) {
                    low = middle;
                } else {
                    high = middle;
                }
            }
            ceiling.angle_factor = low;
        }
        ceiling
    }

    /// The largest factor that changes anything: every chosen term at its widest, or the
    /// angles' limit, whichever comes first (infinite where no chosen term has a width).
    pub fn factor(&self) -> f64 {
        let widest = self
            .term_factor
            .iter()
            .copied()
            .filter(|f| f.is_finite())
            .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f))))
            .unwrap_or(f64::INFINITY);
        widest.min(self.angle_factor)
    }

    /// Each tolerance's scale at a common `factor`: the factor for a chosen term, up to the
    /// factor at which it reaches its widest; 1 for the others.
    pub fn scale(&self, chosen: &[bool], factor: f64) -> Vec<f64> {
        chosen
            .iter()
            .zip(&self.term_factor)
            .map(|(&c, &most)| if c { factor.min(most) } else { 1.0 })
            .collect()
    }

    /// The chosen terms that stopped at their widest at `factor`.
    pub fn stopped(&self, chosen: &[bool], factor: f64) -> Vec<usize> {
        (0..chosen.len())
            .filter(|&t| chosen[t] && self.term_factor[t] <= factor)
            .collect()
    }
}

/// The factor at which tolerance `t` reaches the widest the file may give.
fn term_ceiling(t: &Tolerance, chosen: bool) -> f64 {
    let width = t.distribution.width();
    if !chosen || width <= 0.0 {
        return f64::INFINITY;
    }
    let most = most_width(t.perturbation.target).0;
    let mut factor = most / width;
    // The product must not round above the widest.
    while width * factor > most {
        factor = factor.next_down();
    }
    factor
}
