//! Datum reference frames and best fits: the rigid motion that brings machined surfaces onto
//! their nominal ones, fitted surface by surface in order of precedence, each in the degrees of
//! freedom the earlier ones left free (ISO 5459, ASME Y14.5: the primary datum takes what it
//! can constrain, the secondary what it can of the rest, then the tertiary).
//!
//! Each surface is a set of samples: a nominal point `q` with its unit normal `n`, and the
//! machined point `p`. A rigid motion `T` leaves the sample the deviation `n·(T(p) − q)` from
//! the nominal surface; a surface's fit makes the (weighted) sum of their squares least, the
//! motion linearised as a small rotation `ω` about an origin `o` and a translation `t`
//! (`n·(T(p) − q) ≈ d + ((p − o) × n)·ω + n·t`). Gauss-Newton steps, each applying the exact
//! rotation of its `ω`, repeat until the motion stops changing, so the fit is exact, not first
//! order. The degrees of freedom a surface constrains are the eigenvectors of its normal
//! matrix within the free ones whose eigenvalues are not zero (to rounding); the rest stay free.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6,
};
use rayon::prelude::*;

/// A sample of a surface: its nominal point and unit normal, the machined point, its weight.
#[derive(Debug, Clone, Copy)]
pub(super) struct SurfacePoint {
    pub nominal: Vector3<f64>,
    pub normal: Vector3<f64>,
    pub actual: Vector3<f64>,
    pub weight: f64,
}

impl SurfacePoint {
    /// The deviation along the nominal normal of the machined point moved by `motion`.
    pub fn deviation(&self, motion: &Isometry3<f64>) -> f64 {
        self.normal
            .dot(&(motion.transform_point(&self.actual.into()).coords - self.nominal))
    }
}

/// A surface fitted in turn: its samples and whether it must constrain some degree of freedom
/// the surfaces before it left free (a datum must; a surface floated in what is left need not).
pub(super) struct Surface<'a> {
    pub points: &'a [SurfacePoint],
    pub must_constrain: bool,
}

/// The surface (its index) that constrains no degree of freedom the ones before it left free.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct ConstrainsNothing(pub usize);

/// The rigid motion of the machined points that best fits the surfaces onto their nominal
/// ones, in order of precedence (see the module's documentation).
pub(super) fn fit(surfaces: &[Surface]) -> Result<Isometry3<f64>, ConstrainsNothing> {
    let (origin, length) = centre_and_size(surfaces);
    let mut motion = Isometry3::identity();
    for _ in 0..20 {
        let step = fit_step(surfaces, &motion, &origin, length)?;
        let rotation = Vector3::new(step[0], step[1], step[2]) / length;
        let translation = Vector3::new(step[3], step[4], step[5]);
        // About the origin: p ↦ R(p − o) + o + t.
        let increment = Translation3::from(origin + translation)
            * UnitQuaternion::from_scaled_axis(rotation)
            * Translation3::from(-origin);
        motion = increment * motion;
        // Rounding leaves steps of about 1e-13 mm at coordinates of metres.
        if step.norm() < 1e-12 * length.max(1.0) {
            break;
        }
    }
    Ok(motion)
}

/// The samples' weighted centroid (in nominal position) and their RMS distance from it, which
/// scales rotations to lengths so that both weigh alike in the normal matrix.
fn centre_and_size(surfaces: &[Surface]) -> (Vector3<f64>, f64) {
    let all = || surfaces.iter().flat_map(|s| s.points.iter());
    let total: f64 = all().map(|p| p.weight).sum();
    let centre = all().map(|p| p.nominal * p.weight).sum::<Vector3<f64>>() / total;
    let spread = (all()
        .map(|p| p.weight * (p.nominal - centre).norm_squared())
        .sum::<f64>()
        / total)
        .sqrt();
    (centre, if spread > 0.0 { spread } else { 1.0 })
}

/// One Gauss-Newton step from `motion`: the twist `(L·ω, t)` that fits each surface in turn
/// within the degrees of freedom the earlier ones left free.
fn fit_step(
    surfaces: &[Surface],
    motion: &Isometry3<f64>,
    origin: &Vector3<f64>,
    length: f64,
) -> Result<Vector6<f64>, ConstrainsNothing> {
    let mut free = DMatrix::<f64>::identity(6, 6);
    let mut step = Vector6::zeros();
    for (index, surface) in surfaces.iter().enumerate() {
        if free.ncols() == 0 {
            if surface.must_constrain {
                return Err(ConstrainsNothing(index));
            }
            break;
        }
        let (normal_matrix, rhs) = normal_equations(surface.points, motion, origin, length);
        // What the step so far leaves of this surface's residuals.
        let rhs = rhs - normal_matrix * step;
        let restricted = free.transpose() * normal_matrix * &free;
        let eigen = restricted.symmetric_eigen();
        let largest = normal_matrix.diagonal().max().max(0.0);
        let threshold = 1e-9 * largest;
        let projected = free.transpose() * rhs;
        let mut within = DVector::zeros(free.ncols());
        let mut left = Vec::new();
        for (k, &value) in eigen.eigenvalues.iter().enumerate() {
            let v = eigen.eigenvectors.column(k);
            if value > threshold {
                within += v * (v.dot(&projected) / value);
            } else {
                left.push(v.into_owned());
            }
        }
        if surface.must_constrain && left.len() == free.ncols() {
            return Err(ConstrainsNothing(index));
        }
        step += Vector6::from_iterator((&free * within).iter().copied());
        free = if left.is_empty() {
            DMatrix::zeros(6, 0)
        } else {
            &free * DMatrix::from_columns(&left)
        };
    }
    Ok(step)
}

/// `JᵀWJ` and `−JᵀWd` of a surface's samples moved by `motion`, the Jacobian's row of a sample
/// `[((p − o) × n)/L, n]`.
fn normal_equations(
    points: &[SurfacePoint],
    motion: &Isometry3<f64>,
    origin: &Vector3<f64>,
    length: f64,
) -> (Matrix6<f64>, Vector6<f64>) {
    points
        .par_iter()
        .map(|s| {
            let moved = motion.transform_point(&s.actual.into()).coords;
            let lever = (moved - origin).cross(&s.normal) / length;
            let row = Vector6::new(
                lever.x, lever.y, lever.z, s.normal.x, s.normal.y, s.normal.z,
            );
            let deviation = s.normal.dot(&(moved - s.nominal));
            (
                row * row.transpose() * s.weight,
                -row * (deviation * s.weight),
            )
        })
        .reduce(
            || (Matrix6::zeros(), Vector6::zeros()),
            |(a, b), (c, d)| (a + c, b + d),
        )
}
