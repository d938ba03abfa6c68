//! Piecewise-linear tables and the choice of their nodes.
//!
//! Where a format lets the nodes lie anywhere ([`free_nodes`]), they are chosen among a fine set
//! of candidate positions so that the largest distance between the curve and the chords through
//! it at the nodes is the smallest any choice of that many nodes gives (both ends kept): the
//! minimax over candidates, solved exactly by dynamic programming. Where a format demands
//! equidistant nodes, [`equidistant`] gives them.

use rayon::prelude::*;

/// A piecewise-linear table: strictly increasing positions and their values; linear between
/// nodes, the end value outside.
#[derive(Debug, Clone, PartialEq)]
pub struct Pwl {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
}

impl Pwl {
    pub fn eval(&self, x: f64) -> f64 {
        let n = self.q.len();
        if n == 1 || x <= self.q[0] {
            return self.v[0];
        }
        if x >= self.q[n - 1] {
            return self.v[n - 1];
        }
        let i = self.q.partition_point(|&q| q <= x).clamp(1, n - 1);
        let (q0, q1) = (self.q[i - 1], self.q[i]);
        let u = (x - q0) / (q1 - q0);
        self.v[i - 1] + u * (self.v[i] - self.v[i - 1])
    }
}

/// The positions `start + i·spacing` for `i` in `0..n`.
pub fn equidistant(start: f64, spacing: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| start + i as f64 * spacing).collect()
}

/// A lattice over the travels `ranges` (X, Y, Z, mm): per axis `points` nodes from the start of
/// its travel, `spacing_mm` apart, or spread over the travel with the last node exactly on its
/// end; each node but that last one as `round` writes it. Returns the nodes per axis and the
/// lattice's points, X fastest, then Y, then Z.
pub fn lattice(
    ranges: &[[f64; 2]; 3],
    points: [usize; 3],
    spacing_mm: Option<f64>,
    round: impl Fn(f64) -> f64,
) -> ([Vec<f64>; 3], Vec<[f64; 3]>) {
    let axes: [Vec<f64>; 3] = std::array::from_fn(|d| {
        let [lo, hi] = ranges[d];
        let step = spacing_mm.unwrap_or((hi - lo) / (points[d] - 1) as f64);
        let mut q: Vec<f64> = equidistant(lo, step, points[d])
            .into_iter()
            .map(&round)
            .collect();
        if spacing_mm.is_none() {
            q[points[d] - 1] = hi;
        }
        q
    });
    let mut targets = Vec::with_capacity(points.iter().product());
    for &z in &axes[2] {
        for &y in &axes[1] {
            for &x in &axes[0] {
                targets.push([x, y, z]);
            }
        }
    }
    (axes, targets)
}

/// The largest distance of any of the curves `f` at the candidates strictly between `i` and `j`
/// from its chord through `(q_i, f_i)` and `(q_j, f_j)`.
fn chord_error(q: &[f64], f: &[&[f64]], i: usize, j: usize) -> f64 {
    let mut worst: f64 = 0.0;
    for f in f {
        let slope = (f[j] - f[i]) / (q[j] - q[i]);
        for m in (i + 1)..j {
            worst = worst.max((f[m] - (f[i] + slope * (q[m] - q[i]))).abs());
        }
    }
    worst
}

/// Chooses at most `n` of the candidate positions `q` (strictly increasing) as the nodes of
/// tables of the curves `f` (their values at the candidates; the tables share their nodes), the
/// first and the last candidate always among them, no two closer than `min_spacing`, so that
/// the largest distance of any curve from its chords between consecutive nodes is the smallest
/// possible. Of the choices within `tolerance` of that smallest error, the one with the fewest
/// nodes. A deviation below 1e-12 of the largest value of the curves is none (rounding, not
/// shape). Returns the indices of the nodes in `q`, in order; with `n` at least the number of
/// candidates, every candidate.
pub fn free_nodes(
    q: &[f64],
    f: &[&[f64]],
    n: usize,
    min_spacing: f64,
    tolerance: f64,
) -> Vec<usize> {
    let m = q.len();
    let all_apart = q.windows(2).all(|w| w[1] - w[0] >= min_spacing);
    if m <= 2 || (n >= m && all_apart) {
        return (0..m).collect();
    }
    let n = n.clamp(2, m);
    // Deviations at the rounding of the values are none: a straight piece takes no node.
    let scale = f
        .iter()
        .flat_map(|c| c.iter())
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    let negligible = 1e-12 * scale;
    // cost[i][j]: the chord error of a segment from candidate i to candidate j.
    let allowed = |i: usize, j: usize| q[j] - q[i] >= min_spacing * (1.0 - 1e-12);
    let cost: Vec<Vec<f64>> = (0..m)
        .into_par_iter()
        .map(|i| {
            (0..m)
                .map(|j| {
                    if j > i && allowed(i, j) {
                        Some(chord_error(q, f, i, j))
                            .filter(|&e| e > negligible)
                            .unwrap_or(0.0)
                    } else {
                        f64::INFINITY
                    }
                })
                .collect()
        })
        .collect();
    // best[s][j]: the smallest largest error of s segments from candidate 0 to candidate j;
    // from[s][j] the node before j on that choice.
    let mut best = vec![vec![f64::INFINITY; m]; n];
    let mut from = vec![vec![usize::MAX; m]; n];
    best[0][0] = 0.0;
    for s in 1..n {
        let (done, rest) = best.split_at_mut(s);
        let previous = &done[s - 1];
        for j in s..m {
            let mut b = f64::INFINITY;
            let mut at = usize::MAX;
            for i in (s - 1)..j {
                let e = previous[i].max(cost[i][j]);
                if e < b {
                    b = e;
                    at = i;
                }
            }
            rest[0][j] = b;
            from[s][j] = at;
        }
    }
    // Fewer segments may do as well: take the fewest within the tolerance of the best.
    let target = (1..n).map(|s| best[s][m - 1]).fold(f64::INFINITY, f64::min);
    let segments = (1..n)
        .find(|&s| best[s][m - 1] <= target + tolerance)
        .unwrap_or(n - 1);
    let mut nodes = vec![m - 1];
    let mut j = m - 1;
    for s in (1..=segments).rev() {
        j = from[s][j];
        nodes.push(j);
    }
    nodes.reverse();
    nodes
}

/// `n` candidate positions over `[lo, hi]` evenly, with `extra` positions inside it added
/// (kept apart from the others by a millionth of the travel): where a curve has kinks.
pub fn candidates(lo: f64, hi: f64, n: usize, extra: &[f64]) -> Vec<f64> {
    let mut q = super::fitting::uniform(lo, hi, n);
    let apart = (hi - lo) * 1e-6;
    for &e in extra {
        if e > lo && e < hi && q.iter().all(|&x| (x - e).abs() > apart) {
            q.push(e);
        }
    }
    q.sort_by(f64::total_cmp);
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pwl_holds_its_end_values_and_interpolates_linearly() {
        let t = Pwl {
            q: vec![0.0, 10.0, 30.0],
            v: vec![1.0, 2.0, 0.0],
        };
        assert_eq!(t.eval(-5.0), 1.0);
        assert_eq!(t.eval(5.0), 1.5);
        assert_eq!(t.eval(20.0), 1.0);
        assert_eq!(t.eval(40.0), 0.0);
    }

    #[test]
    fn free_nodes_find_the_kinks_of_a_piecewise_linear_curve() {
        let q: Vec<f64> = (0..=100).map(|i| i as f64).collect();
        let f: Vec<f64> = q
            .iter()
            .map(|&x| if x < 37.0 { x } else { 37.0 - 2.0 * (x - 37.0) })
            .collect();
        assert_eq!(free_nodes(&q, &[&f], 3, 0.0, 1e-12), vec![0, 37, 100]);
        // More nodes than the curve needs: the fewest that do as well.
        assert_eq!(free_nodes(&q, &[&f], 10, 0.0, 1e-12), vec![0, 37, 100]);
    }

    #[test]
    fn free_nodes_beat_equidistant_ones_on_a_curve_bent_at_one_end() {
        let q: Vec<f64> = (0..=200).map(|i| i as f64 / 200.0).collect();
        let f: Vec<f64> = q.iter().map(|&x| x.powi(6)).collect();
        let worst = |nodes: &[usize]| {
            let t = Pwl {
                q: nodes.iter().map(|&i| q[i]).collect(),
                v: nodes.iter().map(|&i| f[i]).collect(),
            };
            q.iter()
                .zip(&f)
                .map(|(&x, &y)| (t.eval(x) - y).abs())
                .fold(0.0, f64::max)
        };
        let free = free_nodes(&q, &[&f], 6, 0.0, 0.0);
        let even: Vec<usize> = (0..6).map(|i| i * 40).collect();
        assert_eq!((free[0], free[5]), (0, 200));
        assert!(worst(&free) < 0.5 * worst(&even));
        // No set of 6 nodes among every 10th candidate does better.
        let coarse: Vec<usize> = (0..=20).map(|i| i * 10).collect();
        let mut best = f64::INFINITY;
        for a in 1..19 {
            for b in a + 1..20 {
                for c in b + 1..20 {
                    for d in c + 1..20 {
                        let nodes = [0, coarse[a], coarse[b], coarse[c], coarse[d], 200];
                        best = best.min(worst(&nodes));
                    }
                }
            }
        }
        assert!(worst(&free) <= best + 1e-15);
    }

    #[test]
    fn free_nodes_keep_the_minimum_spacing() {
        let q: Vec<f64> = (0..=100).map(|i| i as f64).collect();
        let f: Vec<f64> = q.iter().map(|&x| (x / 7.0).sin()).collect();
        let nodes = free_nodes(&q, &[&f], 30, 5.0, 0.0);
        assert!(nodes.windows(2).all(|w| q[w[1]] - q[w[0]] >= 5.0));
        assert_eq!(nodes.last(), Some(&100));
    }
}
