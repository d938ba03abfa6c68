//! The profile of a meshed surface: the normal deviation sampled over the whole surface, each
//! sample standing for its share of the area, and at every vertex for the PLY; judged where the
//! zone sits: nominally, in a datum reference frame, or after the best fit.

use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;

use super::cuts::Evaluator;
use super::datum_frame::{fit, Surface, SurfacePoint};
use super::file::ProfileEvaluation;
use super::FeatureError;
use crate::io::mesh::Mesh;

/// What the profile of a meshed surface comes to.
pub(super) struct ProfileDeviation {
    /// The largest normal deviation from the zone's middle surface, mm.
    pub max_deviation: f64,
    pub worst: [f64; 3],
    /// The fraction of the area outside the zone `±tolerance/2`.
    pub area_outside: f64,
    /// The normal deviation at each vertex, mm.
    pub vertex_deviation: Vec<f32>,
}

/// A profile's datums: each one's name and machined samples, primary first.
pub(super) type DatumSurfaces<'a> = [(&'a str, &'a [SurfacePoint])];

/// What a part of the surface comes to: its largest normal deviation and where, its area
/// outside the zone, its area.
struct Partial {
    max: f64,
    worst: Vector3<f64>,
    outside: f64,
    area: f64,
}

impl Partial {
    fn empty() -> Partial {
        Partial {
            max: 0.0,
            worst: Vector3::zeros(),
            outside: 0.0,
            area: 0.0,
        }
    }

    fn join(self, other: Partial) -> Partial {
        let (max, worst) = if other.max > self.max {
            (other.max, other.worst)
        } else {
            (self.max, self.worst)
        };
        Partial {
            max,
            worst,
            outside: self.outside + other.outside,
            area: self.area + other.area,
        }
    }
}

impl Evaluator<'_> {
    /// The profile of a meshed surface: the normal deviation `n·VE` sampled at the centroids of
    /// every triangle cut into sub-triangles no longer than the sampling spacing (each standing
    /// for its area), and at every vertex (with the area-weighted vertex normal) for the PLY;
    /// the machined surface first moved as `evaluation` says (see [`super::datum_frame`]).
    pub(super) fn profile(
        &self,
        name: &str,
        mesh: &Mesh,
        tolerance: f64,
        evaluation: ProfileEvaluation,
        datums: &DatumSurfaces,
    ) -> Result<ProfileDeviation, FeatureError> {
        super::counts::mesh_points(mesh, self.part.sampling.spacing_mm)
            .map_err(|message| self.feature_error(name, message))?;
        let vertices: Vec<Vector3<f64>> = mesh
            .vertices
            .iter()
            .map(|v| self.part.commanded((*v).into()))
            .collect();
        let corners = |t: &[u32; 3]| t.map(|i| vertices[i as usize]);
        let samples: Vec<SurfacePoint> = mesh
            .triangles
            .par_iter()
            .map(|t| self.sample_triangle(name, corners(t)))
            .collect::<Result<Vec<_>, _>>()?
            .concat();
        let motion = self.profile_motion(name, &samples, evaluation, datums)?;
        let total = samples
            .par_iter()
            .map(|s| {
                let d = s.deviation(&motion).abs();
                Partial {
                    max: d,
                    worst: s.nominal,
                    outside: if d > tolerance / 2.0 { s.weight } else { 0.0 },
                    area: s.weight,
                }
            })
            .reduce(Partial::empty, Partial::join);
        let mut vertex_normals = vec![Vector3::zeros(); vertices.len()];
        for t in &mesh.triangles {
            let [a, b, c] = corners(t);
            let twice_area = (b - a).cross(&(c - a));
            for &i in t {
                vertex_normals[i as usize] += twice_area;
            }
        }
        let vertex_deviation = vertices
            .par_iter()
            .zip(&vertex_normals)
            .map(|(v, n)| {
                let normal = n.normalize();
                self.errors(name, v).map(|(ve, _)| {
                    machined(*v, normal, normal.dot(&ve), 0.0).deviation(&motion) as f32
                })
            })
            .collect::<Result<Vec<f32>, _>>()?;
        Ok(ProfileDeviation {
            max_deviation: total.max,
            worst: total.worst.into(),
            area_outside: total.outside / total.area,
            vertex_deviation,
        })
    }

    /// How the machined surface is moved before it is judged: not at all (nominal), by the
    /// datum reference frame with the surface floated in what the datums leave free, or by the
    /// surface's own best fit.
    fn profile_motion(
        &self,
        name: &str,
        samples: &[SurfacePoint],
        evaluation: ProfileEvaluation,
        datums: &DatumSurfaces,
    ) -> Result<Isometry3<f64>, FeatureError> {
        let mut surfaces: Vec<Surface> = match evaluation {
            ProfileEvaluation::Nominal => return Ok(Isometry3::identity()),
            ProfileEvaluation::BestFit => Vec::new(),
            ProfileEvaluation::Datums => datums
                .iter()
                .map(|(_, points)| Surface {
                    points,
                    must_constrain: true,
                })
                .collect(),
        };
        surfaces.push(Surface {
            points: samples,
            must_constrain: false,
        });
        fit(&surfaces).map_err(|e| {
            let names: Vec<&str> = datums.iter().map(|(n, _)| *n).collect();
            let (datum, before) = (names[e.0], &names[..e.0]);
            self.feature_error(
                name,
                if before.is_empty() {
                    format!("datums: `{datum}` constrains no degree of freedom")
                } else {
                    format!(
                        "datums: `{datum}` constrains no degree of freedom that {} leave(s) free: name a datum that is not parallel to (or coaxial with) them",
                        before.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
                    )
                },
            )
        })
    }

    /// The samples of one triangle `[a, b, c]` (commanded frame): its edges cut into `m` parts
    /// no longer than the sampling spacing, the centroid of each of the `m²` sub-triangles
    /// standing for its area, moved by the normal deviation `n·VE`.
    fn sample_triangle(
        &self,
        name: &str,
        [a, b, c]: [Vector3<f64>; 3],
    ) -> Result<Vec<SurfacePoint>, FeatureError> {
        let twice_area = (b - a).cross(&(c - a));
        let n = twice_area.normalize();
        let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
        let m = super::counts::triangle_cuts(longest, self.part.sampling.spacing_mm) as usize;
        let piece = twice_area.norm() / 2.0 / (m * m) as f64;
        let mut samples = Vec::with_capacity(m * m);
        let at = |i: f64, j: f64| a + (b - a) * (i / m as f64) + (c - a) * (j / m as f64);
        for i in 0..m {
            for j in 0..m - i {
                let (fi, fj) = (i as f64, j as f64);
                let mut centroids = vec![(at(fi, fj) + at(fi + 1.0, fj) + at(fi, fj + 1.0)) / 3.0];
                if i + j + 1 < m {
                    centroids
                        .push((at(fi + 1.0, fj) + at(fi, fj + 1.0) + at(fi + 1.0, fj + 1.0)) / 3.0);
                }
                for p in centroids {
                    let (ve, _) = self.errors(name, &p)?;
                    samples.push(machined(p, n, n.dot(&ve), piece));
                }
            }
        }
        Ok(samples)
    }
}

/// A point of the surface moved along its normal by its deviation.
fn machined(
    nominal: Vector3<f64>,
    normal: Vector3<f64>,
    deviation: f64,
    weight: f64,
) -> SurfacePoint {
    SurfacePoint {
        nominal,
        normal,
        actual: nominal + normal * deviation,
        weight,
    }
}
