//! Writing a field: the header, the offset table (known before any pixel is computed, since
//! uncompressed scanline chunks have a fixed size), then the lines as they arrive; a multi-part
//! field (a sweep of poses) the same way, every header and offset table first.

use std::io::Write;
use std::path::Path;

use super::inputs;
use super::{
    grid_text, FieldError, FieldInfo, FLAG_LONG_NAMES, FLAG_MULTIPART, MAGIC, PIXEL_FLOAT, UNITS,
    VERSION,
};
use crate::io::atomic::AtomicFile;
use crate::model::channels::CHANNELS;

struct HeaderBuilder {
    bytes: Vec<u8>,
    long_names: bool,
}

impl HeaderBuilder {
    fn attribute(&mut self, name: &str, kind: &str, value: &[u8]) {
        self.long_names |= name.len() > 31 || kind.len() > 31;
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
/// its number of chunks (lines).
struct PartAttributes<'a> {
    name: &'a str,
    chunks: u64,
}

/// The header of a field (a single-part file, or one part of a multi-part file), ended by its
/// null byte, and whether it has attribute names longer than 31 bytes.
fn header_attributes(info: &FieldInfo, part: Option<PartAttributes>) -> HeaderBuilder {
    let [nx, ny, nz] = info.dims;
    let mut h = HeaderBuilder {
        bytes: Vec::new(),
        long_names: false,
    };
    let mut channels = Vec::new();
    for name in CHANNELS {
        channels.extend_from_slice(name.as_bytes());
        channels.push(0);
        channels.extend_from_slice(&PIXEL_FLOAT.to_le_bytes());
        channels.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    h.attribute("channels", "chlist", &channels);
    h.attribute("compression", "compression", &[0]);
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
    for (path, text) in &info.csv_files {
        h.string(&format!("volmap.csv.{path}"), text);
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

fn encode_header(info: &FieldInfo) -> Vec<u8> {
    let h = header_attributes(info, None);
    let flags = if h.long_names { FLAG_LONG_NAMES } else { 0 };
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&(VERSION | flags).to_le_bytes());
    out.extend_from_slice(&h.bytes);
    out
}

/// Streams a field into a temporary file, renamed into place by [`FieldWriter::finish`];
/// dropped before that, it leaves nothing behind.
pub struct FieldWriter {
    out: AtomicFile,
    nx: usize,
    total_lines: u64,
    next_line: u64,
    line_bytes: Vec<u8>,
}

impl FieldWriter {
    pub fn create(path: &Path, info: &FieldInfo) -> Result<FieldWriter, FieldError> {
        let mut out = AtomicFile::create(path, 8 << 20)?;
        let nx = info.dims[0];
        let total_lines = (info.dims[1] * info.dims[2]) as u64;
        let header = encode_header(info);
        let chunk_bytes = 8 + (CHANNELS.len() * 4 * nx) as u64;
        let first_chunk = header.len() as u64 + 8 * total_lines;
        let written = (|| -> std::io::Result<()> {
            out.write_all(&header)?;
            for line in 0..total_lines {
                out.write_all(&(first_chunk + line * chunk_bytes).to_le_bytes())?;
            }
            Ok(())
        })();
        written.map_err(|e| out.error(e))?;
        Ok(FieldWriter {
            out,
            nx,
            total_lines,
            next_line: 0,
            line_bytes: Vec::new(),
        })
    }

    /// Appends `lines` lines starting at `first_line` (which must follow the last line written):
    /// `data` holds, per line, `nx` values of each channel in [`CHANNELS`] order.
    pub fn write_lines(
        &mut self,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        if first_line != self.next_line {
            return Err(FieldError::OutOfOrder {
                path: self.out.path().display().to_string(),
                expected: self.next_line,
                got: first_line,
            });
        }
        let result = write_chunks(
            &mut self.out,
            None,
            self.nx,
            first_line,
            lines,
            data,
            &mut self.line_bytes,
        );
        result.map_err(|e| self.out.error(e))?;
        self.next_line += lines;
        Ok(())
    }

    /// Checks that every line was written, and puts the file in place.
    pub fn finish(self) -> Result<(), FieldError> {
        if self.next_line != self.total_lines {
            return Err(FieldError::Incomplete {
                path: self.out.path().display().to_string(),
                written: self.next_line,
                total: self.total_lines,
            });
        }
        Ok(self.out.commit()?)
    }
}

/// Writes `lines` lines from `first_line` as scanline chunks, each with its part number first
/// where `part` is given (a multi-part file).
fn write_chunks(
    out: &mut AtomicFile,
    part: Option<u32>,
    nx: usize,
    first_line: u64,
    lines: u64,
    data: &[f32],
    line_bytes: &mut Vec<u8>,
) -> std::io::Result<()> {
    let values_per_line = CHANNELS.len() * nx;
    for (n, line) in data
        .chunks_exact(values_per_line)
        .take(lines as usize)
        .enumerate()
    {
        if let Some(part) = part {
            out.write_all(&part.to_le_bytes())?;
        }
        out.write_all(&((first_line + n as u64) as i32).to_le_bytes())?;
        out.write_all(&((values_per_line * 4) as i32).to_le_bytes())?;
        if cfg!(target_endian = "little") {
            out.write_all(bytemuck::cast_slice(line))?;
        } else {
            line_bytes.clear();
            line_bytes.extend(line.iter().flat_map(|v| v.to_le_bytes()));
            out.write_all(line_bytes)?;
        }
    }
    Ok(())
}

/// Streams a multi-part field (one part per pose of a sweep) into a temporary file, renamed into
/// place by [`PartsWriter::finish`]; dropped before that, it leaves nothing behind.
///
/// Every chunk of an uncompressed scanline part has a fixed size, so the headers and all the
/// offset tables are written first, and then the parts' lines as they are computed, part after
/// part: memory holds one chunk at a time, whatever the sweep.
pub struct PartsWriter {
    out: AtomicFile,
    /// Each part's `nx` and number of lines.
    parts: Vec<(usize, u64)>,
    part: usize,
    next_line: u64,
    written: u64,
    line_bytes: Vec<u8>,
}

impl PartsWriter {
    /// Starts writing `path` with `count` parts; `part(p)` gives part `p`'s name (unique) and
    /// header, asked once per part and not kept.
    pub fn create(
        path: &Path,
        count: usize,
        part: impl Fn(usize) -> (String, FieldInfo),
    ) -> Result<PartsWriter, FieldError> {
        let mut out = AtomicFile::create(path, 8 << 20)?;
        let mut parts = Vec::with_capacity(count);
        let written = (|| -> std::io::Result<()> {
            if count == 0 {
                return Err(std::io::Error::other("a multi-part field needs a part"));
            }
            // The version field before the headers says whether attribute names may be long:
            // every part of a sweep has the attribute names of the first.
            let mut long_names = None;
            let mut header_bytes = 0u64;
            for p in 0..count {
                let (name, info) = part(p);
                let [nx, ny, nz] = info.dims;
                let lines = (ny * nz) as u64;
                let h = header_attributes(
                    &info,
                    Some(PartAttributes {
                        name: &name,
                        chunks: lines,
                    }),
                );
                let long = *long_names.get_or_insert(h.long_names);
                if p == 0 {
                    out.write_all(&MAGIC)?;
                    let flags = FLAG_MULTIPART | if long { FLAG_LONG_NAMES } else { 0 };
                    out.write_all(&(VERSION | flags).to_le_bytes())?;
                }
                if h.long_names && !long {
                    return Err(std::io::Error::other(format!(
                        "part {name} has attribute names longer than 31 bytes, the first part none"
                    )));
                }
                out.write_all(&h.bytes)?;
                header_bytes += h.bytes.len() as u64;
                parts.push((nx, lines));
            }
            // The empty header that ends the headers.
            out.write_all(&[0])?;
            let tables: u64 = parts.iter().map(|&(_, lines)| 8 * lines).sum();
            let mut offset = MAGIC.len() as u64 + 4 + header_bytes + 1 + tables;
            for &(nx, lines) in &parts {
                let chunk_bytes = 12 + (CHANNELS.len() * 4 * nx) as u64;
                for _ in 0..lines {
                    out.write_all(&offset.to_le_bytes())?;
                    offset += chunk_bytes;
                }
            }
            Ok(())
        })();
        written.map_err(|e| out.error(e))?;
        Ok(PartsWriter {
            out,
            parts,
            part: 0,
            next_line: 0,
            written: 0,
            line_bytes: Vec::new(),
        })
    }

    /// Appends `lines` lines of part `part` starting at `first_line`: the lines of a part in
    /// order, the parts in order, each part whole before the next begins. `data` holds, per
    /// line, `nx` values of each channel in [`CHANNELS`] order.
    pub fn write_lines(
        &mut self,
        part: usize,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        let path = || self.out.path().display().to_string();
        if part != self.part {
            let done = self
                .parts
                .get(self.part)
                .is_some_and(|&(_, total)| self.next_line == total);
            if part != self.part + 1 || !done {
                return Err(FieldError::PartOutOfOrder {
                    path: path(),
                    expected: self.part,
                    got: part,
                });
            }
            self.part = part;
            self.next_line = 0;
        }
        let Some(&(nx, _)) = self.parts.get(part) else {
            return Err(FieldError::PartOutOfOrder {
                path: path(),
                expected: self.part,
                got: part,
            });
        };
        if first_line != self.next_line {
            return Err(FieldError::OutOfOrder {
                path: path(),
                expected: self.next_line,
                got: first_line,
            });
        }
        let result = write_chunks(
            &mut self.out,
            Some(part as u32),
            nx,
            first_line,
            lines,
            data,
            &mut self.line_bytes,
        );
        result.map_err(|e| self.out.error(e))?;
        self.next_line += lines;
        self.written += lines;
        Ok(())
    }

    /// Checks that every line of every part was written, and puts the file in place.
    pub fn finish(self) -> Result<(), FieldError> {
        let total: u64 = self.parts.iter().map(|&(_, lines)| lines).sum();
        if self.written != total {
            return Err(FieldError::Incomplete {
                path: self.out.path().display().to_string(),
                written: self.written,
                total,
            });
        }
        Ok(self.out.commit()?)
    }
}
