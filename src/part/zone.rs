//! Form tolerances as ISO 1101 defines them: the minimum zone, not a least-squares fit.
//!
//! Flatness is the smallest distance between two parallel planes that hold every point;
//! cylindricity the smallest radial distance between two coaxial cylinders that do. Both are
//! found by linear programming on the deviations from the nominal feature (Chebyshev fits):
//!
//! - flatness: with `h` the height of a point over the nominal plane and `(u, v)` its position in
//!   it, minimise `w` subject to `0 ≤ h − (a·u + b·v + c) ≤ w`. The planes' normal is
//!   `n − a·e1 − b·e2`; the width reported is the exact spread of the points along that normal.
//!   The LP neglects the factor `1/√(1 + a² + b²)` in the width, a relative error of `(a² + b²)/2`
//!   (1e-10 for a tilt of 1e-5 between the nominal and the machined plane).
//! - cylindricity: with `r`, `θ`, `z` the cylindrical coordinates of a point about the current
//!   axis, minimise `w` subject to `0 ≤ r − (dx + ax·z)·cos θ − (dy + ay·z)·sin θ − R ≤ w`, move
//!   the axis by the offset `(dx, dy)` and tilt `(ax, ay)` found, and repeat until the axis stops
//!   moving (the linearised distance is exact to second order in the axis change). The width
//!   reported is the exact radial spread about the final axis.
//!
//! Coordinates are centred and scaled to order one before the LP so its tolerances act on
//! relative, not absolute, values.

use microlp::{ComparisonOp, OptimizationDirection, Problem, SolveOutcome};
use nalgebra::Vector3;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ZoneError {
    #[error("{feature}: needs at least {needed} points, got {got}")]
    TooFewPoints {
        feature: &'static str,
        needed: usize,
        got: usize,
    },
    #[error("{feature}: a point is not finite")]
    NotFinite { feature: &'static str },
    #[error("{feature}: the nominal direction has zero length")]
    ZeroDirection { feature: &'static str },
    #[error("{feature}: the minimum-zone linear program failed: {message}")]
    Solver {
        feature: &'static str,
        message: String,
    },
}

crate::error::input_errors!(ZoneError);

/// Two parallel planes holding every point.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneZone {
    /// Distance between the planes, mm.
    pub width_mm: f64,
    /// Unit normal of the planes, on the side of the nominal normal.
    pub normal: Vector3<f64>,
    /// The point farthest above the lower plane and the one on it (indices into the input).
    pub highest: usize,
    pub lowest: usize,
}

/// Two coaxial cylinders holding every point.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderZone {
    /// Radial distance between the cylinders, mm.
    pub width_mm: f64,
    /// A point of the axis and its unit direction.
    pub axis_point: Vector3<f64>,
    pub axis_direction: Vector3<f64>,
    /// Radii of the inner and the outer cylinder, mm.
    pub inner_radius_mm: f64,
    pub outer_radius_mm: f64,
    /// The points on the outer and on the inner cylinder (indices into the input).
    pub outermost: usize,
    pub innermost: usize,
}

/// Two unit vectors completing `n` to a right-handed orthonormal frame.
pub(crate) fn frame(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&helper).normalize();
    (e1, n.cross(&e1))
}

fn check(
    feature: &'static str,
    points: &[Vector3<f64>],
    needed: usize,
    direction: &Vector3<f64>,
) -> Result<Vector3<f64>, ZoneError> {
    if points.len() < needed {
        return Err(ZoneError::TooFewPoints {
            feature,
            needed,
            got: points.len(),
        });
    }
    if points.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(ZoneError::NotFinite { feature });
    }
    let norm = direction.norm();
    if !(norm > 0.0 && norm.is_finite()) {
        return Err(ZoneError::ZeroDirection { feature });
    }
    Ok(direction / norm)
}

/// Rows [`chebyshev`] starts its subset with: a zone is fixed by a handful of rows (four for
/// a plane, six or so for a cylinder), so a small programme solved a few times is much quicker
/// than one of every row (and its memory grows by kilobytes a row: a floor of 240,000 points
/// took 600 MB solved at once).
const CHEBYSHEV_START_ROWS: usize = 32;

/// The most rows one round of [`chebyshev`] adds to its subset.
const CHEBYSHEV_MOST_ADDED: usize = 1000;

/// Minimises `w` subject to `0 ≤ target_i − Σ_k x_k·coefficients_ik ≤ w`; returns `x` and `w`.
///
/// Solved by constraint generation: the programme on a subset (evenly spread rows and the
/// highest and lowest targets), then again with the rows its solution violates most added (as
/// many as the subset has, so rounds are few), until it violates none. The subset's programme
/// is a relaxation of the whole one, so a solution that satisfies every row is the whole
/// programme's optimum: the same answer.
fn chebyshev(
    feature: &'static str,
    rows: &[(Vec<f64>, f64)],
    unknowns: usize,
) -> Result<(Vec<f64>, f64), ZoneError> {
    if rows.len() <= 2 * CHEBYSHEV_START_ROWS {
        return chebyshev_all(feature, rows, unknowns);
    }
    let half = CHEBYSHEV_START_ROWS / 2;
    let mut chosen = vec![false; rows.len()];
    let step = rows.len().div_ceil(half);
    (0..rows.len()).step_by(step).for_each(|i| chosen[i] = true);
    let mut by_target: Vec<usize> = (0..rows.len()).collect();
    by_target.sort_by(|&a, &b| rows[a].1.total_cmp(&rows[b].1));
    let ends = half / 2;
    for &i in by_target[..ends]
        .iter()
        .chain(&by_target[rows.len() - ends..])
    {
        chosen[i] = true;
    }
    loop {
        let subset: Vec<(Vec<f64>, f64)> = (0..rows.len())
            .filter(|&i| chosen[i])
            .map(|i| rows[i].clone())
            .collect();
        let (x, w) = chebyshev_all(feature, &subset, unknowns)?;
        // Violations beyond the solver's own tolerance (targets are of order one).
        let tolerance = 1e-9 * (1.0 + w);
        let mut violated: Vec<(f64, usize)> = rows
            .iter()
            .enumerate()
            .filter(|&(i, _)| !chosen[i])
            .filter_map(|(i, (coefficients, target))| {
                let r = target - coefficients.iter().zip(&x).map(|(c, v)| c * v).sum::<f64>();
                let by = (-r).max(r - w);
                (by > tolerance).then_some((by, i))
            })
            .collect();
        if violated.is_empty() {
            return Ok((x, w));
        }
        violated.sort_by(|a, b| b.0.total_cmp(&a.0));
        let added = subset
            .len()
            .clamp(CHEBYSHEV_START_ROWS, CHEBYSHEV_MOST_ADDED);
        for &(_, i) in violated.iter().take(added) {
            chosen[i] = true;
        }
    }
}

/// [`chebyshev`] as one linear programme of every row.
fn chebyshev_all(
    feature: &'static str,
    rows: &[(Vec<f64>, f64)],
    unknowns: usize,
) -> Result<(Vec<f64>, f64), ZoneError> {
    let mut problem = Problem::new(OptimizationDirection::Minimize);
    let x: Vec<_> = (0..unknowns)
        .map(|_| problem.add_var(0.0, (f64::NEG_INFINITY, f64::INFINITY)))
        .collect();
    let w = problem.add_var(1.0, (0.0, f64::INFINITY));
    // Values at the rounding level of order-one targets are zeros, and so are coefficients below
    // 1e-7 of the largest of their row (w's 1 among them): the solver rejects rows whose
    // coefficients span more than about 1e6, and a term that small moves no row beyond rounding.
    let clean = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v };
    for (coefficients, target) in rows {
        let largest = coefficients.iter().fold(1.0f64, |m, c| m.max(c.abs()));
        let coefficients: Vec<f64> = coefficients
            .iter()
            .map(|&c| if c.abs() < 1e-7 * largest { 0.0 } else { c })
            .collect();
        let target = &clean(*target);
        let terms: Vec<_> = x
            .iter()
            .copied()
            .zip(coefficients.iter().copied())
            .collect();
        problem.add_constraint(terms.as_slice(), ComparisonOp::Le, *target);
        let mut with_w = terms.clone();
        with_w.push((w, 1.0));
        problem.add_constraint(with_w.as_slice(), ComparisonOp::Ge, *target);
    }
    let solver = |message: String| ZoneError::Solver { feature, message };
    match problem.solve().map_err(|e| solver(e.to_string()))? {
        SolveOutcome::Solution(solution) => {
            Ok((x.iter().map(|&v| solution[v]).collect(), solution[w]))
        }
        SolveOutcome::Interrupted(_) => Err(solver("interrupted before a solution".into())),
    }
}

fn spread(values: impl Iterator<Item = f64>) -> (f64, usize, f64, usize) {
    let (mut lo, mut lo_at, mut hi, mut hi_at) = (f64::INFINITY, 0, f64::NEG_INFINITY, 0);
    for (n, v) in values.enumerate() {
        if v < lo {
            (lo, lo_at) = (v, n);
        }
        if v > hi {
            (hi, hi_at) = (v, n);
        }
    }
    (lo, lo_at, hi, hi_at)
}

/// The planes normal to `normal` (unit) through the lowest and highest point.
fn plane_zone(points: &[Vector3<f64>], normal: Vector3<f64>) -> PlaneZone {
    let (lo, lowest, hi, highest) = spread(points.iter().map(|p| normal.dot(p)));
    PlaneZone {
        width_mm: hi - lo,
        normal,
        highest,
        lowest,
    }
}

/// Flatness by the minimum zone. `nominal_normal` is the normal of the feature as drawn.
pub fn flatness_min_zone(
    points: &[Vector3<f64>],
    nominal_normal: &Vector3<f64>,
) -> Result<PlaneZone, ZoneError> {
    const FEATURE: &str = "flatness";
    let n = check(FEATURE, points, 3, nominal_normal)?;
    let (e1, e2) = frame(&n);
    let centre = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let local: Vec<[f64; 3]> = points
        .iter()
        .map(|p| {
            let d = p - centre;
            [e1.dot(&d), e2.dot(&d), n.dot(&d)]
        })
        .collect();
    let length = local
        .iter()
        .map(|l| l[0].abs().max(l[1].abs()))
        .fold(0.0, f64::max)
        .max(1e-300);
    let height = local.iter().map(|l| l[2].abs()).fold(0.0, f64::max);
    // Heights at the rounding level of the coordinates: the points lie in the nominal plane.
    if height <= 1e-13 * (length + centre.norm()) {
        return Ok(plane_zone(points, n));
    }
    let rows: Vec<(Vec<f64>, f64)> = local
        .iter()
        .map(|l| (vec![l[0] / length, l[1] / length, 1.0], l[2] / height))
        .collect();
    let (x, _) = chebyshev(FEATURE, &rows, 3)?;
    let (a, b) = (x[0] * height / length, x[1] * height / length);
    Ok(plane_zone(points, (n - a * e1 - b * e2).normalize()))
}

/// The least-squares plane (the plane through the centroid minimising the squared distances),
/// and the zone of planes parallel to it: wider than the minimum zone, or as wide.
pub fn flatness_least_squares(
    points: &[Vector3<f64>],
    nominal_normal: &Vector3<f64>,
) -> Result<PlaneZone, ZoneError> {
    let n = check("flatness", points, 3, nominal_normal)?;
    let centre = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let covariance = points.iter().fold(nalgebra::Matrix3::zeros(), |acc, p| {
        let d = p - centre;
        acc + d * d.transpose()
    });
    let eigen = covariance.symmetric_eigen();
    let smallest = eigen.eigenvalues.imin();
    let mut normal: Vector3<f64> = eigen.eigenvectors.column(smallest).into_owned();
    if normal.dot(&n) < 0.0 {
        normal = -normal;
    }
    Ok(plane_zone(points, normal))
}

/// Radial distances of the points from an axis.
fn radii(points: &[Vector3<f64>], point: &Vector3<f64>, direction: &Vector3<f64>) -> Vec<f64> {
    points
        .iter()
        .map(|p| {
            let d = p - point;
            (d - direction * direction.dot(&d)).norm()
        })
        .collect()
}

fn cylinder_zone(
    points: &[Vector3<f64>],
    axis_point: Vector3<f64>,
    axis_direction: Vector3<f64>,
) -> CylinderZone {
    let (inner, innermost, outer, outermost) =
        spread(radii(points, &axis_point, &axis_direction).into_iter());
    CylinderZone {
        width_mm: outer - inner,
        axis_point,
        axis_direction,
        inner_radius_mm: inner,
        outer_radius_mm: outer,
        outermost,
        innermost,
    }
}

/// The least-squares line through `points` along `direction` (unit): in the frame of the
/// direction at `centroid`, the offsets across it regressed on the height along it. Returns the
/// line's point at the centroid's height and its unit direction.
fn fitted_axis(
    points: &[Vector3<f64>],
    centroid: &Vector3<f64>,
    direction: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (e1, e2) = frame(direction);
    let (mut zz, mut uz, mut vz) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p - centroid;
        let z = direction.dot(&d);
        zz += z * z;
        uz += e1.dot(&d) * z;
        vz += e2.dot(&d) * z;
    }
    // Points at one height tilt nothing.
    let (a, b) = if zz > 0.0 {
        (uz / zz, vz / zz)
    } else {
        (0.0, 0.0)
    };
    (*centroid, (direction + a * e1 + b * e2).normalize())
}

/// Cylindricity by the minimum zone, starting from the nominal axis (a point and a direction).
pub fn cylindricity_min_zone(
    points: &[Vector3<f64>],
    axis_point: &Vector3<f64>,
    axis_direction: &Vector3<f64>,
) -> Result<CylinderZone, ZoneError> {
    const FEATURE: &str = "cylindricity";
    let mut direction = check(FEATURE, points, 6, axis_direction)?;
    // Start on the nominal axis level with the points' centroid (z centred), or on the line
    // fitted through the points where that holds them in a narrower zone: for points evenly
    // around the circle at each height that line is the displaced and tilted axis itself, where
    // the nominal one may lie farther from it than the radius (a hole of 0.1 mm moved by
    // 0.05 mm) and radii linearised about it say nothing of the wall.
    let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let nominal = axis_point + direction * direction.dot(&(centroid - axis_point));
    let nominal_zone = cylinder_zone(points, nominal, direction);
    let (fitted_point, fitted_direction) = fitted_axis(points, &centroid, &direction);
    let fitted_zone = cylinder_zone(points, fitted_point, fitted_direction);
    let (mut point, mut zone) = if fitted_zone.width_mm < nominal_zone.width_mm {
        direction = fitted_direction;
        (fitted_point, fitted_zone)
    } else {
        (nominal, nominal_zone)
    };
    for _ in 0..20 {
        let (e1, e2) = frame(&direction);
        let local: Vec<(f64, f64, f64, f64)> = points
            .iter()
            .map(|p| {
                let d = p - point;
                let z = direction.dot(&d);
                let radial = d - direction * z;
                let r = radial.norm();
                let (c, s) = if r > 0.0 {
                    (e1.dot(&radial) / r, e2.dot(&radial) / r)
                } else {
                    (1.0, 0.0)
                };
                (r, c, s, z)
            })
            .collect();
        let length = local
            .iter()
            .map(|l| l.3.abs())
            .fold(0.0, f64::max)
            .max(1e-300);
        let mean_r = local.iter().map(|l| l.0).sum::<f64>() / local.len() as f64;
        let scale = local
            .iter()
            .map(|l| (l.0 - mean_r).abs())
            .fold(0.0, f64::max);
        if scale <= 1e-13 * (mean_r + point.norm()) {
            break;
        }
        // Unknowns, mm: dx, dy (offset), ax, ay (tilt times length), R − mean_r; every row divided
        // by the radial spread.
        let rows: Vec<(Vec<f64>, f64)> = local
            .iter()
            .map(|&(r, c, s, z)| {
                let zl = z / length;
                (
                    vec![
                        c / scale,
                        s / scale,
                        c * zl / scale,
                        s * zl / scale,
                        1.0 / scale,
                    ],
                    (r - mean_r) / scale,
                )
            })
            .collect();
        let (x, _) = chebyshev(FEATURE, &rows, 5)?;
        let offset = x[0] * e1 + x[1] * e2;
        let tilt = (x[2] * e1 + x[3] * e2) / length;
        let candidate_point = point + offset;
        let candidate_direction = (direction + tilt).normalize();
        let candidate = cylinder_zone(points, candidate_point, candidate_direction);
        let moved = offset.norm() + tilt.norm() * length;
        if candidate.width_mm < zone.width_mm {
            zone = candidate;
        }
        point = candidate_point;
        direction = candidate_direction;
        if moved <= 1e-12 * (1.0 + mean_r) {
            break;
        }
    }
    Ok(zone)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Constraint generation gives the one programme's optimum: planes of 200 to 20,000 points
    /// with a waviness and a few outliers, solved both ways.
    #[test]
    fn many_rows_solved_by_subsets_give_the_whole_programme_s_optimum() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for count in [200, 2_000, 20_000] {
            let rows: Vec<(Vec<f64>, f64)> = (0..count)
                .map(|_| {
                    let (x, y) = (2.0 * random() - 1.0, 2.0 * random() - 1.0);
                    let mut z = 0.3 * x - 0.2 * y + 0.05 * (7.0 * x).sin() * (5.0 * y).cos();
                    if random() < 0.001 {
                        z += random() - 0.5;
                    }
                    (vec![x, y, 1.0], z)
                })
                .collect();
            let (x, w) = chebyshev("flatness", &rows, 3).unwrap();
            let (x_all, w_all) = chebyshev_all("flatness", &rows, 3).unwrap();
            assert!((w - w_all).abs() < 1e-9, "{count} rows: {w} vs {w_all}");
            assert_eq!((x.len(), x_all.len()), (3, 3), "{count} rows");
            for (a, b) in x.iter().zip(&x_all) {
                assert!((a - b).abs() < 1e-6, "{count} rows: {x:?} vs {x_all:?}");
            }
            // Every row within the zone found.
            for (c, t) in &rows {
                let r = t - c.iter().zip(&x).map(|(c, v)| c * v).sum::<f64>();
                assert!(r > -1e-8 && r < w + 1e-8, "{count} rows: {r} of {w}");
            }
        }
    }
}
