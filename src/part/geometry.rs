//! The geometry the tolerances need: the worst cut of a feature, least-squares and enclosing
//! circles of a hole's sections, the shift of a datum frame.

use nalgebra::{Vector2, Vector3};

use super::cuts::Cut;

/// The cutter position of the cut farthest from the middle of the zone the deviations span.
pub(super) fn worst(cuts: &[&Cut]) -> [f64; 3] {
    let (lo, hi) = cuts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c.deviation), hi.max(c.deviation))
        });
    let mid = (lo + hi) / 2.0;
    let c = cuts
        .iter()
        .max_by(|a, b| {
            (a.deviation - mid)
                .abs()
                .total_cmp(&(b.deviation - mid).abs())
        })
        .expect("cuts");
    c.cutter.into()
}

/// The centre of the least-squares circle through 2-D points (Kåsa's algebraic fit).
pub(super) fn circle_centre(points: &[Vector2<f64>]) -> Vector2<f64> {
    let mean = points.iter().sum::<Vector2<f64>>() / points.len() as f64;
    let (mut suu, mut suv, mut svv, mut suuu, mut svvv, mut suvv, mut svuu) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let (u, v) = (p.x - mean.x, p.y - mean.y);
        suu += u * u;
        suv += u * v;
        svv += v * v;
        suuu += u * u * u;
        svvv += v * v * v;
        suvv += u * v * v;
        svuu += v * u * u;
    }
    let m = nalgebra::Matrix2::new(suu, suv, suv, svv);
    let rhs = Vector2::new(suuu + suvv, svvv + svuu) / 2.0;
    mean + m.lu().solve(&rhs).unwrap_or_else(Vector2::zeros)
}

/// The diameter of the smallest circle holding 2-D points (every pair and triple; the derived
/// median line has few points). The points are first moved to their centroid, so that rounding
/// acts on their spread and not on where they sit.
pub(super) fn enclosing_diameter(points: &[Vector2<f64>]) -> f64 {
    let centroid = points.iter().sum::<Vector2<f64>>() / points.len().max(1) as f64;
    let points: Vec<Vector2<f64>> = points.iter().map(|p| p - centroid).collect();
    let spread = points.iter().map(|p| p.norm()).fold(0.0, f64::max);
    if spread == 0.0 {
        return 0.0;
    }
    let slack = 1e-9 * spread;
    let holds = |c: Vector2<f64>, r: f64| points.iter().all(|p| (p - c).norm() <= r + slack);
    let mut best = f64::INFINITY;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let c = (points[i] + points[j]) / 2.0;
            let r = (points[i] - c).norm();
            if 2.0 * r < best && holds(c, r) {
                best = 2.0 * r;
            }
            for k in j + 1..points.len() {
                let (a, b, p) = (points[i], points[j], points[k]);
                let d = 2.0 * (a.x * (b.y - p.y) + b.x * (p.y - a.y) + p.x * (a.y - b.y));
                // Collinear (to rounding): the pairs cover them.
                if d.abs() <= 1e-12 * spread * spread {
                    continue;
                }
                let ux = (a.norm_squared() * (b.y - p.y)
                    + b.norm_squared() * (p.y - a.y)
                    + p.norm_squared() * (a.y - b.y))
                    / d;
                let uy = (a.norm_squared() * (p.x - b.x)
                    + b.norm_squared() * (a.x - p.x)
                    + p.norm_squared() * (b.x - a.x))
                    / d;
                let c = Vector2::new(ux, uy);
                let r = (a - c).norm();
                if 2.0 * r < best && holds(c, r) {
                    best = 2.0 * r;
                }
            }
        }
    }
    best
}

/// How far the datum planes move the datum frame: the translation `s` that best gives each
/// datum plane its mean deviation along its normal (`n_i·s = m_i`, least squares; along
/// directions no datum constrains, `s` has no component).
pub(super) fn datum_shift(datums: impl Iterator<Item = (Vector3<f64>, f64)>) -> Vector3<f64> {
    let (a, b) = datums.fold(
        (nalgebra::Matrix3::zeros(), Vector3::zeros()),
        |(a, b), (n, m)| (a + n * n.transpose(), b + n * m),
    );
    a.pseudo_inverse(1e-9)
        .map_or(Vector3::zeros(), |inverse| inverse * b)
}

/// The derived median line of a hole: the centres of its sections, with their heights.
pub(super) fn median_line(levels: &[Vec<Cut>]) -> Vec<Vector3<f64>> {
    levels
        .iter()
        .map(|level| {
            let section: Vec<Vector2<f64>> = level.iter().map(|c| c.actual.xy()).collect();
            let centre = circle_centre(&section);
            Vector3::new(centre.x, centre.y, level[0].nominal.z)
        })
        .collect()
}
