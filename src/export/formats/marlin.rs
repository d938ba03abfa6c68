//! `marlin`: Marlin's bed skew compensation, `M852 I<xy> J<xz> K<yz>` then `M500` (marlinfw.org,
//! "M852 - Bed Skew Compensation"; `Configuration.h` "Bed Skew Compensation"; `Planner::skew` in
//! `planner.h`). Each factor lies in −1 to 1 (`SKEW_FACTOR_MIN`, `SKEW_FACTOR_MAX`), is read
//! without an exponent (the number ends at an `E`) into a 32-bit float, and `J`, `K` need
//! `SKEW_CORRECTION_FOR_Z`.
//!
//! Marlin corrects a target only inside its travel: when `X_MIN_POS + 1 ≤ x ≤ X_MAX_POS` and
//! `Y_MIN_POS + 1 ≤ y ≤ Y_MAX_POS`, and only when the corrected X, Y stay within
//! `[X_MIN_POS, X_MAX_POS] × [Y_MIN_POS, Y_MAX_POS]`; other targets pass uncorrected. The
//! residual takes the machine's travels as those limits.

use super::skew::{Skew, TERMS};
use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct Marlin;

const FILE: &str = "volmap_skew.gcode";
/// Decimals of the factors (fixed point: Marlin reads no exponent).
const DECIMALS: usize = 12;
/// `SKEW_FACTOR_MIN`, `SKEW_FACTOR_MAX`.
const FACTOR_LIMIT: f64 = 1.0;

const SPEC: Spec = Spec {
    name: "marlin",
    title: "Marlin (M852 bed skew compensation)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Fixed,
        min_points: 0,
        max_points: 0,
        min_spacing_mm: 0.0,
        default_points: 0,
        source: "Marlin's M852: three factors",
    },
    structure: Structure::Additive(TERMS),
    holds: "three skew factors from -1 to 1: the linear dependence of X on Y and Z and of Y on Z (squareness), applied only to targets at least 1 mm inside the X and Y minimum whose corrected X, Y stay within the travel; not positioning or scale errors, straightness, angular errors' Abbe terms, backlash, offsets, nor anything that varies along an axis",
    uses_direction: false,
};

impl Format for Marlin {
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
        let skew = Skew::fit(fitting)?.rounded(DECIMALS);
        for (plane, f) in skew.named() {
            if f.abs() > FACTOR_LIMIT {
                return Err(ExportError::BeyondFormat {
                    format: SPEC.name,
                    what: format!("the {plane} skew factor"),
                    value: f,
                    holds: "skew factors from -1 to 1 (SKEW_FACTOR_MIN, SKEW_FACTOR_MAX)",
                });
            }
        }
        let [x, y] = [fitting.ranges[0], fitting.ranges[1]];
        let mut text: String = fitting.header.iter().map(|l| format!("; {l}\n")).collect();
        text += "; Marlin bed skew compensation (SKEW_CORRECTION and SKEW_CORRECTION_GCODE; J and K need\n";
        text += "; SKEW_CORRECTION_FOR_Z; M500 needs EEPROM_SETTINGS). The factors describe the machine\n";
        text += "; (x_real = x + I*y + J*z, y_real = y + K*z); Marlin sends x - y*I - z*(J - I*K), y - z*K.\n";
        text += &format!(
            "; Marlin corrects targets with X {} to {} and Y {} to {} mm (X_MIN_POS + 1 .. X_MAX_POS,\n; Y_MIN_POS + 1 .. Y_MAX_POS) whose corrected point stays in the travel. Home after loading.\n",
            x[0] + 1.0,
            x[1],
            y[0] + 1.0,
            y[1]
        );
        text += "G21\n";
        text += &format!(
            "M852 I{:.DECIMALS$} J{:.DECIMALS$} K{:.DECIMALS$}\n",
            skew.xy, skew.xz, skew.yz
        );
        text += "M500\n";
        Ok(vec![WrittenFile {
            name: FILE.into(),
            text,
        }])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        let file = &files[0];
        let mut factors = [0.0f32; 3];
        for (n, line) in file.text.lines().enumerate() {
            let code = line.split(';').next().unwrap_or("").trim();
            let mut words = code.split_whitespace();
            if words.next() != Some("M852") {
                continue;
            }
            for word in words {
                let (letter, value) = word.split_at(1);
                let index = match letter {
                    "I" | "S" => 0,
                    "J" => 1,
                    "K" => 2,
                    _ => {
                        return Err(read_error(
                            &file.name,
                            n + 1,
                            format!("unknown word {word}"),
                        ))
                    }
                };
                let v = marlin_float(value).ok_or_else(|| {
                    read_error(&file.name, n + 1, format!("`{word}` is no number"))
                })?;
                // Marlin ignores a value outside −1 to 1 and keeps the previous one.
                if (v as f64).abs() <= FACTOR_LIMIT {
                    factors[index] = v;
                }
            }
        }
        Ok(Box::new(Gated {
            skew: Skew {
                xy: factors[0] as f64,
                xz: factors[1] as f64,
                yz: factors[2] as f64,
            },
            x: travel_mm[0],
            y: travel_mm[1],
        }))
    }
}

/// A number as Marlin's parser reads it: up to an `E` (no exponent), as a 32-bit float.
fn marlin_float(text: &str) -> Option<f32> {
    let end = text.find(['E', 'e']).unwrap_or(text.len());
    text[..end].parse().ok()
}

/// The skew Marlin applies, with its travel limits.
struct Gated {
    skew: Skew,
    x: [f64; 2],
    y: [f64; 2],
}

impl Control for Gated {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        let within = |v: f64, lo: f64, hi: f64| lo <= v && v <= hi;
        let (x, y) = (target[0], target[1]);
        if within(x, self.x[0] + 1.0, self.x[1]) && within(y, self.y[0] + 1.0, self.y[1]) {
            let raw = self.skew.skewed([x, y, target[2]]);
            if within(raw[0], self.x[0], self.x[1]) && within(raw[1], self.y[0], self.y[1]) {
                c[0] = raw[0];
                c[1] = raw[1];
            }
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        let s = &self.skew;
        vec![TableInfo {
            name: "M852".into(),
            size: format!("I {:.6e}, J {:.6e}, K {:.6e}", s.xy, s.xz, s.yz),
            points: 2,
            corrects: format::SKEW_COMPONENTS,
        }]
    }
}
