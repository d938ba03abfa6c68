//! `linuxcnc`: one compensation file per joint (`COMP_FILE_TYPE = 1`: rows `nominal
//! forward-trim reverse-trim`), the `matrixkins` coefficients for the linear cross terms
//! (squareness), and the INI lines that load them (LinuxCNC docs, "INI Configuration",
//! `[JOINT_<num>]` `COMP_FILE`, `COMP_FILE_TYPE`; matrixkins(9)).
//!
//! What the control does (LinuxCNC's motion module): the kinematics first, `j = C·P` with
//! matrixkins (identity with trivkins), joints 0, 1, 2 = X, Y, Z; then each joint's commanded
//! position `j_k` looks up its file, linear between nominals, the end values outside, the
//! forward trim while the joint moves `+` and the reverse trim while it moves `−`, and the trim
//! is added to the command sent to the drive: `c_k = j_k + trim_k(j_k)`. Trims are stored as
//! 32-bit floats. At most 256 entries per joint (`EMCMOT_COMP_SIZE`), nominals strictly
//! increasing, no comment before the rows (reading stops at the first line that is not three
//! numbers, so provenance goes after them).

use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure, Term, AVERAGING_POINTS, LINEAR};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::export::nodes::{candidates, free_nodes};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct LinuxCnc;

const INI: &str = "linuxcnc.ini";
const HAL: &str = "volmap_matrixkins.hal";
/// Decimals of nominals and trims, mm.
const DECIMALS: usize = 7;
/// Decimals of the matrixkins coefficients.
const COEFFICIENT_DECIMALS: usize = 12;
/// Most entries of one compensation file (LinuxCNC's `EMCMOT_COMP_SIZE`).
const MAX_ENTRIES: usize = 256;

/// The name of joint `joint`'s table in the report.
fn joint_name(joint: usize) -> String {
    format!("joint {joint} ({})", LINEAR[joint])
}

fn comp_file(joint: usize) -> String {
    format!("volmap_joint{joint}_{}.comp", LINEAR[joint])
}

/// Off-diagonal matrixkins terms: the correction of each axis as a slope in the others.
const TERMS: [[Term; 3]; 3] = [
    [Term::Curve, Term::Slope, Term::Slope],
    [Term::Slope, Term::Curve, Term::Slope],
    [Term::Slope, Term::Slope, Term::Curve],
];

/// The versions `--control` takes: the current stable release first (2.9.10 in November 2026),
/// then 2.10, the first with matrixkins (not in any 2.9 tag).
const CONTROLS: &[&str] = &["2.9", "2.10"];

const LIMITS: Limits = Limits {
    nodes: Nodes::Free,
    min_points: 2,
    max_points: MAX_ENTRIES,
    min_spacing_mm: 0.0,
    default_points: MAX_ENTRIES,
    source: "LinuxCNC's EMCMOT_COMP_SIZE",
};

/// LinuxCNC 2.10: joint compensation files and matrixkins.
const SPEC: Spec = Spec {
    name: "linuxcnc",
    title: "LinuxCNC 2.10 (joint compensation files, matrixkins)",
    layout: Layout::Folder,
    limits: LIMITS,
    structure: Structure::Additive(TERMS),
    holds: "per joint, its correction along its own axis as a function of its own position, forward and reverse; with matrixkins one constant linear map of X, Y, Z (squareness); not straightness, angular errors' Abbe terms, sag or other errors that vary with another axis's position nonlinearly, nor rotary axes",
    uses_direction: true,
};

/// LinuxCNC 2.9: joint compensation files alone (trivkins).
const SPEC_2_9: Spec = Spec {
    title: "LinuxCNC 2.9 (joint compensation files; no matrixkins, so no squareness)",
    structure: Structure::Additive([
        [Term::Curve, Term::None, Term::None],
        [Term::None, Term::Curve, Term::None],
        [Term::None, Term::None, Term::Curve],
    ]),
    holds: "per joint, its correction along its own axis as a function of its own position, forward and reverse; not squareness (matrixkins comes with LinuxCNC 2.10), straightness, angular errors' Abbe terms, sag or other errors of another axis's position, nor rotary axes",
    ..SPEC
};

impl Format for LinuxCnc {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn controls(&self) -> &'static [&'static str] {
        CONTROLS
    }

    fn note_tables(&self, files: &mut [WrittenFile], notes: &[(String, String)]) {
        // A joint's file ends in `#` notes (LinuxCNC stops reading at the first line that is
        // not three numbers), and HAL takes `#` comments.
        for (table, line) in notes {
            let file = if table == "matrixkins" {
                HAL.to_string()
            } else {
                match (0..3).find(|&k| *table == joint_name(k)) {
                    Some(k) => comp_file(k),
                    None => continue,
                }
            };
            if let Some(f) = files.iter_mut().find(|f| f.name == file) {
                f.text += &format!("# {line}\n");
            }
        }
    }

    fn spec_for(&self, control: Option<&str>) -> &'static Spec {
        if control == Some("2.9") {
            &SPEC_2_9
        } else {
            &SPEC
        }
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        _spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([MAX_ENTRIES; 3]);
        let mut slopes_only = TERMS;
        for (k, row) in slopes_only.iter_mut().enumerate() {
            row[k] = Term::None;
        }
        // LinuxCNC 2.9 has no matrixkins: C stays the identity (trivkins).
        let with_kinematics = fitting.control != Some("2.9");
        let skew = fitting.additive(fitting.field(), slopes_only, Default::default())?;
        // C = I + S, written to 12 decimals; the trims are fitted against C as written.
        let c: [[f64; 3]; 3] = std::array::from_fn(|k| {
            std::array::from_fn(|i| {
                let v = if i == k {
                    1.0
                } else if with_kinematics {
                    skew.slopes[k][i]
                } else {
                    0.0
                };
                round(v, COEFFICIENT_DECIMALS)
            })
        });
        let uses_kinematics = (0..3).any(|k| (0..3).any(|i| i != k && c[k][i] != 0.0));
        let mut files = Vec::new();
        for (k, &n) in points.iter().enumerate() {
            files.push(WrittenFile {
                name: comp_file(k),
                text: joint_table(fitting, k, n, &c)?,
            });
        }
        files.push(WrittenFile {
            name: INI.into(),
            text: ini_snippet(fitting, uses_kinematics),
        });
        if uses_kinematics {
            let mut text: String = fitting.header.iter().map(|l| format!("# {l}\n")).collect();
            text += "# matrixkins(9): joints = C · (X, Y, Z); C = identity + the linear cross terms of the\n";
            text += "# correction (squareness). Load after the HAL file that does `loadrt [KINS]KINEMATICS`.\n";
            for (k, row) in c.iter().enumerate() {
                for (i, v) in row.iter().enumerate() {
                    let name = |d: usize| LINEAR[d].to_string().to_lowercase();
                    text += &format!(
                        "setp matrixkins.C_{}{} {}\n",
                        name(k),
                        name(i),
                        fixed(*v, COEFFICIENT_DECIMALS)
                    );
                }
            }
            files.push(WrittenFile {
                name: HAL.into(),
                text,
            });
        }
        Ok(files)
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        read_configuration(files).map(|c| Box::new(c) as Box<dyn Control>)
    }
}

/// `v` rounded to `decimals` decimals.
fn round(v: f64, decimals: usize) -> f64 {
    let scale = 10f64.powi(decimals as i32);
    let r = (v * scale).round() / scale;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// `v` with `decimals` decimals, `-0` written `0`.
fn fixed(v: f64, decimals: usize) -> String {
    format!("{:.decimals$}", round(v, decimals))
}

/// The compensation file of joint `k` with at most `n` entries, for the kinematics `c`.
fn joint_table(
    fitting: &Fitting,
    k: usize,
    n: usize,
    c: &[[f64; 3]; 3],
) -> Result<String, ExportError> {
    // The joint positions the table is looked up by: j_k = Σ_i C_ki·t_i over the travels.
    let (mut lo, mut hi) = (0.0, 0.0);
    for (i, range) in fitting.ranges.iter().enumerate() {
        let ends = [c[k][i] * range[0], c[k][i] * range[1]];
        lo += ends[0].min(ends[1]);
        hi += ends[0].max(ends[1]);
    }
    let count = (4 * (n - 1) + 1).clamp(201, 1025);
    let breaks = crate::export::fitting::breakpoints(fitting.machine, LINEAR[k]);
    let mut q = candidates(lo, hi, count, &breaks);
    // The trim of joint k at each candidate: the mean correction of axis k over the others at
    // that position, less what the kinematics' cross terms already add on average.
    let means_of_cross: f64 = (0..3)
        .filter(|&i| i != k)
        .map(|i| c[k][i] * 0.5 * (fitting.ranges[i][0] + fitting.ranges[i][1]))
        .sum();
    let fields = [
        fitting.field_approaching(k, Approach::Positive)?,
        fitting.field_approaching(k, Approach::Negative)?,
    ];
    let same = fields[0].twin().real() == fields[1].twin().real();
    let trims_at = |positions: &[f64]| -> Result<[Vec<f64>; 2], ExportError> {
        let mut grid: [Vec<f64>; 3] = std::array::from_fn(|d| fitting.travel(d, AVERAGING_POINTS));
        grid[k] = positions.to_vec();
        let forward = fields[0].axis_means(k, &grid)?[k].clone();
        let reverse = if same {
            forward.clone()
        } else {
            fields[1].axis_means(k, &grid)?[k].clone()
        };
        let less = |v: Vec<f64>| v.into_iter().map(|g| g - means_of_cross).collect();
        Ok([less(forward), less(reverse)])
    };
    let mut trims = trims_at(&q)?;
    // A kink of the model at command b is a kink of the trim at the target b − trim(b).
    let shifted: Vec<f64> = breaks
        .iter()
        .filter(|&&b| b > lo && b < hi)
        .flat_map(|&b| {
            let i = (0..q.len())
                .min_by(|&x, &y| (q[x] - b).abs().total_cmp(&(q[y] - b).abs()))
                .unwrap_or(0);
            [b - trims[0][i], b - trims[1][i]]
        })
        .filter(|&s| s > lo && s < hi)
        .collect();
    if !shifted.is_empty() {
        let extra = trims_at(&shifted)?;
        let mut merged: Vec<(f64, f64, f64)> = q
            .iter()
            .zip(&trims[0])
            .zip(&trims[1])
            .map(|((&q, &f), &r)| (q, f, r))
            .collect();
        for (n, &s) in shifted.iter().enumerate() {
            if merged.iter().all(|m| (m.0 - s).abs() > (hi - lo) * 1e-9) {
                merged.push((s, extra[0][n], extra[1][n]));
            }
        }
        merged.sort_by(|a, b| a.0.total_cmp(&b.0));
        q = merged.iter().map(|m| m.0).collect();
        trims = [
            merged.iter().map(|m| m.1).collect(),
            merged.iter().map(|m| m.2).collect(),
        ];
    }
    let tolerance = 0.5 * 10f64.powi(-(DECIMALS as i32));
    let nodes = free_nodes(&q, &[&trims[0], &trims[1]], n, 0.0, tolerance);
    let mut text = String::new();
    for &i in &nodes {
        text += &format!(
            "{} {} {}\n",
            fixed(q[i], DECIMALS),
            fixed(trims[0][i], DECIMALS),
            fixed(trims[1][i], DECIMALS)
        );
    }
    // LinuxCNC stops reading at the first line that is not three numbers: the notes go after.
    for line in &fitting.header {
        text += &format!("# {line}\n");
    }
    text += &format!(
        "# joint {k} ({}), COMP_FILE_TYPE 1, mm: nominal forward-trim reverse-trim, {} entries\n",
        LINEAR[k],
        nodes.len()
    );
    text +=
        "# nominal: the joint's commanded position (machine coordinates, after the kinematics)\n";
    text +=
        "# trim: the correction ADDED to the joint's command (not the error); forward while the\n";
    text +=
        "# joint moves +, reverse while it moves -; linear between nominals, end values outside\n";
    Ok(text)
}

/// The INI lines that load the files.
fn ini_snippet(fitting: &Fitting, uses_kinematics: bool) -> String {
    let mut text: String = fitting.header.iter().map(|l| format!("# {l}\n")).collect();
    let version = fitting.control.unwrap_or(CONTROLS[0]);
    text += &format!(
        "# Add these lines to the machine's INI file (LinuxCNC {version}), with the files\n"
    );
    text += "# beside it; then restart LinuxCNC and home. Joints 0, 1, 2 are X, Y, Z, in mm\n";
    text += "# ([TRAJ]LINEAR_UNITS = mm); volmap's axis zeros are the joints' home zeros.\n";
    if uses_kinematics {
        text += "# matrixkins came with LinuxCNC 2.10; the HAL file must load after the one\n";
        text +=
            "# that does `loadrt [KINS]KINEMATICS`. Joints 3, 4, 5 are A, B, C (matrixkins(9)).\n";
        // matrixkins passes the joints after X, Y, Z through to A, B, C in order.
        let joints = fitting
            .machine
            .rotary_axes()
            .iter()
            .map(|l| l.index() + 1)
            .max()
            .unwrap_or(3);
        text += &format!("\n[KINS]\nKINEMATICS = matrixkins\nJOINTS = {joints}\n");
        text += &format!("\n[HAL]\nHALFILE = {HAL}\n");
    } else if version == "2.9" {
        text +=
            "# LinuxCNC 2.9 has no matrixkins (it came with 2.10): the kinematics stay trivkins,\n";
        text += "# and the correction's linear cross terms (squareness) are NOT held (the report says how much).\n";
    } else {
        text += "# The correction has no linear cross terms: the kinematics stay trivkins.\n";
    }
    for k in 0..3 {
        text += &format!(
            "\n[JOINT_{k}]\n# BACKLASH is not used with a COMP_FILE: the reverse trims hold it\nCOMP_FILE = {}\nCOMP_FILE_TYPE = 1\n",
            comp_file(k)
        );
    }
    text
}

/// One joint's table as LinuxCNC holds it: nominals, trims as 32-bit floats.
#[derive(Debug, Clone, PartialEq)]
struct JointTable {
    nominal: Vec<f64>,
    forward: Vec<f32>,
    reverse: Vec<f32>,
}

impl JointTable {
    /// The trim at commanded joint position `j`: linear between nominals, the slope a 32-bit
    /// float as LinuxCNC precomputes it, the end values outside.
    fn trim(&self, j: f64, forward: bool) -> f64 {
        let trims = if forward {
            &self.forward
        } else {
            &self.reverse
        };
        let n = self.nominal.len();
        if n == 0 {
            return 0.0;
        }
        if j < self.nominal[0] {
            return trims[0] as f64;
        }
        let i = self.nominal.partition_point(|&q| q <= j) - 1;
        if i + 1 >= n {
            return trims[n - 1] as f64;
        }
        let slope = ((trims[i + 1] - trims[i]) as f64 / (self.nominal[i + 1] - self.nominal[i]))
            as f32 as f64;
        trims[i] as f64 + slope * (j - self.nominal[i])
    }
}

/// Reads a compensation file as LinuxCNC's `usrmotLoadComp` does: three numbers per line until
/// the first line that is not, an entry that does not increase skipped, at most 256.
fn read_comp(text: &str, name: &str, file_type: u8) -> Result<JointTable, ExportError> {
    let mut table = JointTable {
        nominal: Vec::new(),
        forward: Vec::new(),
        reverse: Vec::new(),
    };
    for (n, line) in text.lines().enumerate() {
        let numbers: Vec<f64> = line
            .split_whitespace()
            .take(3)
            .map_while(|w| w.parse().ok())
            .collect();
        let [nominal, second, third] = numbers[..] else {
            break;
        };
        if table.nominal.len() >= MAX_ENTRIES {
            return Err(read_error(name, n + 1, "more than 256 entries"));
        }
        if table.nominal.last().is_some_and(|&last| nominal <= last) {
            return Err(read_error(name, n + 1, "nominals must increase"));
        }
        let (forward, reverse) = match file_type {
            0 => (nominal - second, nominal - third),
            _ => (second, third),
        };
        table.nominal.push(nominal);
        table.forward.push(forward as f32);
        table.reverse.push(reverse as f32);
    }
    if table.nominal.is_empty() {
        return Err(read_error(name, 1, "no entries"));
    }
    Ok(table)
}

/// The configuration as LinuxCNC loads it from the INI lines, the files they name and the HAL
/// file of matrixkins.
struct Configuration {
    /// `C` of matrixkins (identity with trivkins).
    kinematics: [[f64; 3]; 3],
    joints: [Option<JointTable>; 3],
}

fn file<'a>(files: &'a [WrittenFile], name: &str) -> Result<&'a WrittenFile, ExportError> {
    files
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| read_error(INI, 1, format!("{name} is not among the files written")))
}

fn read_configuration(files: &[WrittenFile]) -> Result<Configuration, ExportError> {
    let ini = file(files, INI)?;
    let mut section = String::new();
    let mut kinematics = "trivkins".to_string();
    let mut hal_files = Vec::new();
    let mut comp: [(Option<String>, u8); 3] = Default::default();
    for (n, line) in ini.text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with(';') {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.to_string();
            continue;
        }
        let (key, value) = line
            .split_once('=')
            .map(|(k, v)| (k.trim(), v.trim()))
            .ok_or_else(|| read_error(INI, n + 1, "not KEY = VALUE"))?;
        let joint = section
            .strip_prefix("JOINT_")
            .and_then(|j| j.parse::<usize>().ok())
            .filter(|&j| j < 3);
        match (section.as_str(), key, joint) {
            ("KINS", "KINEMATICS", _) => kinematics = value.to_string(),
            ("HAL", "HALFILE", _) => hal_files.push(value.to_string()),
            (_, "COMP_FILE", Some(j)) => comp[j].0 = Some(value.to_string()),
            (_, "COMP_FILE_TYPE", Some(j)) => {
                comp[j].1 = value
                    .parse()
                    .ok()
                    .filter(|t| *t <= 1)
                    .ok_or_else(|| read_error(INI, n + 1, "COMP_FILE_TYPE is 0 or 1"))?;
            }
            _ => {}
        }
    }
    let mut c = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if kinematics == "matrixkins" {
        for hal in &hal_files {
            let hal = file(files, hal)?;
            for (n, line) in hal.text.lines().enumerate() {
                let words: Vec<&str> = line.split_whitespace().collect();
                let ["setp", parameter, value] = words[..] else {
                    continue;
                };
                let Some(name) = parameter.strip_prefix("matrixkins.C_") else {
                    continue;
                };
                let index = |ch: char| "xyz".find(ch);
                let mut letters = name.chars();
                let (Some(k), Some(i), None) = (
                    letters.next().and_then(index),
                    letters.next().and_then(index),
                    letters.next(),
                ) else {
                    return Err(read_error(
                        &hal.name,
                        n + 1,
                        format!("no parameter {parameter}"),
                    ));
                };
                c[k][i] = value.parse().map_err(|_| {
                    read_error(&hal.name, n + 1, format!("`{value}` is not a number"))
                })?;
            }
        }
    }
    let mut joints: [Option<JointTable>; 3] = Default::default();
    for (j, (name, file_type)) in comp.iter().enumerate() {
        if let Some(name) = name {
            let f = file(files, name)?;
            joints[j] = Some(read_comp(&f.text, &f.name, *file_type)?);
        }
    }
    Ok(Configuration {
        kinematics: c,
        joints,
    })
}

impl Control for Configuration {
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        let mut out = *target;
        for k in 0..3 {
            let j: f64 = (0..3).map(|i| self.kinematics[k][i] * target[i]).sum();
            let trim = self.joints[k]
                .as_ref()
                .map_or(0.0, |t| t.trim(j, approach[k] == Approach::Positive));
            out[k] = j + trim;
        }
        out
    }

    fn tables(&self) -> Vec<TableInfo> {
        let mut tables: Vec<TableInfo> = self
            .joints
            .iter()
            .enumerate()
            .filter_map(|(k, t)| {
                let t = t.as_ref()?;
                let n = t.nominal.len();
                Some(TableInfo {
                    name: joint_name(k),
                    size: format!(
                        "{n} entries from {:.3} to {:.3} mm, forward and reverse",
                        t.nominal[0],
                        t.nominal[n - 1]
                    ),
                    points: n,
                    corrects: format::component(k),
                })
            })
            .collect();
        let c = &self.kinematics;
        if (0..3).any(|k| (0..3).any(|i| i != k && c[k][i] != 0.0)) {
            tables.push(TableInfo {
                name: "matrixkins".into(),
                size: format!(
                    "C_xy {:.3e}, C_xz {:.3e}, C_yx {:.3e}, C_yz {:.3e}, C_zx {:.3e}, C_zy {:.3e}",
                    c[0][1], c[0][2], c[1][0], c[1][2], c[2][0], c[2][1]
                ),
                points: 2,
                corrects: format::EVERY_COMPONENT,
            });
        }
        tables
    }
}
