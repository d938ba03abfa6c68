//! Reading a field's header: its attributes into a [`FieldInfo`] (the grid's numbers checked),
//! and the image attributes checked against what volmap writes (channels FLOAT or HALF, a
//! compression the readers decode, the data window; in a multi-part file also each part's name,
//! type and chunk count).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read};

use exr::io::Data;

use super::blocks::{compression_name, BlockCodec};
use super::inputs::{self, RawInputs};
use super::{FieldError, FieldInfo};
use crate::model::channels::CHANNELS;

/// OpenEXR's pixel types as a channel list stores them. The crate's `SampleType::read` refuses
/// any other number, where volmap names it in its message.
const PIXEL_UINT: i32 = 0;
const PIXEL_HALF: i32 = 1;
const PIXEL_FLOAT: i32 = 2;

/// The CSV tables of a header as read: `volmap.csvPath.N` and `volmap.csvText.N` by `N`.
#[derive(Default)]
struct CsvAttributes {
    paths: BTreeMap<u32, String>,
    texts: BTreeMap<u32, String>,
}

pub(super) struct Cursor<'a> {
    pub path: &'a str,
    pub reader: &'a mut BufReader<File>,
}

/// `N` numbers of type `T` from the start of `value`, which holds them (its size checked).
fn numbers<T: Data + Copy, const N: usize>(value: &[u8]) -> [T; N] {
    let mut out = [T::default(); N];
    let _ = T::read_slice_le(&mut &value[..], &mut out);
    out
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

    /// The next `n` bytes, held as they arrive: an attribute that claims a gigabyte in a file
    /// of a few bytes ends at the file's end, not in an allocation of its claim.
    pub fn bytes(&mut self, n: usize) -> Result<Vec<u8>, FieldError> {
        let mut buf = Vec::with_capacity(n.min(1 << 16));
        let read = (&mut *self.reader).take(n as u64).read_to_end(&mut buf);
        if read.is_err() || buf.len() < n {
            return Err(self.format("the file ends inside its header"));
        }
        Ok(buf)
    }

    /// The next number of type `T`, little-endian.
    pub fn number<T: Data>(&mut self) -> Result<T, FieldError> {
        T::read_le(&mut *self.reader).map_err(|_| self.format("the file ends inside its header"))
    }

    fn text(&mut self) -> Result<String, FieldError> {
        let mut s = Vec::new();
        loop {
            let b: u8 = self.number()?;
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
        let mut csv = CsvAttributes::default();
        let mut empty = true;
        loop {
            let name = self.text()?;
            if name.is_empty() {
                if empty {
                    return Ok(None);
                }
                self.csv_tables(csv, &mut info)?;
                self.check_numbers(&info)?;
                info.inputs = raw.record(&info, self.path)?;
                return Ok(Some((info, image)));
            }
            empty = false;
            let kind = self.text()?;
            let size = self.number::<u32>()? as usize;
            if size > 1 << 30 {
                return Err(self.format(format!("attribute {name} claims {size} bytes")));
            }
            let value = self.bytes(size)?;
            if let Some(n) = name.strip_prefix("volmap.csvPath.") {
                csv.paths
                    .insert(self.table_number(&name, n)?, string_of(&value));
            } else if let Some(n) = name.strip_prefix("volmap.csvText.") {
                csv.texts
                    .insert(self.table_number(&name, n)?, string_of(&value));
            } else {
                self.attribute(&name, &kind, &value, &mut info, &mut image, &mut raw)?;
            }
        }
    }

    fn table_number(&self, name: &str, n: &str) -> Result<u32, FieldError> {
        n.parse()
            .map_err(|_| self.format(format!("attribute {name}: `{n}` is not a table number")))
    }

    /// The CSV tables of the header (after those of fields written before the tables were
    /// numbered), each path with its text.
    fn csv_tables(&self, csv: CsvAttributes, info: &mut FieldInfo) -> Result<(), FieldError> {
        let CsvAttributes { paths, mut texts } = csv;
        for (n, path) in paths {
            let text = texts.remove(&n).ok_or_else(|| {
                self.format(format!(
                    "attribute volmap.csvPath.{n} has no volmap.csvText.{n}"
                ))
            })?;
            info.csv_files.push((path, text));
        }
        if let Some(n) = texts.keys().next() {
            return Err(self.format(format!(
                "attribute volmap.csvText.{n} has no volmap.csvPath.{n}"
            )));
        }
        Ok(())
    }

    /// The grid's numbers: every origin and pose finite, every step finite and positive (zero
    /// only along a dimension one point deep), naming the attribute at fault.
    fn check_numbers(&self, info: &FieldInfo) -> Result<(), FieldError> {
        const AXES: [&str; 3] = ["X", "Y", "Z"];
        for d in 0..3 {
            let origin = info.origin_mm[d];
            if !origin.is_finite() {
                return Err(self.format(format!(
                    "attribute volmap.origin: {} = {origin} mm is not a finite number",
                    AXES[d]
                )));
            }
            let step = info.spacing_mm[d];
            let fine = step.is_finite() && (step > 0.0 || (step == 0.0 && info.dims[d] <= 1));
            if !fine {
                return Err(self.format(format!(
                    "attribute volmap.spacing: the step along {} is {step} mm; it must be a positive number{}",
                    AXES[d],
                    if info.dims[d] <= 1 { " or 0 (one point)" } else { "" }
                )));
            }
            let pose = info.pose_deg[d];
            if !pose.is_finite() {
                return Err(self.format(format!(
                    "attribute volmap.pose: {} = {pose}° is not a finite number",
                    ["A", "B", "C"][d]
                )));
            }
        }
        Ok(())
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
        let string = || string_of(value);
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
        match (name, kind) {
            ("channels", "chlist") => {
                let mut rest = value;
                while let Some(end) = rest.iter().position(|&b| b == 0) {
                    if end == 0 {
                        break;
                    }
                    let channel = String::from_utf8_lossy(&rest[..end]).into_owned();
                    let pixel = rest.get(end + 1..end + 5).map(numbers::<i32, 1>);
                    let pixel = pixel.map(|[p]| p);
                    image.channels.push((channel, pixel));
                    rest = rest.get(end + 17..).unwrap_or(&[]);
                }
            }
            ("compression", "compression") => image.compression = value.first().copied(),
            ("dataWindow", "box2i") => {
                need(16)?;
                image.window = Some(numbers(value));
            }
            ("name", "string") => image.name = Some(string()),
            ("type", "string") => image.kind = Some(string()),
            ("chunkCount", "int") => {
                need(4)?;
                image.chunk_count = Some(numbers::<i32, 1>(value)[0]);
            }
            ("volmap.dims", "v3i") => {
                need(12)?;
                info.dims = numbers::<i32, 3>(value).map(|d| d.max(0) as usize);
            }
            ("volmap.origin", "v3d") => {
                need(24)?;
                info.origin_mm = numbers(value);
            }
            ("volmap.spacing", "v3d") => {
                need(24)?;
                info.spacing_mm = numbers(value);
            }
            ("volmap.pose", "v3d") => {
                need(24)?;
                info.pose_deg = numbers(value);
            }
            ("volmap.poseAxes", _) => info.pose_axes = string(),
            ("volmap.machine", _) => info.machine_name = string(),
            ("volmap.chain", _) => info.chain = string(),
            ("volmap.machineToml", _) => info.machine_toml = string(),
            ("volmap.device", _) => info.device = string(),
            ("volmap.uncertainty", _) => info.uncertainty = Some(string()),
            (inputs::APPROACH, _) => raw.approach = Some(string()),
            (inputs::TEMPERATURES, _) => raw.temperatures = Some(string()),
            (inputs::REFERENCE, "double") => {
                need(8)?;
                raw.reference_c = Some(numbers::<f64, 1>(value)[0]);
            }
            (n, _) if n.starts_with("volmap.csv.") => info
                .csv_files
                .push((n["volmap.csv.".len()..].to_string(), string())),
            _ => {}
        }
        Ok(())
    }

    /// Checks that the image is a field as volmap writes it for `info` (its channels all FLOAT
    /// or all HALF, a compression the readers decode, a data window of the grid's size) and
    /// returns the codec of its blocks.
    pub fn check_image(
        &self,
        info: &FieldInfo,
        image: &ImageAttributes,
    ) -> Result<BlockCodec, FieldError> {
        let names: Vec<&str> = image.channels.iter().map(|(n, _)| n.as_str()).collect();
        let types: Vec<Option<i32>> = image.channels.iter().map(|&(_, t)| t).collect();
        let half = types.first() == Some(&Some(PIXEL_HALF));
        let uniform = types
            .iter()
            .all(|&t| t == Some(PIXEL_FLOAT) || (half && t == Some(PIXEL_HALF)));
        if names != CHANNELS || !uniform {
            // A channel list is the writer's, of any length: the first few named.
            const SHOWN_CHANNELS: usize = 8;
            let mut found: Vec<String> = image
                .channels
                .iter()
                .take(SHOWN_CHANNELS)
                .map(|(n, t)| format!("{} {}", crate::error::excerpt(n), pixel_type_name(*t)))
                .collect();
            if image.channels.len() > SHOWN_CHANNELS {
                found.push(format!("… ({} channels in all)", image.channels.len()));
            }
            return Err(self.format(format!(
                "channels must be {} all FLOAT (or all HALF), found {}",
                CHANNELS.join(" "),
                if found.is_empty() {
                    "none".to_string()
                } else {
                    found.join(", ")
                }
            )));
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
        let code = image
            .compression
            .ok_or_else(|| self.format("the header has no compression attribute"))?;
        BlockCodec::new(nx, (ny * nz) as u64, code, half).ok_or_else(|| {
            self.format(format!(
                "its compression ({}) is not one volmap reads (none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab)",
                compression_name(code)
            ))
        })
    }

    /// Checks the attributes every part of a multi-part file has (`name`, `type`
    /// `scanlineimage`, `chunkCount` its number of blocks), and returns the part's name.
    pub fn check_part(
        &self,
        part: usize,
        blocks: u64,
        image: &ImageAttributes,
    ) -> Result<String, FieldError> {
        let name = image
            .name
            .clone()
            .ok_or_else(|| self.format(format!("part {part} has no name")))?;
        // A name is the writer's text, of any length: quoted cut.
        let shown = crate::error::excerpt(&name);
        if image.kind.as_deref() != Some("scanlineimage") {
            return Err(self.format(format!(
                "part {part} (`{shown}`) is not a scanline image; volmap reads the fields it writes"
            )));
        }
        if image.chunk_count.map(i64::from) != Some(blocks as i64) {
            return Err(self.format(format!(
                "part {part} (`{shown}`): chunkCount must be its {blocks} blocks of lines"
            )));
        }
        Ok(name)
    }
}

fn string_of(value: &[u8]) -> String {
    String::from_utf8_lossy(value).into_owned()
}

/// An OpenEXR pixel type in words.
fn pixel_type_name(pixel: Option<i32>) -> String {
    match pixel {
        Some(PIXEL_UINT) => "UINT".into(),
        Some(PIXEL_HALF) => "HALF".into(),
        Some(PIXEL_FLOAT) => "FLOAT".into(),
        Some(other) => format!("of pixel type {other}"),
        None => "of no pixel type".into(),
    }
}
