//! Where the cutter goes for each kind of feature and what it leaves: the machine's error at
//! every cutter position, turned into the machined surface's deviation along its normal (see the
//! module's documentation for the formulas).

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::sync::Mutex;

use nalgebra::Vector3;

use super::file::{PartFile, Wall};
use super::zone::ZoneError;
use super::FeatureError;
use crate::io::field::LoadedField;
use crate::model::channels::Sample;
use crate::model::Command;
use crate::reference::Twin;

/// A machined point: where it should be and where it is (commanded frame), its deviation along
/// the surface's outward normal, and the cutter position that cut it.
pub(super) struct Cut {
    pub nominal: Vector3<f64>,
    pub normal: Vector3<f64>,
    pub actual: Vector3<f64>,
    pub deviation: f64,
    pub cutter: Vector3<f64>,
}

impl Cut {
    /// A point moved along the surface normal `n` by `deviation`.
    pub fn along(
        nominal: Vector3<f64>,
        n: Vector3<f64>,
        deviation: f64,
        cutter: Vector3<f64>,
    ) -> Cut {
        Cut {
            nominal,
            normal: n,
            actual: nominal + deviation * n,
            deviation,
            cutter,
        }
    }
}

/// `n` evenly spaced values from `lo` to `hi` with at most `spacing` between them (at least 2).
pub(super) fn steps(lo: f64, hi: f64, spacing: f64) -> Vec<f64> {
    let n = (((hi - lo) / spacing).ceil() as usize).max(1) + 1;
    (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
        .collect()
}

pub(super) struct Evaluator<'a> {
    pub part: &'a PartFile,
    /// The part's rotary pose, as a command with X Y Z to fill in.
    pub pose: Command,
    pub errors: Errors<'a>,
    pub file: &'a str,
}

/// Where the evaluator takes the machine's error from: the machine with its ideal twin, or a
/// field; or, to evaluate a part on many machines, nowhere (the positions asked for are
/// recorded) and then values found beforehand at those positions.
pub(super) enum Errors<'a> {
    Exact(Box<Twin>),
    Field(&'a LoadedField),
    Record(&'a Mutex<CutterPositions>),
    Replay(&'a CutterPositions, &'a [Sample]),
}

/// Every cutter position (commanded X Y Z, mm) a part's evaluation asks the machine's error at,
/// each once. The positions depend on the part alone, never on the machine's error.
#[derive(Debug, Clone, Default)]
pub struct CutterPositions {
    index: HashMap<[u64; 3], usize>,
    pub positions: Vec<[f64; 3]>,
}

impl CutterPositions {
    fn key(tip: &Vector3<f64>) -> [u64; 3] {
        [tip.x.to_bits(), tip.y.to_bits(), tip.z.to_bits()]
    }

    fn record(&mut self, tip: &Vector3<f64>) {
        if let Entry::Vacant(entry) = self.index.entry(Self::key(tip)) {
            entry.insert(self.positions.len());
            self.positions.push([tip.x, tip.y, tip.z]);
        }
    }

    fn find(&self, tip: &Vector3<f64>) -> Option<usize> {
        self.index.get(&Self::key(tip)).copied()
    }

    /// Each position as a command at `pose` (its rotary axes; X Y Z the position's).
    pub fn commands_at(&self, pose: Command) -> Vec<Command> {
        self.positions
            .iter()
            .map(|t| {
                let mut c = pose;
                c[..3].copy_from_slice(t);
                c
            })
            .collect()
    }
}

impl Evaluator<'_> {
    /// VE and ω at the cutter tip position `tip` (commanded frame).
    pub(super) fn errors(
        &self,
        feature: &str,
        tip: &Vector3<f64>,
    ) -> Result<(Vector3<f64>, Vector3<f64>), FeatureError> {
        let mut command = self.pose;
        command[0] = tip.x;
        command[1] = tip.y;
        command[2] = tip.z;
        match &self.errors {
            Errors::Exact(twin) => {
                // As with a field, the machine's error is not asked where it cannot go.
                let beyond = twin.real().axes.iter().find(|a| {
                    let i = a.letter.index();
                    i < 3 && !(a.range[0]..=a.range[1]).contains(&command[i])
                });
                if let Some(axis) = beyond {
                    return Err(FeatureError::Feature {
                        file: self.file.to_string(),
                        feature: feature.to_string(),
                        message: format!(
                            "the cutter position {}={} mm lies outside the travel of {} ({} to {}); check [placement] zero_mm and rotation_deg and the feature's position",
                            axis.letter,
                            crate::limits::number_words(
                                (command[axis.letter.index()] * 1e3).round() / 1e3
                            ),
                            axis.letter,
                            axis.range[0],
                            axis.range[1]
                        ),
                    });
                }
                let d = twin.deviation(&command);
                Ok((d.volumetric_mm, d.orientation_rad))
            }
            Errors::Record(positions) => {
                positions
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .record(tip);
                Ok((Vector3::zeros(), Vector3::zeros()))
            }
            Errors::Replay(positions, values) => {
                let s = positions
                    .find(tip)
                    .and_then(|i| values.get(i))
                    .ok_or_else(|| FeatureError::Feature {
                        file: self.file.to_string(),
                        feature: feature.to_string(),
                        message: format!(
                            "the cutter position ({:.6}, {:.6}, {:.6}) was not among the recorded ones",
                            tip.x, tip.y, tip.z
                        ),
                    })?;
                Ok((
                    Vector3::new(s[0], s[1], s[2]),
                    Vector3::new(s[3], s[4], s[5]),
                ))
            }
            Errors::Field(field) => {
                let s = field.sample(&command).map_err(|(d, lo, hi)| FeatureError::Feature {
                    file: self.file.to_string(),
                    feature: feature.to_string(),
                    message: format!(
                        "the cutter position {}={:.3} mm lies outside the mapped grid ({lo} to {hi}): map a larger grid, or take the errors from the machine model",
                        ['X', 'Y', 'Z'][d],
                        tip[d]
                    ),
                })?;
                Ok((
                    Vector3::new(s[0], s[1], s[2]),
                    Vector3::new(s[3], s[4], s[5]),
                ))
            }
        }
    }

    pub(super) fn floor_cuts(
        &self,
        name: &str,
        corner: [f64; 3],
        size: [f64; 2],
    ) -> Result<Vec<Cut>, FeatureError> {
        let spacing = self.part.sampling.spacing_mm;
        let a = Vector3::z();
        let radius = self.part.cutter.radius_mm;
        let mut cuts = Vec::new();
        for u in steps(0.0, size[0], spacing) {
            for v in steps(0.0, size[1], spacing) {
                let tip = self
                    .part
                    .commanded([corner[0] + u, corner[1] + v, corner[2]]);
                let (ve, omega) = self.errors(name, &tip)?;
                let tilt = omega - a * omega.dot(&a);
                cuts.push(Cut::along(tip, a, a.dot(&ve) - radius * tilt.norm(), tip));
            }
        }
        Ok(cuts)
    }

    /// The cuts of a wall, and its outward normal.
    pub(super) fn wall_cuts(
        &self,
        name: &str,
        wall: &Wall,
    ) -> Result<(Vector3<f64>, Vec<Cut>), FeatureError> {
        let Wall {
            start_mm: start,
            direction_deg,
            length_mm: length,
            depth_mm: depth,
            normal_left,
        } = *wall;
        let spacing = self.part.sampling.spacing_mm;
        let a = Vector3::z();
        let along = self.part.direction(direction_deg);
        let normal = if normal_left {
            a.cross(&along)
        } else {
            along.cross(&a)
        };
        let radius = self.part.cutter.radius_mm;
        self.check_reach(name, depth)?;
        let mut cuts = Vec::new();
        for t in steps(0.0, length, spacing) {
            let bottom = self.part.commanded(start) + along * t;
            let tip = bottom + normal * radius;
            let (ve, omega) = self.errors(name, &tip)?;
            for s in steps(0.0, depth, spacing) {
                let deviation = normal.dot(&(ve + omega.cross(&(a * s))));
                cuts.push(Cut::along(bottom + a * s, normal, deviation, tip));
            }
        }
        Ok((normal, cuts))
    }

    /// The cuts of a hole's wall, grouped by height level.
    pub(super) fn hole_cuts(
        &self,
        name: &str,
        centre: [f64; 3],
        diameter: f64,
        depth: f64,
    ) -> Result<Vec<Vec<Cut>>, FeatureError> {
        let spacing = self.part.sampling.spacing_mm;
        let a = Vector3::z();
        let radius = self.part.cutter.radius_mm;
        self.check_reach(name, depth)?;
        let bottom = self.part.commanded(centre) - a * depth;
        let path_radius = (diameter / 2.0 - radius).max(0.0);
        let angles = super::counts::hole_angles(diameter, spacing) as usize;
        let heights = steps(0.0, depth, spacing);
        let mut levels: Vec<Vec<Cut>> =
            heights.iter().map(|_| Vec::with_capacity(angles)).collect();
        for k in 0..angles {
            let theta = std::f64::consts::TAU * k as f64 / angles as f64;
            let e = Vector3::new(theta.cos(), theta.sin(), 0.0);
            let tip = bottom + e * path_radius;
            let (ve, omega) = self.errors(name, &tip)?;
            for (level, &s) in levels.iter_mut().zip(&heights) {
                // The whole displacement, so a cutter that only shifts and tilts leaves a true
                // (shifted, tilted) cylinder; its radial part is the wall's deviation.
                let displacement = ve + omega.cross(&(a * s));
                let nominal = bottom + e * (diameter / 2.0) + a * s;
                level.push(Cut {
                    nominal,
                    normal: e,
                    actual: nominal + displacement,
                    deviation: e.dot(&displacement),
                    cutter: tip,
                });
            }
        }
        Ok(levels)
    }

    /// The cutter's flutes must reach the whole depth of a wall or hole.
    pub(super) fn check_reach(&self, feature: &str, depth: f64) -> Result<(), FeatureError> {
        let length = self.part.cutter.length_mm;
        if depth > length {
            return Err(self.feature_error(
                feature,
                format!("depth {depth} mm exceeds the cutter length {length} mm"),
            ));
        }
        Ok(())
    }

    pub(super) fn feature_error(&self, feature: &str, message: String) -> FeatureError {
        FeatureError::Feature {
            file: self.file.to_string(),
            feature: feature.to_string(),
            message,
        }
    }

    pub(super) fn tolerance_error(&self, feature: &str) -> impl Fn(ZoneError) -> FeatureError + '_ {
        let feature = feature.to_string();
        move |source| FeatureError::Tolerance {
            file: self.file.to_string(),
            feature: feature.clone(),
            source,
        }
    }
}
