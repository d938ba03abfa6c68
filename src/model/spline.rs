//! The linear systems of cubic splines: the second derivatives of natural and periodic cubic
//! splines through a table's nodes.

/// Second derivatives of the natural cubic spline (zero at both ends): the tridiagonal system
/// `h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (d_i − d_{i-1})`, Thomas algorithm.
pub(super) fn natural_spline_second_derivatives(q: &[f64], v: &[f64]) -> Vec<f64> {
    let n = q.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    let h: Vec<f64> = q.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<f64> = (0..n - 1).map(|i| (v[i + 1] - v[i]) / h[i]).collect();
    // Interior unknowns M_1 … M_{n-2}.
    let k = n - 2;
    let mut diag: Vec<f64> = (0..k).map(|j| 2.0 * (h[j] + h[j + 1])).collect();
    let mut rhs: Vec<f64> = (0..k).map(|j| 6.0 * (slope[j + 1] - slope[j])).collect();
    for j in 1..k {
        let w = h[j] / diag[j - 1];
        diag[j] -= w * h[j];
        rhs[j] -= w * rhs[j - 1];
    }
    m[k] = rhs[k - 1] / diag[k - 1];
    for j in (0..k - 1).rev() {
        m[j + 1] = (rhs[j] - h[j + 1] * m[j + 2]) / diag[j];
    }
    m
}

/// Second derivatives of the periodic cubic spline over closed nodes (`q_n = q_0 + 360°`,
/// `v_n = v_0`): a cyclic tridiagonal system in `M_0 … M_{n-1}`, solved densely for small `n`
/// and by Sherman–Morrison otherwise.
pub(super) fn periodic_spline_second_derivatives(q: &[f64], v: &[f64]) -> Vec<f64> {
    let n = q.len() - 1; // intervals = unknowns
    let h: Vec<f64> = q.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<f64> = (0..n).map(|i| (v[i + 1] - v[i]) / h[i]).collect();
    let prev = |i: usize| (i + n - 1) % n;
    let rhs: Vec<f64> = (0..n).map(|i| 6.0 * (slope[i] - slope[prev(i)])).collect();
    let mut m = if n < 3 {
        let mut a = vec![vec![0.0; n]; n];
        for i in 0..n {
            a[i][prev(i)] += h[prev(i)];
            a[i][i] += 2.0 * (h[prev(i)] + h[i]);
            a[i][(i + 1) % n] += h[i];
        }
        solve_dense(a, rhs.clone())
    } else {
        let sub: Vec<f64> = (0..n).map(|i| h[prev(i)]).collect();
        let diag: Vec<f64> = (0..n).map(|i| 2.0 * (h[prev(i)] + h[i])).collect();
        let sup: Vec<f64> = h.clone();
        solve_cyclic(&sub, &diag, &sup, &rhs)
    };
    m.push(m[0]);
    m
}

fn solve_dense(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&r, &s| a[r][col].abs().total_cmp(&a[s][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col].clone();
        for row in col + 1..n {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x
}

fn solve_tridiagonal(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let mut c = vec![0.0; n];
    let mut d = vec![0.0; n];
    c[0] = sup[0] / diag[0];
    d[0] = rhs[0] / diag[0];
    for i in 1..n {
        let denom = diag[i] - sub[i] * c[i - 1];
        c[i] = sup[i] / denom;
        d[i] = (rhs[i] - sub[i] * d[i - 1]) / denom;
    }
    let mut x = vec![0.0; n];
    x[n - 1] = d[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = d[i] - c[i] * x[i + 1];
    }
    x
}

/// Cyclic tridiagonal system (`sub[0]` couples row 0 to the last unknown, `sup[n-1]` the last row
/// to the first), Sherman–Morrison on top of the Thomas algorithm.
fn solve_cyclic(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let alpha = sup[n - 1];
    let beta = sub[0];
    let gamma = -diag[0];
    let mut modified = diag.to_vec();
    modified[0] -= gamma;
    modified[n - 1] -= alpha * beta / gamma;
    let x = solve_tridiagonal(sub, &modified, sup, rhs);
    let mut u = vec![0.0; n];
    u[0] = gamma;
    u[n - 1] = alpha;
    let z = solve_tridiagonal(sub, &modified, sup, &u);
    let factor = (x[0] + beta * x[n - 1] / gamma) / (1.0 + z[0] + beta * z[n - 1] / gamma);
    x.iter().zip(&z).map(|(xi, zi)| xi - factor * zi).collect()
}
