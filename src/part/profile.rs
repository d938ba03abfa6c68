//! The profile of a meshed surface: the normal deviation sampled over the whole surface, each
//! sample standing for its share of the area, and at every vertex for the PLY.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::cuts::Evaluator;
use super::FeatureError;
use crate::io::mesh::Mesh;

/// What the profile of a meshed surface comes to.
pub(super) struct ProfileDeviation {
    /// The largest normal deviation from the nominal surface, mm.
    pub max_deviation: f64,
    pub worst: [f64; 3],
    /// The fraction of the area outside the zone `±tolerance/2`.
    pub area_outside: f64,
    /// The normal deviation at each vertex, mm.
    pub vertex_deviation: Vec<f32>,
}

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
    /// for its area), and at every vertex (with the area-weighted vertex normal) for the PLY.
    pub(super) fn profile(
        &self,
        name: &str,
        mesh: &Mesh,
        tolerance: f64,
    ) -> Result<ProfileDeviation, FeatureError> {
        let vertices: Vec<Vector3<f64>> = mesh
            .vertices
            .iter()
            .map(|v| self.part.commanded((*v).into()))
            .collect();
        let corners = |t: &[u32; 3]| t.map(|i| vertices[i as usize]);
        let total = mesh
            .triangles
            .par_iter()
            .map(|t| self.sample_triangle(name, corners(t), tolerance))
            .try_reduce(Partial::empty, |x, y| Ok(x.join(y)))?;
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
                self.errors(name, v)
                    .map(|(ve, _)| n.normalize().dot(&ve) as f32)
            })
            .collect::<Result<Vec<f32>, _>>()?;
        Ok(ProfileDeviation {
            max_deviation: total.max,
            worst: total.worst.into(),
            area_outside: total.outside / total.area,
            vertex_deviation,
        })
    }

    /// The normal deviation over one triangle `[a, b, c]` (commanded frame): its edges cut into
    /// `m` parts no longer than the sampling spacing, the centroid of each of the `m²`
    /// sub-triangles standing for its area.
    fn sample_triangle(
        &self,
        name: &str,
        [a, b, c]: [Vector3<f64>; 3],
        tolerance: f64,
    ) -> Result<Partial, FeatureError> {
        let twice_area = (b - a).cross(&(c - a));
        let n = twice_area.normalize();
        let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
        let m = ((longest / self.part.sampling.spacing_mm).ceil() as usize).max(1);
        let piece = twice_area.norm() / 2.0 / (m * m) as f64;
        let mut partial = Partial::empty();
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
                    let d = n.dot(&ve);
                    if d.abs() > partial.max {
                        partial.max = d.abs();
                        partial.worst = p;
                    }
                    if d.abs() > tolerance / 2.0 {
                        partial.outside += piece;
                    }
                    partial.area += piece;
                }
            }
        }
        Ok(partial)
    }
}
