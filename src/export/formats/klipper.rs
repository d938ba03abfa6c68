//! `klipper`: Klipper's `[skew_correction]` with a saved profile `[skew_correction volmap]`
//! (`xy_skew`, `xz_skew`, `yz_skew`), loaded by `SKEW_PROFILE LOAD=volmap` (Klipper docs, "Skew
//! correction", "G-Codes" §`[skew_correction]`; `klippy/extras/skew_correction.py`). The
//! transform applies to every move's end point before the kinematics, over the whole
//! workspace, with no limits on the factors (see [`super::skew`]).

use super::skew::{square_lengths, Skew, TERMS};
use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Fitting, Structure};
use crate::export::format::{
    self, Control, Format, Layout, Limits, Nodes, Spec, TableInfo, WrittenFile,
};
use crate::model::inputs::Approach;
use crate::model::Command;

pub struct Klipper;

const FILE: &str = "volmap_skew.cfg";
const PROFILE: &str = "volmap";
/// Decimals of the factors: 1e-12, a nanometre over a metre.
const DECIMALS: usize = 12;

const SPEC: Spec = Spec {
    name: "klipper",
    title: "Klipper ([skew_correction] profile)",
    layout: Layout::File,
    limits: Limits {
        nodes: Nodes::Fixed,
        min_points: 0,
        max_points: 0,
        min_spacing_mm: 0.0,
        default_points: 0,
        source: "Klipper's skew_correction: three factors",
    },
    structure: Structure::Additive(TERMS),
    holds: "three skew factors: the linear dependence of X on Y and Z and of Y on Z (squareness); not positioning or scale errors, straightness, angular errors' Abbe terms, backlash, offsets, nor anything that varies along an axis",
    uses_direction: false,
};

impl Format for Klipper {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn comment_prefix(&self) -> Option<&'static str> {
        Some("# ")
    }

    fn write(
        &self,
        fitting: &Fitting,
        _points: Option<[usize; 3]>,
        _spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let skew = Skew::fit(fitting)?.rounded(DECIMALS);
        // printer.cfg includes the file by the name it is written as.
        let file = fitting.file_name.clone().unwrap_or_else(|| FILE.into());
        let mut text: String = fitting.header.iter().map(|l| format!("# {l}\n")).collect();
        text += "# Klipper skew correction: the factors describe the machine (x_real = x + xy*y + xz*z,\n";
        text += "# y_real = y + yz*z); Klipper sends x - y*xy - z*(xz - xy*yz), y - z*yz for x, y, z.\n";
        text += &format!(
            "# Load: [include {file}] in printer.cfg (beside it), RESTART; in the start G-code after G28:\n# SKEW_PROFILE LOAD={PROFILE}; in the end G-code: SET_SKEW CLEAR=1. Check with GET_CURRENT_SKEW.\n"
        );
        let lengths: Vec<String> = skew
            .named()
            .iter()
            .map(|(plane, f)| {
                let [ac, bd, ad] = square_lengths(*f, 100.0);
                format!("{plane}={ac:.12},{bd:.12},{ad:.12}")
            })
            .collect();
        text += &format!(
            "# The same factors as the lengths of a virtual 100 mm square, in a session:\n# SET_SKEW {}\n",
            lengths.join(" ")
        );
        text += "[skew_correction]\n\n";
        text += &format!("[skew_correction {PROFILE}]\n");
        for (key, v) in [
            ("xy_skew", skew.xy),
            ("xz_skew", skew.xz),
            ("yz_skew", skew.yz),
        ] {
            text += &format!("{key} = {v:.DECIMALS$}\n");
        }
        Ok(vec![WrittenFile { name: file, text }])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        let file = &files[0];
        Ok(Box::new(read_config(&file.text, &file.name)?))
    }
}

/// The skew Klipper holds after `SKEW_PROFILE LOAD=volmap`; none without `[skew_correction]`.
struct Loaded(Option<Skew>);

/// Reads the configuration as Klipper's config parser does: `[section]`, `key = value` or
/// `key: value`, `#` and `;` comments; the profile's three keys are required.
fn read_config(text: &str, name: &str) -> Result<Loaded, ExportError> {
    let mut section = String::new();
    let mut module = false;
    let mut values: [Option<f64>; 3] = [None; 3];
    let keys = ["xy_skew", "xz_skew", "yz_skew"];
    for (n, line) in text.lines().enumerate() {
        let line = line.split(['#', ';']).next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = s.trim().to_string();
            module |= section == "skew_correction";
            continue;
        }
        let (key, value) = line
            .split_once(['=', ':'])
            .map(|(k, v)| (k.trim(), v.trim()))
            .ok_or_else(|| read_error(name, n + 1, "not `key = value`"))?;
        if section == format!("skew_correction {PROFILE}") {
            let Some(k) = keys.iter().position(|&x| x == key) else {
                return Err(read_error(name, n + 1, format!("unknown option {key}")));
            };
            values[k] = Some(
                value
                    .parse()
                    .map_err(|_| read_error(name, n + 1, format!("`{value}` is not a number")))?,
            );
        }
    }
    if !module {
        return Ok(Loaded(None));
    }
    let [Some(xy), Some(xz), Some(yz)] = values else {
        return Err(read_error(
            name,
            1,
            format!("profile {PROFILE} lacks one of xy_skew, xz_skew, yz_skew"),
        ));
    };
    Ok(Loaded(Some(Skew { xy, xz, yz })))
}

impl Control for Loaded {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        if let Some(skew) = &self.0 {
            let raw = skew.skewed([target[0], target[1], target[2]]);
            c[..3].copy_from_slice(&raw);
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        let s = self.0.unwrap_or(Skew {
            xy: 0.0,
            xz: 0.0,
            yz: 0.0,
        });
        vec![TableInfo {
            name: "skew".into(),
            size: format!(
                "xy_skew {:.6e}, xz_skew {:.6e}, yz_skew {:.6e}",
                s.xy, s.xz, s.yz
            ),
            points: 2,
            corrects: format::SKEW_COMPONENTS,
        }]
    }
}
