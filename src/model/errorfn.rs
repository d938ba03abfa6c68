//! Error values as functions of commanded positions (docs/model.md, "Error values"): of their own
//! axis's position, of another axis's (`of`), of two axes at once (`table2d`), and sums of these.
//!
//! [`ErrorFunction::eval_at`] is the f64 definition used by the CPU reference; it reads the nodes
//! directly (linear interpolation, Lagrange quadratics over node triples, the natural cubic
//! spline). [`ErrorFunction::pieces`] re-expresses a function of the own axis as piecewise
//! polynomials in a local coordinate, the form the GPU evaluates; both are tested to agree.

use super::spline::{natural_spline_second_derivatives, periodic_spline_second_derivatives};
use super::table2d::Table2d;
use super::{AxisLetter, Command};

/// How a table interpolates between its nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interp {
    /// Piecewise linear.
    Linear,
    /// The 1-D three-node elements of Dobariya et al.: Lagrange quadratics over the node triples
    /// (0,1,2), (2,3,4), …; needs an odd node count.
    Quadratic,
    /// Natural cubic spline (periodic spline for periodic tables).
    Cubic,
}

impl Interp {
    pub fn parse(name: &str) -> Option<Interp> {
        match name {
            "linear" => Some(Interp::Linear),
            "quadratic" => Some(Interp::Quadratic),
            "cubic" => Some(Interp::Cubic),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Interp::Linear => "linear",
            Interp::Quadratic => "quadratic",
            Interp::Cubic => "cubic",
        }
    }
}

/// The period of a periodic rotary table, degrees.
pub const PERIOD_DEG: f64 = 360.0;

/// A tabulated error: strictly increasing positions `q` (mm or degrees) and values.
///
/// Periodic tables are closed: when the last node is not at `q0 + 360°` a node `(q0 + 360°, v0)`
/// is appended, so interpolation wraps from the last measured node back to the first.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    q: Vec<f64>,
    v: Vec<f64>,
    interp: Interp,
    periodic: bool,
    /// Second derivatives at the nodes, for `Interp::Cubic`.
    second_derivatives: Vec<f64>,
}

/// Why a table cannot be built; the caller adds the file and key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableError {
    #[error("a table needs at least 2 nodes, found {0}")]
    TooFewNodes(usize),
    #[error("positions must increase strictly: node {index} at {q} follows {previous}")]
    Unsorted { index: usize, q: f64, previous: f64 },
    #[error("`quadratic` needs an odd number of nodes (three-node elements sharing their ends), found {0}")]
    EvenNodeCount(usize),
    #[error("a periodic table spans at most 360°, this one spans {0}°")]
    PeriodTooLong(f64),
    #[error("a periodic table that ends at q0 + 360° must end on its first value ({first}), found {last}")]
    PeriodicEndMismatch { first: f64, last: f64 },
}

crate::error::input_errors!(TableError);

impl Table {
    pub fn new(
        nodes: Vec<(f64, f64)>,
        interp: Interp,
        periodic: bool,
    ) -> Result<Table, TableError> {
        if nodes.len() < 2 {
            return Err(TableError::TooFewNodes(nodes.len()));
        }
        for (index, pair) in nodes.windows(2).enumerate() {
            if pair[1].0 <= pair[0].0 {
                return Err(TableError::Unsorted {
                    index: index + 1,
                    q: pair[1].0,
                    previous: pair[0].0,
                });
            }
        }
        let (mut q, mut v): (Vec<f64>, Vec<f64>) = nodes.into_iter().unzip();
        if periodic {
            let span = q[q.len() - 1] - q[0];
            let closed = (span - PERIOD_DEG).abs() <= 1e-9 * PERIOD_DEG;
            if span > PERIOD_DEG && !closed {
                return Err(TableError::PeriodTooLong(span));
            }
            if closed {
                let last = v[v.len() - 1];
                if (last - v[0]).abs() > 1e-12 * v[0].abs().max(1e-12) {
                    return Err(TableError::PeriodicEndMismatch { first: v[0], last });
                }
                let n = q.len();
                q[n - 1] = q[0] + PERIOD_DEG;
                v[n - 1] = v[0];
            } else {
                q.push(q[0] + PERIOD_DEG);
                v.push(v[0]);
            }
        }
        if interp == Interp::Quadratic && q.len() % 2 == 0 {
            return Err(TableError::EvenNodeCount(q.len()));
        }
        let second_derivatives = match interp {
            Interp::Cubic if periodic => periodic_spline_second_derivatives(&q, &v),
            Interp::Cubic => natural_spline_second_derivatives(&q, &v),
            _ => Vec::new(),
        };
        Ok(Table {
            q,
            v,
            interp,
            periodic,
            second_derivatives,
        })
    }

    pub fn interp(&self) -> Interp {
        self.interp
    }

    /// The table with every value times `k` (a spline's second derivatives scale with them).
    pub fn scaled(&self, k: f64) -> Table {
        Table {
            v: self.v.iter().map(|v| v * k).collect(),
            second_derivatives: self.second_derivatives.iter().map(|m| m * k).collect(),
            ..self.clone()
        }
    }

    pub fn is_periodic(&self) -> bool {
        self.periodic
    }

    /// The nodes after closing a periodic table.
    pub fn nodes(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.q.iter().copied().zip(self.v.iter().copied())
    }

    /// Wraps (periodic) or clamps (end value holds) a position into the table's span.
    pub fn domain_position(&self, q: f64) -> f64 {
        let first = self.q[0];
        let last = self.q[self.q.len() - 1];
        let q = if self.periodic {
            first + (q - first).rem_euclid(PERIOD_DEG)
        } else {
            q
        };
        q.clamp(first, last)
    }

    /// Index `i` of the interval `[q_i, q_i+1]` that holds `q` (already in the domain).
    fn interval(&self, q: f64) -> usize {
        let upper = self.q.partition_point(|&node| node <= q);
        upper.clamp(1, self.q.len() - 1) - 1
    }

    pub fn eval(&self, q: f64) -> f64 {
        let q = self.domain_position(q);
        let i = self.interval(q);
        let (q0, q1, v0, v1) = (self.q[i], self.q[i + 1], self.v[i], self.v[i + 1]);
        match self.interp {
            Interp::Linear => v0 + (v1 - v0) * (q - q0) / (q1 - q0),
            Interp::Quadratic => {
                let first = 2 * (i / 2);
                let (xa, xb, xc) = (self.q[first], self.q[first + 1], self.q[first + 2]);
                let (ya, yb, yc) = (self.v[first], self.v[first + 1], self.v[first + 2]);
                ya * (q - xb) * (q - xc) / ((xa - xb) * (xa - xc))
                    + yb * (q - xa) * (q - xc) / ((xb - xa) * (xb - xc))
                    + yc * (q - xa) * (q - xb) / ((xc - xa) * (xc - xb))
            }
            Interp::Cubic => {
                let h = q1 - q0;
                let a = (q1 - q) / h;
                let b = (q - q0) / h;
                let (m0, m1) = (self.second_derivatives[i], self.second_derivatives[i + 1]);
                a * v0 + b * v1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0
            }
        }
    }

    /// The same function as polynomials in `s = q − start`, one per interval or element.
    fn pieces(&self) -> Vec<Piece> {
        match self.interp {
            Interp::Linear => (0..self.q.len() - 1)
                .map(|i| {
                    let slope = (self.v[i + 1] - self.v[i]) / (self.q[i + 1] - self.q[i]);
                    Piece {
                        start: self.q[i],
                        coefficients: vec![self.v[i], slope],
                    }
                })
                .collect(),
            Interp::Quadratic => (0..(self.q.len() - 1) / 2)
                .map(|e| {
                    let n = 2 * e;
                    let (s1, s2) = (self.q[n + 1] - self.q[n], self.q[n + 2] - self.q[n]);
                    let (y0, y1, y2) = (self.v[n], self.v[n + 1], self.v[n + 2]);
                    // Newton divided differences, expanded to monomials in s.
                    let f01 = (y1 - y0) / s1;
                    let f012 = ((y2 - y1) / (s2 - s1) - f01) / s2;
                    Piece {
                        start: self.q[n],
                        coefficients: vec![y0, f01 - f012 * s1, f012],
                    }
                })
                .collect(),
            Interp::Cubic => (0..self.q.len() - 1)
                .map(|i| {
                    let h = self.q[i + 1] - self.q[i];
                    let (m0, m1) = (self.second_derivatives[i], self.second_derivatives[i + 1]);
                    let slope = (self.v[i + 1] - self.v[i]) / h - h * (2.0 * m0 + m1) / 6.0;
                    Piece {
                        start: self.q[i],
                        coefficients: vec![self.v[i], slope, m0 / 2.0, (m1 - m0) / (6.0 * h)],
                    }
                })
                .collect(),
        }
    }
}

/// A polynomial `Σ c_k s^k` in the local coordinate `s = q − start`, valid from `start` to the
/// next piece's start.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    pub start: f64,
    pub coefficients: Vec<f64>,
}

/// The piecewise-polynomial form of an error function, as the GPU evaluates it: bring `q` into
/// the domain (wrap when periodic, then clamp to `[lo, hi]`), find the last piece with
/// `start ≤ q`, evaluate its polynomial in `q − start`.
#[derive(Debug, Clone, PartialEq)]
pub struct Pieces {
    pub lo: f64,
    pub hi: f64,
    pub periodic: bool,
    pub pieces: Vec<Piece>,
}

impl Pieces {
    /// The f64 evaluation of the GPU form: the CPU twin of the shader's `eval_function`.
    pub fn eval(&self, q: f64) -> f64 {
        let q = if self.periodic {
            self.lo + (q - self.lo).rem_euclid(PERIOD_DEG)
        } else {
            q
        };
        let q = q.clamp(self.lo, self.hi);
        let index = self
            .pieces
            .partition_point(|p| p.start <= q)
            .saturating_sub(1);
        let piece = &self.pieces[index];
        let s = q - piece.start;
        piece
            .coefficients
            .iter()
            .rev()
            .fold(0.0, |acc, c| acc * s + c)
    }
}

/// One error value of a machine file.
#[derive(Debug, Clone, PartialEq)]
pub enum ErrorFunction {
    Constant(f64),
    /// `c0 + c1·q + c2·q² + …`, `q` in mm (degrees for rotary axes).
    Poly(Vec<f64>),
    Table(Table),
    /// The sum of its terms.
    Sum(Vec<ErrorFunction>),
    /// A polynomial or table whose argument is the commanded position of another axis (`of`).
    Of {
        axis: AxisLetter,
        form: Box<ErrorFunction>,
    },
    /// Bilinear in the commanded positions of two axes.
    Table2d(Table2d),
}

impl ErrorFunction {
    /// The value at own position `q` with every other axis at 0; for a function of its own axis
    /// only (see [`ErrorFunction::eval_at`]).
    pub fn eval(&self, q: f64) -> f64 {
        self.eval_at(q, &[0.0; 6])
    }

    /// The value at own position `q` with the commanded positions `command` of every axis.
    pub fn eval_at(&self, q: f64, command: &Command) -> f64 {
        match self {
            ErrorFunction::Constant(c) => *c,
            ErrorFunction::Poly(c) => c.iter().rev().fold(0.0, |acc, ck| acc * q + ck),
            ErrorFunction::Table(t) => t.eval(q),
            ErrorFunction::Sum(terms) => terms.iter().map(|f| f.eval_at(q, command)).sum(),
            ErrorFunction::Of { axis, form } => {
                let at = command[axis.index()];
                form.eval_at(at, command)
            }
            ErrorFunction::Table2d(t) => t.eval(command),
        }
    }

    /// The function times `k`.
    pub fn scaled(&self, k: f64) -> ErrorFunction {
        match self {
            ErrorFunction::Constant(c) => ErrorFunction::Constant(c * k),
            ErrorFunction::Poly(c) => ErrorFunction::Poly(c.iter().map(|c| c * k).collect()),
            ErrorFunction::Table(t) => ErrorFunction::Table(t.scaled(k)),
            ErrorFunction::Sum(terms) => {
                ErrorFunction::Sum(terms.iter().map(|f| f.scaled(k)).collect())
            }
            ErrorFunction::Of { axis, form } => ErrorFunction::Of {
                axis: *axis,
                form: Box::new(form.scaled(k)),
            },
            ErrorFunction::Table2d(t) => ErrorFunction::Table2d(t.scaled(k)),
        }
    }

    /// The axes other than its own the function reads the position of.
    pub fn other_axes(&self) -> Vec<AxisLetter> {
        match self {
            ErrorFunction::Sum(terms) => terms.iter().flat_map(|f| f.other_axes()).collect(),
            ErrorFunction::Of { axis, .. } => vec![*axis],
            ErrorFunction::Table2d(t) => t.axes.to_vec(),
            _ => Vec::new(),
        }
    }

    /// The function as a sum of terms that are not sums themselves (a non-sum is one term).
    pub fn terms(&self) -> Vec<&ErrorFunction> {
        match self {
            ErrorFunction::Sum(terms) => terms.iter().flat_map(|f| f.terms()).collect(),
            other => vec![other],
        }
    }

    /// The piecewise-polynomial form of a term of the own axis; `None` for a sum, whose terms the
    /// GPU evaluates one by one (see [`ErrorFunction::terms`]), and for a function of other
    /// axes.
    pub fn pieces(&self) -> Option<Pieces> {
        match self {
            ErrorFunction::Constant(c) => Some(Pieces {
                lo: f64::NEG_INFINITY,
                hi: f64::INFINITY,
                periodic: false,
                pieces: vec![Piece {
                    start: 0.0,
                    coefficients: vec![*c],
                }],
            }),
            ErrorFunction::Poly(c) => Some(Pieces {
                lo: f64::NEG_INFINITY,
                hi: f64::INFINITY,
                periodic: false,
                pieces: vec![Piece {
                    start: 0.0,
                    coefficients: c.clone(),
                }],
            }),
            ErrorFunction::Table(t) => Some(Pieces {
                lo: t.q[0],
                hi: t.q[t.q.len() - 1],
                periodic: t.periodic,
                pieces: t.pieces(),
            }),
            ErrorFunction::Sum(_) | ErrorFunction::Of { .. } | ErrorFunction::Table2d(_) => None,
        }
    }

    /// True when the function is zero everywhere (it may then be left out of the chain).
    pub fn is_zero(&self) -> bool {
        match self {
            ErrorFunction::Constant(c) => *c == 0.0,
            ErrorFunction::Poly(c) => c.iter().all(|&x| x == 0.0),
            ErrorFunction::Table(t) => t.v.iter().all(|&x| x == 0.0),
            ErrorFunction::Sum(terms) => terms.iter().all(ErrorFunction::is_zero),
            ErrorFunction::Of { form, .. } => form.is_zero(),
            ErrorFunction::Table2d(t) => t.values.iter().flatten().all(|&x| x == 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(nodes: &[(f64, f64)], interp: Interp, periodic: bool) -> Table {
        Table::new(nodes.to_vec(), interp, periodic).unwrap()
    }

    #[test]
    fn linear_and_end_values() {
        let t = table(
            &[(0.0, 0.0), (300.0, 0.012), (600.0, 0.020)],
            Interp::Linear,
            false,
        );
        assert!((t.eval(150.0) - 0.006).abs() < 1e-15);
        assert!((t.eval(450.0) - 0.016).abs() < 1e-15);
        assert_eq!(t.eval(-10.0), 0.0);
        assert_eq!(t.eval(700.0), 0.020);
    }

    #[test]
    fn quadratic_reproduces_a_parabola() {
        let f = |q: f64| 1e-3 + 2e-5 * q - 3e-8 * q * q;
        let nodes: Vec<(f64, f64)> = [0.0, 100.0, 250.0, 400.0, 600.0]
            .iter()
            .map(|&q| (q, f(q)))
            .collect();
        let t = table(&nodes, Interp::Quadratic, false);
        for q in [0.0, 33.0, 100.0, 317.0, 599.0] {
            assert!((t.eval(q) - f(q)).abs() < 1e-15, "{q}");
        }
        assert!(matches!(
            Table::new(nodes[..4].to_vec(), Interp::Quadratic, false),
            Err(TableError::EvenNodeCount(4))
        ));
    }

    #[test]
    fn natural_cubic_reproduces_a_line_and_is_smooth() {
        let t = table(
            &[(0.0, 1.0), (1.0, 3.0), (3.0, 7.0), (4.0, 9.0)],
            Interp::Cubic,
            false,
        );
        assert!((t.eval(2.0) - 5.0).abs() < 1e-12);
        let s = table(
            &[(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (3.0, 1.0)],
            Interp::Cubic,
            false,
        );
        let d = |q: f64| (s.eval(q + 1e-6) - s.eval(q - 1e-6)) / 2e-6;
        assert!((d(1.0 - 1e-3) - d(1.0 + 1e-3)).abs() < 1e-2);
    }

    #[test]
    fn periodic_wraps_and_closes() {
        let t = table(
            &[(0.0, 1.0), (90.0, 2.0), (180.0, 3.0), (270.0, 2.0)],
            Interp::Linear,
            true,
        );
        assert!((t.eval(315.0) - 1.5).abs() < 1e-12);
        assert!((t.eval(-45.0) - 1.5).abs() < 1e-12);
        assert!((t.eval(720.0 + 45.0) - 1.5).abs() < 1e-12);
        let c = table(
            &[(0.0, 1.0), (90.0, 2.0), (180.0, 3.0), (270.0, 2.0)],
            Interp::Cubic,
            true,
        );
        let d = |q: f64| (c.eval(q + 1e-5) - c.eval(q - 1e-5)) / 2e-5;
        assert!((d(0.0) - d(360.0)).abs() < 1e-8);
        assert!((d(-0.01) - d(0.01)).abs() < 1e-3);
    }

    #[test]
    fn pieces_match_direct_evaluation() {
        let all = [
            (-20.0, 0.001),
            (35.0, -0.004),
            (90.0, 0.002),
            (160.0, 0.006),
            (300.0, -0.001),
        ];
        for interp in [Interp::Linear, Interp::Quadratic, Interp::Cubic] {
            for periodic in [false, true] {
                // A periodic table closes with a node at the first plus 360°, and quadratic
                // pieces need an odd count of nodes: that case leaves the last node out.
                let nodes = if interp == Interp::Quadratic && periodic {
                    &all[..4]
                } else {
                    &all[..]
                };
                let t = Table::new(nodes.to_vec(), interp, periodic)
                    .unwrap_or_else(|e| panic!("{interp:?} {periodic}: {e}"));
                let f = ErrorFunction::Table(t);
                let p = f.pieces().expect("a table has pieces");
                for k in 0..1000 {
                    let q = -400.0 + k as f64 * 1.1;
                    assert!(
                        (f.eval(q) - p.eval(q)).abs() < 1e-14,
                        "{interp:?} {periodic} {q}"
                    );
                }
            }
        }
        let poly = ErrorFunction::Poly(vec![1e-3, 2e-6, -1e-9]);
        assert!((poly.eval(500.0) - poly.pieces().expect("one piece").eval(500.0)).abs() < 1e-15);
    }
}
