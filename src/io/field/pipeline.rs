//! The field writer's pipeline: the thread that computes the field (the engine's) hands lines
//! over and goes back to computing, while one thread compresses blocks (on all cores, rayon) and
//! another writes them, so the device, the readback, the compression and the disk are all busy
//! at once.
//!
//! Lines travel in pieces of whole blocks (about 8 MiB) through bounded queues, in buffers that
//! are recycled: memory holds a fixed number of pieces whatever the grid. Each piece's block
//! offsets are written into the offset table (written ahead as zeros) as soon as its blocks are
//! in the file, so no table is kept in memory either.

use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use exr::io::Data;

use super::blocks::{BlockCodec, EncodeError, HALF_MAX};
use super::encode::{io_error, write_chunk};
use super::FieldError;
use crate::io::atomic::AtomicFile;
use crate::model::channels::CHANNELS;

/// Seconds each stage of a field's writing was busy, and the file's size.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct WriteTimes {
    /// The computing thread waited for room in the pipeline (compression or the disk behind).
    pub waiting_s: f64,
    /// Encoding and compressing blocks (wall-clock seconds of the compression stage, whose work
    /// is spread over every core).
    pub compress_s: f64,
    /// Writing blocks into the file.
    pub write_s: f64,
    /// Flushing, syncing to disk and renaming the file at the end.
    pub sync_s: f64,
    /// Bytes of the file.
    pub bytes: u64,
}

/// One field (a part of a file) as the pipeline writes it.
pub(super) struct PartPlan {
    pub codec: BlockCodec,
    pub dims: [usize; 3],
    pub lines: u64,
    /// Where its offset table starts in the file.
    pub table: u64,
}

impl PartPlan {
    pub fn blocks(&self) -> u64 {
        self.lines.div_ceil(self.codec.lines_per_block())
    }
}

/// Lines of one part, whole blocks (the last block of a part may be short).
struct Piece {
    part: usize,
    first_line: u64,
    lines: u64,
    values: Vec<f32>,
}

/// A piece's blocks as stored: its values themselves (uncompressed FLOAT, written as
/// little-endian bytes) or each block's bytes.
enum Encoded {
    Raw(Piece),
    Blocks {
        part: usize,
        first_line: u64,
        blocks: Vec<Vec<u8>>,
    },
}

/// What the writing stage hands back: the file, its seconds of writing and its bytes.
type Written = Result<(AtomicFile, f64, u64), FieldError>;

/// Target bytes of values per piece, and the most one may hold where a block is small.
const PIECE_BYTES: usize = 8 << 20;
const MAX_PIECE_BYTES: usize = 32 << 20;
/// Pieces waiting in each queue.
const QUEUE: usize = 2;
/// Buffers in use at most: both queues full, one piece in each stage's hands and one filling.
const BUFFERS: usize = 2 * QUEUE + 3;

pub(super) struct Pipeline {
    display: String,
    parts: Arc<Vec<PartPlan>>,
    current: Option<Piece>,
    to_compress: Option<SyncSender<Piece>>,
    free: Receiver<Vec<f32>>,
    buffers: usize,
    compressor: Option<JoinHandle<f64>>,
    writer: Option<JoinHandle<Written>>,
    failure: Arc<Mutex<Option<FieldError>>>,
    waiting_s: f64,
}

impl Pipeline {
    /// Starts the stages on `out`, which holds the headers and the offset tables (zeros),
    /// flushed: blocks follow from byte `data_start`.
    pub fn start(
        out: AtomicFile,
        parts: Vec<PartPlan>,
        data_start: u64,
        multipart: bool,
    ) -> Pipeline {
        let display = out.path().display().to_string();
        let parts = Arc::new(parts);
        let failure = Arc::new(Mutex::new(None));
        let (to_compress, compress_in) = mpsc::sync_channel::<Piece>(QUEUE);
        let (to_write, write_in) = mpsc::sync_channel::<Encoded>(QUEUE);
        let (recycle, free) = mpsc::channel::<Vec<f32>>();
        let compressor = {
            let (parts, failure, recycle, display) = (
                parts.clone(),
                failure.clone(),
                recycle.clone(),
                display.clone(),
            );
            std::thread::Builder::new()
                .name("volmap-compress".into())
                .spawn(move || {
                    compress_loop(&parts, compress_in, to_write, recycle, &failure, &display)
                })
                .expect("a thread for the compression")
        };
        let writer = {
            let parts = parts.clone();
            std::thread::Builder::new()
                .name("volmap-write".into())
                .spawn(move || write_loop(out, &parts, data_start, multipart, write_in, recycle))
                .expect("a thread for the writing")
        };
        Pipeline {
            display,
            parts,
            current: None,
            to_compress: Some(to_compress),
            free,
            buffers: 0,
            compressor: Some(compressor),
            writer: Some(writer),
            failure,
            waiting_s: 0.0,
        }
    }

    /// Each part's number of lines.
    pub fn part_lines(&self) -> Vec<u64> {
        self.parts.iter().map(|p| p.lines).collect()
    }

    /// Hands over `lines` lines of part `part` from `first_line` (which follow the lines handed
    /// over before), `data` holding per line `nx` values of each channel.
    pub fn push(
        &mut self,
        part: usize,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FieldError> {
        let parts = self.parts.clone();
        let plan = &parts[part];
        let per_line = plan.codec.values_per_line();
        let piece_lines = piece_lines(&plan.codec);
        let mut rest = &data[..lines as usize * per_line];
        let mut line = first_line;
        while !rest.is_empty() {
            if self.current.is_none() {
                let values = self.buffer()?;
                self.current = Some(Piece {
                    part,
                    first_line: line,
                    lines: 0,
                    values,
                });
            }
            let piece = self.current.as_mut().expect("a piece is filling");
            let take = (piece_lines - piece.lines).min((rest.len() / per_line) as u64);
            let (now, later) = rest.split_at(take as usize * per_line);
            piece.values.extend_from_slice(now);
            piece.lines += take;
            line += take;
            rest = later;
            if piece.lines == piece_lines || line == plan.lines {
                self.send_current()?;
            }
        }
        Ok(())
    }

    /// An empty buffer for a piece: a recycled one, a new one while fewer than [`BUFFERS`]
    /// exist, else the next one a stage gives back.
    fn buffer(&mut self) -> Result<Vec<f32>, FieldError> {
        if let Ok(mut values) = self.free.try_recv() {
            values.clear();
            return Ok(values);
        }
        if self.buffers < BUFFERS {
            self.buffers += 1;
            return Ok(Vec::new());
        }
        let start = Instant::now();
        let got = self.free.recv();
        self.waiting_s += start.elapsed().as_secs_f64();
        match got {
            Ok(mut values) => {
                values.clear();
                Ok(values)
            }
            Err(_) => Err(self.stop()),
        }
    }

    fn send_current(&mut self) -> Result<(), FieldError> {
        let Some(piece) = self.current.take() else {
            return Ok(());
        };
        let start = Instant::now();
        let sent = match &self.to_compress {
            Some(sender) => sender.send(piece).is_ok(),
            None => false,
        };
        self.waiting_s += start.elapsed().as_secs_f64();
        if sent {
            Ok(())
        } else {
            Err(self.stop())
        }
    }

    /// Stops the stages after a failure and returns it.
    fn stop(&mut self) -> FieldError {
        self.to_compress = None;
        let compressor = self.compressor.take().map(|c| c.join());
        let written = self.writer.take().map(|w| w.join());
        if let Some(failure) = self
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            return failure;
        }
        match (compressor, written) {
            (_, Some(Ok(Err(e)))) => e,
            _ => FieldError::Compress {
                path: self.display.clone(),
                what: "a stage of the writing stopped unexpectedly".into(),
            },
        }
    }

    /// Sends the last piece, waits for every block to be written, then syncs the file and puts
    /// it in place.
    pub fn finish(mut self) -> Result<WriteTimes, FieldError> {
        self.send_current()?;
        self.to_compress = None;
        let compress_s = self
            .compressor
            .take()
            .map(|c| c.join().unwrap_or(0.0))
            .unwrap_or(0.0);
        let written = self.writer.take().map(|w| w.join());
        if let Some(failure) = self
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            return Err(failure);
        }
        let (file, write_s, bytes) = match written {
            Some(Ok(result)) => result?,
            _ => return Err(self.stop()),
        };
        let start = Instant::now();
        file.commit()?;
        Ok(WriteTimes {
            waiting_s: self.waiting_s,
            compress_s,
            write_s,
            sync_s: start.elapsed().as_secs_f64(),
            bytes,
        })
    }
}

impl Drop for Pipeline {
    /// An unfinished pipeline stops its stages; the file, never committed, is removed.
    fn drop(&mut self) {
        self.to_compress = None;
        if let Some(c) = self.compressor.take() {
            let _ = c.join();
        }
        if let Some(w) = self.writer.take() {
            let _ = w.join();
        }
    }
}

/// Lines per piece: whole blocks, about [`PIECE_BYTES`], and where blocks are small at least
/// two per core so that every core compresses.
fn piece_lines(codec: &BlockCodec) -> u64 {
    let block_bytes = (codec.lines_per_block() as usize * codec.values_per_line() * 4).max(1);
    let most = (MAX_PIECE_BYTES / block_bytes).max(1);
    let blocks = (PIECE_BYTES / block_bytes)
        .max(2 * rayon::current_num_threads())
        .min(most)
        .max(1);
    blocks as u64 * codec.lines_per_block()
}

/// The compression stage: each piece's blocks encoded in parallel, in order.
fn compress_loop(
    parts: &[PartPlan],
    pieces: Receiver<Piece>,
    to_write: SyncSender<Encoded>,
    recycle: Sender<Vec<f32>>,
    failure: &Mutex<Option<FieldError>>,
    display: &str,
) -> f64 {
    let mut busy = 0.0;
    for piece in pieces {
        let plan = &parts[piece.part];
        let codec = &plan.codec;
        if codec.is_raw_float() {
            if to_write.send(Encoded::Raw(piece)).is_err() {
                break;
            }
            continue;
        }
        let start = Instant::now();
        let lines_per_block = codec.lines_per_block() as usize;
        let per_line = codec.values_per_line();
        let encoded: Vec<Result<Vec<u8>, EncodeError>> = piece
            .values
            .par_chunks(lines_per_block * per_line)
            .map(|values| codec.encode(values))
            .collect();
        // The first block that fails, in file order, whatever thread met it first.
        let blocks: Result<Vec<Vec<u8>>, (usize, EncodeError)> = encoded
            .into_iter()
            .enumerate()
            .map(|(n, block)| block.map_err(|e| (n, e)))
            .collect();
        busy += start.elapsed().as_secs_f64();
        let blocks = match blocks {
            Ok(blocks) => blocks,
            Err((n, e)) => {
                let error = encode_failure(plan, &piece, n, e, display);
                *failure.lock().unwrap_or_else(|p| p.into_inner()) = Some(error);
                break;
            }
        };
        let encoded = Encoded::Blocks {
            part: piece.part,
            first_line: piece.first_line,
            blocks,
        };
        let _ = recycle.send(piece.values);
        if to_write.send(encoded).is_err() {
            break;
        }
    }
    busy
}

/// The error of block `n` of `piece` that could not be encoded.
fn encode_failure(
    plan: &PartPlan,
    piece: &Piece,
    n: usize,
    error: EncodeError,
    display: &str,
) -> FieldError {
    match error {
        EncodeError::HalfRange(index) => {
            let per_line = plan.codec.values_per_line();
            let block_start = n * plan.codec.lines_per_block() as usize * per_line;
            let value = piece.values[block_start + index];
            let line = piece.first_line
                + (n as u64 * plan.codec.lines_per_block())
                + (index / per_line) as u64;
            let [nx, ny, _] = plan.dims;
            let within = index % per_line;
            FieldError::HalfRange {
                path: display.to_string(),
                channel: CHANNELS[within / nx],
                point: [
                    within % nx,
                    (line % ny as u64) as usize,
                    (line / ny as u64) as usize,
                ],
                value,
                max: HALF_MAX,
            }
        }
        EncodeError::Deflate(what) => FieldError::Compress {
            path: display.to_string(),
            what: format!("a block could not be compressed: {what}"),
        },
    }
}

/// A block as the writing stage has it: values stored as they are, or a block's stored bytes.
enum Block<'a> {
    Raw(&'a [f32]),
    Stored(&'a [u8]),
}

/// The writing stage: every block after the last, its offset into its part's table.
fn write_loop(
    mut out: AtomicFile,
    parts: &[PartPlan],
    data_start: u64,
    multipart: bool,
    encoded: Receiver<Encoded>,
    recycle: Sender<Vec<f32>>,
) -> Written {
    let mut position = data_start;
    let mut busy = 0.0;
    let mut offsets = Vec::new();
    for piece in encoded {
        let start = Instant::now();
        let (part, first_line) = match &piece {
            Encoded::Raw(p) => (p.part, p.first_line),
            Encoded::Blocks {
                part, first_line, ..
            } => (*part, *first_line),
        };
        let plan = &parts[part];
        let lines_per_block = plan.codec.lines_per_block();
        let part_number = multipart.then_some(part);
        offsets.clear();
        let mut write_block = |out: &mut AtomicFile, n: usize, bytes: Block| {
            position.write_le(&mut offsets).map_err(io_error)?;
            let y = first_line + n as u64 * lines_per_block;
            position += match bytes {
                Block::Raw(values) => write_chunk(out, part_number, y, values)?,
                Block::Stored(bytes) => write_chunk(out, part_number, y, bytes)?,
            };
            Ok::<(), std::io::Error>(())
        };
        let written = match &piece {
            Encoded::Raw(p) => p
                .values
                .chunks(plan.codec.values_per_line() * lines_per_block as usize)
                .enumerate()
                .try_for_each(|(n, values)| write_block(&mut out, n, Block::Raw(values))),
            Encoded::Blocks { blocks, .. } => blocks
                .iter()
                .enumerate()
                .try_for_each(|(n, bytes)| write_block(&mut out, n, Block::Stored(bytes))),
        };
        let first_block = first_line / lines_per_block;
        let table = written.and_then(|()| out.write_at(&offsets, plan.table + 8 * first_block));
        table.map_err(|e| out.error(e))?;
        if let Encoded::Raw(p) = piece {
            let _ = recycle.send(p.values);
        }
        busy += start.elapsed().as_secs_f64();
    }
    Ok((out, busy, position))
}
