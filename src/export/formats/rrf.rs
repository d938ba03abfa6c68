//! `rrf`: RepRapFirmware's axis skew compensation, `M556 S<length> X<dev> Y<dev> Z<dev> P0`
//! (RepRapFirmware's `GCodes2.cpp`, `case 556`; `Move::AxisTransform` in `Move.cpp`).
//!
//! The firmware stores each deviation over the length `S` as a tangent (32-bit float): `X` sets
//! `tanXY`, `Y` sets `tanYZ`, `Z` sets `tanXZ`; letters without `S` are ignored, `S` must be
//! positive (3.5; at least 1 on 3.4). With `P0` (the default) it sends, for a head position
//! `(x, y, z)` after the tool offset, `x + tanXY·y + tanXZ·z`, `y + tanYZ·z`, `z` (with `P1`
//! the XY term moves to Y: `y + tanXY·x`), to every move, without limits. So the correction
//! `command − target` is exactly linear: X's slopes in Y and Z and Y's slope in Z, through the
//! machine zero. `M500` does not save `M556`: the line belongs in `config.g`.

use super::skew::TERMS;
use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct Rrf;

const FILE: &str = "volmap_skew.g";
/// The length `S` the deviations are given over, mm.
const LENGTH_MM: f64 = 100.0;
/// Decimals of the deviations: 1e-10 mm over 100 mm, far below a 32-bit float's step.
const DECIMALS: usize = 10;

const SPEC: Spec = Spec {
    name: "rrf",
    title: "RepRapFirmware (M556 axis skew compensation)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Fixed,
        min_points: 0,
        max_points: 0,
        min_spacing_mm: 0.0,
        default_points: 0,
        source: "RepRapFirmware's M556: three factors",
    },
    structure: Structure::Additive(TERMS),
    holds: "three skew factors: the linear dependence of X on Y and Z and of Y on Z (squareness), applied to every move; not positioning or scale errors, straightness, angular errors' Abbe terms, backlash, offsets, nor anything that varies along an axis",
    uses_direction: false,
};

/// The firmware's three tangents (32-bit floats) and which axis the XY term corrects.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Tangents {
    xy: f32,
    yz: f32,
    xz: f32,
    /// `P0` (true, the default): X from Y; `P1`: Y from X.
    xy_on_x: bool,
}

impl Format for Rrf {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn comment_prefix(&self) -> Option<&'static str> {
        Some("; ")
    }

    fn write(
        &self,
        fitting: &Fitting,
        _points: Option<[usize; 3]>,
        _spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        // The correction's least-squares slopes are the firmware's tangents themselves.
        let fit = fitting.additive(fitting.field(), TERMS, Default::default())?;
        let deviation = |slope: f64| {
            let text = format!("{:.DECIMALS$}", slope * LENGTH_MM);
            if text
                .trim_start_matches('-')
                .chars()
                .all(|c| c == '0' || c == '.')
            {
                format!("{:.DECIMALS$}", 0.0)
            } else {
                text
            }
        };
        let (xy, xz, yz) = (fit.slopes[0][1], fit.slopes[0][2], fit.slopes[1][2]);
        let mut text: String = fitting.header.iter().map(|l| format!("; {l}\n")).collect();
        text +=
            "; RepRapFirmware axis skew compensation: over S mm, X is the deviation of X along Y\n";
        text += "; (tanXY), Y of Y along Z (tanYZ), Z of X along Z (tanXZ); with P0 the firmware sends\n";
        text +=
            "; x + tanXY*y + tanXZ*z, y + tanYZ*z, z for every move (positive: an obtuse angle).\n";
        text += "; Load: put the M556 line in config.g (M500 does not save it) or M98 P\"volmap_skew.g\"\n";
        text += "; from there; check with M556 alone (\"Axis compensations - XY: ..., YZ: ..., ZX: ...\").\n";
        text += &format!(
            "M556 S{LENGTH_MM:.0} X{} Y{} Z{} P0\n",
            deviation(xy),
            deviation(yz),
            deviation(xz)
        );
        Ok(vec![WrittenFile {
            name: fitting.file_name.clone().unwrap_or_else(|| FILE.into()),
            text,
        }])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        let file = &files[0];
        let mut t = Tangents {
            xy: 0.0,
            yz: 0.0,
            xz: 0.0,
            xy_on_x: true,
        };
        for (n, line) in file.text.lines().enumerate() {
            let code = line.split(';').next().unwrap_or("").trim();
            let mut words = code.split_whitespace();
            if words.next() != Some("M556") {
                continue;
            }
            let mut seen: [Option<f32>; 5] = [None; 5];
            for word in words {
                let mut chars = word.chars();
                let letter = chars.next().unwrap_or(' ').to_ascii_uppercase();
                let Some(slot) = "SXYZP".find(letter) else {
                    // The firmware looks only for the letters it knows.
                    continue;
                };
                let value: f32 = chars
                    .as_str()
                    .parse()
                    .map_err(|_| read_error(&file.name, n + 1, format!("`{word}` is no number")))?;
                seen[slot] = Some(value);
            }
            if let Some(s) = seen[0] {
                if s <= 0.0 {
                    return Err(read_error(
                        &file.name,
                        n + 1,
                        format!("S{s}: the length must be greater than zero"),
                    ));
                }
                // The deviations given become tangents; the others keep their values.
                if let Some(x) = seen[1] {
                    t.xy = x / s;
                }
                if let Some(y) = seen[2] {
                    t.yz = y / s;
                }
                if let Some(z) = seen[3] {
                    t.xz = z / s;
                }
            }
            if let Some(p) = seen[4] {
                t.xy_on_x = p as i32 <= 0;
            }
        }
        Ok(Box::new(t))
    }
}

impl Control for Tangents {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        let [x, y, z] = [target[0], target[1], target[2]];
        let (xy, yz, xz) = (self.xy as f64, self.yz as f64, self.xz as f64);
        if self.xy_on_x {
            c[0] = x + xy * y + xz * z;
            c[1] = y + yz * z;
        } else {
            c[0] = x + xz * z;
            c[1] = y + xy * x + yz * z;
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        vec![TableInfo {
            name: "M556".into(),
            size: format!(
                "tanXY {:.6e}, tanYZ {:.6e}, tanXZ {:.6e} ({})",
                self.xy,
                self.yz,
                self.xz,
                if self.xy_on_x { "P0" } else { "P1" }
            ),
            points: 2,
            corrects: format::SKEW_COMPONENTS,
        }]
    }
}
