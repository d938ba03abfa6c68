//! Field files: OpenEXR, one part, scanlines, no compression, FLOAT channels
//! `OE.X OE.Y OE.Z VE.X VE.Y VE.Z`. The image is `nx` wide and `ny·nz` tall; pixel
//! `(i, j + k·ny)` holds grid point `(i, j, k)`.
//!
//! Uncompressed scanline chunks have a fixed size, so the offset table is known before any pixel
//! is computed: the writer streams lines as they arrive and memory does not grow with the grid.
//! It writes to a temporary file in the target's folder and renames it only when every line is
//! written, so an interrupted run never leaves a truncated field.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::gpu::layout::CHANNELS;
use crate::grid::Grid;

#[derive(Debug, thiserror::Error)]
pub enum FieldError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a volmap field: {what}")]
    Format { path: String, what: String },
    #[error("{path}: lines must arrive in order: expected line {expected}, got {got}")]
    OutOfOrder {
        path: String,
        expected: u64,
        got: u64,
    },
    #[error("{path}: only {written} of {total} lines were written; the field was not saved")]
    Incomplete {
        path: String,
        written: u64,
        total: u64,
    },
}

/// What a field file says about itself, stored as header attributes.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldInfo {
    /// Grid points along X, Y, Z (`volmap.dims`, v3i).
    pub dims: [usize; 3],
    /// Commanded X, Y, Z of pixel (0, 0), mm (`volmap.origin`, v3d).
    pub origin_mm: [f64; 3],
    /// Grid step along X, Y, Z, mm (`volmap.spacing`, v3d).
    pub spacing_mm: [f64; 3],
    /// Commanded A, B, C, degrees (`volmap.pose`, v3d); axes the machine lacks are 0.
    pub pose_deg: [f64; 3],
    /// The rotary axes the machine has, e.g. `BC` (`volmap.poseAxes`).
    pub pose_axes: String,
    /// The machine's `name` (`volmap.machine`).
    pub machine_name: String,
    /// The chain in Hwang's notation (`volmap.chain`).
    pub chain: String,
    /// The machine file, verbatim (`volmap.machineToml`).
    pub machine_toml: String,
    /// CSV tables the machine file reads: `(path as written, text)` (`volmap.csv.<path>`).
    pub csv_files: Vec<(String, String)>,
    /// The device that computed the field (`volmap.device`).
    pub device: String,
}

impl FieldInfo {
    /// The grid of commanded positions the field covers.
    pub fn grid(&self) -> Grid {
        let mut pose = [0.0; 6];
        pose[3..].copy_from_slice(&self.pose_deg);
        Grid {
            dims: self.dims,
            origin_mm: self.origin_mm,
            spacing_mm: self.spacing_mm,
            pose,
        }
    }
}

/// `volmap.units`, written into every field.
pub const UNITS: &str = "VE.X VE.Y VE.Z: mm, volumetric error p_real - p_ideal, workpiece frame; \
OE.X OE.Y OE.Z: rad, rotation vector of R_real R_ideal^T, workpiece frame; \
origin, spacing: mm (commanded X Y Z); pose: degrees (commanded A B C)";

const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const VERSION: u32 = 2;
const FLAG_TILED: u32 = 0x200;
const FLAG_LONG_NAMES: u32 = 0x400;
const FLAG_DEEP: u32 = 0x800;
const FLAG_MULTIPART: u32 = 0x1000;
const PIXEL_FLOAT: i32 = 2;

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

/// The grid and pose in words, exact (shortest round-trip decimals).
pub fn grid_text(info: &FieldInfo) -> String {
    let mut parts: Vec<String> = (0..3)
        .map(|d| {
            let end = info.origin_mm[d] + (info.dims[d].max(1) - 1) as f64 * info.spacing_mm[d];
            format!(
                "{}: {} points from {:?} to {:?} mm, step {:?} mm",
                ["X", "Y", "Z"][d],
                info.dims[d],
                info.origin_mm[d],
                end,
                info.spacing_mm[d]
            )
        })
        .collect();
    for axis in info.pose_axes.chars() {
        let index = "ABC".find(axis).unwrap_or(0);
        parts.push(format!("{axis} at {:?} deg", info.pose_deg[index]));
    }
    parts.join("; ")
}

/// Streams a field into a temporary file, renamed into place by [`FieldWriter::finish`].
pub struct FieldWriter {
    out: Option<BufWriter<File>>,
    temp_path: PathBuf,
    final_path: PathBuf,
    nx: usize,
    total_lines: u64,
    next_line: u64,
    line_bytes: Vec<u8>,
    /// Set once the file is renamed into place; until then dropping removes the temporary file.
    saved: bool,
}

impl FieldWriter {
    pub fn create(path: &Path, info: &FieldInfo) -> Result<FieldWriter, FieldError> {
        let io = |source| FieldError::Io {
            path: path.display().to_string(),
            source,
        };
        let file_name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temp_path = path.with_file_name(format!(".{file_name}.{}.part", std::process::id()));
        let file = File::create(&temp_path).map_err(io)?;
        let mut writer = FieldWriter {
            out: Some(BufWriter::with_capacity(8 << 20, file)),
            temp_path,
            final_path: path.to_path_buf(),
            nx: info.dims[0],
            total_lines: (info.dims[1] * info.dims[2]) as u64,
            next_line: 0,
            line_bytes: Vec::new(),
            saved: false,
        };
        let header = encode_header(info);
        let chunk_bytes = 8 + (CHANNELS.len() * 4 * writer.nx) as u64;
        let table_start = header.len() as u64;
        let first_chunk = table_start + 8 * writer.total_lines;
        let out = writer.out.as_mut().expect("open until finish");
        out.write_all(&header).map_err(io)?;
        for line in 0..writer.total_lines {
            out.write_all(&(first_chunk + line * chunk_bytes).to_le_bytes())
                .map_err(io)?;
        }
        Ok(writer)
    }

    fn io_error(&self, source: std::io::Error) -> FieldError {
        FieldError::Io {
            path: self.final_path.display().to_string(),
            source,
        }
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
                path: self.final_path.display().to_string(),
                expected: self.next_line,
                got: first_line,
            });
        }
        let values_per_line = CHANNELS.len() * self.nx;
        let mut out = self.out.take().expect("open until finish");
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
                    self.line_bytes.clear();
                    self.line_bytes
                        .extend(line.iter().flat_map(|v| v.to_le_bytes()));
                    out.write_all(&self.line_bytes)?;
                }
            }
            Ok(())
        })();
        self.out = Some(out);
        result.map_err(|e| self.io_error(e))?;
        self.next_line += lines;
        Ok(())
    }

    /// Flushes, checks that every line was written, and renames the file into place.
    pub fn finish(mut self) -> Result<(), FieldError> {
        if self.next_line != self.total_lines {
            return Err(FieldError::Incomplete {
                path: self.final_path.display().to_string(),
                written: self.next_line,
                total: self.total_lines,
            });
        }
        let out = self.out.take().expect("open until finish");
        let file = out
            .into_inner()
            .map_err(|e| self.io_error(e.into_error()))?;
        file.sync_all().map_err(|e| self.io_error(e))?;
        drop(file);
        std::fs::rename(&self.temp_path, &self.final_path).map_err(|e| self.io_error(e))?;
        self.saved = true;
        Ok(())
    }
}

impl Drop for FieldWriter {
    fn drop(&mut self) {
        if !self.saved {
            self.out = None;
            let _ = std::fs::remove_file(&self.temp_path);
        }
    }
}

/// Reads fields written by volmap (single-part, scanline, uncompressed) line by line.
pub struct FieldReader {
    path: String,
    file: BufReader<File>,
    /// Where the file stands after the last line read, if known.
    position: Option<u64>,
    /// The bytes of the last line read.
    scratch: Vec<u8>,
    info: FieldInfo,
    offsets: Vec<u64>,
}

struct Cursor<'a> {
    path: &'a str,
    reader: &'a mut BufReader<File>,
}

impl Cursor<'_> {
    fn format(&self, what: impl Into<String>) -> FieldError {
        FieldError::Format {
            path: self.path.to_string(),
            what: what.into(),
        }
    }

    fn bytes(&mut self, n: usize) -> Result<Vec<u8>, FieldError> {
        let mut buf = vec![0; n];
        self.reader
            .read_exact(&mut buf)
            .map_err(|_| self.format("the file ends inside its header"))?;
        Ok(buf)
    }

    fn u32(&mut self) -> Result<u32, FieldError> {
        let b = self.bytes(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn text(&mut self) -> Result<String, FieldError> {
        let mut s = Vec::new();
        loop {
            let b = self.bytes(1)?[0];
            if b == 0 {
                break;
            }
            s.push(b);
            if s.len() > 255 {
                return Err(self.format("an attribute name is longer than 255 bytes"));
            }
        }
        String::from_utf8(s).map_err(|_| self.format("an attribute name is not UTF-8"))
    }
}

fn f64s<const N: usize>(b: &[u8]) -> [f64; N] {
    std::array::from_fn(|n| f64::from_le_bytes(b[8 * n..8 * n + 8].try_into().unwrap_or([0; 8])))
}

impl FieldReader {
    pub fn open(path: &Path) -> Result<FieldReader, FieldError> {
        let display = path.display().to_string();
        let file = File::open(path).map_err(|source| FieldError::Io {
            path: display.clone(),
            source,
        })?;
        let mut reader = BufReader::with_capacity(1 << 20, file);
        let mut c = Cursor {
            path: &display,
            reader: &mut reader,
        };
        if c.bytes(4).map_err(|_| c.format("too short"))? != MAGIC {
            return Err(c.format("not an OpenEXR file (wrong magic number)"));
        }
        let version = c.u32()?;
        if version & 0xff != 2 || version & (FLAG_TILED | FLAG_DEEP | FLAG_MULTIPART) != 0 {
            return Err(c.format("not a single-part scanline OpenEXR file"));
        }
        let mut info = FieldInfo {
            dims: [0; 3],
            origin_mm: [0.0; 3],
            spacing_mm: [0.0; 3],
            pose_deg: [0.0; 3],
            pose_axes: String::new(),
            machine_name: String::new(),
            chain: String::new(),
            machine_toml: String::new(),
            csv_files: Vec::new(),
            device: String::new(),
        };
        let mut channels = Vec::new();
        let mut compression = None;
        let mut window = None;
        loop {
            let name = c.text()?;
            if name.is_empty() {
                break;
            }
            let kind = c.text()?;
            let size = c.u32()? as usize;
            if size > 1 << 30 {
                return Err(c.format(format!("attribute {name} claims {size} bytes")));
            }
            let value = c.bytes(size)?;
            let string = || String::from_utf8_lossy(&value).into_owned();
            let need = |n: usize| {
                if value.len() == n {
                    Ok(())
                } else {
                    Err(FieldError::Format {
                        path: display.clone(),
                        what: format!("attribute {name} has {} bytes, expected {n}", value.len()),
                    })
                }
            };
            match (name.as_str(), kind.as_str()) {
                ("channels", "chlist") => {
                    let mut rest = &value[..];
                    while let Some(end) = rest.iter().position(|&b| b == 0) {
                        if end == 0 {
                            break;
                        }
                        let channel = String::from_utf8_lossy(&rest[..end]).into_owned();
                        let pixel = rest
                            .get(end + 1..end + 5)
                            .map(|b| i32::from_le_bytes(b.try_into().unwrap_or([0; 4])));
                        channels.push((channel, pixel));
                        rest = rest.get(end + 17..).unwrap_or(&[]);
                    }
                }
                ("compression", "compression") => compression = value.first().copied(),
                ("dataWindow", "box2i") => {
                    need(16)?;
                    let v: Vec<i32> = value
                        .chunks(4)
                        .map(|b| i32::from_le_bytes(b.try_into().unwrap_or([0; 4])))
                        .collect();
                    window = Some([v[0], v[1], v[2], v[3]]);
                }
                ("volmap.dims", "v3i") => {
                    need(12)?;
                    for d in 0..3 {
                        info.dims[d] = i32::from_le_bytes(
                            value[4 * d..4 * d + 4].try_into().unwrap_or([0; 4]),
                        )
                        .max(0) as usize;
                    }
                }
                ("volmap.origin", "v3d") => {
                    need(24)?;
                    info.origin_mm = f64s::<3>(&value);
                }
                ("volmap.spacing", "v3d") => {
                    need(24)?;
                    info.spacing_mm = f64s::<3>(&value);
                }
                ("volmap.pose", "v3d") => {
                    need(24)?;
                    info.pose_deg = f64s::<3>(&value);
                }
                ("volmap.poseAxes", _) => info.pose_axes = string(),
                ("volmap.machine", _) => info.machine_name = string(),
                ("volmap.chain", _) => info.chain = string(),
                ("volmap.machineToml", _) => info.machine_toml = string(),
                ("volmap.device", _) => info.device = string(),
                (n, _) if n.starts_with("volmap.csv.") => info
                    .csv_files
                    .push((n["volmap.csv.".len()..].to_string(), string())),
                _ => {}
            }
        }
        let expected: Vec<(String, Option<i32>)> = CHANNELS
            .iter()
            .map(|n| (n.to_string(), Some(PIXEL_FLOAT)))
            .collect();
        if channels != expected {
            return Err(c.format(format!(
                "channels must be FLOAT {}, found {}",
                CHANNELS.join(" "),
                channels
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(" ")
            )));
        }
        if compression != Some(0) {
            return Err(
                c.format("the file is compressed; volmap reads the uncompressed fields it writes")
            );
        }
        let [nx, ny, nz] = info.dims;
        if info.dims.contains(&0) {
            return Err(c.format("missing or empty volmap.dims"));
        }
        if window != Some([0, 0, nx as i32 - 1, (ny * nz) as i32 - 1]) {
            return Err(c.format(format!(
                "the data window does not match volmap.dims {nx}x{ny}x{nz}"
            )));
        }
        let lines = ny * nz;
        let file_bytes = c.reader.get_ref().metadata().map(|m| m.len()).unwrap_or(0);
        let header_bytes = c.reader.stream_position().unwrap_or(0);
        let data_bytes = header_bytes + lines as u64 * (8 + 8 + (CHANNELS.len() * 4 * nx) as u64);
        if data_bytes > file_bytes {
            return Err(c.format(format!(
                "volmap.dims {nx}x{ny}x{nz} needs {data_bytes} bytes but the file has {file_bytes}: truncated"
            )));
        }
        let table = c.bytes(8 * lines)?;
        let offsets = table
            .chunks(8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
            .collect();
        Ok(FieldReader {
            path: display,
            file: reader,
            position: None,
            scratch: Vec::new(),
            info,
            offsets,
        })
    }

    pub fn info(&self) -> &FieldInfo {
        &self.info
    }

    pub fn lines(&self) -> u64 {
        self.offsets.len() as u64
    }

    /// Reads line `line` into `out` (`6 · nx` values, channels in [`CHANNELS`] order).
    pub fn read_line(&mut self, line: u64, out: &mut [f32]) -> Result<(), FieldError> {
        let nx = self.info.dims[0];
        let format = |what: String| FieldError::Format {
            path: self.path.clone(),
            what,
        };
        let offset = *self
            .offsets
            .get(line as usize)
            .ok_or_else(|| format(format!("line {line} is past the last line")))?;
        let io = |source| FieldError::Io {
            path: self.path.clone(),
            source,
        };
        // Lines of volmap's files follow each other: seek (which empties the read buffer) only
        // when this one does not start where the last one ended.
        if self.position != Some(offset) {
            self.file.seek(SeekFrom::Start(offset)).map_err(io)?;
        }
        let mut head = [0u8; 8];
        self.file
            .read_exact(&mut head)
            .map_err(|_| format(format!("line {line} is truncated")))?;
        let y = i32::from_le_bytes([head[0], head[1], head[2], head[3]]);
        let size = i32::from_le_bytes([head[4], head[5], head[6], head[7]]);
        if y as u64 != line || size as usize != CHANNELS.len() * 4 * nx {
            return Err(format(format!(
                "line {line}: chunk header says line {y} of {size} bytes"
            )));
        }
        self.scratch.resize(size as usize, 0);
        self.file
            .read_exact(&mut self.scratch)
            .map_err(|_| format(format!("line {line} is truncated")))?;
        for (v, b) in out.iter_mut().zip(self.scratch.chunks_exact(4)) {
            *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        self.position = Some(offset + 8 + size as u64);
        Ok(())
    }

    /// Reads every line in order, handing each chunk of up to `lines_per_chunk` lines to `f`
    /// as `(first_line, lines, data)`.
    pub fn for_each_chunk(
        &mut self,
        lines_per_chunk: u64,
        mut f: impl FnMut(u64, u64, &[f32]),
    ) -> Result<(), FieldError> {
        let values = CHANNELS.len() * self.info.dims[0];
        let total = self.lines();
        let mut buffer = Vec::new();
        let mut first = 0;
        while first < total {
            let lines = lines_per_chunk.max(1).min(total - first);
            buffer.resize(lines as usize * values, 0.0);
            for n in 0..lines {
                let start = n as usize * values;
                self.read_line(first + n, &mut buffer[start..start + values])?;
            }
            f(first, lines, &buffer);
            first += lines;
        }
        Ok(())
    }
}
