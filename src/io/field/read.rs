//! Reading a field written by volmap: the header checked against what volmap writes, then lines
//! one by one or in chunks, in order.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::{FieldError, FieldInfo, FLAG_DEEP, FLAG_MULTIPART, FLAG_TILED, MAGIC, PIXEL_FLOAT};
use crate::io::FileError;
use crate::model::channels::CHANNELS;

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

/// The header attributes volmap checks besides its own: the channels with their pixel types, the
/// compression, the data window.
#[derive(Default)]
struct ImageAttributes {
    channels: Vec<(String, Option<i32>)>,
    compression: Option<u8>,
    window: Option<[i32; 4]>,
}

impl Cursor<'_> {
    /// Reads the header's attributes up to the empty name that ends them.
    fn header(&mut self) -> Result<(FieldInfo, ImageAttributes), FieldError> {
        let mut info = FieldInfo::default();
        let mut image = ImageAttributes::default();
        loop {
            let name = self.text()?;
            if name.is_empty() {
                return Ok((info, image));
            }
            let kind = self.text()?;
            let size = self.u32()? as usize;
            if size > 1 << 30 {
                return Err(self.format(format!("attribute {name} claims {size} bytes")));
            }
            let value = self.bytes(size)?;
            self.attribute(&name, &kind, &value, &mut info, &mut image)?;
        }
    }

    /// One attribute into the field's info or the image attributes; others are skipped.
    fn attribute(
        &self,
        name: &str,
        kind: &str,
        value: &[u8],
        info: &mut FieldInfo,
        image: &mut ImageAttributes,
    ) -> Result<(), FieldError> {
        let string = || String::from_utf8_lossy(value).into_owned();
        let need = |n: usize| {
            if value.len() == n {
                Ok(())
            } else {
                Err(self.format(format!(
                    "attribute {name} has {} bytes, expected {n}",
                    value.len()
                )))
            }
        };
        let i32_at =
            |k: usize| i32::from_le_bytes(value[4 * k..4 * k + 4].try_into().unwrap_or([0; 4]));
        match (name, kind) {
            ("channels", "chlist") => {
                let mut rest = value;
                while let Some(end) = rest.iter().position(|&b| b == 0) {
                    if end == 0 {
                        break;
                    }
                    let channel = String::from_utf8_lossy(&rest[..end]).into_owned();
                    let pixel = rest
                        .get(end + 1..end + 5)
                        .map(|b| i32::from_le_bytes(b.try_into().unwrap_or([0; 4])));
                    image.channels.push((channel, pixel));
                    rest = rest.get(end + 17..).unwrap_or(&[]);
                }
            }
            ("compression", "compression") => image.compression = value.first().copied(),
            ("dataWindow", "box2i") => {
                need(16)?;
                image.window = Some(std::array::from_fn(i32_at));
            }
            ("volmap.dims", "v3i") => {
                need(12)?;
                info.dims = std::array::from_fn(|d| i32_at(d).max(0) as usize);
            }
            ("volmap.origin", "v3d") => {
                need(24)?;
                info.origin_mm = f64s::<3>(value);
            }
            ("volmap.spacing", "v3d") => {
                need(24)?;
                info.spacing_mm = f64s::<3>(value);
            }
            ("volmap.pose", "v3d") => {
                need(24)?;
                info.pose_deg = f64s::<3>(value);
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
        Ok(())
    }

    /// Checks that the image is the field volmap writes for `info`: its channels, no
    /// compression, a data window of the grid's size.
    fn check_image(&self, info: &FieldInfo, image: &ImageAttributes) -> Result<(), FieldError> {
        let expected: Vec<(String, Option<i32>)> = CHANNELS
            .iter()
            .map(|n| (n.to_string(), Some(PIXEL_FLOAT)))
            .collect();
        if image.channels != expected {
            return Err(self.format(format!(
                "channels must be FLOAT {}, found {}",
                CHANNELS.join(" "),
                image
                    .channels
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(" ")
            )));
        }
        if image.compression != Some(0) {
            return Err(self
                .format("the file is compressed; volmap reads the uncompressed fields it writes"));
        }
        let [nx, ny, nz] = info.dims;
        if info.dims.contains(&0) {
            return Err(self.format("missing or empty volmap.dims"));
        }
        if image.window != Some([0, 0, nx as i32 - 1, (ny * nz) as i32 - 1]) {
            return Err(self.format(format!(
                "the data window does not match volmap.dims {nx}x{ny}x{nz}"
            )));
        }
        Ok(())
    }
}

impl FieldReader {
    pub fn open(path: &Path) -> Result<FieldReader, FieldError> {
        let display = path.display().to_string();
        let file = File::open(path).map_err(|e| FileError::read(path, e))?;
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
        let (info, image) = c.header()?;
        c.check_image(&info, &image)?;
        let [nx, ny, nz] = info.dims;
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
        let io = |source| FileError::Read {
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
