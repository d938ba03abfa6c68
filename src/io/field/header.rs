//! Reading a field's header: its attributes into a [`FieldInfo`], and the image attributes
//! checked against what volmap writes (channels, compression, data window; in a multi-part file
//! also each part's name, type and chunk count).

use std::fs::File;
use std::io::{BufReader, Read};

use super::inputs::{self, RawInputs};
use super::{FieldError, FieldInfo, PIXEL_FLOAT};
use crate::model::channels::CHANNELS;

pub(super) struct Cursor<'a> {
    pub path: &'a str,
    pub reader: &'a mut BufReader<File>,
}

fn f64s<const N: usize>(b: &[u8]) -> [f64; N] {
    std::array::from_fn(|n| f64::from_le_bytes(b[8 * n..8 * n + 8].try_into().unwrap_or([0; 8])))
}

/// The header attributes volmap checks besides its own: the channels with their pixel types, the
/// compression, the data window, and the attributes of a part of a multi-part file.
#[derive(Default)]
pub(super) struct ImageAttributes {
    channels: Vec<(String, Option<i32>)>,
    compression: Option<u8>,
    window: Option<[i32; 4]>,
    /// `name`, `type` and `chunkCount`: required in a multi-part file.
    pub name: Option<String>,
    kind: Option<String>,
    chunk_count: Option<i32>,
}

impl Cursor<'_> {
    pub fn format(&self, what: impl Into<String>) -> FieldError {
        FieldError::Format {
            path: self.path.to_string(),
            what: what.into(),
        }
    }

    pub fn bytes(&mut self, n: usize) -> Result<Vec<u8>, FieldError> {
        let mut buf = vec![0; n];
        self.reader
            .read_exact(&mut buf)
            .map_err(|_| self.format("the file ends inside its header"))?;
        Ok(buf)
    }

    pub fn u32(&mut self) -> Result<u32, FieldError> {
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

    /// Reads one header's attributes up to the empty name that ends them; `None` where the
    /// header is empty (the end of the headers of a multi-part file).
    pub fn header(&mut self) -> Result<Option<(FieldInfo, ImageAttributes)>, FieldError> {
        let mut info = FieldInfo::default();
        let mut image = ImageAttributes::default();
        let mut raw = RawInputs::default();
        let mut empty = true;
        loop {
            let name = self.text()?;
            if name.is_empty() {
                if empty {
                    return Ok(None);
                }
                info.inputs = raw.record(&info, self.path)?;
                return Ok(Some((info, image)));
            }
            empty = false;
            let kind = self.text()?;
            let size = self.u32()? as usize;
            if size > 1 << 30 {
                return Err(self.format(format!("attribute {name} claims {size} bytes")));
            }
            let value = self.bytes(size)?;
            self.attribute(&name, &kind, &value, &mut info, &mut image, &mut raw)?;
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
        raw: &mut RawInputs,
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
            ("name", "string") => image.name = Some(string()),
            ("type", "string") => image.kind = Some(string()),
            ("chunkCount", "int") => {
                need(4)?;
                image.chunk_count = Some(i32_at(0));
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
            (inputs::APPROACH, _) => raw.approach = Some(string()),
            (inputs::TEMPERATURES, _) => raw.temperatures = Some(string()),
            (inputs::REFERENCE, "double") => {
                need(8)?;
                raw.reference_c = Some(f64s::<1>(value)[0]);
            }
            (n, _) if n.starts_with("volmap.csv.") => info
                .csv_files
                .push((n["volmap.csv.".len()..].to_string(), string())),
            _ => {}
        }
        Ok(())
    }

    /// Checks that the image is the field volmap writes for `info`: its channels, no
    /// compression, a data window of the grid's size.
    pub fn check_image(&self, info: &FieldInfo, image: &ImageAttributes) -> Result<(), FieldError> {
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

    /// Checks the attributes every part of a multi-part file has (`name`, `type`
    /// `scanlineimage`, `chunkCount` one per line), and returns the part's name.
    pub fn check_part(
        &self,
        part: usize,
        info: &FieldInfo,
        image: &ImageAttributes,
    ) -> Result<String, FieldError> {
        let name = image
            .name
            .clone()
            .ok_or_else(|| self.format(format!("part {part} has no name")))?;
        if image.kind.as_deref() != Some("scanlineimage") {
            return Err(self.format(format!(
                "part {part} ({name}) is not a scanline image; volmap reads the fields it writes"
            )));
        }
        let lines = (info.dims[1] * info.dims[2]) as i64;
        if image.chunk_count.map(i64::from) != Some(lines) {
            return Err(self.format(format!(
                "part {part} ({name}): chunkCount must be its {lines} lines"
            )));
        }
        Ok(name)
    }
}
