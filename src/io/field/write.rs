//! Writing a field: the header, the offset table (known before any pixel is computed, since
//! uncompressed scanline chunks have a fixed size), then the lines as they arrive.

use std::io::Write;
use std::path::Path;

use super::{
    grid_text, FieldError, FieldInfo, FLAG_LONG_NAMES, MAGIC, PIXEL_FLOAT, UNITS, VERSION,
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

fn encode_header(info: &FieldInfo) -> Vec<u8> {
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
    h.string("volmap.device", &info.device);
    h.string("volmap.version", env!("CARGO_PKG_VERSION"));
    h.bytes.push(0);

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
        let values_per_line = CHANNELS.len() * self.nx;
        let (out, line_bytes) = (&mut self.out, &mut self.line_bytes);
        let result = (|| -> std::io::Result<()> {
            for (n, line) in data
                .chunks_exact(values_per_line)
                .take(lines as usize)
                .enumerate()
            {
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
        })();
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
