//! VE and OE at arbitrary commanded positions: interpolated (trilinear) in a field, on the CPU or
//! the GPU, or exactly from the machine model (the f64 reference).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use rayon::prelude::*;

use super::QueryError;
use crate::engine::DeviceChoice;
use crate::gpu::GpuSampler;
use crate::io::field::{FieldError, FieldFile, GridCell, LoadedField};
use crate::io::points::QueryPoint;
use crate::model::channels::Sample;
use crate::model::Machine;
use crate::reference::Twin;

/// Samples the field at every point, in parallel, visiting the points in grid order (a random
/// order would miss the cache at nearly every corner). Rotary columns, where given, must name
/// the field's own pose.
pub fn sample_field(
    field: &LoadedField,
    points: &[QueryPoint],
    path: &str,
) -> Result<Vec<Sample>, QueryError> {
    let grid = field.info.grid();
    // The number of the grid cell that holds each point (clamped: outliers fail later).
    let cell = |p: &QueryPoint| -> u64 {
        (0..3).rev().fold(0u64, |key, d| {
            let n = grid.dims[d] as u64;
            let step = grid.spacing_mm[d];
            let index = if step > 0.0 {
                ((p.command[d] - grid.origin_mm[d]) / step)
                    .floor()
                    .clamp(0.0, (n - 1) as f64) as u64
            } else {
                0
            };
            key * n + index
        })
    };
    let mut keyed: Vec<(u64, usize)> = points
        .par_iter()
        .enumerate()
        .map(|(n, p)| (cell(p), n))
        .collect();
    keyed.par_sort_unstable();
    let order: Vec<usize> = keyed.into_iter().map(|(_, n)| n).collect();
    let sorted: Vec<(usize, Sample)> = order
        .par_iter()
        .map(|&n| sample_one(field, &points[n], path).map(|s| (n, s)))
        .collect::<Result<_, _>>()?;
    let mut samples = vec![[0.0; 6]; points.len()];
    for (n, s) in sorted {
        samples[n] = s;
    }
    Ok(samples)
}

/// Checks a position against the field (its pose and its grid) and finds its cell.
fn locate(field: &LoadedField, p: &QueryPoint, path: &str) -> Result<GridCell, QueryError> {
    let given = [p.given[3], p.given[4], p.given[5]];
    if let Some((n, value, held)) = field.pose_mismatch(&p.command, given) {
        return Err(QueryError::Pose {
            path: path.to_string(),
            line: p.line,
            axis: ['A', 'B', 'C'][n],
            value,
            field: held,
        });
    }
    field
        .cell(&p.command)
        .map_err(|(d, lo, hi)| QueryError::Outside {
            path: path.to_string(),
            line: p.line,
            axis: ['X', 'Y', 'Z'][d],
            value: p.command[d],
            lo,
            hi,
        })
}

fn sample_one(field: &LoadedField, p: &QueryPoint, path: &str) -> Result<Sample, QueryError> {
    Ok(field.blend(&locate(field, p, path)?))
}

/// A field file opened for sampling: a single-pose field read whole, or a five-axis map (one
/// part per pose) whose parts are read one by one as the points ask for them.
pub enum SampledField {
    One(Box<LoadedField>),
    Parts(FieldFile),
}

impl SampledField {
    pub fn open(path: &Path) -> Result<SampledField, FieldError> {
        SampledField::of(FieldFile::open(path)?)
    }

    /// A field file whose headers are read: a single-pose field is read whole now.
    pub fn of(file: FieldFile) -> Result<SampledField, FieldError> {
        Ok(if file.is_multipart() {
            SampledField::Parts(file)
        } else {
            SampledField::One(Box::new(LoadedField::open_part(&file, 0)?))
        })
    }
}

/// Samples a field file at every point, on the GPU where `sampler` is given: a single-pose
/// field as [`sample_field`] does; in a five-axis map each point in the part whose pose its
/// rotary columns name (within 1e-9°; a rotary axis without a column matches any pose, so the
/// columns must leave one part). A point whose pose no part holds is an error naming its line
/// and listing the file's poses. The parts are read one at a time.
pub fn sample_fields(
    field: &SampledField,
    points: &[QueryPoint],
    path: &str,
    sampler: Option<&GpuSampler>,
) -> Result<Vec<Sample>, QueryError> {
    let sample = |field: &LoadedField, points: &[QueryPoint]| match sampler {
        Some(sampler) => sample_field_gpu(field, points, path, sampler),
        None => sample_field(field, points, path),
    };
    let file = match field {
        SampledField::One(field) => return sample(field, points),
        SampledField::Parts(file) => file,
    };
    let parts = part_of_each(file, points, path)?;
    let mut by_part: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (n, &part) in parts.iter().enumerate() {
        by_part.entry(part).or_default().push(n);
    }
    let mut samples = vec![[0.0; 6]; points.len()];
    for (part, indices) in by_part {
        let field = LoadedField::open_part(file, part)?;
        let subset: Vec<QueryPoint> = indices.iter().map(|&n| points[n].clone()).collect();
        for (n, s) in indices.into_iter().zip(sample(&field, &subset)?) {
            samples[n] = s;
        }
    }
    Ok(samples)
}

/// The part of a multi-part field each point's rotary columns pick.
fn part_of_each(
    file: &FieldFile,
    points: &[QueryPoint],
    path: &str,
) -> Result<Vec<usize>, QueryError> {
    let pose_axes = file.info(0).pose_axes;
    // Points come at few poses: each distinct one is looked up once.
    let mut found: HashMap<([u64; 3], [bool; 3]), usize> = HashMap::new();
    let mut parts = Vec::with_capacity(points.len());
    for p in points {
        let given = [p.given[3], p.given[4], p.given[5]];
        let degrees = [p.command[3], p.command[4], p.command[5]];
        let key = (degrees.map(f64::to_bits), given);
        if let Some(&part) = found.get(&key) {
            parts.push(part);
            continue;
        }
        let matching = file.parts_at(degrees, given);
        let named: Vec<String> = (0..3)
            .filter(|&n| given[n])
            .map(|n| format!("{}={}", ['A', 'B', 'C'][n], degrees[n]))
            .collect();
        let pose = if named.is_empty() {
            "a position without rotary columns".to_string()
        } else {
            named.join(",")
        };
        let missing: Vec<String> = pose_axes
            .chars()
            .filter(|a| "ABC".find(*a).is_some_and(|n| !given[n]))
            .map(String::from)
            .collect();
        let part = match matching[..] {
            [] => {
                return Err(QueryError::NoPose {
                    path: path.to_string(),
                    line: p.line,
                    pose,
                    field: file.path().display().to_string(),
                    poses: file.pose_list(),
                })
            }
            [_, _, ..] if !missing.is_empty() => {
                return Err(QueryError::PartialPose {
                    path: path.to_string(),
                    line: p.line,
                    pose,
                    count: matching.len(),
                    field: file.path().display().to_string(),
                    missing: missing.join(", "),
                })
            }
            [first, ..] => first,
        };
        found.insert(key, part);
        parts.push(part);
    }
    Ok(parts)
}

/// The GPU sampler `choice` asks for, or `None` for the CPU. `Auto` takes a hardware GPU only: on
/// a CPU adapter (lavapipe) the CPU path is faster, and with no adapter there is a note saying
/// so.
pub fn open_sampler(
    choice: DeviceChoice,
) -> Result<(Option<GpuSampler>, Option<String>), QueryError> {
    if choice == DeviceChoice::Cpu {
        return Ok((None, None));
    }
    match GpuSampler::open()? {
        Some(sampler) if choice == DeviceChoice::Gpu || !sampler.is_software() => {
            Ok((Some(sampler), None))
        }
        Some(_) => Ok((None, None)),
        None if choice == DeviceChoice::Auto => Ok((
            None,
            Some("no GPU adapter found: sampling on the CPU".into()),
        )),
        None => Err(QueryError::NoAdapter),
    }
}

/// [`sample_field`] on the GPU: positions checked and their cells found on the host (in
/// parallel, f64), the eight-corner blend in `shaders/sample.wgsl` (f32). The samples agree with
/// the CPU's to f32 rounding of the blend: within 1e-6 of the largest value of the cell's
/// corners.
pub fn sample_field_gpu(
    field: &LoadedField,
    points: &[QueryPoint],
    path: &str,
    sampler: &GpuSampler,
) -> Result<Vec<Sample>, QueryError> {
    let located: Vec<GridCell> = points
        .par_iter()
        .map(|p| locate(field, p, path))
        .collect::<Result<_, _>>()?;
    let samples = sampler.sample(field.info.dims, field.values(), &located, None)?;
    Ok(samples
        .into_par_iter()
        .map(|v| v.map(|x| x as f64))
        .collect())
}

/// The f64 reference at every point, in parallel.
pub fn sample_exact(machine: &Machine, points: &[QueryPoint]) -> Vec<Sample> {
    let twin = Twin::of(machine);
    points
        .par_iter()
        .map(|p| {
            let d = twin.deviation(&p.command);
            let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
            [ve.x, ve.y, ve.z, oe.x, oe.y, oe.z]
        })
        .collect()
}
