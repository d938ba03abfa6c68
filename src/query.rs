//! Point queries: VE and OE at arbitrary commanded positions, from a field file (trilinear
//! interpolation within its grid) or exactly from the machine model (the f64 reference).
//!
//! Positions come from CSV: one header row naming the columns `X Y Z` (mm) and, optionally,
//! `A B C` (degrees); one position per row.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use crate::field::{FieldError, FieldInfo, FieldReader};
use crate::gpu::layout::{SamplePoint, CHANNELS};
use crate::gpu::{GpuError, GpuSampler};
use crate::machine::{AxisLetter, Command, Machine};
use crate::map::DeviceChoice;
use crate::reference;

#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Csv {
        path: String,
        line: usize,
        message: String,
    },
    #[error("{path}: line {line}: {axis}={value} lies outside the field's grid ({lo} to {hi}); a field is not extrapolated")]
    Outside {
        path: String,
        line: usize,
        axis: char,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(
        "{path}: line {line}: {axis}={value}°, but the field holds the pose {axis}={field}° only"
    )]
    Pose {
        path: String,
        line: usize,
        axis: char,
        value: f64,
        field: f64,
    },
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("no GPU adapter found (--device gpu); use --device auto or cpu to sample on the CPU")]
    NoAdapter,
    #[error("{0}")]
    Slice(String),
}

/// One queried position and the CSV line it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct QueryPoint {
    pub line: usize,
    pub command: Command,
    /// Which of the six axis columns the CSV gave (the others are 0).
    pub given: [bool; 6],
}

/// The six values at a point, in the output order VE.X VE.Y VE.Z (mm) OE.X OE.Y OE.Z (rad).
pub type Sample = [f64; 6];

/// The output columns after the position columns.
pub const SAMPLE_COLUMNS: [&str; 6] = ["VE.X", "VE.Y", "VE.Z", "OE.X", "OE.Y", "OE.Z"];

/// Reads positions from CSV text; `path` names it in errors.
pub fn parse_points(text: &str, path: &str) -> Result<Vec<QueryPoint>, QueryError> {
    let csv_error = |line: usize, message: String| QueryError::Csv {
        path: path.to_string(),
        line,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (header_index, header) = lines.next().ok_or_else(|| {
        csv_error(
            1,
            "empty: expected a header row naming X, Y, Z (and A, B, C)".into(),
        )
    })?;
    let mut columns = Vec::new();
    let mut given = [false; 6];
    for name in header.split(',').map(str::trim) {
        let letter = match name.chars().collect::<Vec<_>>()[..] {
            [c] => AxisLetter::from_char(c),
            _ => None,
        }
        .ok_or_else(|| {
            csv_error(
                header_index + 1,
                format!("unknown column `{name}` (the columns are X, Y, Z, A, B, C)"),
            )
        })?;
        if std::mem::replace(&mut given[letter.index()], true) {
            return Err(csv_error(
                header_index + 1,
                format!("column {letter} appears twice"),
            ));
        }
        columns.push(letter);
    }
    for letter in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
        if !given[letter.index()] {
            return Err(csv_error(
                header_index + 1,
                format!("no column {letter}: X, Y and Z are required"),
            ));
        }
    }
    let mut points = Vec::new();
    for (n, row) in lines {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(csv_error(
                n + 1,
                format!(
                    "{} fields, the header names {}",
                    fields.len(),
                    columns.len()
                ),
            ));
        }
        let mut command = [0.0; 6];
        for (letter, field) in columns.iter().zip(&fields) {
            let value: f64 = field
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    csv_error(
                        n + 1,
                        format!("`{field}` in column {letter} is not a finite number"),
                    )
                })?;
            command[letter.index()] = value;
        }
        points.push(QueryPoint {
            line: n + 1,
            command,
            given,
        });
    }
    Ok(points)
}

pub fn read_points(path: &Path) -> Result<Vec<QueryPoint>, QueryError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| QueryError::Io {
        path: name.clone(),
        source,
    })?;
    parse_points(&text, &name)
}

/// The grid cell that holds a position: its lower corner and the position's fractions within it
/// along X, Y, Z (0 along a dimension one point deep).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridCell {
    pub lower: [usize; 3],
    pub fraction: [f64; 3],
}

impl GridCell {
    /// The cell as the GPU sampling kernel takes it.
    pub fn for_gpu(&self) -> SamplePoint {
        let [i, j, k] = self.lower.map(|n| n as u32);
        let [tx, ty, tz] = self.fraction.map(|t| t as f32);
        SamplePoint {
            cell: [i, j, k, 0],
            t: [tx, ty, tz, 0.0],
        }
    }
}

/// A field file read into memory, point-interleaved for sampling: the six values of a grid point
/// in the [`SAMPLE_COLUMNS`] order side by side, so a trilinear sample touches eight places.
pub struct LoadedField {
    pub info: FieldInfo,
    /// `[p][c]` with `p = i + nx·(j + ny·k)`.
    values: Vec<[f32; 6]>,
}

impl LoadedField {
    pub fn open(path: &Path) -> Result<LoadedField, QueryError> {
        let mut reader = FieldReader::open(path)?;
        let info = reader.info().clone();
        let nx = info.dims[0];
        let mut values = Vec::with_capacity(reader.lines() as usize * nx);
        reader.for_each_chunk((1 << 20) / nx as u64, |_, _, chunk| {
            for line in chunk.chunks_exact(CHANNELS.len() * nx) {
                values.extend((0..nx).map(|i| CHANNELS_TO_SAMPLE.map(|c| line[c * nx + i])));
            }
        })?;
        Ok(LoadedField { info, values })
    }

    /// The first rotary axis (0 A, 1 B, 2 C) among those `given` whose position in `command`
    /// differs from the field's pose, with that position and the field's: a field holds one
    /// pose only.
    pub fn pose_mismatch(&self, command: &Command, given: [bool; 3]) -> Option<(usize, f64, f64)> {
        (0..3).find_map(|n| {
            let (asked, held) = (command[3 + n], self.info.pose_deg[n]);
            (given[n] && (asked - held).abs() > 1e-9 * (1.0 + held.abs()))
                .then_some((n, asked, held))
        })
    }

    /// The values at grid point `(i, j, k)`.
    fn at(&self, [i, j, k]: [usize; 3]) -> &[f32; 6] {
        let [nx, ny, _] = self.info.dims;
        &self.values[i + nx * (j + ny * k)]
    }

    /// The grid cell that holds a commanded position (its lower corner) and the fractions of the
    /// position within it; `Err((axis, lo, hi))` when the position lies outside the grid along
    /// `axis`. Positions within 1e-9 of the travel of the grid count as inside (the ends of a
    /// grid are rounded). Along a dimension one point deep the cell is 0 and the fraction 0.
    pub fn cell(&self, command: &Command) -> Result<GridCell, (usize, f64, f64)> {
        let mut base = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let n = self.info.dims[d];
            let (origin, step) = (self.info.origin_mm[d], self.info.spacing_mm[d]);
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

    /// Trilinear interpolation at a commanded position, in f64; `Err((axis, lo, hi))` as
    /// [`LoadedField::cell`]. The GPU twin is `shaders/sample.wgsl`.
    pub fn sample(&self, command: &Command) -> Result<Sample, (usize, f64, f64)> {
        Ok(self.blend(&self.cell(command)?))
    }

    /// The trilinear blend of the eight corners of a cell.
    fn blend(&self, cell: &GridCell) -> Sample {
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

    /// The values of every grid point, `[p][column]` with `p = i + nx·(j + ny·k)` and the
    /// columns of [`SAMPLE_COLUMNS`].
    pub fn values(&self) -> &[[f32; 6]] {
        &self.values
    }
}

/// For each output column of [`SAMPLE_COLUMNS`], its channel in [`CHANNELS`].
const CHANNELS_TO_SAMPLE: [usize; 6] = [3, 4, 5, 0, 1, 2];

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
    let located: Vec<SamplePoint> = points
        .par_iter()
        .map(|p| locate(field, p, path).map(|cell| cell.for_gpu()))
        .collect::<Result<_, _>>()?;
    let samples = sampler.sample(field.info.dims, &field.values, &located, None)?;
    Ok(samples
        .into_par_iter()
        .map(|v| v.map(|x| x as f64))
        .collect())
}

/// The f64 reference at every point, in parallel.
pub fn sample_exact(machine: &Machine, points: &[QueryPoint]) -> Vec<Sample> {
    let ideal = machine.without_errors();
    points
        .par_iter()
        .map(|p| {
            let d = reference::deviation_against(machine, &ideal, &p.command);
            let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
            [ve.x, ve.y, ve.z, oe.x, oe.y, oe.z]
        })
        .collect()
}

/// Writes the positions with their samples as CSV: the position columns the input named, then
/// [`SAMPLE_COLUMNS`]. Rows are formatted in parallel, written in order.
pub fn write_samples(
    out: &mut (impl Write + ?Sized),
    points: &[QueryPoint],
    samples: &[Sample],
) -> std::io::Result<()> {
    let given = points
        .first()
        .map_or([true, true, true, false, false, false], |p| p.given);
    let letters: Vec<usize> = (0..6).filter(|&n| given[n]).collect();
    let mut header: Vec<String> = letters
        .iter()
        .map(|&n| AxisLetter::ALL[n].to_string())
        .collect();
    header.extend(SAMPLE_COLUMNS.iter().map(|c| c.to_string()));
    writeln!(out, "{}", header.join(","))?;
    let blocks: Vec<Vec<u8>> = points
        .par_chunks(16_384)
        .zip(samples.par_chunks(16_384))
        .map(|(points, samples)| {
            let mut block = Vec::with_capacity(points.len() * 160);
            let mut number = ryu::Buffer::new();
            for (p, s) in points.iter().zip(samples) {
                for (n, &letter) in letters.iter().enumerate() {
                    if n > 0 {
                        block.push(b',');
                    }
                    let value = p.command[letter];
                    // Whole millimetres and degrees as integers, the way positions are written.
                    if value.fract() == 0.0 && value.abs() < 1e15 {
                        let _ = write!(block, "{}", value as i64);
                    } else {
                        block.extend_from_slice(number.format(value).as_bytes());
                    }
                }
                for v in s {
                    block.push(b',');
                    block.extend_from_slice(number.format(*v).as_bytes());
                }
                block.push(b'\n');
            }
            block
        })
        .collect();
    for block in blocks {
        out.write_all(&block)?;
    }
    Ok(())
}

/// A plane of a field for a colour map: `values[r * cols + c]`, row 0 at the low end of the
/// vertical axis.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldSlice {
    pub title: String,
    /// Horizontal and vertical axis labels.
    pub labels: [String; 2],
    /// `(horizontal lo, hi, vertical lo, hi)`, mm.
    pub extent: (f64, f64, f64, f64),
    pub cols: usize,
    pub rows: usize,
    pub values: Vec<f64>,
    pub unit: String,
}

/// Reads the grid plane across axis `normal` (`x`, `y` or `z`) nearest to `at` (mm; default the
/// middle) and takes `quantity` there: `VE` (|VE|, mm), `OE` (|OE|, rad) or one channel
/// (`VE.X` … `OE.Z`). Only the lines the plane crosses are read.
pub fn field_slice(
    path: &Path,
    normal: &str,
    at: Option<f64>,
    quantity: &str,
) -> Result<FieldSlice, QueryError> {
    let d = match normal.trim() {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        other => return Err(QueryError::Slice(format!("--normal {other}: x, y or z"))),
    };
    // Which channels make the quantity, and the unit.
    let (channels, magnitude, unit): (Vec<usize>, bool, &str) = match quantity.trim() {
        "VE" => (vec![3, 4, 5], true, "|VE| (mm)"),
        "OE" => (vec![0, 1, 2], true, "|OE| (rad)"),
        other => match CHANNELS.iter().position(|c| *c == other) {
            Some(c) => (vec![c], false, if c < 3 { "rad" } else { "mm" }),
            None => {
                return Err(QueryError::Slice(format!(
                    "--quantity {other}: VE, OE or one of {}",
                    CHANNELS.join(", ")
                )))
            }
        },
    };
    let mut reader = FieldReader::open(path)?;
    let info = reader.info().clone();
    let [nx, ny, nz] = info.dims;
    let n = info.dims[d];
    let index = match at {
        None => n / 2,
        Some(q) => {
            let (origin, step) = (info.origin_mm[d], info.spacing_mm[d]);
            let end = origin + (n - 1) as f64 * step;
            if q < origin.min(end) - 1e-9 || q > origin.max(end) + 1e-9 {
                return Err(QueryError::Slice(format!(
                    "--at {q}: outside the field's grid along {} ({origin} to {end})",
                    ['X', 'Y', 'Z'][d]
                )));
            }
            if step > 0.0 {
                ((q - origin) / step).round() as usize
            } else {
                0
            }
            .min(n - 1)
        }
    };
    let (h, v) = match d {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let (cols, rows) = (info.dims[h], info.dims[v]);
    let mut values = vec![0.0; cols * rows];
    let mut line = vec![0.0f32; CHANNELS.len() * nx];
    let value_at = |line: &[f32], i: usize| -> f64 {
        let parts = channels.iter().map(|&c| line[c * nx + i] as f64);
        if magnitude {
            parts.map(|x| x * x).sum::<f64>().sqrt()
        } else {
            parts.sum()
        }
    };
    for k in 0..nz {
        for j in 0..ny {
            let wanted = match d {
                0 => true,
                1 => j == index,
                _ => k == index,
            };
            if !wanted {
                continue;
            }
            reader.read_line((k * ny + j) as u64, &mut line)?;
            match d {
                0 => values[k * cols + j] = value_at(&line, index),
                1 => (0..nx).for_each(|i| values[k * cols + i] = value_at(&line, i)),
                _ => (0..nx).for_each(|i| values[j * cols + i] = value_at(&line, i)),
            }
        }
    }
    let axis = ['X', 'Y', 'Z'];
    let span = |a: usize| {
        let o = info.origin_mm[a];
        (o, o + (info.dims[a] - 1) as f64 * info.spacing_mm[a])
    };
    let (h_lo, h_hi) = span(h);
    let (v_lo, v_hi) = span(v);
    let position = info.origin_mm[d] + index as f64 * info.spacing_mm[d];
    Ok(FieldSlice {
        title: format!(
            "{}: {} at {}={position:.1} mm",
            info.machine_name,
            if magnitude {
                format!("|{}|", quantity.trim())
            } else {
                quantity.trim().to_string()
            },
            axis[d]
        ),
        labels: [format!("{} (mm)", axis[h]), format!("{} (mm)", axis[v])],
        extent: (h_lo, h_hi, v_lo, v_hi),
        cols,
        rows,
        values,
        unit: unit.to_string(),
    })
}
