//! A field read into memory for sampling at arbitrary positions: trilinear interpolation within
//! its grid (the GPU twin is `shaders/sample.wgsl`).

use std::ops::Range;
use std::path::Path;

use super::{FieldError, FieldFile, FieldInfo, FieldReader};
use crate::model::channels::{Sample, CHANNELS};
use crate::model::Command;

/// The grid cell that holds a position: its lower corner and the position's fractions within it
/// along X, Y, Z (0 along a dimension one point deep).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridCell {
    pub lower: [usize; 3],
    pub fraction: [f64; 3],
}

impl FieldInfo {
    /// The first rotary axis (0 A, 1 B, 2 C) among those `given` whose position in `command`
    /// differs from the field's pose, with that position and the field's: a field holds one
    /// pose only.
    pub fn pose_mismatch(&self, command: &Command, given: [bool; 3]) -> Option<(usize, f64, f64)> {
        (0..3).find_map(|n| {
            let (asked, held) = (command[3 + n], self.pose_deg[n]);
            (given[n] && (asked - held).abs() > 1e-9 * (1.0 + held.abs()))
                .then_some((n, asked, held))
        })
    }

    /// The grid cell that holds a commanded position (its lower corner) and the fractions of the
    /// position within it; `Err((axis, lo, hi))` when the position lies outside the grid along
    /// `axis`. Positions within 1e-9 of the travel of the grid count as inside (the ends of a
    /// grid are rounded). Along a dimension one point deep the cell is 0 and the fraction 0.
    pub fn cell(&self, command: &Command) -> Result<GridCell, (usize, f64, f64)> {
        let mut base = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let n = self.dims[d];
            let (origin, step) = (self.origin_mm[d], self.spacing_mm[d]);
            let end = origin + (n - 1) as f64 * step;
            let slack = 1e-9 * (1.0 + origin.abs().max(end.abs()));
            let q = command[d];
            if q < origin - slack || q > end + slack {
                return Err((d, origin, end));
            }
            if n > 1 {
                let u = ((q - origin) / step).clamp(0.0, (n - 1) as f64);
                base[d] = (u.floor() as usize).min(n - 2);
                t[d] = u - base[d] as f64;
            }
        }
        Ok(GridCell {
            lower: base,
            fraction: t,
        })
    }
}

/// The most bytes of values a reader holds of one field at once: a field this large or smaller
/// is read whole (24 bytes a point: about 89 million points, 447³); a larger one is sampled in
/// slabs of whole z planes of at most this size.
pub const FIELD_MEMORY_BYTES: u64 = 2 << 30;

/// [`FIELD_MEMORY_BYTES`], or the bytes `VOLMAP_FIELD_MEMORY_BYTES` sets (a smaller machine;
/// the tests, to read small fields in slabs).
pub fn field_memory_bytes() -> u64 {
    static BYTES: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *BYTES.get_or_init(|| {
        std::env::var("VOLMAP_FIELD_MEMORY_BYTES")
            .ok()
            .and_then(|v| v.trim().parse().ok())
            .filter(|&b| b > 0)
            .unwrap_or(FIELD_MEMORY_BYTES)
    })
}

/// Bytes a point takes in memory.
const POINT_BYTES: u64 = 24;

/// A field file read into memory, point-interleaved for sampling: the six values of a grid point
/// in the [`SAMPLE_COLUMNS`](crate::model::channels::SAMPLE_COLUMNS) order side by side, so a
/// trilinear sample touches eight places. It holds the whole field, or (a field larger than
/// [`FIELD_MEMORY_BYTES`]) a slab of its z planes, [`LoadedField::planes`].
pub struct LoadedField {
    pub info: FieldInfo,
    /// The first z plane held.
    first_plane: usize,
    /// `[p][c]` with `p = i + nx·(j + ny·(k − first_plane))`.
    values: Vec<[f32; 6]>,
}

impl LoadedField {
    /// Reads a single-part field file (or a sweep of one pose) whole; a file of several poses is
    /// an error listing them.
    pub fn open(path: &Path) -> Result<LoadedField, FieldError> {
        let file = FieldFile::open(path)?;
        LoadedField::open_part(&file, file.single()?)
    }

    /// Reads part `part` of a field file whole: an error for a field larger than
    /// [`field_memory_bytes`].
    pub fn open_part(file: &FieldFile, part: usize) -> Result<LoadedField, FieldError> {
        let [nx, ny, nz] = file.info(part).dims;
        let bytes = (nx * ny * nz) as u64 * POINT_BYTES;
        let limit = field_memory_bytes();
        if bytes > limit {
            return Err(FieldError::TooLarge {
                path: file.path().display().to_string(),
                what: format!("reading its {nx}x{ny}x{nz} grid whole"),
                bytes,
                limit,
            });
        }
        LoadedField::read(file.reader(part)?, 0..nz)
    }

    /// Reads the z planes `planes` of part `part` of a field file.
    pub fn open_planes(
        file: &FieldFile,
        part: usize,
        planes: Range<usize>,
    ) -> Result<LoadedField, FieldError> {
        LoadedField::read(file.reader(part)?, planes)
    }

    /// Reads the z planes `planes` of the standard uncertainties of part `part` (the part of
    /// uncertainties after it, the same grid): an error where the file holds none.
    pub fn open_uncertainties(
        file: &FieldFile,
        part: usize,
        planes: Range<usize>,
    ) -> Result<LoadedField, FieldError> {
        LoadedField::read(file.required_uncertainty_reader(part)?, planes)
    }

    /// The number of z planes a slab of this field may hold within [`field_memory_bytes`]: all
    /// of them where the field fits, at least two (a cell's) else; an error where two planes do
    /// not fit.
    pub fn slab_planes(file: &FieldFile, part: usize) -> Result<usize, FieldError> {
        let [nx, ny, nz] = file.info(part).dims;
        let plane = (nx * ny) as u64 * POINT_BYTES;
        let limit = field_memory_bytes();
        let planes = (limit / plane.max(1)) as usize;
        if planes >= nz {
            return Ok(nz);
        }
        if planes < 2 {
            return Err(FieldError::TooLarge {
                path: file.path().display().to_string(),
                what: format!("sampling between two z planes of its {nx}x{ny}x{nz} grid"),
                bytes: 2 * plane,
                limit,
            });
        }
        Ok(planes)
    }

    fn read(mut reader: FieldReader, planes: Range<usize>) -> Result<LoadedField, FieldError> {
        let info = reader.info().clone();
        let [nx, ny, nz] = info.dims;
        let planes = planes.start.min(nz)..planes.end.min(nz);
        let lines = (planes.start * ny) as u64..(planes.end * ny) as u64;
        let mut values = Vec::with_capacity((lines.end - lines.start) as usize * nx);
        reader.for_each_chunk_of(lines, ((1 << 20) / nx as u64).max(1), |_, _, chunk| {
            for line in chunk.chunks_exact(CHANNELS.len() * nx) {
                values.extend((0..nx).map(|i| CHANNELS_TO_SAMPLE.map(|c| line[c * nx + i])));
            }
        })?;
        Ok(LoadedField {
            info,
            first_plane: planes.start,
            values,
        })
    }

    /// The z planes held.
    pub fn planes(&self) -> Range<usize> {
        let plane = (self.info.dims[0] * self.info.dims[1]).max(1);
        self.first_plane..self.first_plane + self.values.len() / plane
    }

    /// Whether the slab holds every corner of `cell`.
    pub fn holds(&self, cell: &GridCell) -> bool {
        let planes = self.planes();
        let k = cell.lower[2];
        let upper = if self.info.dims[2] > 1 { k + 1 } else { k };
        planes.contains(&k) && planes.contains(&upper)
    }

    /// See [`FieldInfo::pose_mismatch`].
    pub fn pose_mismatch(&self, command: &Command, given: [bool; 3]) -> Option<(usize, f64, f64)> {
        self.info.pose_mismatch(command, given)
    }

    /// The values at grid point `(i, j, k)`, which the slab holds.
    fn at(&self, [i, j, k]: [usize; 3]) -> &[f32; 6] {
        let [nx, ny, _] = self.info.dims;
        &self.values[i + nx * (j + ny * (k - self.first_plane))]
    }

    /// See [`FieldInfo::cell`].
    pub fn cell(&self, command: &Command) -> Result<GridCell, (usize, f64, f64)> {
        self.info.cell(command)
    }

    /// Trilinear interpolation at a commanded position, in f64; `Err((axis, lo, hi))` as
    /// [`LoadedField::cell`]. The GPU twin is `shaders/sample.wgsl`.
    pub fn sample(&self, command: &Command) -> Result<Sample, (usize, f64, f64)> {
        Ok(self.blend(&self.cell(command)?))
    }

    /// The trilinear blend of the eight corners of a cell.
    pub fn blend(&self, cell: &GridCell) -> Sample {
        let (base, t) = (cell.lower, cell.fraction);
        let mut out = [0.0; 6];
        for corner in 0..8usize {
            let mut weight = 1.0;
            let mut ijk = base;
            for d in 0..3 {
                let upper = corner >> d & 1 == 1;
                if upper {
                    if self.info.dims[d] == 1 {
                        weight = 0.0;
                        break;
                    }
                    ijk[d] += 1;
                    weight *= t[d];
                } else {
                    weight *= 1.0 - t[d];
                }
            }
            if weight == 0.0 {
                continue;
            }
            for (o, v) in out.iter_mut().zip(self.at(ijk)) {
                *o += weight * *v as f64;
            }
        }
        out
    }

    /// The values of every grid point held, `[p][column]` with `p = i + nx·(j + ny·(k − k0))`,
    /// `k0` the first plane held, and the columns of
    /// [`SAMPLE_COLUMNS`](crate::model::channels::SAMPLE_COLUMNS).
    pub fn values(&self) -> &[[f32; 6]] {
        &self.values
    }
}

/// For each output column of [`SAMPLE_COLUMNS`](crate::model::channels::SAMPLE_COLUMNS), its channel in [`CHANNELS`].
const CHANNELS_TO_SAMPLE: [usize; 6] = [3, 4, 5, 0, 1, 2];
