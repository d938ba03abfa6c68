//! Every feature of a part evaluated against its tolerance: the cuts of each feature, the GD&T
//! error they leave, and the rating. Holes come first (the datums of parallel holes), positions
//! and profiles last (after their datum planes and holes); the rows come back in the order of
//! the file.

use std::collections::HashMap;

use nalgebra::{Vector2, Vector3};

use std::sync::Mutex;

use super::cuts::{Cut, CutterPositions, Errors, Evaluator};
use super::datum_frame::SurfacePoint;
use super::file::{FeatureSpec, PartFile, ProfileEvaluation};
use super::geometry::{datum_shift, enclosing_diameter, median_line, worst};
use super::profile::DatumSurfaces;
use super::uncertainty::{expanded_uncertainties, Conformance};
use super::{zone, ErrorSource, Evaluation, FeatureError, FeatureResult, Verdict};
use crate::io::mesh::Mesh;
use crate::limits::number_words;
use crate::model::channels::Sample;
use crate::model::{AxisLetter, Command, Machine};
use crate::reference::Twin;

/// What the features evaluated so far leave for the datums of later ones.
#[derive(Default)]
struct Datums {
    /// Each hole's derived median line.
    medians: HashMap<String, Vec<Vector3<f64>>>,
    /// Each plane's outward normal and mean deviation along it: where it moves a datum frame.
    planes: HashMap<String, (Vector3<f64>, f64)>,
    /// Each plane's and hole's machined samples: what establishes a profile's datum frame.
    surfaces: HashMap<String, Vec<SurfacePoint>>,
}

impl Datums {
    fn keep_surface(&mut self, name: &str, cuts: &[&Cut]) {
        let points = cuts
            .iter()
            .map(|c| SurfacePoint {
                nominal: c.nominal,
                normal: c.normal,
                actual: c.actual,
                weight: 1.0,
            })
            .collect();
        self.surfaces.insert(name.to_string(), points);
    }
}

/// What a feature's error is judged against, and its datums.
fn judged_against(feature: &FeatureSpec) -> (Evaluation, Vec<String>) {
    match feature {
        FeatureSpec::EndMilledPlane { .. }
        | FeatureSpec::FlankMilledPlane { .. }
        | FeatureSpec::Hole { .. } => (Evaluation::MinimumZone, Vec::new()),
        FeatureSpec::RibHeight { .. } => (Evaluation::Nominal, Vec::new()),
        FeatureSpec::ParallelHole { datum, .. } => (Evaluation::Datums, vec![datum.clone()]),
        FeatureSpec::HolePosition { datums, .. } | FeatureSpec::RibPosition { datums, .. } => {
            (Evaluation::Datums, datums.clone())
        }
        FeatureSpec::Profile { datums, .. } => match feature.profile_evaluation() {
            Some(ProfileEvaluation::Datums) => (Evaluation::Datums, datums.clone()),
            Some(ProfileEvaluation::BestFit) => (Evaluation::BestFit, Vec::new()),
            _ => (Evaluation::Nominal, Vec::new()),
        },
    }
}

/// A feature's error (mm), the commanded position of the cutter where its worst point was cut,
/// and, for profiles, the fraction of the area outside the zone.
type Evaluated = (f64, [f64; 3], Option<f64>);

/// Evaluates every feature of the part.
pub fn evaluate(
    part: &PartFile,
    source: ErrorSource,
    file: &str,
) -> Result<Vec<FeatureResult>, FeatureError> {
    let pose = part.pose();
    if let ErrorSource::Field(field) = &source {
        if let Some((n, value, held)) = field.pose_mismatch(&pose, [true; 3]) {
            let axis = ['A', 'B', 'C'][n];
            return Err(FeatureError::Feature {
                file: file.to_string(),
                feature: "(placement)".into(),
                message: format!(
                    "the part is machined at {axis}={value}°, the field holds {axis}={held}°"
                ),
            });
        }
    }
    if let ErrorSource::Exact(machine) = &source {
        check_pose_on(machine, &pose, file)?;
    }
    let (errors, machine) = match source {
        ErrorSource::Exact(machine) => (Errors::Exact(Box::new(Twin::of(machine))), Some(machine)),
        ErrorSource::Field(field) => (Errors::Field(field), None),
    };
    let mut rows = evaluate_with(part, errors, file)?;
    // A field holds no uncertainties: its values are taken as exact (U = 0).
    if let Some(machine) = machine.filter(|m| !m.uncertainty.is_empty()) {
        let expanded = expanded_uncertainties(part, machine, file)?;
        for (row, u) in rows.iter_mut().zip(expanded) {
            row.u_expanded_mm = u;
            row.conformance = Conformance::of(row.error_mm, u, row.tolerance_mm);
        }
    }
    Ok(rows)
}

/// Checks the part's pose (`placement.pose_deg`) against the machine: an axis it lacks, or a
/// position outside the axis's travel, is an error naming the placement.
fn check_pose_on(machine: &Machine, pose: &Command, file: &str) -> Result<(), FeatureError> {
    for letter in [AxisLetter::A, AxisLetter::B, AxisLetter::C] {
        let degrees = pose[letter.index()];
        let message = match machine.axis(letter) {
            None if degrees != 0.0 => format!(
                "pose_deg: {letter}={degrees}°, but the machine (chain {}) has no {letter} axis",
                machine.chain.hwang_notation()
            ),
            Some(axis) if !(axis.range[0]..=axis.range[1]).contains(&degrees) => format!(
                "pose_deg: {letter}={degrees}° lies outside the travel of {letter} ({} to {})",
                axis.range[0], axis.range[1]
            ),
            _ => continue,
        };
        return Err(FeatureError::Feature {
            file: file.to_string(),
            feature: "(placement)".into(),
            message,
        });
    }
    Ok(())
}

/// Every cutter position the evaluation of `part` asks the machine's error at.
pub fn cutter_positions(part: &PartFile, file: &str) -> Result<CutterPositions, FeatureError> {
    let positions = Mutex::new(CutterPositions::default());
    evaluate_with(part, Errors::Record(&positions), file)?;
    Ok(positions.into_inner().unwrap_or_else(|e| e.into_inner()))
}

/// Evaluates every feature of the part from the machine's VE and OE (in
/// [`crate::model::channels::SAMPLE_COLUMNS`] order) at each of `positions`, found beforehand.
pub fn evaluate_at(
    part: &PartFile,
    file: &str,
    positions: &CutterPositions,
    values: &[Sample],
) -> Result<Vec<FeatureResult>, FeatureError> {
    evaluate_with(part, Errors::Replay(positions, values), file)
}

fn evaluate_with(
    part: &PartFile,
    errors: Errors,
    file: &str,
) -> Result<Vec<FeatureResult>, FeatureError> {
    let pose = part.pose();
    let evaluator = Evaluator {
        part,
        pose,
        errors,
        file,
    };
    let mut order: Vec<&FeatureSpec> = part.features.iter().collect();
    order.sort_by_key(|f| match f {
        FeatureSpec::Hole { .. } => 0,
        FeatureSpec::HolePosition { .. }
        | FeatureSpec::RibPosition { .. }
        | FeatureSpec::Profile { .. } => 2,
        _ => 1,
    });
    let mut datums = Datums::default();
    let mut results = Vec::new();
    for feature in order {
        let (error_mm, worst_point, area_outside) = evaluator.feature(feature, &mut datums)?;
        if !error_mm.is_finite() || !area_outside.unwrap_or(0.0).is_finite() {
            return Err(evaluator.feature_error(
                feature.name(),
                format!(
                    "its error is not a finite number: the machine's error at its cutter positions (the worst at X={} Y={} Z={} mm) is beyond any number; check [placement] zero_mm and the feature's position against the machine's travel",
                    number_words(worst_point[0]),
                    number_words(worst_point[1]),
                    number_words(worst_point[2])
                ),
            ));
        }
        let tolerance_mm = feature.tolerance();
        let safety = (error_mm > 0.0).then(|| tolerance_mm / error_mm);
        let (evaluation, datum_names) = judged_against(feature);
        results.push(FeatureResult {
            name: feature.name().to_string(),
            kind: feature.kind().to_string(),
            error_mm,
            tolerance_mm,
            safety,
            verdict: safety.map_or(Verdict::Fit, Verdict::of),
            u_expanded_mm: 0.0,
            conformance: Conformance::of(error_mm, 0.0, tolerance_mm),
            worst_point,
            area_outside,
            evaluation,
            datums: datum_names,
        });
    }
    results.sort_by_key(|r| part.features.iter().position(|f| f.name() == r.name));
    Ok(results)
}

/// The mean deviation of a surface's cuts along its normal.
fn mean_deviation(cuts: &[Cut]) -> f64 {
    cuts.iter().map(|c| c.deviation).sum::<f64>() / cuts.len() as f64
}

impl Evaluator<'_> {
    fn feature(
        &self,
        feature: &FeatureSpec,
        datums: &mut Datums,
    ) -> Result<Evaluated, FeatureError> {
        let name = feature.name();
        Ok(match feature {
            FeatureSpec::Profile {
                mesh,
                tolerance_mm,
                ply,
                datums: names,
                ..
            } => {
                let surfaces: Vec<(&str, &[SurfacePoint])> = names
                    .iter()
                    .map(|d| (d.as_str(), datums.surfaces[d].as_slice()))
                    .collect();
                let evaluation = feature.profile_evaluation().expect("a profile");
                let judged = (evaluation, surfaces.as_slice());
                self.profile_error(name, mesh, *tolerance_mm, ply.as_deref(), judged)?
            }
            FeatureSpec::HolePosition {
                centre_mm,
                diameter_mm,
                depth_mm,
                datums: planes,
                ..
            } => {
                let shift = datum_shift(planes.iter().map(|d| datums.planes[d]));
                self.hole_position(name, *centre_mm, *diameter_mm, *depth_mm, shift)?
            }
            FeatureSpec::RibPosition { datums: planes, .. } => {
                let shift = datum_shift(planes.iter().map(|d| datums.planes[d]));
                let (normal, cuts) = self.wall_cuts(name, &feature.wall().expect("a wall"))?;
                rib_position(&cuts, normal.dot(&shift))
            }
            FeatureSpec::EndMilledPlane {
                corner_mm, size_mm, ..
            } => {
                let cuts = self.floor_cuts(name, *corner_mm, *size_mm)?;
                datums
                    .planes
                    .insert(name.to_string(), (Vector3::z(), mean_deviation(&cuts)));
                datums.keep_surface(name, &cuts.iter().collect::<Vec<_>>());
                self.flatness(name, &cuts, &Vector3::z())?
            }
            FeatureSpec::RibHeight {
                corner_mm, size_mm, ..
            } => {
                let cuts = self.floor_cuts(name, *corner_mm, *size_mm)?;
                let c = cuts
                    .iter()
                    .max_by(|a, b| a.deviation.abs().total_cmp(&b.deviation.abs()))
                    .expect("cuts");
                (c.deviation.abs(), c.cutter.into(), None)
            }
            FeatureSpec::FlankMilledPlane { .. } => {
                let (normal, cuts) = self.wall_cuts(name, &feature.wall().expect("a wall"))?;
                datums
                    .planes
                    .insert(name.to_string(), (normal, mean_deviation(&cuts)));
                datums.keep_surface(name, &cuts.iter().collect::<Vec<_>>());
                self.flatness(name, &cuts, &normal)?
            }
            FeatureSpec::Hole {
                centre_mm,
                diameter_mm,
                depth_mm,
                ..
            }
            | FeatureSpec::ParallelHole {
                centre_mm,
                diameter_mm,
                depth_mm,
                ..
            } => {
                let datum = match feature {
                    FeatureSpec::ParallelHole { datum, .. } => Some(datum.as_str()),
                    _ => None,
                };
                self.hole(name, *centre_mm, *diameter_mm, *depth_mm, datum, datums)?
            }
        })
    }

    /// A hole's cylindricity, or with a datum hole its parallelism to it; its median line is kept
    /// for the holes that take it as their datum.
    fn hole(
        &self,
        name: &str,
        centre: [f64; 3],
        diameter: f64,
        depth: f64,
        parallel_to: Option<&str>,
        datums: &mut Datums,
    ) -> Result<Evaluated, FeatureError> {
        let levels = self.hole_cuts(name, centre, diameter, depth)?;
        let cuts: Vec<&Cut> = levels.iter().flatten().collect();
        let axis = median_line(&levels);
        datums.medians.insert(name.to_string(), axis.clone());
        datums.keep_surface(name, &cuts);
        let error = match parallel_to {
            Some(datum) => {
                let datum_axis = datums.medians.get(datum).expect("holes come first");
                parallelism(&axis, datum_axis)
            }
            None => {
                let points: Vec<_> = cuts.iter().map(|c| c.actual).collect();
                let top = self.part.commanded(centre);
                zone::cylindricity_min_zone(&points, &top, &Vector3::z())
                    .map_err(self.tolerance_error(name))?
                    .width_mm
            }
        };
        Ok((error, worst(&cuts), None))
    }

    /// The position of a hole whose true position the datums shift by `shift`: the diameter of
    /// the cylinder about the true position that holds its derived median line.
    fn hole_position(
        &self,
        name: &str,
        centre: [f64; 3],
        diameter: f64,
        depth: f64,
        shift: Vector3<f64>,
    ) -> Result<Evaluated, FeatureError> {
        let levels = self.hole_cuts(name, centre, diameter, depth)?;
        let true_position = self.part.commanded(centre) + shift;
        let (distance, at) = median_line(&levels)
            .into_iter()
            .map(|c| ((c - true_position).xy().norm(), c))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .expect("levels");
        Ok((2.0 * distance, at.into(), None))
    }

    /// The flatness of a surface's cuts about the surface's normal, by the minimum zone.
    fn flatness(
        &self,
        name: &str,
        cuts: &[Cut],
        normal: &Vector3<f64>,
    ) -> Result<Evaluated, FeatureError> {
        let points: Vec<_> = cuts.iter().map(|c| c.actual).collect();
        let zone = zone::flatness_min_zone(&points, normal).map_err(self.tolerance_error(name))?;
        Ok((zone.width_mm, worst(&cuts.iter().collect::<Vec<_>>()), None))
    }

    /// A meshed surface's profile error, with the PLY of its vertices' deviations where asked.
    fn profile_error(
        &self,
        name: &str,
        mesh: &str,
        tolerance_mm: f64,
        ply: Option<&str>,
        (evaluation, datums): (ProfileEvaluation, &DatumSurfaces),
    ) -> Result<Evaluated, FeatureError> {
        let mesh_error = |source| FeatureError::Mesh {
            file: self.file.to_string(),
            feature: name.to_string(),
            source,
        };
        let mesh = Mesh::read_stl(&self.part.base.join(mesh)).map_err(mesh_error)?;
        let profile = self.profile(name, &mesh, tolerance_mm, evaluation, datums)?;
        // A part evaluated on many machines (recorded, replayed) writes no per-machine file.
        let one_machine = matches!(self.errors, Errors::Exact(_) | Errors::Field(_));
        if let (Some(ply), true) = (ply, one_machine) {
            let path = self.part.base.join(ply);
            // ParaView opens the VTK file; MeshLab and the rest the PLY.
            let vtk = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("vtp"));
            let write = if vtk {
                Mesh::write_vtp
            } else {
                Mesh::write_ply
            };
            write(&mesh, &path, "deviation_mm", &profile.vertex_deviation).map_err(mesh_error)?;
        }
        Ok((
            2.0 * profile.max_deviation,
            profile.worst,
            Some(profile.area_outside),
        ))
    }
}

/// The position of a rib's side whose true position the datums move by `moved` along its
/// normal: the width of the zone about the true position that holds it.
fn rib_position(cuts: &[Cut], moved: f64) -> Evaluated {
    let c = cuts
        .iter()
        .max_by(|a, b| {
            (a.deviation - moved)
                .abs()
                .total_cmp(&(b.deviation - moved).abs())
        })
        .expect("cuts");
    (2.0 * (c.deviation - moved).abs(), c.cutter.into(), None)
}

/// The parallelism of a hole to a datum hole: the diameter of the smallest cylinder parallel to
/// the datum's axis that holds the hole's derived median line.
fn parallelism(axis: &[Vector3<f64>], datum_axis: &[Vector3<f64>]) -> f64 {
    let direction = (datum_axis[datum_axis.len() - 1] - datum_axis[0]).normalize();
    let (e1, e2) = zone::frame(&direction);
    let projected: Vec<Vector2<f64>> = axis
        .iter()
        .map(|p| Vector2::new(e1.dot(p), e2.dot(p)))
        .collect();
    enclosing_diameter(&projected)
}
