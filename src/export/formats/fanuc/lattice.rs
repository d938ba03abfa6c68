//! `fanuc-3d`: the lattice of FANUC's three-dimensional error compensation (an option of the
//! Series 30i family): one compensation vector (X, Y, Z) per lattice point, absolute (not
//! incremental), in detection units (1 µm, IS-B), blended trilinearly between the eight points
//! of the lattice cell around the position (FANUC A-79351E, "Calculation of compensation").
//!
//! FANUC does not publish the transfer format of the lattice in the documents volmap cites
//! (it is written by FOCAS `cnc_wrvolc` or the machine builder's tool), so the lattice is
//! written as a CSV table the builder's tool can take: `NO,X,Y,Z,CX,CY,CZ`, X fastest, with a
//! header of `#` comment lines saying the machine, the inputs, the lattice and the sign: the
//! values are ADDED to the command (the correction, `−error` to first order). Outside the
//! lattice the nearest face's values are taken (not documented: the lattice should cover the
//! travels, which volmap's does).

use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::export::formats::grid_csv::Grid;
use crate::export::nodes::lattice;
use crate::io::csv::Csv;
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct FanucLattice;

const FILE: &str = "LATTICE.CSV";
const COLUMNS: [&str; 7] = ["NO", "X", "Y", "Z", "CX", "CY", "CZ"];
/// The detection unit: 1 µm (IS-B on a metric machine), mm.
const UNIT_MM: f64 = 0.001;

const SPEC: Spec = Spec {
    name: "fanuc-3d",
    title: "FANUC three-dimensional error compensation (lattice of compensation vectors)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        max_points: 101,
        min_spacing_mm: 1.0,
        default_points: 21,
        source: "volmap's limit for the lattice: the documents volmap cites give no lattice size; the machine builder's setting decides",
    },
    structure: Structure::Grid,
    holds: "the three-dimensional error compensation lattice holds any correction of X, Y and Z at the pose and tool length, in whole µm at the lattice points, trilinear between them; not the tool orientation",
    uses_direction: false,
};

impl Format for FanucLattice {
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
        let (axes, targets) = lattice(&fitting.ranges, points, spacing_mm, |x| {
            (x / UNIT_MM).round() * UNIT_MM
        });
        let corrections = fitting.field().corrections(&targets)?;
        let mut text = String::new();
        for line in &fitting.header {
            text += &format!("# {line}\n");
        }
        text += "# format: volmap fanuc-3d, FANUC three-dimensional error compensation: the compensation vector at each lattice point\n";
        for (d, q) in axes.iter().enumerate() {
            let step = if q.len() > 1 { q[1] - q[0] } else { 0.0 };
            text += &format!(
                "# lattice {}: {} points from {:.3} to {:.3} mm, interval {:.3} mm\n",
                COLUMNS[d + 1],
                q.len(),
                q[0],
                q[q.len() - 1],
                step
            );
        }
        text += "# NO: lattice point number, X fastest (NO = i + nx*(j + ny*k)); X, Y, Z: its machine coordinates, mm\n";
        text += "# CX, CY, CZ: the compensation ADDED to the command of each axis (the correction, not the error), absolute, detection units (1 um)\n";
        text += "# between lattice points: trilinear (FANUC A-79351E); outside the lattice: the nearest face's values\n";
        text += &COLUMNS.join(",");
        text += "\n";
        for (n, (t, d)) in targets.iter().zip(&corrections).enumerate() {
            let units = |v: f64| (v / UNIT_MM).round() as i64;
            text += &format!(
                "{n},{:.3},{:.3},{:.3},{},{},{}\n",
                t[0],
                t[1],
                t[2],
                units(d[0]),
                units(d[1]),
                units(d[2])
            );
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
        Ok(Box::new(Lattice(read_lattice(&file.text, &file.name)?)))
    }
}

/// Reads a lattice back as the control would: the header row, a complete regular lattice
/// numbered X fastest, whole detection units.
pub fn read_lattice(text: &str, name: &str) -> Result<Grid, ExportError> {
    let from_csv = |e: crate::io::csv::CsvError| read_error(name, e.line, e.message);
    let mut csv = Csv::new(text, name);
    let header = csv.header("naming NO,X,Y,Z,CX,CY,CZ").map_err(from_csv)?;
    if header.names != COLUMNS {
        return Err(read_error(
            name,
            header.line,
            format!(
                "the header names {}, not {}",
                header.names.join(","),
                COLUMNS.join(",")
            ),
        ));
    }
    let mut rows = Vec::new();
    for row in csv.rows() {
        row.require_fields(COLUMNS.len()).map_err(from_csv)?;
        let number: usize = row
            .text(0, "NO")
            .map_err(from_csv)?
            .parse()
            .map_err(|_| read_error(name, row.line, "NO is not a point number"))?;
        let mut position = [0.0; 3];
        for (d, p) in position.iter_mut().enumerate() {
            *p = row.number(d + 1, COLUMNS[d + 1]).map_err(from_csv)?;
        }
        let mut value = [0.0; 3];
        for (d, v) in value.iter_mut().enumerate() {
            let text = row.text(d + 4, COLUMNS[d + 4]).map_err(from_csv)?;
            let units: i64 = text.parse().map_err(|_| {
                read_error(
                    name,
                    row.line,
                    format!(
                        "{} = `{text}`: a whole number of detection units",
                        COLUMNS[d + 4]
                    ),
                )
            })?;
            *v = units as f64 * UNIT_MM;
        }
        rows.push((row.line, number, position, value));
    }
    let mut axes: [Vec<f64>; 3] = Default::default();
    for (d, axis) in axes.iter_mut().enumerate() {
        let mut q: Vec<f64> = rows.iter().map(|r| r.2[d]).collect();
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
                "{} points do not make a complete lattice of {nx} x {ny} x {nz}",
                rows.len()
            ),
        ));
    }
    for (d, q) in axes.iter().enumerate() {
        if q.len() > 2 {
            let step = q[1] - q[0];
            if q.windows(2)
                .any(|w| ((w[1] - w[0]) - step).abs() > 0.5 * UNIT_MM)
            {
                return Err(read_error(
                    name,
                    header.line,
                    format!(
                        "the {} positions are not at equal intervals",
                        COLUMNS[d + 1]
                    ),
                ));
            }
        }
    }
    let mut values = vec![[f64::NAN; 3]; rows.len()];
    for (line, number, p, v) in &rows {
        let index = |d: usize| axes[d].partition_point(|&q| q < p[d]);
        let at = index(0) + nx * (index(1) + ny * index(2));
        if *number != at {
            return Err(read_error(
                name,
                *line,
                format!("point {number} is lattice point {at} by its position"),
            ));
        }
        if !values[at][0].is_nan() {
            return Err(read_error(name, *line, "a lattice point given twice"));
        }
        values[at] = *v;
    }
    Ok(Grid { axes, values })
}

/// The lattice as the control applies it.
pub struct Lattice(pub Grid);

impl Control for Lattice {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let d = self.0.interpolate([target[0], target[1], target[2]]);
        let mut c = *target;
        for k in 0..3 {
            c[k] += d[k];
        }
        c
    }

    fn nodes(&self) -> Option<Vec<[f64; 3]>> {
        Some(self.0.nodes())
    }

    fn tables(&self) -> Vec<TableInfo> {
        let n: Vec<usize> = self.0.axes.iter().map(Vec::len).collect();
        let step = |d: usize| {
            let q = &self.0.axes[d];
            if q.len() > 1 {
                format!("{:.3}", q[1] - q[0])
            } else {
                "-".into()
            }
        };
        vec![TableInfo {
            name: "3-D lattice".into(),
            size: format!(
                "{} x {} x {} points ({}), interval {} x {} x {} mm",
                n[0],
                n[1],
                n[2],
                self.0.values.len(),
                step(0),
                step(1),
                step(2)
            ),
            points: n.iter().copied().max().unwrap_or(1),
            corrects: format::EVERY_COMPONENT,
        }]
    }
}
