//! `grid-csv`: the generic three-dimensional correction grid, `X,Y,Z,dX,dY,dZ` at the nodes
//! of a regular grid over the travels (X fastest, then Y, then Z), in mm, with a header of
//! comment lines saying the machine, the inputs, the pose, the grid and the sign: the values
//! are added to the command (`command = target + (dX, dY, dZ)`). The control is taken to
//! interpolate trilinearly between the nodes, the edge's values outside. Where the machine gives
//! uncertainties, `u(dX),u(dY),u(dZ)` follow: each correction's standard uncertainty, mm.
//!
//! The CSV follows volmap's one CSV grammar (one header row, comma-separated fields, `#`
//! comment lines) and reads back with its one reader.

use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure};
use crate::export::format::{
    Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile, EVERY_COMPONENT,
};
use crate::export::nodes::lattice;
use crate::export::uncertainty;
use crate::io::csv::Csv;
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct GridCsv;

const FILE: &str = "grid.csv";
const COLUMNS: [&str; 6] = ["X", "Y", "Z", "dX", "dY", "dZ"];
/// The standard uncertainties of the corrections, named as `sample` names its u columns: the
/// u of the column named inside. Written only where the machine gives uncertainties.
const U_COLUMNS: [&str; 3] = ["u(dX)", "u(dY)", "u(dZ)"];
/// Decimals of positions and corrections, mm: 1 nm.
const DECIMALS: usize = 6;
/// Decimals of the uncertainties, mm: 1 pm (a u is often a fraction of a micrometre).
const U_DECIMALS: usize = 9;

const SPEC: Spec = Spec {
    name: "grid-csv",
    title: "generic 3-D correction grid (CSV)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        max_points: 101,
        min_spacing_mm: 0.1,
        default_points: 21,
        source: "volmap's limits for the generic grid",
    },
    structure: Structure::Grid,
    holds: "a 3-D grid holds any correction of X, Y and Z at the pose, to within its trilinear interpolation between nodes",
    uses_direction: false,
};

impl Format for GridCsv {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn comment_prefix(&self) -> Option<&'static str> {
        Some("# ")
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([SPEC.limits.default_points; 3]);
        let (axes, targets) = lattice(&fitting.ranges, points, spacing_mm, |x| x);
        let corrections = fitting.field().corrections(&targets)?;
        let u = uncertainty::correction_u(fitting, &targets);
        let mut text = String::new();
        for line in &fitting.header {
            text += &format!("# {line}\n");
        }
        text +=
            "# format: volmap grid-csv, the command correction at the nodes of a regular grid\n";
        for (d, q) in axes.iter().enumerate() {
            let step = if q.len() > 1 { q[1] - q[0] } else { 0.0 };
            text += &format!(
                "# grid {}: {} points from {} to {} mm, spacing {} mm\n",
                COLUMNS[d],
                q.len(),
                fmt(q[0]),
                fmt(q[q.len() - 1]),
                fmt(step)
            );
        }
        text += "# rows: X fastest, then Y, then Z; positions and corrections in mm\n";
        text += "# sign: the correction is ADDED to the command: command = target + (dX, dY, dZ) (the correction, not the error)\n";
        text += "# between nodes: trilinear interpolation; outside the grid the nearest edge's values\n";
        if u.is_some() {
            text += "# u(dX), u(dY), u(dZ): the standard uncertainty of each correction, mm, from the u of the machine's error values (GUM first order at the node's command)\n";
        }
        text += &COLUMNS.join(",");
        if u.is_some() {
            text += ",";
            text += &U_COLUMNS.join(",");
        }
        text += "\n";
        for (n, (t, d)) in targets.iter().zip(&corrections).enumerate() {
            text += &format!(
                "{},{},{},{},{},{}",
                fmt(t[0]),
                fmt(t[1]),
                fmt(t[2]),
                fmt(d[0]),
                fmt(d[1]),
                fmt(d[2])
            );
            if let Some(u) = &u {
                let [ux, uy, uz] = u[n];
                text += &format!(",{ux:.U_DECIMALS$},{uy:.U_DECIMALS$},{uz:.U_DECIMALS$}");
            }
            text += "\n";
        }
        Ok(vec![WrittenFile {
            name: FILE.into(),
            text,
        }])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        let file = &files[0];
        Ok(Box::new(read_grid(&file.text, &file.name)?))
    }
}

/// A number with [`DECIMALS`] decimals, `-0` written `0`.
fn fmt(v: f64) -> String {
    let text = format!("{v:.DECIMALS$}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        format!("{:.DECIMALS$}", 0.0)
    } else {
        text
    }
}

/// A grid read back: the node positions per axis and the corrections, X fastest.
pub struct Grid {
    pub axes: [Vec<f64>; 3],
    pub values: Vec<[f64; 3]>,
}

/// The columns of a `grid-csv` header: the corrections', with the uncertainties' or without.
fn columns_of(names: &[String]) -> Option<usize> {
    let plain = names.len() >= COLUMNS.len() && names[..COLUMNS.len()] == COLUMNS;
    match names.len() {
        6 if plain => Some(6),
        9 if plain && names[COLUMNS.len()..] == U_COLUMNS => Some(9),
        _ => None,
    }
}

/// Reads a `grid-csv` file as a control would: the header row, a complete regular grid.
pub fn read_grid(text: &str, name: &str) -> Result<Grid, ExportError> {
    let from_csv = |e: crate::io::csv::CsvError| read_error(name, e.line, e.message);
    let mut csv = Csv::new(text, name);
    let header = csv.header("naming X,Y,Z,dX,dY,dZ").map_err(from_csv)?;
    let Some(fields) = columns_of(&header.names) else {
        return Err(read_error(
            name,
            header.line,
            format!(
                "the header names {}, not X,Y,Z,dX,dY,dZ (then, optionally, u(dX),u(dY),u(dZ))",
                header.names.join(",")
            ),
        ));
    };
    let mut rows = Vec::new();
    for row in csv.rows() {
        row.require_fields(fields).map_err(from_csv)?;
        let mut v = [0.0; 6];
        for (n, c) in COLUMNS.iter().enumerate() {
            v[n] = row.number(n, c).map_err(from_csv)?;
        }
        // The uncertainties must read as numbers, none below zero; the control ignores them.
        for (n, c) in U_COLUMNS.iter().enumerate().take(fields - 6) {
            let u = row.number(6 + n, c).map_err(from_csv)?;
            if u < 0.0 {
                return Err(read_error(
                    name,
                    row.line,
                    format!("{c} is {u}, below zero"),
                ));
            }
        }
        rows.push((row.line, v));
    }
    let mut axes: [Vec<f64>; 3] = Default::default();
    for (d, axis) in axes.iter_mut().enumerate() {
        let mut q: Vec<f64> = rows.iter().map(|(_, v)| v[d]).collect();
        q.sort_by(f64::total_cmp);
        q.dedup();
        *axis = q;
    }
    let [nx, ny, nz] = [axes[0].len(), axes[1].len(), axes[2].len()];
    if rows.len() != nx * ny * nz {
        return Err(read_error(
            name,
            header.line,
            format!(
                "{} rows do not make a complete grid of {nx} x {ny} x {nz} nodes",
                rows.len()
            ),
        ));
    }
    for (d, q) in axes.iter().enumerate() {
        if q.len() > 2 {
            let step = q[1] - q[0];
            // Positions written to DECIMALS decimals differ from an even step by their rounding.
            let slack = 2.0 * 10f64.powi(-(DECIMALS as i32)) + 1e-9 * step.abs();
            if q.windows(2).any(|w| ((w[1] - w[0]) - step).abs() > slack) {
                return Err(read_error(
                    name,
                    header.line,
                    format!("the {} positions are not evenly spaced", COLUMNS[d]),
                ));
            }
        }
    }
    let mut values = vec![[f64::NAN; 3]; rows.len()];
    for (line, v) in &rows {
        let index = |d: usize| axes[d].partition_point(|&q| q < v[d]);
        let at = index(0) + nx * (index(1) + ny * index(2));
        if !values[at][0].is_nan() {
            return Err(read_error(name, *line, "a node given twice"));
        }
        values[at] = [v[3], v[4], v[5]];
    }
    Ok(Grid { axes, values })
}

impl Grid {
    /// The nodes' positions, X fastest, then Y, then Z.
    pub fn nodes(&self) -> Vec<[f64; 3]> {
        let mut out = Vec::with_capacity(self.values.len());
        for &z in &self.axes[2] {
            for &y in &self.axes[1] {
                for &x in &self.axes[0] {
                    out.push([x, y, z]);
                }
            }
        }
        out
    }

    /// The cell index and fraction of `x` along axis `d`, clamped to the grid.
    fn locate(&self, d: usize, x: f64) -> (usize, f64) {
        let q = &self.axes[d];
        if q.len() == 1 {
            return (0, 0.0);
        }
        let x = x.clamp(q[0], q[q.len() - 1]);
        let i = q.partition_point(|&p| p <= x).clamp(1, q.len() - 1) - 1;
        (i, (x - q[i]) / (q[i + 1] - q[i]))
    }

    /// The correction at `xyz`, trilinear in its cell.
    pub fn interpolate(&self, xyz: [f64; 3]) -> [f64; 3] {
        let [nx, ny] = [self.axes[0].len(), self.axes[1].len()];
        let cells: [(usize, f64); 3] = std::array::from_fn(|d| self.locate(d, xyz[d]));
        let mut out = [0.0; 3];
        for corner in 0..8 {
            let mut w = 1.0;
            let mut at = [0usize; 3];
            for d in 0..3 {
                let (i, u) = cells[d];
                let upper = corner >> d & 1 == 1;
                if upper && self.axes[d].len() == 1 {
                    w = 0.0;
                }
                at[d] = if upper {
                    (i + 1).min(self.axes[d].len() - 1)
                } else {
                    i
                };
                w *= if upper { u } else { 1.0 - u };
            }
            if w == 0.0 {
                continue;
            }
            let v = self.values[at[0] + nx * (at[1] + ny * at[2])];
            for k in 0..3 {
                out[k] += w * v[k];
            }
        }
        out
    }
}

impl Control for Grid {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let d = self.interpolate([target[0], target[1], target[2]]);
        let mut c = *target;
        for k in 0..3 {
            c[k] += d[k];
        }
        c
    }

    fn nodes(&self) -> Option<Vec<[f64; 3]>> {
        Some(self.nodes())
    }

    fn tables(&self) -> Vec<TableInfo> {
        let n: Vec<usize> = self.axes.iter().map(Vec::len).collect();
        let step = |d: usize| {
            let q = &self.axes[d];
            if q.len() > 1 {
                fmt_short(q[1] - q[0])
            } else {
                "-".into()
            }
        };
        vec![TableInfo {
            name: "grid".into(),
            size: format!(
                "{} x {} x {} points ({}), spacing {} x {} x {} mm",
                n[0],
                n[1],
                n[2],
                self.values.len(),
                step(0),
                step(1),
                step(2)
            ),
            points: n.iter().copied().max().unwrap_or(1),
            corrects: EVERY_COMPONENT,
        }]
    }
}

/// A spacing in words: at most 3 decimals, trailing zeros dropped.
fn fmt_short(v: f64) -> String {
    let text = format!("{v:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}
