//! A plane of a field for a colour map, reading only the lines the plane crosses.

use std::path::Path;

use super::QueryError;
use crate::io::field::{FieldError, FieldFile, FieldInfo, FieldReader};
use crate::io::vtk::ImageGrid;
use crate::model::channels::CHANNELS;

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
    /// The colour bar's label, the quantity as the title names it with its unit: `|VE| (mm)`,
    /// `OE.Z (rad)`.
    pub unit: String,
    /// Whether the values are signed (a channel, drawn on a scale diverging about zero) rather
    /// than a magnitude.
    pub signed: bool,
    /// Where the plane lies in the field's grid (one index along the normal), for VTK.
    pub image: ImageGrid,
    /// The quantity with its unit as one word, the name of a VTK array: `VE_magnitude_mm`,
    /// `OE.Z_rad`.
    pub array_name: String,
}

/// What a slice shows at each point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// |VE|, mm.
    VolumetricMagnitude,
    /// |OE|, rad.
    OrientationMagnitude,
    /// One channel of [`CHANNELS`] (`VE.X` … `OE.Z`).
    Channel(usize),
    /// |u(VE)|, mm: the root sum of squares of the standard uncertainties of VE's components,
    /// from the part of uncertainties `map --uncertainty` writes.
    UncertaintyMagnitude,
    /// The standard uncertainty of one channel of [`CHANNELS`] (`u(VE.X)` … `u(OE.Z)`).
    Uncertainty(usize),
}

impl Quantity {
    /// `VE`, `OE`, a channel name, `u` (or `u(VE)`) or `u(` a channel name `)`, in either case
    /// (as the axis of a slice is).
    pub fn parse(text: &str) -> Option<Quantity> {
        let text = text.trim().to_ascii_uppercase();
        let channel = |name: &str| CHANNELS.iter().position(|c| *c == name);
        match text.as_str() {
            "VE" => Some(Quantity::VolumetricMagnitude),
            "OE" => Some(Quantity::OrientationMagnitude),
            "U" | "U(VE)" => Some(Quantity::UncertaintyMagnitude),
            other => match other.strip_prefix("U(").and_then(|t| t.strip_suffix(')')) {
                Some(inner) => channel(inner.trim()).map(Quantity::Uncertainty),
                None => channel(other).map(Quantity::Channel),
            },
        }
    }

    /// Its name as the colour bar and the title write it: `|VE|`, `|OE|`, `VE.X`, `u(VE)`,
    /// `u(VE.X)`.
    pub fn name(self) -> String {
        match self {
            Quantity::VolumetricMagnitude => "|VE|".into(),
            Quantity::OrientationMagnitude => "|OE|".into(),
            Quantity::Channel(c) => CHANNELS[c].into(),
            Quantity::UncertaintyMagnitude => "u(VE)".into(),
            Quantity::Uncertainty(c) => format!("u({})", CHANNELS[c]),
        }
    }

    /// Whether it is drawn from the part of uncertainties.
    pub fn is_uncertainty(self) -> bool {
        matches!(
            self,
            Quantity::UncertaintyMagnitude | Quantity::Uncertainty(_)
        )
    }

    /// What can be asked for, in words.
    pub fn choices() -> String {
        format!(
            "VE, OE or one of {}; or of a field with uncertainties u (|u(VE)|) or one of u(VE.X) … u(OE.Z)",
            CHANNELS.join(", ")
        )
    }

    /// The channels that make the quantity, whether it is their magnitude (drawn from zero up
    /// rather than about zero), and the unit.
    fn channels(self) -> (Vec<usize>, bool, &'static str) {
        let unit = |c: usize| if c < 3 { "rad" } else { "mm" };
        match self {
            Quantity::VolumetricMagnitude | Quantity::UncertaintyMagnitude => {
                (vec![3, 4, 5], true, "mm")
            }
            Quantity::OrientationMagnitude => (vec![0, 1, 2], true, "rad"),
            Quantity::Channel(c) => (vec![c], false, unit(c)),
            // A standard uncertainty is never negative: a magnitude's scale.
            Quantity::Uncertainty(c) => (vec![c], true, unit(c)),
        }
    }
}

/// Reads the grid plane across axis `normal` (`x`, `y` or `z`) nearest to `at` (mm; default the
/// middle) and takes `quantity` there: `VE` (|VE|, mm), `OE` (|OE|, rad) or one channel
/// (`VE.X` … `OE.Z`). Only the lines the plane crosses are read. A five-axis map (a multi-part
/// file) needs [`field_slice_at_pose`].
pub fn field_slice(
    path: &Path,
    normal: &str,
    at: Option<f64>,
    quantity: &str,
) -> Result<FieldSlice, QueryError> {
    field_slice_at_pose(path, None, normal, at, quantity)
}

/// [`field_slice`] in the part of the field file that holds `pose` (degrees of A, B, C, with its
/// words for messages): a five-axis map has one part per pose, and one not holding the pose is an
/// error listing those it holds; so is a single-part file at another pose. Without a pose, a
/// file of several poses is an error listing them.
pub fn field_slice_at_pose(
    path: &Path,
    pose: Option<([f64; 3], &str)>,
    normal: &str,
    at: Option<f64>,
    quantity: &str,
) -> Result<FieldSlice, QueryError> {
    let d = match normal.trim() {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        other => return Err(QueryError::SliceNormal(other.to_string())),
    };
    let parsed = Quantity::parse(quantity)
        .ok_or_else(|| QueryError::SliceQuantity(quantity.trim().to_string()))?;
    let (channels, magnitude, unit) = parsed.channels();
    crate::io::source::note_source(path);
    let file = FieldFile::open(path)?;
    let part = match pose {
        Some((degrees, words)) => file.part_at(degrees, words)?,
        None => file.single()?,
    };
    let mut reader = if parsed.is_uncertainty() {
        file.required_uncertainty_reader(part)?
    } else {
        file.reader(part)?
    };
    let info = reader.info().clone();
    let index = plane_index(&info, d, at)?;
    let (h, v) = match d {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let (cols, rows) = (info.dims[h], info.dims[v]);
    // The plane's values are held at once, 8 bytes each: bounded as a field read is.
    let bytes = (cols as u64).saturating_mul(rows as u64).saturating_mul(8);
    let limit = crate::io::field::field_memory_bytes();
    if bytes > limit {
        return Err(FieldError::TooLarge {
            path: path.display().to_string(),
            what: format!("a slice of {cols}x{rows} points"),
            bytes,
            limit,
        }
        .into());
    }
    let values = read_plane(&mut reader, d, index, |line, i| {
        let nx = info.dims[0];
        let parts = channels.iter().map(|&c| line[c * nx + i] as f64);
        if magnitude {
            parts.map(|x| x * x).sum::<f64>().sqrt()
        } else {
            parts.sum()
        }
    })?;
    let axis = ['X', 'Y', 'Z'];
    let span = |a: usize| {
        let o = info.origin_mm[a];
        (o, o + (info.dims[a] - 1) as f64 * info.spacing_mm[a])
    };
    let (h_lo, h_hi) = span(h);
    let (v_lo, v_hi) = span(v);
    let position = info.origin_mm[d] + index as f64 * info.spacing_mm[d];
    let mut extent = info.dims.map(|n| [0, n - 1]);
    extent[d] = [index, index];
    let image = ImageGrid {
        extent,
        origin_mm: info.origin_mm,
        spacing_mm: info.spacing_mm,
    };
    let array_name = match parsed {
        Quantity::VolumetricMagnitude => "VE_magnitude_mm".to_string(),
        Quantity::OrientationMagnitude => "OE_magnitude_rad".to_string(),
        Quantity::Channel(c) => format!("{}_{unit}", CHANNELS[c]),
        Quantity::UncertaintyMagnitude => "u_VE_magnitude_mm".to_string(),
        Quantity::Uncertainty(c) => format!("u_{}_{unit}", CHANNELS[c]),
    };
    // The part of a sweep says its pose; a single-pose field's title stays as it was.
    let machine = if file.is_multipart() {
        format!("{} at {}", info.machine_name, file.name(part))
    } else {
        info.machine_name.clone()
    };
    Ok(FieldSlice {
        title: format!(
            "{machine}: {} at {}={position:.1} mm",
            parsed.name(),
            axis[d]
        ),
        labels: [format!("{} (mm)", axis[h]), format!("{} (mm)", axis[v])],
        extent: (h_lo, h_hi, v_lo, v_hi),
        cols,
        rows,
        values,
        unit: format!("{} ({unit})", parsed.name()),
        signed: !magnitude,
        image,
        array_name,
    })
}

/// The grid plane across dimension `d` nearest to `at` (mm; default the middle).
fn plane_index(info: &FieldInfo, d: usize, at: Option<f64>) -> Result<usize, QueryError> {
    let n = info.dims[d];
    let Some(q) = at else {
        return Ok(n / 2);
    };
    let (origin, step) = (info.origin_mm[d], info.spacing_mm[d]);
    let end = origin + (n - 1) as f64 * step;
    // A position that is not a number lies on no grid.
    if !(q >= origin.min(end) - 1e-9 && q <= origin.max(end) + 1e-9) {
        return Err(QueryError::SliceOutside {
            axis: ['X', 'Y', 'Z'][d],
            at: q,
            lo: origin,
            hi: end,
        });
    }
    Ok(if step > 0.0 {
        ((q - origin) / step).round() as usize
    } else {
        0
    }
    .min(n - 1))
}

/// The values of plane `index` across dimension `d`, `value_at(line, i)` at each of its points,
/// row by row; only the lines the plane crosses are read.
fn read_plane(
    reader: &mut FieldReader,
    d: usize,
    index: usize,
    value_at: impl Fn(&[f32], usize) -> f64,
) -> Result<Vec<f64>, QueryError> {
    let [nx, ny, nz] = reader.info().dims;
    let cols = if d == 0 { ny } else { nx };
    let rows = if d == 2 { ny } else { nz };
    let mut values = vec![0.0; cols * rows];
    let mut line = vec![0.0f32; CHANNELS.len() * nx];
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
    Ok(values)
}
