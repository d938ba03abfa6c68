//! What a part file asks of the evaluation, checked as it is read and before any cut: every
//! coordinate and angle a finite number, and the machined points each feature is sampled at
//! (from its sizes and the sampling spacing, the way [`super::cuts`] samples it) within
//! [`MAX_FEATURE_POINTS`], all features together within [`MAX_PART_POINTS`]. A meshed surface's
//! points are counted when its mesh is read ([`mesh_points`]).

use super::file::{FeatureSpec, PartFile};
use super::FeatureError;
use crate::io::mesh::Mesh;
use crate::limits::{self, number_words, sampled_points, MAX_FEATURE_POINTS, MAX_PART_POINTS};

/// The angles a hole's wall is cut at: its circumference in steps of at most `spacing`, at
/// least 24.
pub(super) fn hole_angles(diameter: f64, spacing: f64) -> f64 {
    (std::f64::consts::PI * diameter / spacing).ceil().max(24.0)
}

/// The samples of one triangle whose longest edge is `longest` (mm): its edges cut into `m`
/// parts no longer than `spacing`, `m²` sub-triangles.
pub(super) fn triangle_cuts(longest: f64, spacing: f64) -> f64 {
    (longest / spacing).ceil().max(1.0)
}

/// The machined points of a meshed surface sampled at `spacing`: `m²` per triangle, one per
/// vertex; refused beyond [`MAX_FEATURE_POINTS`] before any is sampled.
pub(super) fn mesh_points(mesh: &Mesh, spacing: f64) -> Result<u64, String> {
    let mut count = mesh.vertices.len() as f64;
    let mut longest_edge = 0.0f64;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
        longest_edge = longest_edge.max(longest);
        count += triangle_cuts(longest, spacing).powi(2);
        if count > MAX_FEATURE_POINTS as f64 {
            break;
        }
    }
    limits::within(count, MAX_FEATURE_POINTS).map_err(|e| {
        format!(
            "the mesh sampled at spacing_mm = {} (each triangle cut into parts no longer than it; its longest edge {} mm) gives {} machined points, more than the limit of {} per feature: is the mesh in mm? else raise [sampling] spacing_mm",
            number_words(spacing),
            number_words(longest_edge),
            limits::count_words(e.count),
            e.limit
        )
    })
}

impl PartFile {
    /// Every coordinate finite, and the points each feature is sampled at within the limits.
    pub(super) fn check_counts(&self, file: &str) -> Result<(), FeatureError> {
        let error = |feature: &str, message: String| FeatureError::Feature {
            file: file.to_string(),
            feature: feature.to_string(),
            message,
        };
        let placement = &self.placement;
        finite(&placement.zero_mm, "zero_mm", "mm").map_err(|m| error("(placement)", m))?;
        finite(&[placement.rotation_deg], "rotation_deg", "degrees")
            .map_err(|m| error("(placement)", m))?;
        let spacing = number_words(self.sampling.spacing_mm);
        let points = |length: f64| sampled_points(length, self.sampling.spacing_mm);
        let mut total = 0.0;
        for f in &self.features {
            let name = f.name();
            coordinates(f).map_err(|m| error(name, m))?;
            let (count, keys) = match *f {
                FeatureSpec::EndMilledPlane { size_mm, .. }
                | FeatureSpec::RibHeight { size_mm, .. } => {
                    (points(size_mm[0]) * points(size_mm[1]), "size_mm")
                }
                FeatureSpec::FlankMilledPlane {
                    length_mm,
                    depth_mm,
                    ..
                }
                | FeatureSpec::RibPosition {
                    length_mm,
                    depth_mm,
                    ..
                } => (
                    points(length_mm) * points(depth_mm),
                    "length_mm and depth_mm",
                ),
                FeatureSpec::Hole {
                    diameter_mm,
                    depth_mm,
                    ..
                }
                | FeatureSpec::ParallelHole {
                    diameter_mm,
                    depth_mm,
                    ..
                }
                | FeatureSpec::HolePosition {
                    diameter_mm,
                    depth_mm,
                    ..
                } => (
                    hole_angles(diameter_mm, self.sampling.spacing_mm) * points(depth_mm),
                    "diameter_mm and depth_mm",
                ),
                FeatureSpec::Profile { .. } => continue,
            };
            limits::within(count, MAX_FEATURE_POINTS).map_err(|e| {
                error(
                    name,
                    format!(
                        "{keys} sampled every {spacing} mm ([sampling] spacing_mm) give {} machined points, more than the limit of {} per feature: check the sizes, or raise spacing_mm",
                        limits::count_words(e.count),
                        e.limit
                    ),
                )
            })?;
            total += count;
        }
        limits::within(total, MAX_PART_POINTS).map_err(|e| {
            error(
                "(sampling)",
                format!(
                    "the features sampled every {spacing} mm (spacing_mm) give {} machined points together, more than the limit of {} per part: raise spacing_mm",
                    limits::count_words(e.count),
                    e.limit
                ),
            )
        })?;
        Ok(())
    }
}

/// `values` of `key` all finite.
fn finite(values: &[f64], key: &str, unit: &str) -> Result<(), String> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(n) => {
            let key = if values.len() > 1 {
                format!("{key}[{n}]")
            } else {
                key.to_string()
            };
            Err(format!(
                "{key} must be a finite number of {unit}, found {}",
                number_words(values[n])
            ))
        }
    }
}

/// A feature's positions and directions all finite.
fn coordinates(f: &FeatureSpec) -> Result<(), String> {
    match f {
        FeatureSpec::EndMilledPlane { corner_mm, .. }
        | FeatureSpec::RibHeight { corner_mm, .. } => finite(corner_mm, "corner_mm", "mm"),
        FeatureSpec::FlankMilledPlane {
            start_mm,
            direction_deg,
            ..
        }
        | FeatureSpec::RibPosition {
            start_mm,
            direction_deg,
            ..
        } => {
            finite(start_mm, "start_mm", "mm")?;
            finite(&[*direction_deg], "direction_deg", "degrees")
        }
        FeatureSpec::Hole { centre_mm, .. }
        | FeatureSpec::ParallelHole { centre_mm, .. }
        | FeatureSpec::HolePosition { centre_mm, .. } => finite(centre_mm, "centre_mm", "mm"),
        FeatureSpec::Profile { .. } => Ok(()),
    }
}
