//! The skew correction Klipper and Marlin share (Klipper's `skew_correction.py` is a port of
//! Marlin's `Planner::skew`): three factors `xy`, `xz`, `yz` that describe the machine as
//! `p_real = M_K · raw`, `M_K = [[1, xy, xz], [0, 1, yz], [0, 0, 1]]`, and the command the
//! firmware sends for a target `(x, y, z)`:
//!
//! `x_raw = x − y·xy − z·(xz − xy·yz)`, `y_raw = y − z·yz`, `z_raw = z`.
//!
//! So the correction `raw − target` is `−xy·y − (xz − xy·yz)·z` on X and `−yz·z` on Y: slopes
//! of X in Y and Z and of Y in Z, through the machine zero. The factors are fitted from the
//! least-squares slopes of the machine's correction ([`Fitting::additive`]), so an offset the
//! skew cannot hold does not tilt them; a squareness `EC0Y = c` alone gives `xy = −tan c`.

use crate::export::error::ExportError;
use crate::export::fitting::{Fitting, Term};

/// What a skew holds: X from Y and Z, Y from Z, as slopes.
pub const TERMS: [[Term; 3]; 3] = [
    [Term::None, Term::Slope, Term::Slope],
    [Term::None, Term::None, Term::Slope],
    [Term::None, Term::None, Term::None],
];

/// Skew factors, dimensionless.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skew {
    pub xy: f64,
    pub xz: f64,
    pub yz: f64,
}

impl Skew {
    /// The factors that undo the linear cross terms of the correction at the inputs asked.
    pub fn fit(fitting: &Fitting) -> Result<Skew, ExportError> {
        let fit = fitting.additive(fitting.field(), TERMS, Default::default())?;
        let xy = -fit.slopes[0][1];
        let yz = -fit.slopes[1][2];
        let xz = -fit.slopes[0][2] + xy * yz;
        Ok(Skew { xy, xz, yz })
    }

    /// The command sent for target `t` (X, Y, Z).
    pub fn skewed(&self, t: [f64; 3]) -> [f64; 3] {
        [
            t[0] - t[1] * self.xy - t[2] * (self.xz - self.xy * self.yz),
            t[1] - t[2] * self.yz,
            t[2],
        ]
    }

    /// The factors in the order XY, XZ, YZ, with their names.
    pub fn named(&self) -> [(&'static str, f64); 3] {
        [("XY", self.xy), ("XZ", self.xz), ("YZ", self.yz)]
    }

    /// Each factor rounded to `decimals` decimals.
    pub fn rounded(&self, decimals: usize) -> Skew {
        let r = |v: f64| {
            let scale = 10f64.powi(decimals as i32);
            let r = (v * scale).round() / scale;
            if r == 0.0 {
                0.0
            } else {
                r
            }
        };
        Skew {
            xy: r(self.xy),
            xz: r(self.xz),
            yz: r(self.yz),
        }
    }
}

/// The diagonal and side of a virtual square of side `side_mm` whose measured lengths give the
/// skew factor `f` (Klipper's and Marlin's `AC, BD, AD`): the angle θ at A has `cot θ = f`.
pub fn square_lengths(f: f64, side_mm: f64) -> [f64; 3] {
    let cos = f / (1.0 + f * f).sqrt();
    [
        side_mm * (2.0 * (1.0 + cos)).sqrt(),
        side_mm * (2.0 * (1.0 - cos)).sqrt(),
        side_mm,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Klipper's `calc_skew_factor` (parallelogram law, then the angle at A).
    fn factor_from_lengths([ac, bd, ad]: [f64; 3]) -> f64 {
        let ab = (2.0 * ac * ac + 2.0 * bd * bd - 4.0 * ad * ad).sqrt() / 2.0;
        (std::f64::consts::FRAC_PI_2 - ((ac * ac - ab * ab - ad * ad) / (2.0 * ab * ad)).acos())
            .tan()
    }

    #[test]
    fn the_square_lengths_give_the_factor_back() {
        for f in [-1.5e-5, 0.0, 2.0e-4, 0.3] {
            let back = factor_from_lengths(square_lengths(f, 100.0));
            assert!((back - f).abs() < 1e-12, "{f}: {back}");
        }
    }

    #[test]
    fn skewed_inverts_the_firmware_model_of_the_machine() {
        let s = Skew {
            xy: 1e-3,
            xz: -2e-3,
            yz: 5e-4,
        };
        let t = [100.0, 200.0, 300.0];
        let raw = s.skewed(t);
        // p_real = M_K · raw
        let real = [
            raw[0] + s.xy * raw[1] + s.xz * raw[2],
            raw[1] + s.yz * raw[2],
            raw[2],
        ];
        for d in 0..3 {
            assert!((real[d] - t[d]).abs() < 1e-12);
        }
    }
}
