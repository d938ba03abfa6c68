//! `volmap map`: the machine over a grid, on the GPU or the CPU, streamed into a field file, with
//! the closing statistics and the optional spot check against the reference.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::map_uncertainty::{map_uncertainty, uncertainty_part, UncertaintySummary};
use super::reference;
use super::uncertainty::UncertaintyMethod;
use super::{Engine, EngineError};
use crate::io::field::{
    FieldError, FieldInfo, FieldWriter, PartsWriter, Storage, WriteTimes, SINGLE_MAP_PART,
};
use crate::io::vtk::FieldImage;
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::random::SplitMix64;
pub use crate::model::statistics::FieldStats;
use crate::model::Machine;
use crate::reference::Twin;

/// The largest differences between the field and the reference at the checked points.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckResult {
    pub points: usize,
    pub max_ve_diff_mm: f64,
    pub max_oe_diff_rad: f64,
    /// The point farthest beyond (or nearest to) the tolerances, relative to each: what a failed
    /// check names. `None` where no point was checked.
    pub worst: Option<CheckedPoint>,
}

/// One checked point and its differences from the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedPoint {
    /// The pose's number in a sweep (0 for a single map).
    pub pose: usize,
    /// The grid's point number and its indices `(i, j, k)`.
    pub point: u64,
    pub indices: [usize; 3],
    /// The commanded position, mm.
    pub at_mm: [f64; 3],
    pub ve_diff_mm: f64,
    pub oe_diff_rad: f64,
    /// `|VE|` and `|OE|` of the reference there: the tolerances grow with them
    /// ([`ve_tolerance_mm`], [`oe_tolerance_rad`]).
    pub ve_mm: f64,
    pub oe_rad: f64,
}

impl CheckedPoint {
    /// Point `p` of `grid`: the field's `got` against the reference's `want`, both in channel
    /// order, the tolerances from the reference's values `value` there (channel order; `want`
    /// itself for a field of values).
    pub fn of(
        grid: &Grid,
        p: u64,
        got: &[f32; 6],
        want: &[f64; 6],
        value: &[f64; 6],
    ) -> CheckedPoint {
        let indices = grid.indices(p);
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let diff = |range: std::ops::Range<usize>| {
            range
                .map(|c| (got[c] as f64 - want[c]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        CheckedPoint {
            pose: 0,
            point: p,
            indices,
            at_mm: grid.command(indices)[..3]
                .try_into()
                .expect("three linear axes"),
            ve_diff_mm: diff(3..6),
            oe_diff_rad: diff(0..3),
            ve_mm: norm(&value[3..6]),
            oe_rad: norm(&value[0..3]),
        }
    }

    /// How far beyond the tolerances the point lies: above 1 fails.
    pub fn excess(&self) -> f64 {
        (self.ve_diff_mm / ve_tolerance_mm(self.ve_mm))
            .max(self.oe_diff_rad / oe_tolerance_rad(self.oe_rad))
    }
}

/// The accuracy docs/model.md (section 7) asks of the f32 field against the f64 reference:
/// 1e-6 mm and 1e-9 rad, or [`ULPS`] f32 units in the last place of the value where that is
/// larger (an f32 holds 7.6 mm to 4.8e-7 mm: no f32 field can be nearer than its rounding).
pub const VE_TOLERANCE_MM: f64 = 1e-6;
pub const OE_TOLERANCE_RAD: f64 = 1e-9;
/// The f32 units in the last place of a value the field may differ from the reference by, where
/// more than the fixed tolerances: the rounding of the chain's products in f32 (measured at
/// angles near 0.01 rad: 4 on lavapipe in the map's kernel, 9.5 on an NVIDIA H200 in the
/// per-point kernel).
pub const ULPS: f64 = 16.0;

/// One f32 unit in the last place at `x`: the gap from `|x|` (as an f32) to the next f32.
pub fn ulp_f32(x: f64) -> f64 {
    let v = (x.abs() as f32).min(f32::MAX / 2.0);
    (f32::from_bits(v.to_bits() + 1) - v) as f64
}

/// The tolerance of a VE whose reference has the length `ve_mm`: the larger of
/// [`VE_TOLERANCE_MM`] and [`ULPS`] f32 units in the last place of it.
pub fn ve_tolerance_mm(ve_mm: f64) -> f64 {
    VE_TOLERANCE_MM.max(ULPS * ulp_f32(ve_mm))
}

/// The tolerance of an OE whose reference has the angle `oe_rad`, as [`ve_tolerance_mm`].
pub fn oe_tolerance_rad(oe_rad: f64) -> f64 {
    OE_TOLERANCE_RAD.max(ULPS * ulp_f32(oe_rad))
}

impl CheckResult {
    /// Whether every checked point is within its tolerances.
    pub fn passed(&self) -> bool {
        self.worst.as_ref().is_none_or(|w| w.excess() <= 1.0)
    }

    /// Adds one checked point.
    pub fn add(&mut self, checked: CheckedPoint) {
        self.merge(&CheckResult {
            points: 0,
            max_ve_diff_mm: checked.ve_diff_mm,
            max_oe_diff_rad: checked.oe_diff_rad,
            worst: Some(checked),
        });
    }

    /// Adds the check of another pose of a sweep.
    pub fn merge(&mut self, other: &CheckResult) {
        self.points += other.points;
        self.max_ve_diff_mm = self.max_ve_diff_mm.max(other.max_ve_diff_mm);
        self.max_oe_diff_rad = self.max_oe_diff_rad.max(other.max_oe_diff_rad);
        if let Some(theirs) = &other.worst {
            if self
                .worst
                .as_ref()
                .is_none_or(|w| theirs.excess() > w.excess())
            {
                self.worst = Some(theirs.clone());
            }
        }
    }
}

/// What `map` reports at the end.
#[derive(Debug, Clone)]
pub struct MapSummary {
    pub stats: FieldStats,
    pub seconds: f64,
    pub device: String,
    pub check: Option<CheckResult>,
    /// Where the time went.
    pub times: MapTimes,
    /// The part of uncertainties, where asked for.
    pub uncertainty: Option<UncertaintySummary>,
}

/// Where a map's time went: seconds each stage was busy, the stages overlapping (the engine
/// computes the next chunk while the field writer compresses and writes the last ones).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct MapTimes {
    /// The map's thread in the engine: computing and, on a GPU, reading chunks back.
    pub engine_s: f64,
    /// The map's thread handing chunks over: statistics, the spot check's values, the VTK
    /// image, the copy into the writer and any wait for room in it (`write.waiting_s`).
    pub handoff_s: f64,
    /// The field writer's stages, and the file's size.
    pub write: WriteTimes,
}

impl MapTimes {
    /// Adds the times of another map (a later pose of a sweep).
    pub fn add(&mut self, other: &MapTimes) {
        self.engine_s += other.engine_s;
        self.handoff_s += other.handoff_s;
        self.write.waiting_s += other.write.waiting_s;
        self.write.compress_s += other.write.compress_s;
        self.write.write_s += other.write.write_s;
        self.write.sync_s += other.write.sync_s;
        self.write.bytes = self.write.bytes.max(other.write.bytes);
    }
}

/// Options of one map run.
#[derive(Debug, Clone, Default)]
pub struct MapOptions {
    /// Upper bound of points per chunk (below the device's own limit); `None`: the default.
    pub chunk_points: Option<u64>,
    /// Points to recompute with the reference afterwards (the spot check of a map).
    pub check_points: usize,
    /// A VTK ImageData file (`.vti`) to write the field into as well, for ParaView (a map of
    /// one pose; a sweep writes none).
    pub vtk_image: Option<PathBuf>,
    /// How the field file stores its values (compression, HALF channels).
    pub storage: Storage,
    /// Tests only: this point of every pose is moved by [`CORRUPTION_MM`] in VE's x between the
    /// engine and everything after it, so that the spot check must fail (a correct engine never
    /// fails it).
    #[doc(hidden)]
    pub corrupt_point_for_tests: Option<u64>,
    /// The standard uncertainties of the channels, in a part after the values', computed so.
    pub uncertainty: Option<UncertaintyMethod>,
}

/// What [`MapOptions::corrupt_point_for_tests`] adds to VE's x, mm: 2 µm, far beyond the
/// tolerance and any f32 rounding.
#[doc(hidden)]
pub const CORRUPTION_MM: f32 = 2e-3;

/// The chunk with [`MapOptions::corrupt_point_for_tests`] applied, where it holds that point.
pub(super) fn corrupted_for_tests(
    point: Option<u64>,
    first_line: u64,
    lines: u64,
    nx: usize,
    data: &[f32],
) -> Option<Vec<f32>> {
    let point = point?;
    let first_point = first_line * nx as u64;
    if !(first_point..first_point + lines * nx as u64).contains(&point) {
        return None;
    }
    let local = (point - first_point) as usize;
    let (line, i) = (local / nx, local % nx);
    let mut data = data.to_vec();
    // VE's x: channel 3 (the channel order is OE's three, then VE's three).
    data[line * CHANNELS.len() * nx + 3 * nx + i] += CORRUPTION_MM;
    Some(data)
}

/// `n` distinct pseudo-random point numbers below `total`, sorted (SplitMix64, a seed fixed by
/// `total`).
pub fn sample_points(total: u64, n: usize) -> Vec<u64> {
    let mut rng = SplitMix64::new(0x9E37_79B9_7F4A_7C15 ^ total);
    let mut next = || rng.next_u64();
    let mut points: Vec<u64> = if n as u64 >= total {
        (0..total).collect()
    } else {
        let mut set = std::collections::BTreeSet::new();
        while set.len() < n {
            set.insert(next() % total);
        }
        set.into_iter().collect()
    };
    points.sort_unstable();
    points
}

/// The header of the field a map writes: of `machine` at its evaluation inputs
/// ([`Machine::inputs`], set by [`Machine::at`]).
pub fn field_info(machine: &Machine, grid: &Grid, device: &str) -> FieldInfo {
    FieldInfo {
        dims: grid.dims,
        origin_mm: grid.origin_mm,
        spacing_mm: grid.spacing_mm,
        pose_deg: [grid.pose[3], grid.pose[4], grid.pose[5]],
        pose_axes: machine.rotary_axes().iter().map(|a| a.as_char()).collect(),
        machine_name: machine.name.clone(),
        chain: machine.chain.hwang_notation(),
        machine_toml: machine.source.toml.clone(),
        csv_files: machine.source.csv_files.clone(),
        device: device.to_string(),
        inputs: machine.inputs.record(machine),
        uncertainty: None,
    }
}

/// Maps `machine` over `grid` into the field file `out` (and the VTK image the options name).
/// `on_progress(points_done)` is called
/// after each chunk.
pub fn map_to_file(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    out: &Path,
    options: &MapOptions,
    mut on_progress: impl FnMut(u64),
) -> Result<MapSummary, EngineError> {
    let device = engine.name();
    let info = field_info(machine, grid, &device);
    let mut writer = match options.uncertainty {
        None => Writer::One(FieldWriter::create_stored(out, &info, options.storage)?),
        Some(method) => {
            let parts = [
                (SINGLE_MAP_PART.to_string(), info.clone()),
                uncertainty_part(machine, grid, &info, method, true),
            ];
            Writer::Parts(PartsWriter::create_stored(
                out,
                2,
                |p| parts[p].clone(),
                options.storage,
            )?)
        }
    };
    let mut image = match &options.vtk_image {
        Some(path) => Some(FieldImage::create(path, &info).map_err(FieldError::from)?),
        None => None,
    };
    let nx = grid.dims[0];
    let mut stats = FieldStats::default();
    let checked = sample_points(grid.points(), options.check_points);
    let mut captured: Vec<[f32; 6]> = Vec::with_capacity(checked.len());
    let start = Instant::now();
    let mut handoff_s = 0.0;
    engine.run(
        machine,
        grid,
        options.chunk_points,
        |first_line, lines, data| -> Result<(), EngineError> {
            let handing = Instant::now();
            let corrupted =
                corrupted_for_tests(options.corrupt_point_for_tests, first_line, lines, nx, data);
            let data = corrupted.as_deref().unwrap_or(data);
            check_finite(machine, grid, first_line, lines, data)?;
            writer.write_lines(0, first_line, lines, data)?;
            if let Some(image) = &mut image {
                image
                    .write_lines(first_line, lines, data)
                    .map_err(FieldError::from)?;
            }
            stats.add_chunk(first_line, lines, nx, data);
            let end_point = capture(&checked, &mut captured, first_line, lines, nx, data);
            on_progress(end_point);
            handoff_s += handing.elapsed().as_secs_f64();
            Ok(())
        },
    )?;
    let uncertainty = match options.uncertainty {
        None => None,
        Some(method) => Some(map_uncertainty(
            machine,
            grid,
            engine,
            method,
            (options.chunk_points, options.check_points, 0),
            |first_line, lines, data| Ok(writer.write_lines(1, first_line, lines, data)?),
        )?),
    };
    let engine_s = start.elapsed().as_secs_f64() - handoff_s;
    let write = writer.finish()?;
    if let Some(image) = image {
        image.finish().map_err(FieldError::from)?;
    }
    let seconds = start.elapsed().as_secs_f64();
    let check =
        (!checked.is_empty()).then(|| check_against_reference(machine, grid, &checked, &captured));
    Ok(MapSummary {
        stats,
        seconds,
        device,
        check,
        times: MapTimes {
            engine_s,
            handoff_s,
            write,
        },
        uncertainty,
    })
}

/// The field file of a map of one pose: one part, or the values' and the uncertainties'.
enum Writer {
    One(FieldWriter),
    Parts(PartsWriter),
}

impl Writer {
    fn write_lines(
        &mut self,
        part: usize,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        match self {
            Writer::One(w) => w.write_lines(first_line, lines, data),
            Writer::Parts(w) => w.write_lines(part, first_line, lines, data),
        }
    }

    fn finish(self) -> Result<WriteTimes, FieldError> {
        match self {
            Writer::One(w) => w.finish(),
            Writer::Parts(w) => w.finish(),
        }
    }
}

/// Every value of a chunk of `lines` lines from `first_line` a finite number: a field holding
/// others is refused, naming the first point where a value is not and the inputs.
pub(super) fn check_finite(
    machine: &Machine,
    grid: &Grid,
    first_line: u64,
    lines: u64,
    data: &[f32],
) -> Result<(), EngineError> {
    let nx = grid.dims[0];
    let values = &data[..lines as usize * CHANNELS.len() * nx];
    let Some(n) = values.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let (line, within) = (n / (CHANNELS.len() * nx), n % (CHANNELS.len() * nx));
    let (channel, i) = (within / nx, within % nx);
    let point = (first_line + line as u64) * nx as u64 + i as u64;
    let [x, y, z] = grid.indices(point).map(|v| v as f64);
    let at = |d: usize, v: f64| grid.origin_mm[d] + v * grid.spacing_mm[d];
    Err(EngineError::NotFinite {
        what: format!(
            "{} at X={:.3} Y={:.3} Z={:.3} mm",
            CHANNELS[channel],
            at(0, x),
            at(1, y),
            at(2, z)
        ),
        inputs: machine.inputs.describe(machine),
    })
}

/// Keeps the values of the points of `checked` that a chunk holds (in point order, after those
/// kept so far), and returns the number of the point after the chunk.
pub(super) fn capture(
    checked: &[u64],
    captured: &mut Vec<[f32; 6]>,
    first_line: u64,
    lines: u64,
    nx: usize,
    data: &[f32],
) -> u64 {
    let first_point = first_line * nx as u64;
    let end_point = first_point + lines * nx as u64;
    for &p in checked
        .iter()
        .skip(captured.len())
        .take_while(|&&p| p < end_point)
    {
        let local = (p - first_point) as usize;
        let (line, i) = (local / nx, local % nx);
        let base = line * CHANNELS.len() * nx + i;
        captured.push(std::array::from_fn(|c| data[base + c * nx]));
    }
    end_point
}

/// Recomputes `points` with the f64 reference and compares with `values` (channel order), one
/// value per point.
pub fn check_against_reference(
    machine: &Machine,
    grid: &Grid,
    points: &[u64],
    values: &[[f32; 6]],
) -> CheckResult {
    // A value missing would leave its point unchecked and the check passing on less.
    assert_eq!(points.len(), values.len(), "a value per checked point");
    let twin = Twin::of(machine);
    let mut result = CheckResult {
        points: points.len(),
        max_ve_diff_mm: 0.0,
        max_oe_diff_rad: 0.0,
        worst: None,
    };
    for (&p, got) in points.iter().zip(values) {
        let want = reference::point_values(&twin, grid, grid.indices(p));
        result.add(CheckedPoint::of(grid, p, got, &want, &want));
    }
    result
}
