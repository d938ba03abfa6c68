//! Reading a field written by volmap: the headers checked against what volmap writes, the parts
//! of a multi-part file (one per pose of a sweep) found by their pose, then lines one by one or
//! in chunks, in order, each block decoded once. The offset tables are read a window at a time
//! and checked against the file's length first: memory does not grow with the grid.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use exr::io::Data;
use exr::meta::magic_number;

use super::blocks::{compression_name, BlockCodec};
use super::header::Cursor;
use super::{pose_list, FieldError, FieldInfo, POSE_TOLERANCE_DEG};
use crate::io::FileError;
use crate::model::channels::CHANNELS;
use crate::model::inputs::InputsRecord;

/// The flags of the version field volmap checks. The crate's `Requirements::read` decodes them
/// too, but refuses flags it does not know and takes the version from four bits, not eight:
/// volmap reads the field as it always has, for the same files and messages.
const FLAG_TILED: u32 = 0x200;
const FLAG_DEEP: u32 = 0x800;
const FLAG_MULTIPART: u32 = 0x1000;

/// One part of a field file: its name (empty in a single-part file), its header, how its blocks
/// are stored and where its offset table starts.
struct Part {
    name: String,
    info: FieldInfo,
    /// The OpenEXR compression code and whether the channels are HALF.
    code: u8,
    half: bool,
    blocks: u64,
    table: u64,
    /// Its number in the file.
    index: usize,
    /// The part of the standard uncertainties of this part's channels, where the file has one.
    uncertainty: Option<Box<Part>>,
}

/// A field file with its headers read: one part, or (a five-axis map over the rotary axes) one
/// part per pose, each a field of its own. Lines are read through a [`FieldReader`] of a part.
pub struct FieldFile {
    path: PathBuf,
    display: String,
    multipart: bool,
    /// Whether the parts are a sweep's, one per pose (a map of one pose with its uncertainties
    /// is multi-part too: its part of errors is named [`SINGLE_MAP_PART`]).
    sweep: bool,
    /// Where the blocks start (after every offset table) and where the file ends.
    data_start: u64,
    file_bytes: u64,
    /// Parts after the first whose machine file and CSV tables are the first's keep them empty
    /// here (a sweep repeats them in every part): [`FieldFile::info`] puts them back.
    parts: Vec<Part>,
}

impl FieldFile {
    pub fn open(path: &Path) -> Result<FieldFile, FieldError> {
        let display = path.display().to_string();
        crate::io::source::refuse_special(path)?;
        let file = crate::io::source::open_file(path)?;
        let mut reader = BufReader::with_capacity(1 << 20, file);
        let mut c = Cursor {
            path: &display,
            reader: &mut reader,
        };
        if c.bytes(4).map_err(|_| c.format("too short"))? != magic_number::BYTES {
            return Err(c.format("not an OpenEXR file (wrong magic number)"));
        }
        let version: u32 = c.number()?;
        if version & 0xff != 2 || version & (FLAG_TILED | FLAG_DEEP) != 0 {
            return Err(c.format("not a scanline OpenEXR file"));
        }
        let multipart = version & FLAG_MULTIPART != 0;
        let mut parts: Vec<Part> = Vec::new();
        // The least each part's blocks can take: a chunk header and a byte each, or the raw
        // values where they are stored uncompressed.
        let mut least_data = 0u64;
        while let Some((mut info, image)) = c.header()? {
            let codec = c.check_image(&info, &image)?;
            let lines = (info.dims[1] as u64).saturating_mul(info.dims[2] as u64);
            let blocks = lines.div_ceil(codec.lines_per_block());
            let head = if multipart { 12 } else { 8 };
            let least_block = if codec.is_uncompressed() {
                codec.raw_bytes(codec.lines_per_block().min(lines))
            } else {
                1
            };
            least_data = least_data.saturating_add(blocks.saturating_mul(head + least_block));
            let name = if multipart {
                let name = c.check_part(parts.len(), blocks, &image)?;
                if let Some(first) = parts.first() {
                    if info.machine_toml == first.info.machine_toml
                        && info.csv_files == first.info.csv_files
                    {
                        info.machine_toml = String::new();
                        info.csv_files = Vec::new();
                    }
                }
                name
            } else {
                String::new()
            };
            let (code, half) = codec.stored();
            parts.push(Part {
                name,
                info,
                code,
                half,
                blocks,
                table: 0,
                index: parts.len(),
                uncertainty: None,
            });
            if !multipart {
                break;
            }
        }
        if parts.is_empty() {
            return Err(c.format("the file has no header"));
        }
        // The offset tables follow the headers, one per part; then the blocks, each with its
        // part number in a multi-part file. Nothing is read of them before the sizes the
        // headers imply are checked against the file's.
        let mut at = c.reader.stream_position().unwrap_or(0);
        for part in &mut parts {
            part.table = at;
            at = at.saturating_add(part.blocks.saturating_mul(8));
        }
        let data_start = at;
        let parts = attach_uncertainties(&c, parts)?;
        let sweep = multipart && !(parts.len() == 1 && parts[0].name == SINGLE_MAP_PART);
        let needed = data_start.saturating_add(least_data);
        let file_bytes = c.reader.get_ref().metadata().map(|m| m.len()).unwrap_or(0);
        if needed > file_bytes {
            let what = match &parts[..] {
                [one] => {
                    let [nx, ny, nz] = one.info.dims;
                    format!("volmap.dims {nx}x{ny}x{nz} needs")
                }
                many => format!("its {} parts need", many.len()),
            };
            return Err(c.format(format!(
                "{what} at least {needed} bytes but the file has {file_bytes}: truncated"
            )));
        }
        Ok(FieldFile {
            path: path.to_path_buf(),
            display,
            multipart,
            sweep,
            data_start,
            file_bytes,
            parts,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the file has the parts of a sweep (even one), rather than the one field of a map
    /// at one pose.
    pub fn is_multipart(&self) -> bool {
        self.sweep
    }

    /// The number of parts: the poses of the file.
    pub fn parts(&self) -> usize {
        self.parts.len()
    }

    /// Part `part`'s header without the machine's file and CSV tables: what a summary of every
    /// part reads, in memory that does not grow with the machine's text times the parts.
    pub fn info_without_machine(&self, part: usize) -> FieldInfo {
        self.parts[part].info.without_machine()
    }

    /// The header of part `part`.
    pub fn info(&self, part: usize) -> FieldInfo {
        let mut info = self.parts[part].info.clone();
        if part > 0 && info.machine_toml.is_empty() {
            info.machine_toml = self.parts[0].info.machine_toml.clone();
            info.csv_files = self.parts[0].info.csv_files.clone();
        }
        info
    }

    /// How part `part` stores its values, in words: its compression (`none`, `zip`, `pxr24`,
    /// …), and `, HALF` for 16-bit channels.
    pub fn storage(&self, part: usize) -> String {
        let stored = &self.parts[part];
        let name = compression_name(stored.code);
        if stored.half {
            format!("{name}, HALF")
        } else {
            name
        }
    }

    /// How part `part` stores its values, where volmap writes that storage (`none`, `zip`,
    /// `pxr24`, FLOAT or HALF); `None` for a compression it only reads.
    pub fn stored(&self, part: usize) -> Option<super::Storage> {
        let stored = &self.parts[part];
        Some(super::Storage {
            compression: super::Compression::parse(&compression_name(stored.code))?,
            half: stored.half,
        })
    }

    /// The evaluation inputs part `part` was computed for.
    pub fn inputs(&self, part: usize) -> &InputsRecord {
        &self.parts[part].info.inputs
    }

    /// The pose of part `part`, degrees of A, B, C.
    pub fn pose_deg(&self, part: usize) -> [f64; 3] {
        self.parts[part].info.pose_deg
    }

    /// The name of part `part`: the pose it holds (`B=-90,C=0`); in a single-part file the
    /// name of its pose.
    pub fn name(&self, part: usize) -> String {
        let part = &self.parts[part];
        if self.sweep {
            part.name.clone()
        } else {
            part.info.pose_name()
        }
    }

    /// Every part's pose in words, for messages (the first few where there are many).
    pub fn pose_list(&self) -> String {
        pose_list(&(0..self.parts()).map(|p| self.name(p)).collect::<Vec<_>>())
    }

    /// The parts whose pose equals `pose_deg` (A, B, C) within 1e-9° on every axis `given`.
    pub fn parts_at(&self, pose_deg: [f64; 3], given: [bool; 3]) -> Vec<usize> {
        (0..self.parts())
            .filter(|&p| {
                let held = self.pose_deg(p);
                (0..3).all(|n| !given[n] || (pose_deg[n] - held[n]).abs() <= POSE_TOLERANCE_DEG)
            })
            .collect()
    }

    /// The part at the pose `pose_deg` (A, B, C, every axis): an error listing the poses the
    /// file holds where none is at it. `pose` is the pose in words, for that message.
    pub fn part_at(&self, pose_deg: [f64; 3], pose: &str) -> Result<usize, FieldError> {
        self.parts_at(pose_deg, [true; 3])
            .first()
            .copied()
            .ok_or_else(|| FieldError::NoPose {
                path: self.display.clone(),
                pose: pose.to_string(),
                poses: self.pose_list(),
            })
    }

    /// The one part of a single-part file (or of a sweep of one pose); a file of several poses
    /// is an error listing them.
    pub fn single(&self) -> Result<usize, FieldError> {
        if self.parts() > 1 {
            return Err(FieldError::Poses {
                path: self.display.clone(),
                count: self.parts(),
                poses: self.pose_list(),
            });
        }
        Ok(0)
    }

    /// The method of the standard uncertainties of part `part`'s channels, where the file holds
    /// them.
    pub fn uncertainty(&self, part: usize) -> Option<&str> {
        self.parts[part]
            .uncertainty
            .as_ref()
            .and_then(|u| u.info.uncertainty.as_deref())
    }

    /// Whether every part holds the standard uncertainties of its channels (volmap writes them
    /// for every pose of a map or for none).
    pub fn has_uncertainties(&self) -> bool {
        (0..self.parts()).all(|p| self.uncertainty(p).is_some())
    }

    /// A reader of the standard uncertainties of part `part`'s channels, where the file holds
    /// them (the same layout as the part's values).
    pub fn uncertainty_reader(&self, part: usize) -> Option<Result<FieldReader, FieldError>> {
        let stored = self.parts[part].uncertainty.as_deref()?;
        let mut info = self.info(part);
        info.uncertainty = stored.info.uncertainty.clone();
        Some(self.reader_of(stored, info))
    }

    /// [`FieldFile::uncertainty_reader`], where a part without uncertainties is an error
    /// naming the file (and the part's pose in a sweep).
    pub fn required_uncertainty_reader(&self, part: usize) -> Result<FieldReader, FieldError> {
        self.uncertainty_reader(part).unwrap_or_else(|| {
            Err(FieldError::NoUncertainty {
                path: self.display.clone(),
                at: if self.sweep {
                    format!(" at the pose {}", self.name(part))
                } else {
                    String::new()
                },
            })
        })
    }

    /// A reader of the lines of part `part`.
    pub fn reader(&self, part: usize) -> Result<FieldReader, FieldError> {
        self.reader_of(&self.parts[part], self.info(part))
    }

    fn reader_of(&self, stored: &Part, info: FieldInfo) -> Result<FieldReader, FieldError> {
        let file = File::open(&self.path).map_err(|e| FileError::read(&self.path, e))?;
        let lines = (info.dims[1] * info.dims[2]) as u64;
        let codec = BlockCodec::new(info.dims[0], lines, stored.code, stored.half)
            .expect("the header's compression was checked");
        Ok(FieldReader {
            path: self.display.clone(),
            file: BufReader::with_capacity(1 << 20, file),
            position: None,
            info,
            part: self.multipart.then_some(stored.index as u32),
            codec,
            lines,
            blocks: stored.blocks,
            table: stored.table,
            data_start: self.data_start,
            file_bytes: self.file_bytes,
            offsets_first: 0,
            offsets: Vec::new(),
            block: None,
            values: Vec::new(),
        })
    }
}

/// The name of the part of errors of a map of one pose with its uncertainties (its part of
/// uncertainties is `u`); a sweep's parts are named by their poses.
pub const SINGLE_MAP_PART: &str = "errors";

/// The parts of errors, each with the part of its uncertainties that follows it: a part of
/// uncertainties must follow one of errors of the same grid and pose.
fn attach_uncertainties(c: &Cursor, all: Vec<Part>) -> Result<Vec<Part>, FieldError> {
    let mut parts: Vec<Part> = Vec::with_capacity(all.len());
    for part in all {
        if part.info.uncertainty.is_none() {
            parts.push(part);
            continue;
        }
        let index = part.index;
        match parts.last_mut() {
            Some(errors)
                if errors.uncertainty.is_none()
                    && errors.index + 1 == index
                    && errors.info.dims == part.info.dims
                    && errors.info.pose_deg == part.info.pose_deg =>
            {
                errors.uncertainty = Some(Box::new(part))
            }
            _ => {
                return Err(c.format(format!(
                    "part {index} holds uncertainties (volmap.uncertainty) but does not follow the part of the errors of its grid and pose"
                )))
            }
        }
    }
    if parts.is_empty() {
        return Err(c.format("the file holds uncertainties but no errors"));
    }
    Ok(parts)
}

/// Offsets read from a table at a time.
const OFFSET_WINDOW: u64 = 8192;

/// Reads the lines of one field (a single-part file, or one part of a multi-part file) written
/// by volmap: scanline blocks, decoded one at a time.
pub struct FieldReader {
    path: String,
    file: BufReader<File>,
    /// Where the file stands after the last read, if known.
    position: Option<u64>,
    info: FieldInfo,
    /// The part number every block's chunk starts with, in a multi-part file.
    part: Option<u32>,
    codec: BlockCodec,
    lines: u64,
    blocks: u64,
    /// Where the part's offset table starts, where the blocks start and where the file ends.
    table: u64,
    data_start: u64,
    file_bytes: u64,
    /// A window of the offset table: the offsets of blocks `offsets_first ..`.
    offsets_first: u64,
    offsets: Vec<u64>,
    /// The block decoded last and its values (per line, `nx` values of each channel).
    block: Option<u64>,
    values: Vec<f32>,
}

impl FieldReader {
    /// Opens a single-part field file (or a sweep of one pose); a file of several poses is an
    /// error listing them (see [`FieldFile`] to read one of its parts).
    pub fn open(path: &Path) -> Result<FieldReader, FieldError> {
        let file = FieldFile::open(path)?;
        file.reader(file.single()?)
    }

    pub fn info(&self) -> &FieldInfo {
        &self.info
    }

    pub fn lines(&self) -> u64 {
        self.lines
    }

    fn format(&self, what: String) -> FieldError {
        FieldError::Format {
            path: self.path.clone(),
            what,
        }
    }

    fn seek(&mut self, to: u64) -> Result<(), FieldError> {
        // Blocks of volmap's files follow each other: seek (which empties the read buffer)
        // only when the next read does not start where the last one ended.
        if self.position != Some(to) {
            self.file
                .seek(SeekFrom::Start(to))
                .map_err(|source| FileError::Read {
                    path: self.path.clone(),
                    source,
                })?;
        }
        Ok(())
    }

    /// Where block `block` starts, from the window of the offset table that holds it.
    fn offset(&mut self, block: u64) -> Result<u64, FieldError> {
        let held = self.offsets_first..self.offsets_first + self.offsets.len() as u64;
        if !held.contains(&block) {
            let count = OFFSET_WINDOW.min(self.blocks - block);
            self.seek(self.table + 8 * block)?;
            self.offsets.clear();
            self.offsets.resize(count as usize, 0);
            if u64::read_slice_le(&mut self.file, &mut self.offsets).is_err() {
                self.offsets.clear();
                return Err(self.format("the file ends inside its offset tables".into()));
            }
            self.position = Some(self.table + 8 * (block + count));
            self.offsets_first = block;
        }
        let offset = self.offsets[(block - self.offsets_first) as usize];
        if offset < self.data_start || offset >= self.file_bytes {
            return Err(self.format(format!(
                "the offset of block {block} ({offset}) lies outside the file's blocks"
            )));
        }
        Ok(offset)
    }

    /// Reads and decodes block `block` into `values`, unless it is there already.
    fn load_block(&mut self, block: u64) -> Result<(), FieldError> {
        if self.block == Some(block) {
            return Ok(());
        }
        self.block = None;
        let offset = self.offset(block)?;
        self.seek(offset)?;
        let per_block = self.codec.lines_per_block();
        let first_line = block * per_block;
        let lines = per_block.min(self.lines - first_line);
        let head_bytes = if self.part.is_some() { 12 } else { 8 };
        let truncated = |r: &Self| r.format(format!("the block of line {first_line} is truncated"));
        let number = |r: &mut Self| i32::read_le(&mut r.file).map_err(|_| truncated(r));
        let got = match self.part {
            Some(_) => Some(number(self)? as u32),
            None => None,
        };
        let (y, size) = (number(self)?, number(self)?);
        if let (Some(part), Some(got)) = (self.part, got) {
            if got != part {
                return Err(self.format(format!(
                    "the block of line {first_line} of part {part}: its chunk header says part {got}"
                )));
            }
        }
        // A block is never stored larger than its raw values (OpenEXR keeps them raw then).
        let most = self.codec.raw_bytes(lines);
        if y as i64 != first_line as i64 || size <= 0 || size as u64 > most {
            return Err(self.format(format!(
                "block of line {first_line}: its chunk header says line {y} of {size} bytes (at most {most})"
            )));
        }
        if offset + head_bytes as u64 + size as u64 > self.file_bytes {
            return Err(truncated(self));
        }
        let mut stored = vec![0u8; size as usize];
        self.file
            .read_exact(&mut stored)
            .map_err(|_| truncated(self))?;
        self.position = Some(offset + head_bytes as u64 + size as u64);
        let mut values = std::mem::take(&mut self.values);
        let decoded = self.codec.decode(first_line, lines, stored, &mut values);
        self.values = values;
        decoded.map_err(|what| self.format(format!("block of line {first_line}: {what}")))?;
        // volmap never writes a value that is not a number: one is damage, not an error field.
        if let Some(at) = self.values.iter().position(|v| !v.is_finite()) {
            let per_line = self.codec.values_per_line();
            let nx = (per_line / CHANNELS.len()).max(1);
            let ny = self.info().dims[1].max(1) as u64;
            let line = first_line + (at / per_line) as u64;
            let (channel, i) = ((at % per_line) / nx, at % nx);
            let what = format!(
                "{} of grid point ({i}, {}, {}) is {}, not a number volmap writes",
                CHANNELS.get(channel).copied().unwrap_or("a channel"),
                line % ny,
                line / ny,
                self.values[at]
            );
            return Err(self.format(what));
        }
        self.block = Some(block);
        Ok(())
    }

    /// Reads line `line` into `out` (`6 · nx` values, channels in
    /// [`CHANNELS`](crate::model::channels::CHANNELS) order).
    pub fn read_line(&mut self, line: u64, out: &mut [f32]) -> Result<(), FieldError> {
        if line >= self.lines {
            return Err(self.format(format!("line {line} is past the last line")));
        }
        let per_block = self.codec.lines_per_block();
        self.load_block(line / per_block)?;
        let per_line = self.codec.values_per_line();
        let start = (line % per_block) as usize * per_line;
        out[..per_line].copy_from_slice(&self.values[start..start + per_line]);
        Ok(())
    }

    /// Reads every line in order, handing each chunk of up to `lines_per_chunk` lines to `f`
    /// as `(first_line, lines, data)`.
    pub fn for_each_chunk(
        &mut self,
        lines_per_chunk: u64,
        f: impl FnMut(u64, u64, &[f32]),
    ) -> Result<(), FieldError> {
        self.for_each_chunk_of(0..self.lines, lines_per_chunk, f)
    }

    /// [`FieldReader::for_each_chunk`] over the lines of `range` only.
    pub fn for_each_chunk_of(
        &mut self,
        range: std::ops::Range<u64>,
        lines_per_chunk: u64,
        mut f: impl FnMut(u64, u64, &[f32]),
    ) -> Result<(), FieldError> {
        let values = self.codec.values_per_line();
        let end = range.end.min(self.lines);
        let mut buffer = Vec::new();
        let mut first = range.start;
        while first < end {
            let lines = lines_per_chunk.max(1).min(end - first);
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
