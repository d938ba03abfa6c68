//! Sums of one-dimensional tables, one per (corrected axis, input axis) pair: what the SINUMERIK
//! (MSEC and CEC) and the HEIDENHAIN (`*.COM`) tables hold. The correction is fitted as
//!
//! ```text
//! d_k(t) ≈ Σ_i f_ki(t_i)        k, i ∈ {X, Y, Z}
//! ```
//!
//! (the additive fit of [`Fitting::additive`], every term a curve, each cross curve `f_ki`
//! zero at the start of axis `i`'s travel and the rest of row `k`'s constant carried by the
//! own-axis curve `f_kk`), with every linear axis approaching `+`. Where the machine has
//! reversal terms on axis `j`, the fit is repeated with `j` approaching `−` and the difference
//! of its curves along `j` (constant included) is what a table read only while `j` moves in the
//! negative direction must add.
//!
//! Both formats fix or choose the node positions themselves and write the curves at them; the
//! Heidenhain format chooses free nodes shared by the curves of one table
//! ([`free_nodes`](super::nodes::free_nodes)).

use crate::export::error::ExportError;
use crate::export::fitting::{Field, Fitting, Term, LINEAR};
use crate::model::inputs::Approach;
use crate::model::perturbation::ErrorTarget;
use crate::model::{AxisLetter, Machine};

/// Every term of a sum of 1-D tables from any linear axis to any linear axis.
pub const ALL_CURVES: [[Term; 3]; 3] = [[Term::Curve; 3]; 3];

/// The correction as curves of one axis position each, at the positions asked.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisCurves {
    /// `positions[i]`: where along axis `i` the curves are given, mm.
    pub positions: [Vec<f64>; 3],
    /// `plus[k][i]`: the correction of axis `k` as a function of axis `i` at `positions[i]`,
    /// every linear axis approaching `+`; a cross curve (`i ≠ k`) is zero at its first
    /// position, the constant of row `k` is in `plus[k][k]`.
    pub plus: [[Vec<f64>; 3]; 3],
    /// `minus[j]`, where axis `j` has reversal terms: `minus[j][k]`, what the correction of axis
    /// `k` gains as a function of axis `j` while `j` approaches `−` (at `positions[j]`).
    pub minus: [Option<[Vec<f64>; 3]>; 3],
    /// What the own-axis curve `plus[k][k]` took from the cross curves' starts.
    pub own_shift: [f64; 3],
}

/// Whether `machine` has an error value with a `reverse` form on axis `letter`.
pub fn has_reversal(machine: &Machine, letter: AxisLetter) -> bool {
    machine.dependent.iter().any(|d| {
        d.reverse.is_some()
            && matches!(d.target, ErrorTarget::Component { axis, .. } if axis == letter)
    })
}

/// The field of the fitting's machine at its inputs with the linear axes approaching as
/// `approach` says (the rotary axes as asked).
fn field_approaching(fitting: &Fitting, approach: [Approach; 3]) -> Result<Field, ExportError> {
    let mut inputs = fitting.inputs.clone();
    inputs.approach[..3].copy_from_slice(&approach);
    Field::new(fitting.machine.at(&inputs), fitting.pose)
}

/// The field every linear axis approaching `+` at, where it is not the one asked.
fn plus_field(fitting: &Fitting) -> Result<Option<Field>, ExportError> {
    let reverses = LINEAR.iter().any(|&l| has_reversal(fitting.machine, l));
    let asked_plus = fitting.inputs.approach[..3]
        .iter()
        .all(|&a| a == Approach::Positive);
    if asked_plus || !reverses {
        // The field asked is the all-`+` one (no linear axis reverses, or none approaches `−`).
        Ok(None)
    } else {
        field_approaching(fitting, [Approach::Positive; 3]).map(Some)
    }
}

/// Fits the curves of the correction at `positions` (per linear axis).
pub fn fit(fitting: &Fitting, positions: [Vec<f64>; 3]) -> Result<AxisCurves, ExportError> {
    let reversing: [bool; 3] = LINEAR.map(|l| has_reversal(fitting.machine, l));
    let plus_field = plus_field(fitting)?;
    let plus_of = plus_field.as_ref().unwrap_or(fitting.field());
    let plus = fitting.additive(plus_of, ALL_CURVES, positions.clone())?;
    let mut minus: [Option<[Vec<f64>; 3]>; 3] = Default::default();
    for j in (0..3).filter(|&j| reversing[j]) {
        let mut approach = [Approach::Positive; 3];
        approach[j] = Approach::Negative;
        let field = field_approaching(fitting, approach)?;
        let negative = fitting.additive(&field, ALL_CURVES, positions.clone())?;
        minus[j] = Some(std::array::from_fn(|k| {
            let offset = negative.constant[k] - plus.constant[k];
            negative.curves[k][j]
                .iter()
                .zip(&plus.curves[k][j])
                .map(|(n, p)| n - p + offset)
                .collect()
        }));
    }
    let mut tables: [[Vec<f64>; 3]; 3] =
        std::array::from_fn(|k| std::array::from_fn(|i| plus.table(k, i)));
    // Each cross curve starts at zero: a squareness reads `y·tan γ`, a straightness starts
    // from its first point; the own-axis curve takes the difference (the sum is unchanged).
    let mut own_shift = [0.0; 3];
    for (k, row) in tables.iter_mut().enumerate() {
        for i in (0..3).filter(|&i| i != k) {
            let start = row[i][0];
            row[i].iter_mut().for_each(|v| *v -= start);
            own_shift[k] += start;
        }
        row[k].iter_mut().for_each(|v| *v += own_shift[k]);
    }
    Ok(AxisCurves {
        plus: tables,
        positions,
        minus,
        own_shift,
    })
}

/// The own-axis curves `f_kk` of `curves` (the same fit, the same constants) at other positions,
/// `at[k]` along each axis `k`.
pub fn own_curves_at(
    fitting: &Fitting,
    curves: &AxisCurves,
    at: [Vec<f64>; 3],
) -> Result<[Vec<f64>; 3], ExportError> {
    let plus_field = plus_field(fitting)?;
    let plus_of = plus_field.as_ref().unwrap_or(fitting.field());
    let fit = fitting.additive(plus_of, ALL_CURVES, at)?;
    Ok(std::array::from_fn(|k| {
        fit.table(k, k)
            .iter()
            .map(|v| v + curves.own_shift[k])
            .collect()
    }))
}

#[cfg(test)]
mod tests {
    use crate::export::nodes::{free_nodes, Pwl};

    #[test]
    fn the_nodes_of_several_curves_find_the_kinks_of_each() {
        let q: Vec<f64> = (0..=100).map(f64::from).collect();
        let a: Vec<f64> = q.iter().map(|&x| (x - 30.0).abs()).collect();
        let b: Vec<f64> = q.iter().map(|&x| (x - 70.0).max(0.0)).collect();
        assert_eq!(
            free_nodes(&q, &[&a, &b], 10, 0.0, 1e-12),
            vec![0, 30, 70, 100]
        );
        // One curve alone needs one kink.
        assert_eq!(free_nodes(&q, &[&a], 10, 0.0, 1e-12), vec![0, 30, 100]);
    }

    #[test]
    fn the_nodes_of_several_curves_are_the_minimax_choice() {
        let q: Vec<f64> = (0..=60).map(|i| f64::from(i) / 60.0).collect();
        let a: Vec<f64> = q.iter().map(|&x| x.powi(4)).collect();
        let b: Vec<f64> = q.iter().map(|&x| (1.0 - x).powi(3)).collect();
        let worst = |nodes: &[usize]| {
            [&a, &b]
                .iter()
                .map(|f| {
                    let t = Pwl {
                        q: nodes.iter().map(|&i| q[i]).collect(),
                        v: nodes.iter().map(|&i| f[i]).collect(),
                    };
                    q.iter()
                        .zip(f.iter())
                        .map(|(&x, &y)| (t.eval(x) - y).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max)
        };
        let chosen = free_nodes(&q, &[&a, &b], 4, 0.0, 0.0);
        assert_eq!(chosen.len(), 4);
        let mut best = f64::INFINITY;
        for i in 1..59 {
            for j in i + 1..60 {
                best = best.min(worst(&[0, i, j, 60]));
            }
        }
        assert!(worst(&chosen) <= best + 1e-15, "{chosen:?}");
        // A spacing kept: no two nodes closer than 0.2.
        let spaced = free_nodes(&q, &[&a, &b], 6, 0.2, 0.0);
        assert!(spaced.windows(2).all(|w| q[w[1]] - q[w[0]] >= 0.2 - 1e-12));
    }
}
