//! Reading a field written by volmap: the headers checked against what volmap writes, the parts
//! of a multi-part file (one per pose of a sweep) found by their pose, then lines one by one or
//! in chunks, in order.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::header::Cursor;
use super::{
    pose_list, FieldError, FieldInfo, FLAG_DEEP, FLAG_MULTIPART, FLAG_TILED, MAGIC,
    POSE_TOLERANCE_DEG,
};
use crate::io::FileError;
use crate::model::channels::CHANNELS;
use crate::model::inputs::InputsRecord;

/// One part of a field file: its name (empty in a single-part file), its header and where its
/// offset table starts.
struct Part {
    name: String,
    info: FieldInfo,
    table: u64,
}

/// A field file with its headers read: one part, or (a five-axis map over the rotary axes) one
/// part per pose, each a field of its own. Lines are read through a [`FieldReader`] of a part.
pub struct FieldFile {
    path: PathBuf,
    display: String,
    multipart: bool,
    /// Parts after the first whose machine file and CSV tables are the first's keep them empty
    /// here (a sweep repeats them in every part): [`FieldFile::info`] puts them back.
    parts: Vec<Part>,
}

impl FieldFile {
    pub fn open(path: &Path) -> Result<FieldFile, FieldError> {
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
        if version & 0xff != 2 || version & (FLAG_TILED | FLAG_DEEP) != 0 {
            return Err(c.format("not a scanline OpenEXR file"));
        }
        let multipart = version & FLAG_MULTIPART != 0;
        let mut parts: Vec<Part> = Vec::new();
        while let Some((mut info, image)) = c.header()? {
            c.check_image(&info, &image)?;
            let name = if multipart {
                let name = c.check_part(parts.len(), &info, &image)?;
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
            parts.push(Part {
                name,
                info,
                table: 0,
            });
            if !multipart {
                break;
            }
        }
        if parts.is_empty() {
            return Err(c.format("the file has no header"));
        }
        // The offset tables follow the headers, one per part; then the lines, each with its part
        // number in a multi-part file.
        let mut at = c.reader.stream_position().unwrap_or(0);
        let mut data_bytes = at;
        for part in &mut parts {
            // Dimensions come from the file: sums that overflow count as more than it has.
            let [nx, ny, nz] = part.info.dims.map(|d| d as u64);
            let chunk_head = if multipart { 12 } else { 8 };
            let lines = ny.saturating_mul(nz);
            let chunk = (CHANNELS.len() as u64 * 4).saturating_mul(nx) + 8 + chunk_head;
            part.table = at;
            at = at.saturating_add(lines.saturating_mul(8));
            data_bytes = data_bytes.saturating_add(lines.saturating_mul(chunk));
        }
        let file_bytes = c.reader.get_ref().metadata().map(|m| m.len()).unwrap_or(0);
        if data_bytes > file_bytes {
            let what = match &parts[..] {
                [one] => {
                    let [nx, ny, nz] = one.info.dims;
                    format!("volmap.dims {nx}x{ny}x{nz} needs")
                }
                many => format!("its {} parts need", many.len()),
            };
            return Err(c.format(format!(
                "{what} {data_bytes} bytes but the file has {file_bytes}: truncated"
            )));
        }
        Ok(FieldFile {
            path: path.to_path_buf(),
            display,
            multipart,
            parts,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the file has the parts of a sweep (even one), rather than the one field of a map
    /// at one pose.
    pub fn is_multipart(&self) -> bool {
        self.multipart
    }

    /// The number of parts: the poses of the file.
    pub fn parts(&self) -> usize {
        self.parts.len()
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
        if self.multipart {
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

    /// A reader of the lines of part `part`.
    pub fn reader(&self, part: usize) -> Result<FieldReader, FieldError> {
        let file = File::open(&self.path).map_err(|e| FileError::read(&self.path, e))?;
        let mut file = BufReader::with_capacity(1 << 20, file);
        let info = self.info(part);
        let [_, ny, nz] = info.dims;
        let lines = ny * nz;
        let read = |source| FileError::Read {
            path: self.display.clone(),
            source,
        };
        file.seek(SeekFrom::Start(self.parts[part].table))
            .map_err(read)?;
        let mut table = vec![0u8; 8 * lines];
        file.read_exact(&mut table)
            .map_err(|_| FieldError::Format {
                path: self.display.clone(),
                what: "the file ends inside its offset tables".into(),
            })?;
        let offsets = table
            .chunks(8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
            .collect();
        Ok(FieldReader {
            path: self.display.clone(),
            file,
            position: None,
            scratch: Vec::new(),
            info,
            part: self.multipart.then_some(part as u32),
            offsets,
        })
    }
}

/// Reads the lines of one field (a single-part file, or one part of a multi-part file) written
/// by volmap: scanline, uncompressed.
pub struct FieldReader {
    path: String,
    file: BufReader<File>,
    /// Where the file stands after the last line read, if known.
    position: Option<u64>,
    /// The bytes of the last line read.
    scratch: Vec<u8>,
    info: FieldInfo,
    /// The part number every line's chunk starts with, in a multi-part file.
    part: Option<u32>,
    offsets: Vec<u64>,
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
        let head_bytes = if self.part.is_some() { 12 } else { 8 };
        let mut head = [0u8; 12];
        self.file
            .read_exact(&mut head[..head_bytes])
            .map_err(|_| format(format!("line {line} is truncated")))?;
        let word = |at: usize| [head[at], head[at + 1], head[at + 2], head[at + 3]];
        let (y, size) = (
            i32::from_le_bytes(word(head_bytes - 8)),
            i32::from_le_bytes(word(head_bytes - 4)),
        );
        if let Some(part) = self.part {
            let got = u32::from_le_bytes(word(0));
            if got != part {
                return Err(format(format!(
                    "line {line} of part {part}: chunk header says part {got}"
                )));
            }
        }
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
        self.position = Some(offset + head_bytes as u64 + size as u64);
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
