//! A Monte Carlo study split into shards (docs/design.md, "Shards on a batch scheduler"). The
//! draws are counter-based (seed, sample, term), so the K-th of M equal ranges of samples is all a
//! shard needs: each writes its samples' statistics (a [`SampleFile`]), and [`merge`] puts the
//! files together into exactly the statistics one run of all the samples gives, whatever the
//! order the files come in.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use super::conformance::NominalFeature;
use crate::error::{Classify, ErrorKind};
use crate::model::perturbation::Tolerance;
use crate::model::statistics::FieldStats;

/// What a [`SampleFile`] says it is, in its `format` field.
pub const SAMPLE_FORMAT: &str = "volmap samples 1";

/// The `index`-th (from 0) of `count` equal ranges of a study's samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

/// What is wrong with a shard or with the files to merge.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("a shard `{0}`: give K/M, the K-th (from 0) of M equal ranges (of the samples, or of the poses), K < M")]
    Syntax(String),
    #[error(
        "shard {index}/{count}: {count} shards of {samples} samples or poses leave some empty"
    )]
    Empty {
        index: u64,
        count: u64,
        samples: usize,
    },
    #[error("{path}: {message}")]
    File { path: String, message: String },
    #[error("no sample files to merge")]
    NoFiles,
}

impl Classify for ShardError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Input
    }
}

impl std::str::FromStr for Shard {
    type Err = ShardError;

    fn from_str(text: &str) -> Result<Shard, ShardError> {
        let syntax = || ShardError::Syntax(crate::error::excerpt(text).into_owned());
        let (k, m) = text.trim().split_once('/').ok_or_else(syntax)?;
        let (index, count): (u64, u64) = (
            k.trim().parse().map_err(|_| syntax())?,
            m.trim().parse().map_err(|_| syntax())?,
        );
        if index >= count {
            return Err(syntax());
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// Its samples: from `index·N/M` up to `(index+1)·N/M`, so the M ranges cover `0..N` once.
    pub fn range(&self, samples: usize) -> Result<Range<usize>, ShardError> {
        let at = |k: u64| (k as u128 * samples as u128 / self.count as u128) as usize;
        let range = at(self.index)..at(self.index + 1);
        if range.is_empty() {
            return Err(ShardError::Empty {
                index: self.index,
                count: self.count,
                samples,
            });
        }
        Ok(range)
    }
}

/// What must be the same in every shard of one study: the machine, the tolerances, where the
/// fields are evaluated, the draws and their number, and the specification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyKey {
    pub machine: String,
    /// The hash of the machine's file and tables (`sha256:…`): shards of two machine files of
    /// one name are not one study.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine_sha256: Option<String>,
    /// Each tolerance: its key and its distribution with its width.
    pub tolerances: Vec<String>,
    pub grid: [usize; 3],
    pub poses: Vec<String>,
    pub approach: String,
    pub temperatures: String,
    pub seed: u64,
    /// The samples of the whole study (all shards).
    pub samples: usize,
    pub spec_mm: Option<f64>,
    /// `features --tolerances`: the part file and the confidence of the verdicts (the grid
    /// and poses are then not used: the part says where the cutter goes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
}

/// The text that identifies a tolerance in a [`StudyKey`].
pub fn tolerance_text(tolerance: &Tolerance) -> String {
    format!(
        "{} {:?}",
        tolerance.perturbation.target.key(),
        tolerance.distribution
    )
}

/// One sampled machine's field statistics, as [`FieldStats`] keeps them (every number written
/// so that it reads back exactly).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleRecord {
    pub sample: usize,
    pub points: u64,
    pub sum_sq_ve_mm2: f64,
    pub max_ve_mm: f64,
    pub max_ve_point: u64,
    pub max_ve_pose: usize,
    pub max_oe_rad: f64,
    pub max_axis_mm: [f64; 3],
}

impl SampleRecord {
    pub fn of(sample: usize, s: &FieldStats) -> SampleRecord {
        SampleRecord {
            sample,
            points: s.points,
            sum_sq_ve_mm2: s.sum_sq_ve,
            max_ve_mm: s.max_ve_mm,
            max_ve_point: s.max_ve_point,
            max_ve_pose: s.max_ve_pose,
            max_oe_rad: s.max_oe_rad,
            max_axis_mm: s.max_axis_mm,
        }
    }

    pub fn stats(&self) -> FieldStats {
        FieldStats {
            points: self.points,
            sum_sq_ve: self.sum_sq_ve_mm2,
            max_ve_mm: self.max_ve_mm,
            max_ve_point: self.max_ve_point,
            max_ve_pose: self.max_ve_pose,
            max_oe_rad: self.max_oe_rad,
            max_axis_mm: self.max_axis_mm,
        }
    }
}

/// A feature of a part on the samples of a shard: as on the nominal machine, and its error on
/// each sample, mm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureSamples {
    pub nominal: NominalFeature,
    pub errors_mm: Vec<f64>,
}

/// What a shard computed of each of its samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Samples {
    /// `budget`: each sampled machine's field statistics.
    Fields(Vec<SampleRecord>),
    /// `features --tolerances`: each feature's error on each sampled machine.
    Features(Vec<FeatureSamples>),
}

/// The results of a range of a study's samples: what a shard writes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleFile {
    pub format: String,
    pub study: StudyKey,
    /// The first sample of the range.
    pub first: usize,
    pub results: Samples,
}

/// A merged study's results over all its samples, in sample order.
#[derive(Debug, Clone, PartialEq)]
pub enum Merged {
    Fields(Vec<FieldStats>),
    /// Each feature as on the nominal machine, and its errors.
    Features(Vec<NominalFeature>, Vec<Vec<f64>>),
}

impl SampleFile {
    pub fn of_fields(study: StudyKey, first: usize, stats: &[FieldStats]) -> SampleFile {
        SampleFile {
            format: SAMPLE_FORMAT.to_string(),
            study,
            first,
            results: Samples::Fields(
                stats
                    .iter()
                    .enumerate()
                    .map(|(n, s)| SampleRecord::of(first + n, s))
                    .collect(),
            ),
        }
    }

    pub fn of_features(
        study: StudyKey,
        first: usize,
        nominal: Vec<NominalFeature>,
        errors: Vec<Vec<f64>>,
    ) -> SampleFile {
        SampleFile {
            format: SAMPLE_FORMAT.to_string(),
            study,
            first,
            results: Samples::Features(
                nominal
                    .into_iter()
                    .zip(errors)
                    .map(|(nominal, errors_mm)| FeatureSamples { nominal, errors_mm })
                    .collect(),
            ),
        }
    }

    /// The number of samples it holds.
    pub fn count(&self) -> usize {
        match &self.results {
            Samples::Fields(records) => records.len(),
            Samples::Features(features) => features.first().map_or(0, |f| f.errors_mm.len()),
        }
    }

    /// Reads a file `path` names (only for the errors).
    pub fn read(path: &str, text: &str) -> Result<SampleFile, ShardError> {
        let file: SampleFile = serde_json::from_str(text).map_err(|e| ShardError::File {
            path: path.to_string(),
            message: format!("not a sample file written by `budget --per-sample FILE.json`: {e}"),
        })?;
        if file.format != SAMPLE_FORMAT {
            return Err(ShardError::File {
                path: path.to_string(),
                message: format!(
                    "its format is `{}`, not `{SAMPLE_FORMAT}`",
                    crate::error::excerpt(&file.format)
                ),
            });
        }
        let message = match &file.results {
            Samples::Fields(records) => records
                .iter()
                .enumerate()
                .find(|(n, r)| r.sample != file.first + n)
                .map(|(n, r)| format!(
                    "its record {n} is sample {}, not {}: the samples of a file are consecutive from `first`",
                    r.sample,
                    file.first + n
                )),
            Samples::Features(features) => features
                .iter()
                .find(|f| f.errors_mm.len() != file.count())
                .map(|f| format!(
                    "feature `{}` has {} errors where the first has {}",
                    crate::error::excerpt(&f.nominal.name),
                    f.errors_mm.len(),
                    file.count()
                )),
        };
        match message {
            Some(message) => Err(ShardError::File {
                path: path.to_string(),
                message,
            }),
            None => Ok(file),
        }
    }
}

/// Puts sample files (each with the path it was read from) together: they must be of one study
/// and cover its samples `0..N` once. The study and its results in sample order.
pub fn merge(files: &[(String, SampleFile)]) -> Result<(StudyKey, Merged), ShardError> {
    let (first_path, first) = files.first().ok_or(ShardError::NoFiles)?;
    let refuse = |path: &str, message: String| ShardError::File {
        path: path.to_string(),
        message,
    };
    for (path, file) in files {
        if file.study != first.study {
            return Err(refuse(
                path,
                format!(
                    "it is of another study than {first_path} ({}): merge the shards of one run only",
                    difference(&file.study, &first.study)
                ),
            ));
        }
    }
    let mut order: Vec<&(String, SampleFile)> = files.iter().collect();
    order.sort_by_key(|(_, f)| (f.first, f.count()));
    let samples = first.study.samples;
    let mut merged = match &first.results {
        Samples::Fields(_) => Merged::Fields(Vec::with_capacity(samples)),
        Samples::Features(features) => Merged::Features(
            features.iter().map(|f| f.nominal.clone()).collect(),
            vec![Vec::with_capacity(samples); features.len()],
        ),
    };
    let mut done = 0;
    let mut covered_by: Option<&str> = None;
    for (path, file) in order {
        let end = file.first + file.count();
        if file.first != done {
            return Err(refuse(
                path,
                if file.first < done {
                    format!(
                        "its samples {}..{end} overlap those of {}",
                        file.first,
                        covered_by.unwrap_or("another file")
                    )
                } else {
                    format!(
                        "samples {done}..{} are in no file given (a shard missing)",
                        file.first
                    )
                },
            ));
        }
        if end > samples {
            return Err(refuse(
                path,
                format!("its samples end at {end}, beyond the study's {samples}"),
            ));
        }
        match (&mut merged, &file.results) {
            (Merged::Fields(stats), Samples::Fields(records)) => {
                stats.extend(records.iter().map(SampleRecord::stats))
            }
            (Merged::Features(nominal, errors), Samples::Features(features))
                if features.len() == nominal.len()
                    && features.iter().zip(nominal.iter()).all(|(f, n)| f.nominal == *n) =>
            {
                for (e, f) in errors.iter_mut().zip(features) {
                    e.extend(&f.errors_mm);
                }
            }
            _ => {
                return Err(refuse(
                    path,
                    format!("its results are not of the kind of {first_path}'s (fields or features, the same features)"),
                ))
            }
        }
        done = end;
        covered_by = Some(path);
    }
    if done != samples {
        return Err(refuse(
            covered_by.unwrap_or(first_path),
            format!("the files given hold samples 0..{done} of the study's {samples}: a shard is missing"),
        ));
    }
    Ok((first.study.clone(), merged))
}

/// Which field of two study keys differs, in words.
fn difference(a: &StudyKey, b: &StudyKey) -> String {
    let fields = [
        ("machine", a.machine != b.machine),
        ("tolerances", a.tolerances != b.tolerances),
        ("grid", a.grid != b.grid),
        ("poses", a.poses != b.poses),
        ("approach", a.approach != b.approach),
        ("temperatures", a.temperatures != b.temperatures),
        ("seed", a.seed != b.seed),
        ("samples", a.samples != b.samples),
        ("spec", a.spec_mm != b.spec_mm),
        ("part", a.part != b.part),
        ("confidence", a.confidence != b.confidence),
    ];
    let names: Vec<&str> = fields.iter().filter(|f| f.1).map(|f| f.0).collect();
    format!("its {} differ", names.join(", "))
}
