//! The standard uncertainties of a machine's error values (docs/model.md, "Uncertainty of the
//! error values"): which error values carry a `u`, how a perturbation of each uncertain quantity
//! changes its error value, and the covariance between the quantities.
//!
//! Every uncertain quantity `e_i` adds `e_i · δ_i(q)` to one error value, `δ_i` its shape: `1` for
//! a constant or a polynomial; for table node `i`, the table's interpolation of the unit
//! perturbation of that node (exact: the interpolations are linear in the node values); for a
//! table's `u_scale`, the interpolation of the nodes `q_i − q_0`. A part used only for one approach
//! direction (`value` beside a `reverse`, or the `reverse` itself) perturbs only that direction;
//! a `per_kelvin` coefficient's perturbation is times `ΔT` of its input.

use super::inputs::{Approach, Inputs, Thermal};
use super::perturbation::ErrorTarget;
use super::{AxisLetter, ErrorFunction, Interp, Machine, Table};

/// One error value, or one part of one (its `reverse`, a `per_kelvin` coefficient, a term of a
/// `sum`), that carries standard uncertainties.
#[derive(Debug, Clone, PartialEq)]
pub struct UncertainValue {
    /// Its name in `[covariance]`: the error value's key (`axes.Y.EC0Y`, `spindle.EZS`), followed
    /// by the part where the `u` stands on a part (`axes.X.EXX.reverse`,
    /// `spindle.EZS.per_kelvin.spindle`, `axes.X.EXX.sum[1]`).
    pub name: String,
    /// The error value it perturbs.
    pub target: ErrorTarget,
    /// The approach direction of the target's axis it is used for; `None`: every direction.
    pub approach: Option<Approach>,
    /// The thermal input (index in `[thermal].inputs`) whose `ΔT` multiplies it, for a
    /// `per_kelvin` coefficient.
    pub per_kelvin: Option<usize>,
    pub kind: UncertainKind,
}

/// What carries the uncertainty: a scalar, or the nodes of a table.
#[derive(Debug, Clone, PartialEq)]
pub enum UncertainKind {
    /// `value + e`, `e` with standard deviation `u`: one quantity, shape 1.
    Scalar { u: f64 },
    /// Node `i` is `v_i + e_i + s·(q_i − q_0)`: one quantity per node, then `s` (`u_scale`).
    Table {
        /// The axis whose position the table reads where it is not its own (`of`).
        of: Option<AxisLetter>,
        /// The node positions as written (a periodic table's closing node left out: it is the
        /// first node).
        positions: Vec<f64>,
        interp: Interp,
        periodic: bool,
        /// One per node.
        u: Vec<f64>,
        u_scale: f64,
    },
}

/// The uncertain quantities of a machine and their covariances. Quantities are numbered value
/// by value: a scalar is one, a table of `n` nodes is `n + 1` (its nodes, then its scale).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Uncertainty {
    pub values: Vec<UncertainValue>,
    /// `(i, j, cov(e_i, e_j))` with `i < j`, quantities by number, from `[covariance]`.
    pub covariance: Vec<(usize, usize, f64)>,
}

/// Where the covariance matrix is not positive semi-definite: the quantities of the entries
/// that cannot hold together.
#[derive(Debug, Clone, PartialEq)]
pub struct NotPositiveSemidefinite {
    /// Pairs of quantity numbers, as in [`Uncertainty::covariance`].
    pub pairs: Vec<(usize, usize)>,
}

impl UncertainKind {
    /// The number of quantities it holds.
    pub fn count(&self) -> usize {
        match self {
            UncertainKind::Scalar { .. } => 1,
            UncertainKind::Table { positions, .. } => positions.len() + 1,
        }
    }

    /// The standard uncertainty of its quantity `k`.
    pub fn sigma(&self, k: usize) -> f64 {
        match self {
            UncertainKind::Scalar { u } => *u,
            UncertainKind::Table { u, u_scale, .. } => u.get(k).copied().unwrap_or(*u_scale),
        }
    }
}

impl UncertainValue {
    /// The deviation of the error value for perturbations `e` of its quantities (one each, in
    /// order): `Σ_k e_k · δ_k(q)`, before any `ΔT` factor.
    pub fn delta(&self, e: &[f64]) -> ErrorFunction {
        match &self.kind {
            UncertainKind::Scalar { .. } => ErrorFunction::Constant(e[0]),
            UncertainKind::Table {
                of,
                positions,
                interp,
                periodic,
                ..
            } => {
                let s = e[positions.len()];
                let q0 = positions[0];
                let nodes = positions
                    .iter()
                    .zip(e)
                    .map(|(&q, &ek)| (q, ek + s * (q - q0)))
                    .collect();
                // The positions were a valid table when the file was read.
                let table = Table::new(nodes, *interp, *periodic)
                    .expect("the positions of a table read from the machine file");
                let form = ErrorFunction::Table(table);
                match of {
                    Some(axis) => ErrorFunction::Of {
                        axis: *axis,
                        form: Box::new(form),
                    },
                    None => form,
                }
            }
        }
    }

    /// The factor the deviation enters with at the evaluation inputs: 0 where the part is not
    /// used (the other approach direction), `ΔT` of a `per_kelvin` coefficient's input, else 1.
    pub fn factor(&self, inputs: &Inputs, thermal: Option<&Thermal>) -> f64 {
        if let (Some(wanted), ErrorTarget::Component { axis, .. }) = (self.approach, self.target) {
            if inputs.approach[axis.index()] != wanted {
                return 0.0;
            }
        }
        match (self.per_kelvin, thermal) {
            (None, _) => 1.0,
            (Some(input), Some(thermal)) => thermal.inputs.get(input).map_or(0.0, |name| {
                inputs.temperature_c(name, thermal.reference_c) - thermal.reference_c
            }),
            (Some(_), None) => 0.0,
        }
    }
}

impl Uncertainty {
    /// Whether no error value carries a `u`.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The number of quantities.
    pub fn count(&self) -> usize {
        self.values.iter().map(|v| v.kind.count()).sum()
    }

    /// `(value, k)` of every quantity, by number.
    pub fn quantities(&self) -> Vec<(usize, usize)> {
        self.values
            .iter()
            .enumerate()
            .flat_map(|(v, value)| (0..value.kind.count()).map(move |k| (v, k)))
            .collect()
    }

    /// The standard uncertainty of every quantity, by number.
    pub fn sigmas(&self) -> Vec<f64> {
        self.values
            .iter()
            .flat_map(|v| (0..v.kind.count()).map(|k| v.kind.sigma(k)))
            .collect()
    }

    /// The name of quantity `i` in words: a scalar's name, `NAME node N` (from 1) or `NAME
    /// u_scale`.
    pub fn quantity_name(&self, i: usize) -> String {
        let Some(&(v, k)) = self.quantities().get(i) else {
            return format!("quantity {i}");
        };
        let value = &self.values[v];
        match &value.kind {
            UncertainKind::Scalar { .. } => value.name.clone(),
            UncertainKind::Table { positions, .. } if k < positions.len() => {
                format!("{} node {}", value.name, k + 1)
            }
            UncertainKind::Table { .. } => format!("{} u_scale", value.name),
        }
    }

    /// The directions the machine is perturbed along: one per independent quantity with a spread
    /// (`u_i` on it alone), one per column of the correlated groups' factor; their outer products
    /// sum to the covariance matrix.
    pub fn directions(&self) -> Result<Vec<Vec<f64>>, NotPositiveSemidefinite> {
        let sigmas = self.sigmas();
        let (members, factor) = self.correlated_factor()?;
        let n = sigmas.len();
        let mut directions = Vec::new();
        for (i, &sigma) in sigmas.iter().enumerate() {
            if sigma == 0.0 || members.binary_search(&i).is_ok() {
                continue;
            }
            let mut e = vec![0.0; n];
            e[i] = sigma;
            directions.push(e);
        }
        for column in 0..members.len() {
            let mut e = vec![0.0; n];
            for (row, &member) in factor.iter().zip(&members) {
                e[member] = row[column];
            }
            // A perfectly correlated quantity leaves a zero column: nothing to perturb.
            if e.iter().any(|&x| x != 0.0) {
                directions.push(e);
            }
        }
        Ok(directions)
    }

    /// The quantities that take part in a covariance entry, in order, and a factor `F` of
    /// their covariance matrix (`F·Fᵀ = C`, row-major, `F` lower triangular): the Cholesky
    /// factor of a positive semi-definite matrix. Every other quantity is independent of all
    /// others. Refused where `C` is not positive semi-definite, naming the entries at fault.
    #[allow(clippy::type_complexity)]
    pub fn correlated_factor(
        &self,
    ) -> Result<(Vec<usize>, Vec<Vec<f64>>), NotPositiveSemidefinite> {
        let mut members: Vec<usize> = self
            .covariance
            .iter()
            .flat_map(|&(i, j, _)| [i, j])
            .collect();
        members.sort_unstable();
        members.dedup();
        let sigmas = self.sigmas();
        let m = members.len();
        let at = |i: usize| members.binary_search(&i).expect("a member");
        // The correlation matrix: the Cholesky steps then compare with 1, whatever the units.
        let mut r = vec![vec![0.0; m]; m];
        for (a, row) in r.iter_mut().enumerate() {
            row[a] = 1.0;
        }
        for &(i, j, c) in &self.covariance {
            let (si, sj) = (sigmas[i], sigmas[j]);
            if si == 0.0 || sj == 0.0 {
                if c != 0.0 {
                    return Err(NotPositiveSemidefinite {
                        pairs: vec![(i, j)],
                    });
                }
                continue;
            }
            let (a, b) = (at(i), at(j));
            r[a][b] = c / (si * sj);
            r[b][a] = r[a][b];
        }
        // A correlation beyond ±1 is the commonest fault: name its pair alone.
        const TOLERANCE: f64 = 1e-9;
        if let Some(&(i, j, _)) = self
            .covariance
            .iter()
            .find(|&&(i, j, _)| r[at(i)][at(j)].abs() > 1.0 + TOLERANCE)
        {
            return Err(NotPositiveSemidefinite {
                pairs: vec![(i, j)],
            });
        }
        // The entries between member `k` and the members before it: those at fault where the
        // factorisation fails at `k`.
        let at_fault = |k: usize| NotPositiveSemidefinite {
            pairs: self
                .covariance
                .iter()
                .filter(|&&(a, b, _)| {
                    let (a, b) = (at(a), at(b));
                    a.max(b) == k
                })
                .map(|&(a, b, _)| (a, b))
                .collect(),
        };
        let mut l = vec![vec![0.0; m]; m];
        for j in 0..m {
            let pivot = r[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
            if pivot < -TOLERANCE {
                return Err(at_fault(j));
            }
            if pivot <= TOLERANCE {
                // A perfectly correlated quantity: its column below must vanish too.
                for i in j + 1..m {
                    let rest = r[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
                    if rest.abs() > 1e-6 {
                        return Err(at_fault(i));
                    }
                }
                continue;
            }
            let d = pivot.sqrt();
            l[j][j] = d;
            for i in j + 1..m {
                l[i][j] = (r[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / d;
            }
        }
        // Back to the quantities' units: F = D·L, D the standard uncertainties.
        for (a, row) in l.iter_mut().enumerate() {
            let s = sigmas[members[a]];
            row.iter_mut().for_each(|x| *x *= s);
        }
        Ok((members, l))
    }
}

impl Machine {
    /// The machine with perturbations `e` (one per quantity of [`Machine::uncertainty`], by
    /// number) added to its error values, at the evaluation inputs it is at
    /// ([`Machine::inputs`]).
    pub fn with_deviations(&self, e: &[f64]) -> Machine {
        let mut machine = self.clone();
        let mut first = 0;
        for value in &self.uncertainty.values {
            let n = value.kind.count();
            machine.add_deviation(value, &e[first..first + n]);
            first += n;
        }
        machine
    }

    /// Adds the deviation of one uncertain value for its perturbations `e`, times its factor at
    /// the machine's inputs.
    pub fn add_deviation(&mut self, value: &UncertainValue, e: &[f64]) {
        let factor = value.factor(&self.inputs, self.thermal.as_ref());
        if factor == 0.0 || e.iter().all(|&x| x == 0.0) {
            return;
        }
        self.add_to_error(value.target, value.delta(e).scaled(factor));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar(name: &str, u: f64) -> UncertainValue {
        UncertainValue {
            name: name.into(),
            target: ErrorTarget::Spindle { index: 0 },
            approach: None,
            per_kelvin: None,
            kind: UncertainKind::Scalar { u },
        }
    }

    #[test]
    fn a_table_nodes_shape_is_its_interpolated_unit_perturbation() {
        let value = UncertainValue {
            kind: UncertainKind::Table {
                of: None,
                positions: vec![0.0, 100.0, 300.0],
                interp: Interp::Linear,
                periodic: false,
                u: vec![1.0, 1.0, 1.0],
                u_scale: 1.0,
            },
            ..scalar("t", 0.0)
        };
        assert_eq!(value.kind.count(), 4);
        let node1 = value.delta(&[0.0, 1.0, 0.0, 0.0]);
        assert_eq!(node1.eval(50.0), 0.5);
        assert_eq!(node1.eval(200.0), 0.5);
        assert_eq!(node1.eval(300.0), 0.0);
        let scale = value.delta(&[0.0, 0.0, 0.0, 2.0]);
        assert_eq!(scale.eval(250.0), 500.0);
        assert_eq!(scale.eval(400.0), 600.0, "the end value holds");
    }

    #[test]
    fn perfect_correlation_factors_and_beyond_it_is_refused() {
        let mut u = Uncertainty {
            values: vec![scalar("a", 2.0), scalar("b", 3.0), scalar("c", 1.0)],
            covariance: vec![(0, 1, 6.0)],
        };
        let (members, f) = u.correlated_factor().unwrap();
        assert_eq!(members, [0, 1]);
        // F·Fᵀ gives the matrix back: [[4, 6], [6, 9]].
        let c = |a: usize, b: usize| f[a][0] * f[b][0] + f[a][1] * f[b][1];
        assert!((c(0, 0) - 4.0).abs() < 1e-12 && (c(0, 1) - 6.0).abs() < 1e-12);
        assert!((c(1, 1) - 9.0).abs() < 1e-12);
        u.covariance = vec![(0, 1, 6.1)];
        assert_eq!(u.correlated_factor().unwrap_err().pairs, [(0, 1)]);
        // Each pair possible alone, not all three together: +1, +1 and -1.
        u.covariance = vec![(0, 1, 6.0), (0, 2, 2.0), (1, 2, -3.0)];
        assert!(!u.correlated_factor().unwrap_err().pairs.is_empty());
    }
}
