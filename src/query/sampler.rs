//! Sampling a field file batch after batch: a single-pose field read whole, the parts of a
//! five-axis map one by one, a field larger than memory in slabs of z planes; its values or the
//! standard uncertainties of them (the part of uncertainties `map --uncertainty` writes).

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::Path;

use rayon::prelude::*;

use super::sample::{locate_in, sample_field_gpu_within, sample_field_within, with_nan};
use super::{Outside, QueryError};
use crate::gpu::GpuSampler;
use crate::io::field::{FieldError, FieldFile, GridCell, LoadedField};
use crate::io::points::QueryPoint;
use crate::model::channels::Sample;

/// A field file opened for sampling: a single-pose field that fits in memory is read whole;
/// the parts of a five-axis map are read one by one as the points ask for them, and a field
/// larger than [`field_memory_bytes`](crate::io::field::field_memory_bytes) in slabs of z
/// planes.
pub struct SampledField {
    file: FieldFile,
    whole: Option<Box<LoadedField>>,
    /// Whether it samples the standard uncertainties of the values rather than the values.
    uncertainty: bool,
}

impl SampledField {
    pub fn open(path: &Path) -> Result<SampledField, FieldError> {
        crate::io::source::note_source(path);
        SampledField::of(FieldFile::open(path)?)
    }

    /// A field file whose headers are read: a single-pose field that fits in memory is read
    /// whole now.
    pub fn of(file: FieldFile) -> Result<SampledField, FieldError> {
        let whole = if !file.is_multipart() && fits_whole(&file, 0)? {
            Some(Box::new(LoadedField::open_part(&file, 0)?))
        } else {
            None
        };
        Ok(SampledField {
            file,
            whole,
            uncertainty: false,
        })
    }

    /// The standard uncertainties of a field file's values (`map --uncertainty`), sampled as
    /// [`SampledField::of`] samples the values (the same grid, read whole or in slabs alike):
    /// `None` where a part holds none.
    pub fn uncertainty_of(file: FieldFile) -> Result<Option<SampledField>, FieldError> {
        if !file.has_uncertainties() {
            return Ok(None);
        }
        let whole = if !file.is_multipart() && fits_whole(&file, 0)? {
            let nz = file.info(0).dims[2];
            Some(Box::new(LoadedField::open_uncertainties(&file, 0, 0..nz)?))
        } else {
            None
        };
        Ok(Some(SampledField {
            file,
            whole,
            uncertainty: true,
        }))
    }

    /// Part `part` whole (it fits) or its z planes `planes`: its values, or their standard
    /// uncertainties.
    fn read(&self, part: usize, planes: Option<Range<usize>>) -> Result<LoadedField, FieldError> {
        let file = &self.file;
        match (self.uncertainty, planes) {
            (false, None) => LoadedField::open_part(file, part),
            (false, Some(planes)) => LoadedField::open_planes(file, part, planes),
            (true, None) => LoadedField::open_uncertainties(file, part, 0..file.info(part).dims[2]),
            (true, Some(planes)) => LoadedField::open_uncertainties(file, part, planes),
        }
    }
}

/// Whether part `part` is read whole (else in slabs of z planes).
fn fits_whole(file: &FieldFile, part: usize) -> Result<bool, FieldError> {
    Ok(LoadedField::slab_planes(file, part)? >= file.info(part).dims[2])
}

/// Samples a field file at every point, on the GPU where `sampler` is given: a single-pose
/// field as [`sample_field`](super::sample_field) does; in a five-axis map each point in the part whose pose its
/// rotary columns name (within 1e-9°; a rotary axis without a column matches any pose, so the
/// columns must leave one part). A point whose pose no part holds is an error naming its line
/// and listing the file's poses. The parts are read one at a time.
pub fn sample_fields(
    field: &SampledField,
    points: &[QueryPoint],
    path: &str,
    sampler: Option<&GpuSampler>,
) -> Result<Vec<Sample>, QueryError> {
    Ok(FieldSampler::new(field, sampler, path, Outside::Error)
        .sample(points)?
        .into_iter()
        .map(Option::unwrap_or_default)
        .collect())
}

/// Samples a field file batch after batch, as [`sample_fields`] does for one: the part (or the
/// slab of a part) read last is kept for the next batch, so points in the order of their poses
/// (and along Z in a field read in slabs) read each once.
pub struct FieldSampler<'a> {
    field: &'a SampledField,
    gpu: Option<&'a GpuSampler>,
    path: String,
    outside: Outside,
    kept: Option<(usize, LoadedField)>,
}

impl<'a> FieldSampler<'a> {
    /// `path` names the points file in errors; `outside` says what to do with positions outside
    /// the grid.
    pub fn new(
        field: &'a SampledField,
        gpu: Option<&'a GpuSampler>,
        path: &str,
        outside: Outside,
    ) -> FieldSampler<'a> {
        FieldSampler {
            field,
            gpu,
            path: path.to_string(),
            outside,
            kept: None,
        }
    }

    /// The samples of a batch, `None` where [`Outside::Skip`] leaves a position out.
    pub fn sample(&mut self, points: &[QueryPoint]) -> Result<Vec<Option<Sample>>, QueryError> {
        if let Some(whole) = &self.field.whole {
            return self.sample_loaded(whole, points);
        }
        let file = &self.field.file;
        let parts = if file.is_multipart() {
            part_of_each(file, points, &self.path)?
        } else {
            vec![0; points.len()]
        };
        let mut by_part: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (n, &part) in parts.iter().enumerate() {
            by_part.entry(part).or_default().push(n);
        }
        // The part kept from the last batch goes first, so it is not read again.
        let kept = self.kept.as_ref().map(|(n, _)| *n);
        let mut order: Vec<(usize, Vec<usize>)> = by_part.into_iter().collect();
        order.sort_by_key(|(part, _)| Some(*part) != kept);
        let mut samples = vec![None; points.len()];
        for (part, indices) in order {
            let subset: Vec<QueryPoint> = indices.iter().map(|&n| points[n].clone()).collect();
            let sampled = if fits_whole(file, part)? {
                if self.kept.as_ref().is_none_or(|(n, _)| *n != part) {
                    self.kept = None;
                    self.kept = Some((part, self.field.read(part, None)?));
                }
                let field = &self.kept.as_ref().expect("the part was just read").1;
                self.sample_loaded(field, &subset)?
            } else {
                self.sample_in_slabs(part, &subset)?
            };
            for (n, s) in indices.into_iter().zip(sampled) {
                samples[n] = s;
            }
        }
        Ok(samples)
    }

    fn sample_loaded(
        &self,
        field: &LoadedField,
        points: &[QueryPoint],
    ) -> Result<Vec<Option<Sample>>, QueryError> {
        match self.gpu {
            Some(gpu) => sample_field_gpu_within(field, points, &self.path, gpu, self.outside),
            None => sample_field_within(field, points, &self.path, self.outside),
        }
    }

    /// Samples points in part `part`, too large to read whole: each point located from the
    /// header, then the points of each slab of z planes (a slab holds `planes` planes and
    /// overlaps the next by one, so it holds both planes of the cells whose lower corner is in
    /// it) sampled in that slab.
    fn sample_in_slabs(
        &mut self,
        part: usize,
        points: &[QueryPoint],
    ) -> Result<Vec<Option<Sample>>, QueryError> {
        let file = &self.field.file;
        let info = file.info(part);
        let nz = info.dims[2];
        let planes = LoadedField::slab_planes(file, part)?;
        let step = planes - 1;
        let located: Vec<Result<Option<GridCell>, QueryError>> = points
            .par_iter()
            .map(|p| locate_in(&info, p, &self.path, self.outside))
            .collect();
        let cells: Vec<Option<GridCell>> = located.into_iter().collect::<Result<_, _>>()?;
        let slab_of = |cell: &GridCell| (cell.lower[2] / step).min((nz - 2) / step);
        let mut by_slab: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (n, cell) in cells.iter().enumerate() {
            if let Some(cell) = cell {
                by_slab.entry(slab_of(cell)).or_default().push(n);
            }
        }
        let kept_slab = self
            .kept
            .as_ref()
            .filter(|(p, _)| *p == part)
            .map(|(_, f)| f.planes().start / step);
        let mut order: Vec<(usize, Vec<usize>)> = by_slab.into_iter().collect();
        order.sort_by_key(|(slab, _)| Some(*slab) != kept_slab);
        let mut samples: Vec<Option<Sample>> = vec![None; points.len()];
        for (slab, members) in order {
            let first = slab * step;
            let wanted = first..(first + planes).min(nz);
            if self
                .kept
                .as_ref()
                .is_none_or(|(p, f)| *p != part || f.planes() != wanted)
            {
                self.kept = None;
                self.kept = Some((part, self.field.read(part, Some(wanted))?));
            }
            let field = &self.kept.as_ref().expect("the slab was just read").1;
            let slab_cells: Vec<GridCell> = members
                .iter()
                .map(|&n| cells[n].expect("grouped cells are inside"))
                .collect();
            let values: Vec<Sample> = match self.gpu {
                Some(gpu) => {
                    let first_plane = field.planes().start;
                    let shifted: Vec<GridCell> = slab_cells
                        .iter()
                        .map(|c| GridCell {
                            lower: [c.lower[0], c.lower[1], c.lower[2] - first_plane],
                            fraction: c.fraction,
                        })
                        .collect();
                    let [nx, ny, _] = info.dims;
                    let dims = [nx, ny, field.planes().len()];
                    gpu.sample(dims, field.values(), &shifted, None)?
                        .into_iter()
                        .map(|v| v.map(|x| x as f64))
                        .collect()
                }
                None => slab_cells.par_iter().map(|c| field.blend(c)).collect(),
            };
            for (n, v) in members.into_iter().zip(values) {
                samples[n] = Some(v);
            }
        }
        Ok(with_nan(samples, self.outside))
    }
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
