//! Writing a field's header: the image attributes OpenEXR needs and volmap's own. Attribute names
//! are volmap's, never the input's, so they stay within OpenEXR's 31 bytes whatever the machine
//! file holds (a CSV table's path, however long, is an attribute value).

use super::blocks::{compression_code, Storage};
use super::inputs;
use super::{
    grid_text, FieldInfo, FLAG_LONG_NAMES, FLAG_MULTIPART, MAGIC, PIXEL_FLOAT, PIXEL_HALF, UNITS,
    VERSION,
};
use crate::model::channels::CHANNELS;

/// The names of the attributes of the `n`-th CSV table the machine file reads: its path as the
/// machine file writes it, and its text.
pub(super) fn csv_attribute_names(n: usize) -> (String, String) {
    (format!("volmap.csvPath.{n}"), format!("volmap.csvText.{n}"))
}

/// The longest attribute name (and type name) OpenEXR reads without the long-names flag.
const SHORT_NAME_BYTES: usize = 31;

pub(super) struct HeaderBuilder {
    pub bytes: Vec<u8>,
    pub long_names: bool,
}

impl HeaderBuilder {
    fn attribute(&mut self, name: &str, kind: &str, value: &[u8]) {
        self.long_names |= name.len() > SHORT_NAME_BYTES || kind.len() > SHORT_NAME_BYTES;
        for s in [name, kind] {
            self.bytes.extend_from_slice(s.as_bytes());
            self.bytes.push(0);
        }
        self.bytes
            .extend_from_slice(&(value.len() as i32).to_le_bytes());
        self.bytes.extend_from_slice(value);
    }

    fn string(&mut self, name: &str, value: &str) {
        self.attribute(name, "string", value.as_bytes());
    }

    fn v3d(&mut self, name: &str, v: [f64; 3]) {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.attribute(name, "v3d", &bytes);
    }
}

/// The attributes of a part of a multi-part file besides a single-part field's: its name and
/// its number of chunks (blocks of lines).
pub(super) struct PartAttributes<'a> {
    pub name: &'a str,
    pub chunks: u64,
}

/// The header of a field (a single-part file, or one part of a multi-part file), ended by its
/// null byte, and whether it has attribute names longer than 31 bytes.
pub(super) fn header_attributes(
    info: &FieldInfo,
    storage: Storage,
    part: Option<PartAttributes>,
) -> HeaderBuilder {
    let [nx, ny, nz] = info.dims;
    let mut h = HeaderBuilder {
        bytes: Vec::new(),
        long_names: false,
    };
    let pixel = if storage.half {
        PIXEL_HALF
    } else {
        PIXEL_FLOAT
    };
    let mut channels = Vec::new();
    for name in CHANNELS {
        channels.extend_from_slice(name.as_bytes());
        channels.push(0);
        channels.extend_from_slice(&pixel.to_le_bytes());
        channels.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    h.attribute("channels", "chlist", &channels);
    h.attribute(
        "compression",
        "compression",
        &[compression_code(storage.compression)],
    );
    let window: Vec<u8> = [0i32, 0, nx as i32 - 1, (ny * nz) as i32 - 1]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    h.attribute("dataWindow", "box2i", &window);
    h.attribute("displayWindow", "box2i", &window);
    h.attribute("lineOrder", "lineOrder", &[0]);
    h.attribute("pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    h.attribute("screenWindowCenter", "v2f", &[0u8; 8]);
    h.attribute("screenWindowWidth", "float", &1.0f32.to_le_bytes());
    if let Some(part) = part {
        h.string("name", part.name);
        h.string("type", "scanlineimage");
        h.attribute("chunkCount", "int", &(part.chunks as i32).to_le_bytes());
    }
    let dims: Vec<u8> = info
        .dims
        .iter()
        .flat_map(|&d| (d as i32).to_le_bytes())
        .collect();
    h.attribute("volmap.dims", "v3i", &dims);
    h.v3d("volmap.origin", info.origin_mm);
    h.v3d("volmap.spacing", info.spacing_mm);
    h.v3d("volmap.pose", info.pose_deg);
    // The same in words, for tools that do not print v3d values (exrheader among them).
    h.string("volmap.grid", &grid_text(info));
    h.string("volmap.poseAxes", &info.pose_axes);
    h.string("volmap.units", UNITS);
    h.string("volmap.machine", &info.machine_name);
    h.string("volmap.chain", &info.chain);
    h.string("volmap.machineToml", &info.machine_toml);
    for (n, (path, text)) in info.csv_files.iter().enumerate() {
        let (path_name, text_name) = csv_attribute_names(n);
        h.string(&path_name, path);
        h.string(&text_name, text);
    }
    h.string(inputs::APPROACH, &info.inputs.approach_text());
    h.string(inputs::TEMPERATURES, &info.inputs.temperatures_text());
    if let Some(reference) = info.inputs.reference_c {
        h.attribute(inputs::REFERENCE, "double", &reference.to_le_bytes());
    }
    h.string(inputs::WORDS, &info.inputs.describe());
    h.string("volmap.device", &info.device);
    h.string("volmap.version", env!("CARGO_PKG_VERSION"));
    h.bytes.push(0);
    h
}

/// The magic number and version field: `multipart` files, and whether `long_names` are used.
pub(super) fn file_start(multipart: bool, long_names: bool) -> Vec<u8> {
    let mut flags = 0;
    if multipart {
        flags |= FLAG_MULTIPART;
    }
    if long_names {
        flags |= FLAG_LONG_NAMES;
    }
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&(VERSION | flags).to_le_bytes());
    out
}
