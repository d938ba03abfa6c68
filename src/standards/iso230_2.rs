//! ISO 230-2 positioning figures of one linear axis, from the deviations `x_ij = P_ij − P_i`
//! (actual minus target position) at targets `i`, runs `j`, approached in the positive (↑) and
//! negative (↓) direction:
//!
//! - `x̄_i↑`, `x̄_i↓`: the mean deviations; `x̄_i = (x̄_i↑ + x̄_i↓)/2`;
//! - `s_i↑`, `s_i↓`: the estimators of the standard uncertainty, `√(Σ_j (x_ij − x̄_i)² / (n − 1))`
//!   (0 for a single run);
//! - reversal value `B_i = x̄_i↑ − x̄_i↓`; `B = max |B_i|`; mean reversal value `B̄ = Σ B_i / m`;
//! - repeatability `R_i↑ = 4 s_i↑`, `R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)`, `R↑ = max R_i↑`,
//!   `R = max R_i`;
//! - systematic positioning error `E↑ = max x̄_i↑ − min x̄_i↑`,
//!   `E = max(x̄_i↑, x̄_i↓) − min(x̄_i↑, x̄_i↓)`;
//! - mean positioning error `M = max x̄_i − min x̄_i`;
//! - accuracy `A↑ = max(x̄_i↑ + 2 s_i↑) − min(x̄_i↑ − 2 s_i↑)`,
//!   `A = max(x̄_i↑ + 2 s_i↑, x̄_i↓ + 2 s_i↓) − min(x̄_i↑ − 2 s_i↑, x̄_i↓ − 2 s_i↓)`.

/// Deviations (mm) of a positioning test: `up[i][j]` at target `i`, run `j`, approached in the
/// positive direction; `down[i][j]` in the negative.
#[derive(Debug, Clone, PartialEq)]
pub struct PositioningData {
    pub targets_mm: Vec<f64>,
    pub up: Vec<Vec<f64>>,
    pub down: Vec<Vec<f64>>,
}

/// The ISO 230-2 figures, mm.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PositioningFigures {
    pub a: f64,
    pub a_up: f64,
    pub a_down: f64,
    pub b: f64,
    pub b_mean: f64,
    pub e: f64,
    pub e_up: f64,
    pub e_down: f64,
    pub m: f64,
    pub r: f64,
    pub r_up: f64,
    pub r_down: f64,
}

impl PositioningFigures {
    /// `(name, value)` in the order the standard lists them.
    pub fn named(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("A", self.a),
            ("A↑", self.a_up),
            ("A↓", self.a_down),
            ("B", self.b),
            ("B̄", self.b_mean),
            ("E", self.e),
            ("E↑", self.e_up),
            ("E↓", self.e_down),
            ("M", self.m),
            ("R", self.r),
            ("R↑", self.r_up),
            ("R↓", self.r_down),
        ]
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

fn uncertainty(values: &[f64]) -> f64 {
    if values.len() < 2 {
        return 0.0;
    }
    let m = mean(values);
    (values.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (values.len() - 1) as f64).sqrt()
}

fn spread(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = values.fold(f64::INFINITY, f64::min);
    max - min
}

impl PositioningData {
    /// The mean deviations `x̄_i↑` and `x̄_i↓`.
    pub fn means(&self) -> (Vec<f64>, Vec<f64>) {
        (
            self.up.iter().map(|r| mean(r)).collect(),
            self.down.iter().map(|r| mean(r)).collect(),
        )
    }

    pub fn figures(&self) -> PositioningFigures {
        let (up, down) = self.means();
        let s_up: Vec<f64> = self.up.iter().map(|r| uncertainty(r)).collect();
        let s_down: Vec<f64> = self.down.iter().map(|r| uncertainty(r)).collect();
        let m = up.len();
        let reversal: Vec<f64> = (0..m).map(|i| up[i] - down[i]).collect();
        let r_i: Vec<f64> = (0..m)
            .map(|i| {
                (2.0 * s_up[i] + 2.0 * s_down[i] + reversal[i].abs())
                    .max(4.0 * s_up[i])
                    .max(4.0 * s_down[i])
            })
            .collect();
        let max_of = |v: &mut dyn Iterator<Item = f64>| v.fold(f64::NEG_INFINITY, f64::max);
        let min_of = |v: &mut dyn Iterator<Item = f64>| v.fold(f64::INFINITY, f64::min);
        let upper_up = (0..m).map(|i| up[i] + 2.0 * s_up[i]);
        let lower_up = (0..m).map(|i| up[i] - 2.0 * s_up[i]);
        let upper_down = (0..m).map(|i| down[i] + 2.0 * s_down[i]);
        let lower_down = (0..m).map(|i| down[i] - 2.0 * s_down[i]);
        PositioningFigures {
            a: max_of(&mut upper_up.clone().chain(upper_down.clone()))
                - min_of(&mut lower_up.clone().chain(lower_down.clone())),
            a_up: max_of(&mut upper_up.clone()) - min_of(&mut lower_up.clone()),
            a_down: max_of(&mut upper_down.clone()) - min_of(&mut lower_down.clone()),
            b: reversal.iter().fold(0.0, |b, r| b.max(r.abs())),
            b_mean: mean(&reversal),
            e: spread(up.iter().chain(&down).copied()),
            e_up: spread(up.iter().copied()),
            e_down: spread(down.iter().copied()),
            m: spread((0..m).map(|i| 0.5 * (up[i] + down[i]))),
            r: r_i.iter().copied().fold(0.0, f64::max),
            r_up: s_up.iter().fold(0.0, |r, s| r.max(4.0 * s)),
            r_down: s_down.iter().fold(0.0, |r, s| r.max(4.0 * s)),
        }
    }
}
