//! `klipper-twist`: Klipper's `[axis_twist_compensation]` (`klippy/extras/axis_twist_compensation.py`).
//!
//! The module corrects the probe's readings, not the moves: on `probe:update_results` it adds to
//! each result's Z the table's value at the toolhead's X (`z_compensations` from
//! `compensation_start_x` to `compensation_end_x`, evenly spaced, linear between values and
//! extrapolated along the end segments) plus, where given, the Y table's at its Y
//! (`zy_compensations`). The bed mesh (or Z tilt) made from those readings then moves the nozzle.
//! A probe beside the nozzle reads the bed with the toolhead at `B − offset` where the nozzle
//! prints at `B`: a carriage that rolls along X (a twisted gantry) lifts one and not the other.
//!
//! Here the table is the least-squares additive fit (along X, and along Y where it holds more
//! than its decimals) of `e_p,z(T) − e_n,z(T + offset)`, the probe's Z error at toolhead `T` less
//! the nozzle's over the same bed point, zero-mean as Klipper's calibration leaves it. The
//! control it hands the residual is Klipper printing with a bed mesh probed at every point
//! through this table (the mesh's own interpolation left out; `z_offset` calibrated on average):
//! the nozzle at `B` moves by the corrected reading of the probe at `B − offset`.

use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{mean, uniform, Field, Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct KlipperTwist;

const FILE: &str = "volmap_twist.cfg";
const SECTION: &str = "axis_twist_compensation";
/// Klipper's calibration writes six decimals.
const DECIMALS: usize = 6;
/// Points of the other axis each table value is the mean over.
const ACROSS: usize = 21;

const SPEC: Spec = Spec {
    name: "klipper-twist",
    title: "Klipper ([axis_twist_compensation] of the probe's readings)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        max_points: 1001,
        min_spacing_mm: 0.0,
        default_points: 11,
        source: "Klipper's axis_twist_compensation: any number of values, at least two (volmap writes up to 1001)",
    },
    structure: Structure::ZOfXY,
    holds: "a correction of the probe's Z readings along X (and Y): what a bed mesh probed through it moves Z by at each X, Y; nothing of X's or Y's corrections, nor of how Z's varies with Z",
    uses_direction: false,
};

/// One table as Klipper holds it: values evenly from `start` to `end` of the toolhead's X or Y.
#[derive(Debug, Clone, PartialEq)]
struct Twist {
    values: Vec<f64>,
    start: f64,
    end: f64,
}

impl Twist {
    /// `_get_interpolated_z_compensation`: linear, extrapolated along the end segments.
    fn at(&self, coord: f64) -> f64 {
        let n = self.values.len();
        let spacing = (self.end - self.start) / (n - 1) as f64;
        let t = (coord - self.start) / spacing;
        let i = (t.floor().max(0.0) as usize).min(n - 2);
        let t = t - i as f64;
        (1.0 - t) * self.values[i] + t * self.values[i + 1]
    }
}

/// The probe's machine: the nozzle's with the probe's offset added to the tool offset.
fn probe_field(fitting: &Fitting, offset: [f64; 2]) -> Result<Field, ExportError> {
    let mut probe = fitting.machine.at(fitting.inputs);
    probe.tool_offset_mm[0] += offset[0];
    probe.tool_offset_mm[1] += offset[1];
    Field::new(probe, fitting.pose)
}

/// Z's error of `field`'s tip at command X, Y on the bed (Z at the start of its travel), mm.
fn z_error(field: &Field, x: f64, y: f64, z: f64) -> f64 {
    let c = field.command([x, y, z]);
    let t = field.twin();
    (t.real_tip(&c) - t.ideal_tip(&c)).z
}

/// The toolhead positions along axis `d` where the probe and the nozzle both reach the bed.
fn reach(fitting: &Fitting, offset: [f64; 2], d: usize) -> Result<[f64; 2], ExportError> {
    let [lo, hi] = fitting.ranges[d];
    let span = [lo.max(lo - offset[d]), hi.min(hi - offset[d])];
    if span[1] - span[0] <= 0.0 {
        return Err(ExportError::Unrepresentable {
            format: SPEC.name,
            message: format!(
                "a probe {} mm from the nozzle leaves no bed both reach",
                offset[d]
            ),
        });
    }
    Ok(span)
}

/// The probe's reading error against the nozzle's over the same bed point, at toolhead X, Y.
struct Probing {
    nozzle: Field,
    probe: Field,
    offset: [f64; 2],
    bed_z: f64,
    /// Where the toolhead probes: the reach of both probe and nozzle, X and Y.
    spans: [[f64; 2]; 2],
}

impl Probing {
    fn new(fitting: &Fitting) -> Result<Probing, ExportError> {
        let offset = fitting
            .probe_offset_mm
            .ok_or(ExportError::NoProbeOffset { format: SPEC.name })?;
        Ok(Probing {
            nozzle: Field::new(fitting.machine.at(fitting.inputs), fitting.pose)?,
            probe: probe_field(fitting, offset)?,
            offset,
            bed_z: fitting.ranges[2][0],
            spans: [reach(fitting, offset, 0)?, reach(fitting, offset, 1)?],
        })
    }

    /// [`ACROSS`] positions over the toolhead's reach along axis `d`.
    fn across(&self, d: usize) -> Vec<f64> {
        uniform(self.spans[d][0], self.spans[d][1], ACROSS)
    }

    /// What the probe reads wrong against the nozzle at each of [`ACROSS`] × [`ACROSS`]
    /// toolhead positions over its reach, less the tables where given.
    fn left(&self, x: Option<&Twist>, y: Option<&Twist>) -> Vec<f64> {
        let (xs, ys) = (self.across(0), self.across(1));
        let mut left = Vec::with_capacity(xs.len() * ys.len());
        for &tx in &xs {
            for &ty in &ys {
                left.push(
                    self.difference(tx, ty)
                        - x.map_or(0.0, |t| t.at(tx))
                        - y.map_or(0.0, |t| t.at(ty)),
                );
            }
        }
        left
    }

    /// `e_p,z(T) − e_n,z(T + offset)`.
    fn difference(&self, x: f64, y: f64) -> f64 {
        z_error(&self.probe, x, y, self.bed_z)
            - z_error(
                &self.nozzle,
                x + self.offset[0],
                y + self.offset[1],
                self.bed_z,
            )
    }
}

impl Format for KlipperTwist {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn comment_prefix(&self) -> Option<&'static str> {
        Some("# ")
    }

    fn takes_probe_offset(&self) -> bool {
        true
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        _spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let [nx, ny, _] = points.unwrap_or([SPEC.limits.default_points; 3]);
        let probing = Probing::new(fitting)?;
        let spans = probing.spans;
        let xs = uniform(spans[0][0], spans[0][1], nx);
        let ys = uniform(spans[1][0], spans[1][1], ny);
        let (across_x, across_y) = (probing.across(0), probing.across(1));
        // The additive fit on a factorial grid: each axis's mean over the other, less the mean.
        let along_x: Vec<f64> = xs
            .iter()
            .map(|&x| {
                mean(
                    &across_y
                        .iter()
                        .map(|&y| probing.difference(x, y))
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        let along_y: Vec<f64> = ys
            .iter()
            .map(|&y| {
                mean(
                    &across_x
                        .iter()
                        .map(|&x| probing.difference(x, y))
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        let round = |v: f64| {
            let scale = 10f64.powi(DECIMALS as i32);
            (v * scale).round() / scale
        };
        let table = |values: &[f64], nodes: &[f64]| {
            let m = mean(values);
            Twist {
                values: values.iter().map(|v| round(v - m)).collect(),
                start: nodes[0],
                end: nodes[nodes.len() - 1],
            }
        };
        let (tx, ty) = (table(&along_x, &xs), table(&along_y, &ys));
        let list = |t: &Twist| {
            t.values
                .iter()
                .map(|x| format!("{:.DECIMALS$}", if *x == 0.0 { 0.0 } else { *x }))
                .collect::<Vec<_>>()
                .join(", ")
        };
        // What the probe reads wrong against the nozzle, z_offset aside, without and with.
        let before = probing.left(None, None);
        let after = probing.left(Some(&tx), Some(&ty));
        let spread = |v: &[f64]| {
            let m = mean(v);
            v.iter().map(|d| (d - m).abs()).fold(0.0, f64::max) * 1000.0
        };
        let file = fitting.file_name.clone().unwrap_or_else(|| FILE.into());
        let mut text: String = fitting.header.iter().map(|l| format!("# {l}\n")).collect();
        text += &format!(
            "# Klipper axis twist compensation for a probe at x_offset {:.3}, y_offset {:.3} mm from the nozzle:\n",
            probing.offset[0], probing.offset[1]
        );
        text += "# it corrects the probe's readings (added to each result's Z at the toolhead's X, Y), not the\n";
        text += "# moves. Load: [include ";
        text += &file;
        text += "] in printer.cfg, RESTART, then probe again\n# (BED_MESH_CALIBRATE, Z_TILT_ADJUST): only new readings are corrected.\n";
        text += &format!(
            "# The probe's readings against the nozzle's over the same bed point (z_offset aside), over\n# {ACROSS} x {ACROSS} toolhead positions: largest {:.3} um off without the tables, {:.3} um with.\n",
            spread(&before),
            spread(&after)
        );
        text += &format!("[{SECTION}]\n");
        text += &format!("z_compensations: {}\n", list(&tx));
        text += &format!("compensation_start_x: {:.3}\n", tx.start);
        text += &format!("compensation_end_x: {:.3}\n", tx.end);
        if ty.values.iter().any(|v| *v != 0.0) {
            text += &format!("zy_compensations: {}\n", list(&ty));
            text += &format!("compensation_start_y: {:.3}\n", ty.start);
            text += &format!("compensation_end_y: {:.3}\n", ty.end);
        }
        Ok(vec![WrittenFile { name: file, text }])
    }

    fn read(
        &self,
        _files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        // The readings need the machine and the probe: see `read_for`.
        Err(ExportError::NoProbeOffset { format: SPEC.name })
    }

    fn read_for(
        &self,
        files: &[WrittenFile],
        fitting: &Fitting,
    ) -> Result<Box<dyn Control>, ExportError> {
        let probing = Probing::new(fitting)?;
        let (x, y) = read_config(&files[0])?;
        // z_offset calibrated on average: the mean of what the tables leave.
        let z_offset = mean(&probing.left(x.as_ref(), y.as_ref()));
        Ok(Box::new(Probed {
            z_offset,
            probing,
            x,
            y,
        }))
    }
}

/// `[axis_twist_compensation]` as Klipper's config reads it: `key: value` or `key = value`,
/// `#`/`;` comments; a table needs its start and end and two values or more.
fn read_config(file: &WrittenFile) -> Result<(Option<Twist>, Option<Twist>), ExportError> {
    let name = &file.name;
    let mut section = String::new();
    let mut values: std::collections::BTreeMap<String, (usize, String)> = Default::default();
    for (n, line) in file.text.lines().enumerate() {
        let line = line.split(['#', ';']).next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = s.trim().to_string();
            continue;
        }
        let (key, value) = line
            .split_once([':', '='])
            .map(|(k, v)| (k.trim(), v.trim()))
            .ok_or_else(|| read_error(name, n + 1, "not `key: value`"))?;
        if section == SECTION {
            values.insert(key.to_string(), (n + 1, value.to_string()));
        }
    }
    let number = |key: &str| -> Result<Option<f64>, ExportError> {
        values
            .get(key)
            .map(|(n, v)| {
                v.parse()
                    .map_err(|_| read_error(name, *n, format!("{key}: `{v}` is not a number")))
            })
            .transpose()
    };
    let table = |list: &str, start: &str, end: &str| -> Result<Option<Twist>, ExportError> {
        let Some((n, text)) = values.get(list) else {
            return Ok(None);
        };
        let parsed: Result<Vec<f64>, _> = text
            .split(',')
            .map(str::trim)
            .filter(|v| !v.is_empty())
            .map(str::parse)
            .collect();
        let values =
            parsed.map_err(|_| read_error(name, *n, format!("{list}: not a list of numbers")))?;
        if values.len() < 2 {
            return Err(read_error(name, *n, format!("{list}: two values or more")));
        }
        let (Some(start), Some(end)) = (number(start)?, number(end)?) else {
            return Err(read_error(
                name,
                *n,
                format!("{list} needs {start} and {end}"),
            ));
        };
        Ok(Some(Twist { values, start, end }))
    };
    Ok((
        table(
            "z_compensations",
            "compensation_start_x",
            "compensation_end_x",
        )?,
        table(
            "zy_compensations",
            "compensation_start_y",
            "compensation_end_y",
        )?,
    ))
}

/// Klipper printing with a bed mesh probed at every point through the tables.
struct Probed {
    probing: Probing,
    x: Option<Twist>,
    y: Option<Twist>,
    z_offset: f64,
}

impl Control for Probed {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let p = &self.probing;
        // The mesh at bed point B was probed with the toolhead at B − offset (its edge held).
        let tx = (target[0] - p.offset[0]).clamp(p.spans[0][0], p.spans[0][1]);
        let ty = (target[1] - p.offset[1]).clamp(p.spans[1][0], p.spans[1][1]);
        let reading = -z_error(&p.probe, tx, ty, p.bed_z)
            + self.x.as_ref().map_or(0.0, |t| t.at(tx))
            + self.y.as_ref().map_or(0.0, |t| t.at(ty));
        let mut c = *target;
        c[2] += reading + self.z_offset;
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        let describe = |axis: &str, t: &Twist| TableInfo {
            name: format!("twist along {axis}"),
            size: format!(
                "{} values from {:.3} to {:.3} mm (toolhead {axis})",
                t.values.len(),
                t.start,
                t.end
            ),
            points: t.values.len(),
            corrects: format::component(2),
        };
        self.x
            .iter()
            .map(|t| describe("X", t))
            .chain(self.y.iter().map(|t| describe("Y", t)))
            .collect()
    }
}
