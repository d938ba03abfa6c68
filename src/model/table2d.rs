//! An error value of two axes at once (docs/model.md, "Two axes at once"): `values[i][j]` at
//! (`x[i]`, `y[j]`), bilinear between the nodes, clamped to the edge outside.

use super::{AxisLetter, Command};

#[derive(Debug, Clone, PartialEq)]
pub struct Table2d {
    /// The axes whose commanded positions are the first and second argument.
    pub axes: [AxisLetter; 2],
    /// Strictly increasing positions of the first and second argument (mm or degrees).
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// `values[i][j]` at (`x[i]`, `y[j]`): `x.len()` rows of `y.len()`.
    pub values: Vec<Vec<f64>>,
}

/// Why a two-axis table cannot be built; the caller adds the file and key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Table2dError {
    #[error("`{0}` needs at least 2 positions, found {1}")]
    TooFewNodes(&'static str, usize),
    #[error("`{name}` must increase strictly: position {index} at {q} follows {previous}")]
    Unsorted {
        name: &'static str,
        index: usize,
        q: f64,
        previous: f64,
    },
    #[error("`values` has {rows} rows, but `x` has {expected} positions: one row per x")]
    Rows { rows: usize, expected: usize },
    #[error("`values` row {row} has {len} values, but `y` has {expected} positions")]
    Columns {
        row: usize,
        len: usize,
        expected: usize,
    },
}

crate::error::input_errors!(Table2dError);

impl Table2d {
    pub fn new(
        axes: [AxisLetter; 2],
        x: Vec<f64>,
        y: Vec<f64>,
        values: Vec<Vec<f64>>,
    ) -> Result<Table2d, Table2dError> {
        for (name, q) in [("x", &x), ("y", &y)] {
            if q.len() < 2 {
                return Err(Table2dError::TooFewNodes(name, q.len()));
            }
            if let Some(index) = (1..q.len()).find(|&i| q[i] <= q[i - 1]) {
                return Err(Table2dError::Unsorted {
                    name,
                    index,
                    q: q[index],
                    previous: q[index - 1],
                });
            }
        }
        if values.len() != x.len() {
            return Err(Table2dError::Rows {
                rows: values.len(),
                expected: x.len(),
            });
        }
        if let Some((row, r)) = values.iter().enumerate().find(|(_, r)| r.len() != y.len()) {
            return Err(Table2dError::Columns {
                row,
                len: r.len(),
                expected: y.len(),
            });
        }
        Ok(Table2d { axes, x, y, values })
    }

    /// The value at the commanded positions: bilinear in the cell that holds them, the edge's
    /// value outside.
    pub fn eval(&self, command: &Command) -> f64 {
        let (i, u) = cell(&self.x, command[self.axes[0].index()]);
        let (j, v) = cell(&self.y, command[self.axes[1].index()]);
        let f = |a: usize, b: usize| self.values[a][b];
        (1.0 - u) * ((1.0 - v) * f(i, j) + v * f(i, j + 1))
            + u * ((1.0 - v) * f(i + 1, j) + v * f(i + 1, j + 1))
    }

    pub fn scaled(&self, k: f64) -> Table2d {
        Table2d {
            values: self
                .values
                .iter()
                .map(|r| r.iter().map(|v| v * k).collect())
                .collect(),
            ..self.clone()
        }
    }
}

/// The interval of `nodes` that holds `q` (clamped to the ends) and the fraction along it.
fn cell(nodes: &[f64], q: f64) -> (usize, f64) {
    let n = nodes.len();
    let q = q.clamp(nodes[0], nodes[n - 1]);
    let i = nodes.partition_point(|&p| p <= q).clamp(1, n - 1) - 1;
    (i, (q - nodes[i]) / (nodes[i + 1] - nodes[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use AxisLetter::*;

    #[test]
    fn bilinear_at_the_nodes_between_them_and_clamped_outside() {
        let t = Table2d::new(
            [X, Z],
            vec![0.0, 100.0, 300.0],
            vec![0.0, 50.0],
            vec![vec![0.0, 1.0], vec![2.0, 4.0], vec![6.0, 8.0]],
        )
        .unwrap();
        let at = |x: f64, z: f64| t.eval(&[x, 0.0, z, 0.0, 0.0, 0.0]);
        assert_eq!(at(100.0, 50.0), 4.0);
        assert_eq!(at(300.0, 0.0), 6.0);
        assert_eq!(at(50.0, 25.0), (0.0 + 1.0 + 2.0 + 4.0) / 4.0);
        assert_eq!(at(200.0, 0.0), 4.0);
        assert_eq!(at(-10.0, 80.0), 1.0);
        assert_eq!(at(400.0, -5.0), 6.0);
        assert!(
            Table2d::new([X, Z], vec![0.0, 1.0], vec![0.0, 1.0], vec![vec![0.0, 1.0]]).is_err()
        );
        assert!(Table2d::new(
            [X, Z],
            vec![1.0, 0.0],
            vec![0.0, 1.0],
            vec![vec![0.0; 2]; 2]
        )
        .is_err());
    }
}
