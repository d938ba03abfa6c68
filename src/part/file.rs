//! The part file (TOML): where the part sits, the cutter, the sampling, and the features with
//! their tolerances, checked as they are read. Every error names the file and the feature.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;
use serde::Deserialize;

use super::FeatureError;
use crate::io::read_text;
use crate::model::{AxisLetter, Command};

/// The part file (TOML).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartFile {
    /// The folder mesh paths are relative to: the part file's.
    #[serde(skip)]
    pub base: std::path::PathBuf,
    pub name: String,
    pub placement: Placement,
    pub cutter: Cutter,
    #[serde(default)]
    pub sampling: Sampling,
    pub features: Vec<FeatureSpec>,
}

/// Where the part sits: its zero in commanded coordinates (mm), its rotation about the commanded
/// z axis (degrees), and the rotary axes' positions while it is machined (degrees).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    pub zero_mm: [f64; 3],
    #[serde(default)]
    pub rotation_deg: f64,
    #[serde(default)]
    pub pose_deg: HashMap<String, f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cutter {
    pub radius_mm: f64,
    pub length_mm: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sampling {
    /// Distance between sampled cutter positions along a feature, mm.
    #[serde(default = "default_spacing")]
    pub spacing_mm: f64,
}

fn default_spacing() -> f64 {
    5.0
}

impl Default for Sampling {
    fn default() -> Sampling {
        Sampling {
            spacing_mm: default_spacing(),
        }
    }
}

/// One feature and its tolerance (mm), in the part frame.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FeatureSpec {
    /// A pocket floor: the rectangle from `corner_mm` spanning `size_mm` along part x and y;
    /// flatness.
    EndMilledPlane {
        name: String,
        corner_mm: [f64; 3],
        size_mm: [f64; 2],
        tolerance_mm: f64,
    },
    /// The top of a rib, as the rectangle of a floor; its height (largest deviation from
    /// nominal).
    RibHeight {
        name: String,
        corner_mm: [f64; 3],
        size_mm: [f64; 2],
        tolerance_mm: f64,
    },
    /// A wall from `start_mm` (its bottom) along `direction_deg` (in the part's xy plane) for
    /// `length_mm`, `depth_mm` high, its outward normal to the right of the direction when
    /// `normal_left` is false; flatness.
    FlankMilledPlane {
        name: String,
        start_mm: [f64; 3],
        direction_deg: f64,
        length_mm: f64,
        depth_mm: f64,
        #[serde(default)]
        normal_left: bool,
        tolerance_mm: f64,
    },
    /// A hole along the tool axis: centre of its top, diameter, depth; cylindricity.
    Hole {
        name: String,
        centre_mm: [f64; 3],
        diameter_mm: f64,
        depth_mm: f64,
        tolerance_mm: f64,
    },
    /// A hole whose axis must be parallel to the axis of the hole `datum` (a `hole` feature);
    /// parallelism.
    ParallelHole {
        name: String,
        centre_mm: [f64; 3],
        diameter_mm: f64,
        depth_mm: f64,
        datum: String,
        tolerance_mm: f64,
    },
    /// The position of a hole against datum planes (`end_milled_plane` or `flank_milled_plane`
    /// features): its derived median line within a cylinder of diameter `tolerance_mm` about the
    /// true position, which moves with the datums.
    HolePosition {
        name: String,
        centre_mm: [f64; 3],
        diameter_mm: f64,
        depth_mm: f64,
        datums: Vec<String>,
        tolerance_mm: f64,
    },
    /// The position of a rib's side (a wall, as for `flank_milled_plane`) against datum planes:
    /// within a zone `tolerance_mm` wide about its true position, which moves with the datums.
    RibPosition {
        name: String,
        start_mm: [f64; 3],
        direction_deg: f64,
        length_mm: f64,
        depth_mm: f64,
        #[serde(default)]
        normal_left: bool,
        datums: Vec<String>,
        tolerance_mm: f64,
    },
    /// A free-form surface given as an STL mesh (part frame, mm; a path relative to the part
    /// file): the surface profile, a zone `tolerance_mm` wide centred on the nominal surface,
    /// placed as `evaluation` says (with `datums`, in their reference frame). `ply`, when given,
    /// is where the per-vertex normal deviation is written: binary PLY (for MeshLab), or VTK XML
    /// PolyData (for ParaView) where the name ends in `.vtp`.
    Profile {
        name: String,
        mesh: String,
        tolerance_mm: f64,
        #[serde(default)]
        ply: Option<String>,
        /// Datum features in order of precedence (primary first): planes or holes of the part.
        #[serde(default)]
        datums: Vec<String>,
        /// Where the zone sits; by default `datums` where datums are named, else `nominal`.
        #[serde(default)]
        evaluation: Option<ProfileEvaluation>,
    },
}

/// Where a profile's zone sits before the surface is judged against it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProfileEvaluation {
    /// Where the drawing puts it, in the commanded frame: every error of the machine counts.
    Nominal,
    /// Moved with the datum reference frame that the machined datum features establish; the
    /// degrees of freedom the datums leave free float to the best fit.
    Datums,
    /// Moved by the rigid motion that best fits the surface (least squares, six degrees of
    /// freedom): the form alone.
    BestFit,
}

/// A wall as the cutter's side machines it: from `start_mm` (its bottom) along `direction_deg`
/// (in the part's xy plane) for `length_mm`, `depth_mm` high, its outward normal to the left of
/// the direction when `normal_left`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    pub start_mm: [f64; 3],
    pub direction_deg: f64,
    pub length_mm: f64,
    pub depth_mm: f64,
    pub normal_left: bool,
}

impl FeatureSpec {
    /// The wall of a flank-milled plane or a rib's side.
    pub fn wall(&self) -> Option<Wall> {
        match *self {
            FeatureSpec::FlankMilledPlane {
                start_mm,
                direction_deg,
                length_mm,
                depth_mm,
                normal_left,
                ..
            }
            | FeatureSpec::RibPosition {
                start_mm,
                direction_deg,
                length_mm,
                depth_mm,
                normal_left,
                ..
            } => Some(Wall {
                start_mm,
                direction_deg,
                length_mm,
                depth_mm,
                normal_left,
            }),
            _ => None,
        }
    }

    pub fn name(&self) -> &str {
        match self {
            FeatureSpec::EndMilledPlane { name, .. }
            | FeatureSpec::RibHeight { name, .. }
            | FeatureSpec::FlankMilledPlane { name, .. }
            | FeatureSpec::Hole { name, .. }
            | FeatureSpec::ParallelHole { name, .. }
            | FeatureSpec::HolePosition { name, .. }
            | FeatureSpec::RibPosition { name, .. }
            | FeatureSpec::Profile { name, .. } => name,
        }
    }

    pub fn kind(&self) -> &'static str {
        match self {
            FeatureSpec::EndMilledPlane { .. } => "end_milled_plane",
            FeatureSpec::RibHeight { .. } => "rib_height",
            FeatureSpec::FlankMilledPlane { .. } => "flank_milled_plane",
            FeatureSpec::Hole { .. } => "hole",
            FeatureSpec::ParallelHole { .. } => "parallel_hole",
            FeatureSpec::HolePosition { .. } => "hole_position",
            FeatureSpec::RibPosition { .. } => "rib_position",
            FeatureSpec::Profile { .. } => "profile",
        }
    }

    /// A profile's evaluation, its default resolved (`datums` where it names datums).
    pub fn profile_evaluation(&self) -> Option<ProfileEvaluation> {
        match self {
            FeatureSpec::Profile {
                datums, evaluation, ..
            } => Some(evaluation.unwrap_or(if datums.is_empty() {
                ProfileEvaluation::Nominal
            } else {
                ProfileEvaluation::Datums
            })),
            _ => None,
        }
    }

    pub fn tolerance(&self) -> f64 {
        match self {
            FeatureSpec::EndMilledPlane { tolerance_mm, .. }
            | FeatureSpec::RibHeight { tolerance_mm, .. }
            | FeatureSpec::FlankMilledPlane { tolerance_mm, .. }
            | FeatureSpec::Hole { tolerance_mm, .. }
            | FeatureSpec::ParallelHole { tolerance_mm, .. }
            | FeatureSpec::HolePosition { tolerance_mm, .. }
            | FeatureSpec::RibPosition { tolerance_mm, .. }
            | FeatureSpec::Profile { tolerance_mm, .. } => *tolerance_mm,
        }
    }
}

impl PartFile {
    pub fn read(path: &Path) -> Result<PartFile, FeatureError> {
        let file = path.display().to_string();
        let text = read_text(path)?;
        let mut part = PartFile::parse(&text, &file)?;
        part.base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        part.check_named_files(&file)?;
        Ok(part)
    }

    /// Every deviation file the part's features write: (feature, path).
    pub fn ply_paths(&self) -> Vec<(&str, std::path::PathBuf)> {
        self.features
            .iter()
            .filter_map(|f| match f {
                FeatureSpec::Profile {
                    name,
                    ply: Some(ply),
                    ..
                } => Some((name.as_str(), self.base.join(ply))),
                _ => None,
            })
            .collect()
    }

    /// The meshes read and the deviation files written lie in the part file's folder or below it
    /// (a `ply` naming `/etc/…` or `../../x` would replace a file the part has no business
    /// with), and no two features write one deviation file.
    fn check_named_files(&self, file: &str) -> Result<(), FeatureError> {
        use crate::io::source::{confined, Identity, Reach};
        let check = Check { file };
        let mut written: Vec<(&str, Identity)> = Vec::new();
        for f in &self.features {
            let FeatureSpec::Profile {
                name, mesh, ply, ..
            } = f
            else {
                continue;
            };
            confined(&self.base, Path::new(mesh), Reach::Folder)
                .map_err(|e| check.error(name, format!("mesh: {e}")))?;
            let Some(ply) = ply else {
                continue;
            };
            let path = confined(&self.base, Path::new(ply), Reach::Folder)
                .map_err(|e| check.error(name, format!("ply: {e}")))?;
            let identity = Identity::of_named(&path);
            if let Some((first, _)) = written.iter().find(|(_, i)| i.is(&identity)) {
                return Err(check.error(
                    name,
                    format!(
                        "ply: `{}` is also the deviation file of feature `{first}`: each needs a file of its own",
                        crate::error::excerpt(ply)
                    ),
                ));
            }
            written.push((name, identity));
        }
        Ok(())
    }

    pub fn parse(text: &str, file: &str) -> Result<PartFile, FeatureError> {
        if let Some(message) = crate::error::toml_beyond_limits(text) {
            return Err(FeatureError::Toml {
                file: file.to_string(),
                message,
            });
        }
        let part: PartFile = toml::from_str(text).map_err(|e| FeatureError::Toml {
            file: file.to_string(),
            message: crate::error::toml_message(&e, text),
        })?;
        let check = Check { file };
        check.positive("(cutter)", "radius_mm", part.cutter.radius_mm)?;
        check.positive("(cutter)", "length_mm", part.cutter.length_mm)?;
        check.positive("(sampling)", "spacing_mm", part.sampling.spacing_mm)?;
        let mut kinds = HashMap::new();
        for f in &part.features {
            check.positive(f.name(), "tolerance_mm", f.tolerance())?;
            if kinds.insert(f.name().to_string(), f.kind()).is_some() {
                return Err(check.error(f.name(), "two features have this name".into()));
            }
            check.sizes(f)?;
        }
        // Datum planes of positions first, then the datum holes of parallel holes.
        let (positions, others): (Vec<&FeatureSpec>, Vec<&FeatureSpec>) =
            part.features.iter().partition(|f| {
                matches!(
                    f,
                    FeatureSpec::HolePosition { .. } | FeatureSpec::RibPosition { .. }
                )
            });
        for f in positions.into_iter().chain(others) {
            check.datums(f, &kinds)?;
        }
        for (axis, value) in &part.placement.pose_deg {
            if !matches!(axis.as_str(), "A" | "B" | "C") || !value.is_finite() {
                return Err(check.error(
                    "(placement)",
                    format!(
                        "pose_deg: `{axis}` is not a rotary axis (A, B, C) with a finite value"
                    ),
                ));
            }
        }
        part.check_counts(file)?;
        Ok(part)
    }

    /// The commanded position of a point given in the part frame.
    pub(super) fn commanded(&self, p: [f64; 3]) -> Vector3<f64> {
        let (s, c) = self.placement.rotation_deg.to_radians().sin_cos();
        let z = self.placement.zero_mm;
        Vector3::new(
            z[0] + c * p[0] - s * p[1],
            z[1] + s * p[0] + c * p[1],
            z[2] + p[2],
        )
    }

    /// A direction of the part's xy plane, in the commanded frame.
    pub(super) fn direction(&self, angle_deg: f64) -> Vector3<f64> {
        let a = (angle_deg + self.placement.rotation_deg).to_radians();
        Vector3::new(a.cos(), a.sin(), 0.0)
    }

    /// The rotary axes' positions the part is machined at (X Y Z zero).
    pub fn pose(&self) -> Command {
        let mut command = [0.0; 6];
        for (axis, value) in &self.placement.pose_deg {
            if let Some(letter) = axis.chars().next().and_then(AxisLetter::from_char) {
                command[letter.index()] = *value;
            }
        }
        command
    }
}

/// The checks of a part file's values, naming the file and the feature.
struct Check<'a> {
    file: &'a str,
}

impl Check<'_> {
    fn error(&self, feature: &str, message: String) -> FeatureError {
        FeatureError::Feature {
            file: self.file.to_string(),
            feature: feature.to_string(),
            message,
        }
    }

    fn positive(&self, feature: &str, what: &str, v: f64) -> Result<(), FeatureError> {
        if v > 0.0 && v.is_finite() {
            Ok(())
        } else {
            Err(self.error(
                feature,
                format!("{what} must be a positive number of mm, found {v}"),
            ))
        }
    }

    /// A feature's sizes.
    fn sizes(&self, f: &FeatureSpec) -> Result<(), FeatureError> {
        let name = f.name();
        match f {
            FeatureSpec::EndMilledPlane { size_mm, .. }
            | FeatureSpec::RibHeight { size_mm, .. } => {
                self.positive(name, "size_mm[0]", size_mm[0])?;
                self.positive(name, "size_mm[1]", size_mm[1])
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
            } => {
                self.positive(name, "length_mm", *length_mm)?;
                self.positive(name, "depth_mm", *depth_mm)
            }
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
            } => {
                self.positive(name, "diameter_mm", *diameter_mm)?;
                self.positive(name, "depth_mm", *depth_mm)
            }
            FeatureSpec::Profile { .. } => Ok(()),
        }
    }

    /// A feature's datums, against the kinds of the part's features by name: one to three planes
    /// for positions, a hole for a parallel hole.
    fn datums(
        &self,
        f: &FeatureSpec,
        kinds: &HashMap<String, &'static str>,
    ) -> Result<(), FeatureError> {
        let name = f.name();
        match f {
            FeatureSpec::HolePosition { datums, .. } | FeatureSpec::RibPosition { datums, .. } => {
                if datums.is_empty() || datums.len() > 3 {
                    return Err(self.error(
                        name,
                        format!("names {} datums: give one to three", datums.len()),
                    ));
                }
                for datum in datums {
                    match kinds.get(datum) {
                        Some(&"end_milled_plane") | Some(&"flank_milled_plane") => {}
                        Some(kind) => {
                            return Err(self.error(name, format!("datum `{datum}` is a {kind}: datums are end_milled_plane or flank_milled_plane features")))
                        }
                        None => {
                            return Err(self.error(
                                name,
                                format!("datum `{datum}` names no feature of the part"),
                            ))
                        }
                    }
                }
                Ok(())
            }
            FeatureSpec::Profile {
                datums, evaluation, ..
            } => self.profile_datums(name, datums, *evaluation, kinds),
            FeatureSpec::ParallelHole { datum, .. } => match kinds.get(datum) {
                Some(&"hole") => Ok(()),
                Some(kind) => {
                    Err(self.error(name, format!("datum `{datum}` is a {kind}, not a hole")))
                }
                None => Err(self.error(
                    name,
                    format!("datum `{datum}` names no feature of the part"),
                )),
            },
            _ => Ok(()),
        }
    }

    /// A profile's datums: one to three distinct planes or holes of the part, which the
    /// evaluation must use (`datums`) where they are named, and must be named for it.
    fn profile_datums(
        &self,
        name: &str,
        datums: &[String],
        evaluation: Option<ProfileEvaluation>,
        kinds: &HashMap<String, &'static str>,
    ) -> Result<(), FeatureError> {
        match (evaluation, datums.is_empty()) {
            (Some(ProfileEvaluation::Datums), true) => {
                return Err(self.error(
                    name,
                    "evaluation = \"datums\" needs `datums`: the planes or holes that establish the datum reference frame".into(),
                ))
            }
            (Some(e @ (ProfileEvaluation::Nominal | ProfileEvaluation::BestFit)), false) => {
                let e = if e == ProfileEvaluation::Nominal { "nominal" } else { "best_fit" };
                return Err(self.error(
                    name,
                    format!("evaluation = \"{e}\" ignores `datums`: give one or the other (or evaluation = \"datums\")"),
                ));
            }
            _ => {}
        }
        if datums.len() > 3 {
            return Err(self.error(
                name,
                format!(
                    "datums: names {} datums: give one to three (primary, secondary, tertiary)",
                    datums.len()
                ),
            ));
        }
        for (i, datum) in datums.iter().enumerate() {
            if datums[..i].contains(datum) {
                return Err(self.error(name, format!("datums: `{datum}` is named twice")));
            }
            match kinds.get(datum) {
                Some(&("end_milled_plane" | "flank_milled_plane" | "hole")) => {}
                Some(kind) => {
                    return Err(self.error(name, format!("datums: `{datum}` is a {kind}: datums of a profile are end_milled_plane, flank_milled_plane or hole features")))
                }
                None => {
                    return Err(self.error(
                        name,
                        format!("datums: `{datum}` names no feature of the part"),
                    ))
                }
            }
        }
        Ok(())
    }
}
