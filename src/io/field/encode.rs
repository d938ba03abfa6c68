//! Encoding a field's container with the `exr` crate's encoders: the file's start (magic number
//! and version flags), each header attribute by attribute (volmap's attributes as custom ones),
//! the null byte that ends the headers of a multi-part file, the scanline chunks and the offsets
//! that point at them.
//!
//! The attributes are written one by one, in volmap's order, rather than as the crate's
//! [`Header`](exr::meta::header::Header): `Header::write` puts its own attributes in its own
//! order (`chunkCount` and `type` first, in a single-part file too) and the custom ones in the
//! order of a `HashMap`, which changes from run to run, so the same field would not be the same
//! file twice. Attribute names are volmap's, never the input's, so they stay within OpenEXR's 31
//! bytes whatever the machine file holds (a CSV table's path, however long, is an attribute
//! value).

use std::io::Write;

use exr::io::Data;
use exr::math::Vec2;
use exr::meta::attribute::{self, AttributeValue, BlockType, IntegerBounds, LineOrder, Text};
use exr::meta::header::standard_names as names;
use exr::meta::{magic_number, sequence_end, Requirements};
use exr::prelude::SmallVec;

use super::blocks::{channel_list, Storage};
use super::inputs;
use super::{grid_text, FieldInfo, UNITS};

/// The names of the attributes of the `n`-th CSV table the machine file reads: its path as the
/// machine file writes it, and its text.
pub(super) fn csv_attribute_names(n: usize) -> (String, String) {
    (format!("volmap.csvPath.{n}"), format!("volmap.csvText.{n}"))
}

/// The longest attribute name OpenEXR reads without the long-names flag.
const SHORT_NAME_BYTES: usize = 31;

/// An error of the `exr` crate's encoders as an I/O error: its own where it is one.
pub(super) fn io_error(error: exr::error::Error) -> std::io::Error {
    match error {
        exr::error::Error::Io(error) => error,
        other => std::io::Error::other(other.to_string()),
    }
}

/// A string value: the writer's text, UTF-8 as it is (the crate's `Text` holds bytes).
fn text(value: &str) -> AttributeValue {
    AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes()))
}

pub(super) struct HeaderBuilder {
    pub bytes: Vec<u8>,
    pub long_names: bool,
}

impl HeaderBuilder {
    fn attribute(&mut self, name: &[u8], value: AttributeValue) -> std::io::Result<()> {
        self.long_names |= name.len() > SHORT_NAME_BYTES;
        attribute::write(name, &value, &mut self.bytes).map_err(io_error)
    }

    fn string(&mut self, name: &str, value: &str) -> std::io::Result<()> {
        self.attribute(name.as_bytes(), text(value))
    }

    /// Three doubles: OpenEXR has no type of its own for them, `v3d` is a custom one.
    fn v3d(&mut self, name: &str, v: [f64; 3]) -> std::io::Result<()> {
        let mut bytes = SmallVec::new();
        for x in v {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        let kind = Text::from("v3d");
        self.attribute(name.as_bytes(), AttributeValue::Custom { kind, bytes })
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
) -> std::io::Result<HeaderBuilder> {
    use AttributeValue as V;
    let [nx, ny, nz] = info.dims;
    let mut h = HeaderBuilder {
        bytes: Vec::new(),
        long_names: false,
    };
    // A grid has at most i32::MAX lines (`model::grid`), as OpenEXR's windows address.
    let window = IntegerBounds::new(Vec2(0, 0), Vec2(nx, ny * nz));
    h.attribute(names::CHANNELS, V::ChannelList(channel_list(storage.half)))?;
    h.attribute(
        names::COMPRESSION,
        V::Compression(storage.compression.exr()),
    )?;
    h.attribute(names::DATA_WINDOW, V::IntegerBounds(window))?;
    h.attribute(names::DISPLAY_WINDOW, V::IntegerBounds(window))?;
    h.attribute(names::LINE_ORDER, V::LineOrder(LineOrder::Increasing))?;
    h.attribute(names::PIXEL_ASPECT, V::F32(1.0))?;
    h.attribute(names::WINDOW_CENTER, V::FloatVec2(Vec2(0.0, 0.0)))?;
    h.attribute(names::WINDOW_WIDTH, V::F32(1.0))?;
    if let Some(part) = part {
        h.attribute(names::NAME, text(part.name))?;
        h.attribute(names::BLOCK_TYPE, V::BlockType(BlockType::ScanLine))?;
        h.attribute(names::CHUNKS, V::I32(part.chunks as i32))?;
    }
    let dims = (nx as i32, ny as i32, nz as i32);
    h.attribute(b"volmap.dims", V::IntVec3(dims))?;
    h.v3d("volmap.origin", info.origin_mm)?;
    h.v3d("volmap.spacing", info.spacing_mm)?;
    h.v3d("volmap.pose", info.pose_deg)?;
    // The same for tools that do not print v3d values (exrheader among them): in OpenEXR's own
    // 32-bit vector type (what exrheader prints; the v3d ones are the values) and in words.
    let f = |v: [f64; 3]| V::FloatVec3((v[0] as f32, v[1] as f32, v[2] as f32));
    h.attribute(b"volmap.origin_mm", f(info.origin_mm))?;
    h.attribute(b"volmap.spacing_mm", f(info.spacing_mm))?;
    h.string("volmap.grid", &grid_text(info))?;
    h.string("volmap.poseAxes", &info.pose_axes)?;
    h.string("volmap.units", UNITS)?;
    h.string("volmap.machine", &info.machine_name)?;
    h.string("volmap.chain", &info.chain)?;
    h.string("volmap.machineToml", &info.machine_toml)?;
    for (n, (path, text)) in info.csv_files.iter().enumerate() {
        let (path_name, text_name) = csv_attribute_names(n);
        h.string(&path_name, path)?;
        h.string(&text_name, text)?;
    }
    h.string(inputs::APPROACH, &info.inputs.approach_text())?;
    h.string(inputs::TEMPERATURES, &info.inputs.temperatures_text())?;
    if let Some(reference) = info.inputs.reference_c {
        h.attribute(inputs::REFERENCE.as_bytes(), V::F64(reference))?;
    }
    h.string(inputs::WORDS, &info.inputs.describe())?;
    h.string("volmap.device", &info.device)?;
    if let Some(method) = &info.uncertainty {
        h.string("volmap.uncertainty", method)?;
    }
    h.string("volmap.version", env!("CARGO_PKG_VERSION"))?;
    sequence_end::write(&mut h.bytes).map_err(io_error)?;
    Ok(h)
}

/// The magic number and version field: `multipart` files (a sweep, even of one pose), and
/// whether `long_names` are used.
pub(super) fn write_file_start(
    out: &mut impl Write,
    multipart: bool,
    long_names: bool,
) -> std::io::Result<()> {
    magic_number::write(out).map_err(io_error)?;
    let requirements = Requirements {
        file_format_version: 2,
        is_single_layer_and_tiled: false,
        has_long_names: long_names,
        has_deep_data: false,
        has_multiple_layers: multipart,
    };
    requirements.write(out).map_err(io_error)
}

/// The empty header that ends the headers of a multi-part file.
pub(super) fn write_headers_end(out: &mut impl Write) -> std::io::Result<()> {
    sequence_end::write(out).map_err(io_error)
}

/// Writes one scanline chunk: the part number in a multi-part file, the block's first line and
/// its stored bytes (`values`, little-endian) with their count; returns the bytes written.
///
/// This is the layout of the crate's `Chunk::write`, which volmap does not call: it writes the
/// part number only where a file has several headers (a sweep of one pose is a multi-part file
/// too), and it takes the block as an owned byte vector, a copy of every value of a raw FLOAT
/// block.
pub(super) fn write_chunk<T: Data>(
    out: &mut impl Write,
    part: Option<usize>,
    first_line: u64,
    values: &[T],
) -> std::io::Result<u64> {
    let bytes = values.len() * T::BYTE_SIZE;
    let mut head = 8;
    if let Some(part) = part {
        (part as i32).write_le(out).map_err(io_error)?;
        head += 4;
    }
    (first_line as i32).write_le(out).map_err(io_error)?;
    (bytes as i32).write_le(out).map_err(io_error)?;
    T::write_slice_le(out, values).map_err(io_error)?;
    Ok(head + bytes as u64)
}
