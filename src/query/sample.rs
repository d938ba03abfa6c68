//! VE and OE at arbitrary commanded positions: interpolated (trilinear) in a field, on the CPU or
//! the GPU, or exactly from the machine model (the f64 reference).

use rayon::prelude::*;

use super::QueryError;
use crate::engine::DeviceChoice;
use crate::gpu::GpuSampler;
use crate::io::field::{FieldInfo, GridCell, LoadedField};
use crate::io::points::{PointColumns, QueryPoint};
use crate::model::channels::Sample;
use crate::model::{AxisLetter, Machine};
use crate::reference::Twin;

/// What to do with a position outside the field's grid.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Outside {
    /// Stop with an error naming its line (a field is never extrapolated).
    #[default]
    Error,
    /// Leave it out: its sample is `None`.
    Skip,
    /// Answer NaN for every value.
    Nan,
}

/// Samples the field at every point, in parallel, visiting the points in grid order (a random
/// order would miss the cache at nearly every corner). Rotary columns, where given, must name
/// the field's own pose.
pub fn sample_field(
    field: &LoadedField,
    points: &[QueryPoint],
    path: &str,
) -> Result<Vec<Sample>, QueryError> {
    Ok(sample_field_within(field, points, path, Outside::Error)?
        .into_iter()
        .map(Option::unwrap_or_default)
        .collect())
}

/// [`sample_field`] with a choice for positions outside the grid: `None` where
/// [`Outside::Skip`] leaves one out. An error names the first line at fault.
pub fn sample_field_within(
    field: &LoadedField,
    points: &[QueryPoint],
    path: &str,
    outside: Outside,
) -> Result<Vec<Option<Sample>>, QueryError> {
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
    let sorted: Vec<(usize, Result<Option<Sample>, QueryError>)> = keyed
        .into_par_iter()
        .map(|(_, n)| {
            let sample = locate_within(field, &points[n], path, outside)
                .map(|cell| cell.map(|cell| field.blend(&cell)));
            (n, sample)
        })
        .collect();
    let mut samples = vec![None; points.len()];
    let mut first_error: Option<(usize, QueryError)> = None;
    for (n, sample) in sorted {
        match sample {
            Ok(sample) => samples[n] = sample,
            Err(e) if first_error.as_ref().is_none_or(|(m, _)| n < *m) => {
                first_error = Some((n, e))
            }
            Err(_) => {}
        }
    }
    match first_error {
        Some((_, e)) => Err(e),
        None => Ok(with_nan(samples, outside)),
    }
}

/// Fills the samples [`Outside::Nan`] asks for with NaN.
pub(super) fn with_nan(samples: Vec<Option<Sample>>, outside: Outside) -> Vec<Option<Sample>> {
    if outside != Outside::Nan {
        return samples;
    }
    samples
        .into_iter()
        .map(|s| Some(s.unwrap_or([f64::NAN; 6])))
        .collect()
}

/// [`locate`], with `None` for a position outside the grid where `outside` lets it pass.
fn locate_within(
    field: &LoadedField,
    p: &QueryPoint,
    path: &str,
    outside: Outside,
) -> Result<Option<GridCell>, QueryError> {
    locate_in(&field.info, p, path, outside)
}

/// [`locate_within`] from a field's header alone.
pub(super) fn locate_in(
    info: &FieldInfo,
    p: &QueryPoint,
    path: &str,
    outside: Outside,
) -> Result<Option<GridCell>, QueryError> {
    match locate(info, p, path) {
        Ok(cell) => Ok(Some(cell)),
        Err(QueryError::Outside { .. }) if outside != Outside::Error => Ok(None),
        Err(e) => Err(e),
    }
}

/// Checks a position against the field (its pose and its grid) and finds its cell.
fn locate(field: &FieldInfo, p: &QueryPoint, path: &str) -> Result<GridCell, QueryError> {
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
    Ok(
        sample_field_gpu_within(field, points, path, sampler, Outside::Error)?
            .into_iter()
            .map(Option::unwrap_or_default)
            .collect(),
    )
}

/// [`sample_field_gpu`] with a choice for positions outside the grid, as
/// [`sample_field_within`].
pub fn sample_field_gpu_within(
    field: &LoadedField,
    points: &[QueryPoint],
    path: &str,
    sampler: &GpuSampler,
    outside: Outside,
) -> Result<Vec<Option<Sample>>, QueryError> {
    // Collected in order, so the error is the first line's.
    let located: Vec<Result<Option<GridCell>, QueryError>> = points
        .par_iter()
        .map(|p| locate_within(field, p, path, outside))
        .collect();
    let located: Vec<Option<GridCell>> = located.into_iter().collect::<Result<_, _>>()?;
    let inside: Vec<GridCell> = located.iter().flatten().copied().collect();
    let values = if inside.is_empty() {
        Vec::new()
    } else {
        sampler.sample(field.info.dims, field.values(), &inside, None)?
    };
    let mut values = values.into_iter();
    let samples = located
        .iter()
        .map(|cell| {
            cell.as_ref().map(|_| {
                values
                    .next()
                    .expect("one value per cell inside")
                    .map(|x| x as f64)
            })
        })
        .collect();
    Ok(with_nan(samples, outside))
}

/// Checks the columns of a points file against the machine sampled exactly: a rotary column
/// for an axis the machine lacks is an error naming it.
pub fn check_exact_columns(
    machine: &Machine,
    columns: &PointColumns,
    path: &str,
) -> Result<(), QueryError> {
    // The points file holds X, Y and Z always: a linear axis the machine lacks stands at 0
    // (see `sample_exact_within`).
    for letter in columns.axes.iter().flatten() {
        if machine.axis(*letter).is_none() && !letter.is_linear() {
            return Err(QueryError::NoAxis {
                path: path.to_string(),
                line: columns.line,
                axis: letter.as_char(),
                chain: machine.chain.hwang_notation(),
            });
        }
    }
    Ok(())
}

/// [`sample_exact`] for positions within the machine's travels: a position with an axis
/// outside its range is an error naming its line and the coordinate, or left out or answered
/// NaN as `outside` says (the model is not evaluated where the machine cannot go).
pub fn sample_exact_within(
    machine: &Machine,
    points: &[QueryPoint],
    path: &str,
    outside: Outside,
) -> Result<Vec<Option<Sample>>, QueryError> {
    let axes: Vec<(usize, char, [f64; 2])> = machine
        .axes
        .iter()
        .map(|a| (a.letter.index(), a.letter.as_char(), a.range))
        // A linear axis the machine lacks has a travel of its 0 alone.
        .chain(
            AxisLetter::ALL[..3]
                .iter()
                .filter(|l| machine.axis(**l).is_none())
                .map(|l| (l.index(), l.as_char(), [0.0, 0.0])),
        )
        .collect();
    let beyond = |p: &QueryPoint| {
        axes.iter()
            .find(|(i, _, r)| !(r[0]..=r[1]).contains(&p.command[*i]))
            .map(|&(i, axis, [lo, hi])| QueryError::OutsideTravel {
                path: path.to_string(),
                line: p.line,
                axis,
                value: p.command[i],
                lo,
                hi,
            })
    };
    let mut inside = Vec::with_capacity(points.len());
    let mut within = Vec::with_capacity(points.len());
    for p in points {
        match beyond(p) {
            Some(e) if outside == Outside::Error => return Err(e),
            Some(_) => within.push(false),
            None => {
                within.push(true);
                inside.push(p.clone());
            }
        }
    }
    let mut values = sample_exact(machine, &inside).into_iter();
    let samples = within
        .into_iter()
        .map(|w| w.then(|| values.next().expect("one value per point inside")))
        .collect();
    Ok(with_nan(samples, outside))
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
