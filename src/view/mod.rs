//! `volmap view`: one self-contained HTML page of a field and its machine, opened from disk in a
//! browser with no server and no network (docs/view.md). The page's data are the field's values
//! at a subset of its grid nodes (every node up to [`MAX_NODES`] along an axis, else evenly
//! spaced nodes, the ends included): values at nodes, never interpolated, so the page shows at
//! each node what `volmap sample` gives there.
//!
//! Layout of the values in the page: point `p = i + nx·(j + ny·k)` over the nodes shown, then
//! the six channels of [`CHANNELS`] (OE.X OE.Y OE.Z in rad, VE.X VE.Y VE.Z in mm), f32 little
//! endian, base64.

mod page;

pub use page::page;

use base64::Engine as _;
use serde::Serialize;

use crate::engine::uncertainty::UncertaintyMethod;
use crate::engine::{Engine, EngineError};
use crate::io::field::{FieldError, FieldFile, FieldInfo};
use crate::model::channels::CHANNELS;
use crate::model::grid::Grid;
use crate::model::Machine;
use crate::part::FeatureResult;

/// Nodes shown along each axis at most: 64³ nodes of 6 f32 values are 6.3 MB, 8.4 MB in base64,
/// which a browser decodes in well under a second.
pub const MAX_NODES: usize = 64;
/// Parts (poses) a page holds at most: the page's data grow with them.
pub const MAX_PARTS: usize = 64;

/// One field of the page: one pose of the machine.
#[derive(Debug, Clone, Serialize)]
pub struct ViewPart {
    /// The pose in words (`B=30,C=60`; empty for a machine without rotary axes).
    pub name: String,
    pub pose_deg: [f64; 3],
    /// The evaluation inputs in words.
    pub inputs: String,
    /// The grid nodes of the field along X, Y, Z.
    pub full_dims: [usize; 3],
    /// The nodes shown along X, Y, Z.
    pub dims: [usize; 3],
    /// Which of the field's nodes are shown along each axis (indices into its grid).
    pub node_indices: [Vec<usize>; 3],
    /// Commanded X, Y, Z of the nodes shown along each axis, mm.
    pub coords_mm: [Vec<f64>; 3],
    /// The values (see the module's documentation), base64.
    pub values: String,
    /// The standard uncertainties of the channels at the same nodes, where the field has them.
    pub uncertainty: Option<String>,
    /// The method of the uncertainties, as the field records it.
    pub uncertainty_method: Option<String>,
    /// The largest |VE| over every node of the field (not only those shown), mm, and where.
    pub largest_ve_mm: f64,
    pub largest_at_mm: [f64; 3],
    /// The largest |OE| over every node of the field, rad.
    pub largest_oe_rad: f64,
}

/// A feature of a part evaluated on the machine, as the page lists it.
#[derive(Debug, Clone, Serialize)]
pub struct ViewFeature {
    pub name: String,
    pub kind: String,
    pub error_mm: f64,
    pub tolerance_mm: f64,
    pub u_expanded_mm: f64,
    /// Li's rating: `fit`, `inspect` or `unfit`.
    pub verdict: String,
    /// The ISO 14253-1 decision in words.
    pub conformance: String,
    /// The commanded position of the cutter where its worst point was cut, mm.
    pub worst_point_mm: [f64; 3],
}

impl ViewFeature {
    pub fn of(row: &FeatureResult) -> ViewFeature {
        ViewFeature {
            name: row.name.clone(),
            kind: row.kind.clone(),
            error_mm: row.error_mm,
            tolerance_mm: row.tolerance_mm,
            u_expanded_mm: row.u_expanded_mm,
            verdict: format!("{:?}", row.verdict).to_lowercase(),
            conformance: row.conformance.words().to_string(),
            worst_point_mm: row.worst_point,
        }
    }
}

/// Everything the page shows.
#[derive(Debug, Clone, Serialize)]
pub struct ViewData {
    /// The volmap that wrote the page.
    pub written_by: String,
    pub machine: String,
    pub chain: String,
    /// Where the values come from: the field file's name, or the machine mapped.
    pub source: String,
    pub device: String,
    pub channels: [&'static str; 6],
    pub parts: Vec<ViewPart>,
    /// The part file whose features are drawn, where one was given.
    pub part_file: Option<String>,
    pub features: Vec<ViewFeature>,
    /// The commanded positions of the cutter the features' evaluation asked for, mm (at most
    /// [`MAX_CUTTER_POINTS`], evenly taken).
    pub cutter_points_mm: Vec<[f64; 3]>,
}

/// Cutter positions the page draws at most.
pub const MAX_CUTTER_POINTS: usize = 20_000;

/// The nodes shown of `n` along an axis: all up to `max`, else `max` evenly spaced, both ends
/// included.
pub fn shown_nodes(n: usize, max: usize) -> Vec<usize> {
    let max = max.max(2);
    if n <= max {
        return (0..n).collect();
    }
    (0..max)
        .map(|j| ((j as f64) * (n - 1) as f64 / (max - 1) as f64).round() as usize)
        .collect()
}

/// `values` as base64 of their little-endian bytes.
pub fn encode(values: &[f32]) -> String {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// The nodes shown and their coordinates, for a grid of `dims` from `origin_mm` by `spacing_mm`.
fn nodes(
    dims: [usize; 3],
    origin_mm: [f64; 3],
    spacing_mm: [f64; 3],
    max: usize,
) -> ([Vec<usize>; 3], [Vec<f64>; 3]) {
    let indices = [0, 1, 2].map(|d| shown_nodes(dims[d], max));
    let coords = [0, 1, 2].map(|d| {
        indices[d]
            .iter()
            .map(|&i| origin_mm[d] + i as f64 * spacing_mm[d])
            .collect()
    });
    (indices, coords)
}

/// The largest |VE| (mm), where (node indices), and the largest |OE| (rad) over lines of a
/// field, each line `6·nx` values channel by channel.
#[derive(Default)]
struct Largest {
    ve_mm: f64,
    at: [usize; 3],
    oe_rad: f64,
}

impl Largest {
    fn line(&mut self, line: &[f32], nx: usize, j: usize, k: usize) {
        for i in 0..nx {
            let c = |n: usize| line[n * nx + i] as f64;
            let ve = c(3).hypot(c(4)).hypot(c(5));
            let oe = c(0).hypot(c(1)).hypot(c(2));
            if ve > self.ve_mm {
                self.ve_mm = ve;
                self.at = [i, j, k];
            }
            self.oe_rad = self.oe_rad.max(oe);
        }
    }
}

/// Part `part` of a field file at the nodes shown (at most `max` along an axis): every line of
/// the field read once, in order (memory holds the nodes shown, not the field).
pub fn read_part(file: &FieldFile, part: usize, max: usize) -> Result<ViewPart, FieldError> {
    let info = file.info(part);
    let [nx, ny, nz] = info.dims;
    let (indices, coords) = nodes(info.dims, info.origin_mm, info.spacing_mm, max);
    let shown = [indices[0].len(), indices[1].len(), indices[2].len()];
    let mut values = vec![0.0f32; shown[0] * shown[1] * shown[2] * 6];
    let mut reader = file.reader(part)?;
    let mut line = vec![0.0f32; 6 * nx];
    let mut largest = Largest::default();
    // Which shown row (j) and plane (k) each line of the field is, if any.
    let row_of = position_map(ny, &indices[1]);
    let plane_of = position_map(nz, &indices[2]);
    for (k, &plane) in plane_of.iter().enumerate() {
        for (j, &row) in row_of.iter().enumerate() {
            reader.read_line((j + ny * k) as u64, &mut line)?;
            largest.line(&line, nx, j, k);
            if let (Some(jj), Some(kk)) = (row, plane) {
                gather(&line, nx, &indices[0], shown, jj, kk, &mut values);
            }
        }
    }
    let uncertainty = match file.uncertainty_reader(part) {
        Some(reader) => {
            let mut reader = reader?;
            let mut u = vec![0.0f32; values.len()];
            for (kk, &k) in indices[2].iter().enumerate() {
                for (jj, &j) in indices[1].iter().enumerate() {
                    reader.read_line((j + ny * k) as u64, &mut line)?;
                    gather(&line, nx, &indices[0], shown, jj, kk, &mut u);
                }
            }
            Some(encode(&u))
        }
        None => None,
    };
    Ok(ViewPart {
        name: file.name(part),
        pose_deg: info.pose_deg,
        inputs: info.inputs.describe(),
        full_dims: info.dims,
        dims: shown,
        uncertainty,
        uncertainty_method: file.uncertainty(part).map(str::to_string),
        largest_ve_mm: largest.ve_mm,
        largest_at_mm: at_mm(&info, largest.at),
        largest_oe_rad: largest.oe_rad,
        node_indices: indices,
        coords_mm: coords,
        values: encode(&values),
    })
}

fn at_mm(info: &FieldInfo, at: [usize; 3]) -> [f64; 3] {
    [0, 1, 2].map(|d| info.origin_mm[d] + at[d] as f64 * info.spacing_mm[d])
}

/// For each of `n` nodes, its place among `shown`, if shown.
fn position_map(n: usize, shown: &[usize]) -> Vec<Option<usize>> {
    let mut map = vec![None; n];
    for (place, &node) in shown.iter().enumerate() {
        map[node] = Some(place);
    }
    map
}

/// The shown points of one field line (channel by channel) into the page's layout (point by
/// point) at shown row `jj` and plane `kk`.
fn gather(
    line: &[f32],
    nx: usize,
    xs: &[usize],
    shown: [usize; 3],
    jj: usize,
    kk: usize,
    out: &mut [f32],
) {
    for (ii, &i) in xs.iter().enumerate() {
        let p = ii + shown[0] * (jj + shown[1] * kk);
        for c in 0..6 {
            out[6 * p + c] = line[c * nx + i];
        }
    }
}

/// The machine mapped over `grid` on `engine` (with the first-order uncertainty where its
/// error values carry one), at most `max` nodes shown along an axis.
pub fn map_part(
    machine: &Machine,
    grid: &Grid,
    engine: &Engine,
    max: usize,
    (name, inputs): (String, String),
) -> Result<ViewPart, EngineError> {
    let [nx, ny, nz] = grid.dims;
    let (indices, coords) = nodes(grid.dims, grid.origin_mm, grid.spacing_mm, max);
    let shown = [indices[0].len(), indices[1].len(), indices[2].len()];
    let row_of = position_map(ny, &indices[1]);
    let plane_of = position_map(nz, &indices[2]);
    let mut values = vec![0.0f32; shown[0] * shown[1] * shown[2] * 6];
    let mut largest = Largest::default();
    engine.run::<EngineError>(machine, grid, None, |first_line, lines, data| {
        for n in 0..lines as usize {
            let line_index = first_line as usize + n;
            let (j, k) = (line_index % ny, line_index / ny);
            let line = &data[n * 6 * nx..(n + 1) * 6 * nx];
            largest.line(line, nx, j, k);
            if let (Some(jj), Some(kk)) = (row_of[j], plane_of[k]) {
                gather(line, nx, &indices[0], shown, jj, kk, &mut values);
            }
        }
        Ok(())
    })?;
    let (uncertainty, method) = if machine.uncertainty.is_empty() {
        (None, None)
    } else {
        let method = UncertaintyMethod::FirstOrder;
        let mut u = vec![0.0f32; values.len()];
        engine.run_uncertainty::<EngineError>(
            machine,
            grid,
            method,
            None,
            |first_line, lines, data| {
                for n in 0..lines as usize {
                    let line_index = first_line as usize + n;
                    let (j, k) = (line_index % ny, line_index / ny);
                    if let (Some(jj), Some(kk)) = (row_of[j], plane_of[k]) {
                        let line = &data[n * 6 * nx..(n + 1) * 6 * nx];
                        gather(line, nx, &indices[0], shown, jj, kk, &mut u);
                    }
                }
                Ok(())
            },
        )?;
        (Some(encode(&u)), Some(method.describe()))
    };
    Ok(ViewPart {
        name,
        pose_deg: [grid.pose[3], grid.pose[4], grid.pose[5]],
        inputs,
        full_dims: grid.dims,
        dims: shown,
        uncertainty,
        uncertainty_method: method,
        largest_ve_mm: largest.ve_mm,
        largest_at_mm: [0, 1, 2]
            .map(|d| grid.origin_mm[d] + largest.at[d] as f64 * grid.spacing_mm[d]),
        largest_oe_rad: largest.oe_rad,
        node_indices: indices,
        coords_mm: coords,
        values: encode(&values),
    })
}

/// The page's data of `parts` with the machine's name and chain, `source` and `device` in words.
pub fn view_data(
    machine: (&str, &str),
    source: String,
    device: String,
    parts: Vec<ViewPart>,
) -> ViewData {
    ViewData {
        written_by: format!("volmap {}", env!("CARGO_PKG_VERSION")),
        machine: machine.0.to_string(),
        chain: machine.1.to_string(),
        source,
        device,
        channels: CHANNELS,
        parts,
        part_file: None,
        features: Vec::new(),
        cutter_points_mm: Vec::new(),
    }
}

/// At most [`MAX_CUTTER_POINTS`] of `points`, evenly taken.
pub fn thin_points(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    if points.len() <= MAX_CUTTER_POINTS {
        return points.to_vec();
    }
    let step = points.len() as f64 / MAX_CUTTER_POINTS as f64;
    (0..MAX_CUTTER_POINTS)
        .map(|n| points[(n as f64 * step) as usize])
        .collect()
}
