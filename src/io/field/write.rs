//! Writing a field: the headers ([`super::encode`]) and the offset tables first (zeros, filled
//! in as blocks are written), then the lines as they arrive, handed to the pipeline
//! ([`super::pipeline`]) that compresses and writes them behind the computation; a multi-part
//! field (a sweep of poses) the same way, every header and offset table first.

use std::io::{Read, Write};
use std::path::Path;

use super::blocks::{BlockCodec, Storage};
use super::encode::{header_attributes, write_file_start, write_headers_end, PartAttributes};
use super::pipeline::{PartPlan, Pipeline, WriteTimes};
use super::{FieldError, FieldInfo};
use crate::io::atomic::AtomicFile;

/// Writes `count` zero bytes.
fn zeros(out: &mut AtomicFile, count: u64) -> std::io::Result<()> {
    std::io::copy(&mut std::io::repeat(0).take(count), out).map(|_| ())
}

/// Creates `path` with the headers of `count` parts and zeroed offset tables, and starts the
/// pipeline that writes their blocks. `part(p)` gives part `p`'s name (`None` for the one field
/// of a single-part file) and header: each header is built, written and dropped before the next,
/// so memory holds one header (a machine file and its CSV tables) whatever the number of parts.
fn start(
    path: &Path,
    count: usize,
    part: &dyn Fn(usize) -> (Option<String>, FieldInfo),
    storage: Storage,
) -> Result<Pipeline, FieldError> {
    let mut out = AtomicFile::create(path, 8 << 20)?;
    let mut plans = Vec::with_capacity(count);
    let mut multipart = false;
    let mut long_names = false;
    let mut at = 8u64;
    let written = (|| -> std::io::Result<u64> {
        for p in 0..count {
            let (name, info) = part(p);
            if p == 0 {
                multipart = name.is_some();
                // The version flags say whether names are long: rewritten below if one is.
                write_file_start(&mut out, multipart, false)?;
            }
            let [nx, ny, nz] = info.dims;
            let lines = (ny * nz) as u64;
            let codec = BlockCodec::for_writing(nx, lines, storage);
            let chunks = lines.div_ceil(codec.lines_per_block());
            let header = header_attributes(
                &info,
                storage,
                name.as_deref().map(|name| PartAttributes { name, chunks }),
            )?;
            long_names |= header.long_names;
            out.write_all(&header.bytes)?;
            at += header.bytes.len() as u64;
            plans.push(PartPlan {
                codec,
                dims: info.dims,
                lines,
                table: 0,
            });
        }
        if multipart {
            write_headers_end(&mut out)?;
            at += 1;
        }
        for plan in &mut plans {
            plan.table = at;
            zeros(&mut out, 8 * plan.blocks())?;
            at += 8 * plan.blocks();
        }
        // The tables are filled in place as blocks are written: they must be in the file first.
        out.flush()?;
        if long_names {
            let mut start = Vec::new();
            write_file_start(&mut start, multipart, true)?;
            out.write_at(&start, 0)?;
        }
        Ok(at)
    })();
    let data_start = written.map_err(|e| out.error(e))?;
    Ok(Pipeline::start(out, plans, data_start, multipart))
}

/// Streams a field into a temporary file, renamed into place by [`FieldWriter::finish`];
/// dropped before that, it leaves nothing behind.
pub struct FieldWriter {
    pipeline: Pipeline,
    display: String,
    total_lines: u64,
    next_line: u64,
}

impl FieldWriter {
    /// An uncompressed FLOAT field.
    pub fn create(path: &Path, info: &FieldInfo) -> Result<FieldWriter, FieldError> {
        FieldWriter::create_stored(path, info, Storage::default())
    }

    /// A field stored as `storage` says.
    pub fn create_stored(
        path: &Path,
        info: &FieldInfo,
        storage: Storage,
    ) -> Result<FieldWriter, FieldError> {
        let pipeline = start(path, 1, &|_| (None, info.clone()), storage)?;
        Ok(FieldWriter {
            pipeline,
            display: path.display().to_string(),
            total_lines: (info.dims[1] * info.dims[2]) as u64,
            next_line: 0,
        })
    }

    /// Appends `lines` lines starting at `first_line` (which must follow the last line written):
    /// `data` holds, per line, `nx` values of each channel in
    /// [`CHANNELS`](crate::model::channels::CHANNELS) order.
    pub fn write_lines(
        &mut self,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        if first_line != self.next_line {
            return Err(FieldError::OutOfOrder {
                path: self.display.clone(),
                expected: self.next_line,
                got: first_line,
            });
        }
        let lines = lines.min(self.total_lines - first_line);
        self.pipeline.push(0, first_line, lines, data)?;
        self.next_line += lines;
        Ok(())
    }

    /// Checks that every line was written, waits for the last blocks, and puts the file in
    /// place; returns how long each stage of the writing was busy.
    pub fn finish(self) -> Result<WriteTimes, FieldError> {
        if self.next_line != self.total_lines {
            return Err(FieldError::Incomplete {
                path: self.display,
                written: self.next_line,
                total: self.total_lines,
            });
        }
        self.pipeline.finish()
    }
}

/// Streams a multi-part field (one part per pose of a sweep) into a temporary file, renamed into
/// place by [`PartsWriter::finish`]; dropped before that, it leaves nothing behind.
///
/// The headers and all the offset tables are written first, and then the parts' lines as they
/// are computed, part after part: memory holds a few pieces at a time, whatever the sweep.
pub struct PartsWriter {
    pipeline: Pipeline,
    display: String,
    /// Each part's number of lines.
    parts: Vec<u64>,
    part: usize,
    next_line: u64,
    written: u64,
}

impl PartsWriter {
    /// Starts writing `path` with `count` uncompressed FLOAT parts; `part(p)` gives part `p`'s
    /// name (unique) and header.
    pub fn create(
        path: &Path,
        count: usize,
        part: impl Fn(usize) -> (String, FieldInfo),
    ) -> Result<PartsWriter, FieldError> {
        PartsWriter::create_stored(path, count, part, Storage::default())
    }

    /// [`PartsWriter::create`] with every part stored as `storage` says.
    pub fn create_stored(
        path: &Path,
        count: usize,
        part: impl Fn(usize) -> (String, FieldInfo),
        storage: Storage,
    ) -> Result<PartsWriter, FieldError> {
        if count == 0 {
            return Err(FieldError::Format {
                path: path.display().to_string(),
                what: "a multi-part field needs a part".into(),
            });
        }
        let pipeline = start(
            path,
            count,
            &|p| {
                let (name, info) = part(p);
                (Some(name), info)
            },
            storage,
        )?;
        let lines = pipeline.part_lines();
        Ok(PartsWriter {
            pipeline,
            display: path.display().to_string(),
            parts: lines,
            part: 0,
            next_line: 0,
            written: 0,
        })
    }

    /// Appends `lines` lines of part `part` starting at `first_line`: the lines of a part in
    /// order, the parts in order, each part whole before the next begins. `data` holds, per
    /// line, `nx` values of each channel in [`CHANNELS`](crate::model::channels::CHANNELS) order.
    pub fn write_lines(
        &mut self,
        part: usize,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        let out_of_order = |expected| FieldError::PartOutOfOrder {
            path: self.display.clone(),
            expected,
            got: part,
        };
        if part != self.part {
            let done = self
                .parts
                .get(self.part)
                .is_some_and(|&total| self.next_line == total);
            if part != self.part + 1 || !done {
                return Err(out_of_order(self.part));
            }
            self.part = part;
            self.next_line = 0;
        }
        let Some(&total) = self.parts.get(part) else {
            return Err(out_of_order(self.part));
        };
        if first_line != self.next_line {
            return Err(FieldError::OutOfOrder {
                path: self.display.clone(),
                expected: self.next_line,
                got: first_line,
            });
        }
        let lines = lines.min(total - first_line);
        self.pipeline.push(part, first_line, lines, data)?;
        self.next_line += lines;
        self.written += lines;
        Ok(())
    }

    /// Checks that every line of every part was written, waits for the last blocks, and puts
    /// the file in place; returns how long each stage of the writing was busy.
    pub fn finish(self) -> Result<WriteTimes, FieldError> {
        let total: u64 = self.parts.iter().sum();
        if self.written != total {
            return Err(FieldError::Incomplete {
                path: self.display,
                written: self.written,
                total,
            });
        }
        self.pipeline.finish()
    }
}
