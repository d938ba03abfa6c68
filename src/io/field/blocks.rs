//! The pixel blocks of a field: how its values are stored (`--compression`, `--half`) and the
//! codec that turns lines of f32 values into an OpenEXR scanline block and back. Decompression is
//! the `exr` crate's (OpenEXR's ZIP and PXR24 and every other method the crate reads); volmap's
//! own ZIP and PXR24 blocks are laid out as OpenEXR lays them out and deflated at a faster level
//! than the crate's encoders ([`super::prepare`]).
//!
//! A block holds `lines_per_block` lines (1 uncompressed, 16 for ZIP and PXR24); within it, per
//! line, the `nx` values of each channel in [`CHANNELS`] order: the layout of an engine's chunk.

use exr::compression::Compression as ExrCompression;
use exr::math::Vec2;
use exr::meta::attribute::{
    ChannelDescription, ChannelList, IntegerBounds, LineOrder, SampleType, Text,
};
use exr::meta::header::Header;
use exr::meta::BlockDescription;
use exr::prelude::f16;

use super::prepare;
use crate::model::channels::CHANNELS;

/// How a field's blocks are compressed when volmap writes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Values as they are: 1 nm and better (f32).
    #[default]
    None,
    /// OpenEXR's ZIP (deflate over blocks of 16 lines): lossless.
    Zip,
    /// OpenEXR's PXR24: f32 values rounded to 24 bits (15-bit mantissa), then deflated; HALF
    /// values losslessly.
    Pxr24,
}

impl Compression {
    pub const ALL: [Compression; 3] = [Compression::None, Compression::Zip, Compression::Pxr24];

    /// The name `--compression` takes and messages use.
    pub fn name(self) -> &'static str {
        match self {
            Compression::None => "none",
            Compression::Zip => "zip",
            Compression::Pxr24 => "pxr24",
        }
    }

    pub fn parse(text: &str) -> Option<Compression> {
        Compression::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(text.trim()))
    }

    /// The `exr` crate's name of the compression.
    pub(super) fn exr(self) -> ExrCompression {
        match self {
            Compression::None => ExrCompression::Uncompressed,
            Compression::Zip => ExrCompression::ZIP16,
            Compression::Pxr24 => ExrCompression::PXR24,
        }
    }
}

/// How a field's values are stored: the compression and the channels' type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Storage {
    pub compression: Compression,
    /// HALF (16-bit) channels instead of FLOAT: a picture, not a measurement.
    pub half: bool,
}

impl Storage {
    /// The storage in words: `none`, `pxr24, HALF`.
    pub fn describe(self) -> String {
        if self.half {
            format!("{}, HALF", self.compression.name())
        } else {
            self.compression.name().to_string()
        }
    }
}

/// The largest finite HALF value; larger magnitudes would be stored as infinity.
pub const HALF_MAX: f32 = 65504.0;

/// OpenEXR's compression codes (the `compression` attribute's byte), in the order of the
/// format, with their names.
const EXR_COMPRESSIONS: [(ExrCompression, &str); 10] = [
    (ExrCompression::Uncompressed, "none"),
    (ExrCompression::RLE, "rle"),
    (ExrCompression::ZIP1, "zips"),
    (ExrCompression::ZIP16, "zip"),
    (ExrCompression::PIZ, "piz"),
    (ExrCompression::PXR24, "pxr24"),
    (ExrCompression::B44, "b44"),
    (ExrCompression::B44A, "b44a"),
    (ExrCompression::DWAA(None), "dwaa"),
    (ExrCompression::DWAB(None), "dwab"),
];

/// The compression byte volmap writes for `compression`.
pub(super) fn compression_code(compression: Compression) -> u8 {
    EXR_COMPRESSIONS
        .iter()
        .position(|(c, _)| *c == compression.exr())
        .unwrap_or(0) as u8
}

/// The name of an OpenEXR compression code, for messages (`code 12` for one the format does
/// not define).
pub(super) fn compression_name(code: u8) -> String {
    EXR_COMPRESSIONS
        .get(code as usize)
        .map_or(format!("code {code}"), |(_, name)| name.to_string())
}

/// The six channels of a field, HALF or FLOAT, as the header's `channels` lists them.
pub(super) fn channel_list(half: bool) -> ChannelList {
    let sample = if half {
        SampleType::F16
    } else {
        SampleType::F32
    };
    ChannelList::new(
        CHANNELS
            .iter()
            .map(|name| ChannelDescription::new(Text::from(*name), sample, false))
            .collect(),
    )
}

/// Encodes and decodes the blocks of one field (a part of a file): lines `nx` long.
pub(super) struct BlockCodec {
    header: Header,
    code: u8,
    compression: ExrCompression,
    nx: usize,
    half: bool,
    lines_per_block: u64,
}

impl BlockCodec {
    /// The codec of a field `nx` wide and `lines` tall in OpenEXR compression `code`, HALF or
    /// FLOAT channels; `None` for a code the `exr` crate does not decompress.
    pub fn new(nx: usize, lines: u64, code: u8, half: bool) -> Option<BlockCodec> {
        let (compression, _) = *EXR_COMPRESSIONS.get(code as usize)?;
        let header = Header::new(
            Text::from("field"),
            Vec2(nx, lines.min(i32::MAX as u64) as usize),
            channel_list(half).list,
        )
        .with_encoding(
            compression,
            BlockDescription::ScanLines,
            LineOrder::Increasing,
        );
        Some(BlockCodec {
            header,
            code,
            compression,
            nx,
            half,
            lines_per_block: compression.scan_lines_per_block() as u64,
        })
    }

    /// The codec volmap writes with.
    pub fn for_writing(nx: usize, lines: u64, storage: Storage) -> BlockCodec {
        BlockCodec::new(
            nx,
            lines,
            compression_code(storage.compression),
            storage.half,
        )
        .expect("volmap writes compressions the exr crate has")
    }

    pub fn lines_per_block(&self) -> u64 {
        self.lines_per_block
    }

    /// Values per line: `nx` of each channel.
    pub fn values_per_line(&self) -> usize {
        CHANNELS.len() * self.nx
    }

    /// The bytes of `lines` lines uncompressed.
    pub fn raw_bytes(&self, lines: u64) -> u64 {
        lines * self.values_per_line() as u64 * if self.half { 2 } else { 4 }
    }

    /// Whether blocks are stored as the values' little-endian bytes, which need no codec.
    pub fn is_raw_float(&self) -> bool {
        self.is_uncompressed() && !self.half
    }

    pub fn is_uncompressed(&self) -> bool {
        self.compression == ExrCompression::Uncompressed
    }

    /// The OpenEXR compression code and whether the channels are HALF.
    pub fn stored(&self) -> (u8, bool) {
        (self.code, self.half)
    }

    fn section(&self, first_line: u64, lines: u64) -> IntegerBounds {
        IntegerBounds::new(Vec2(0, first_line as i32), Vec2(self.nx, lines as usize))
    }

    /// The stored bytes of the block of `values` (its lines, in the chunk layout): ZIP and
    /// PXR24 in OpenEXR's layout deflated at volmap's level ([`super::prepare`]), the
    /// little-endian values where compression would not make the block smaller (as OpenEXR
    /// stores such blocks). A value beyond HALF's range in a HALF field is an error naming its
    /// index in `values`.
    pub fn encode(&self, values: &[f32]) -> Result<Vec<u8>, EncodeError> {
        let little_endian: Vec<u8>;
        let prepared = if self.half {
            let mut bits = Vec::with_capacity(values.len());
            for (n, &v) in values.iter().enumerate() {
                if v.abs() > HALF_MAX {
                    return Err(EncodeError::HalfRange(n));
                }
                bits.push(f16::from_f32(v).to_bits());
            }
            little_endian = bits.iter().flat_map(|b| b.to_le_bytes()).collect();
            match self.compression {
                ExrCompression::ZIP16 => Some(prepare::zip_bytes(&little_endian)),
                ExrCompression::PXR24 => Some(prepare::pxr24_half_bytes(&bits, self.nx)),
                _ => None,
            }
        } else {
            little_endian = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            match self.compression {
                ExrCompression::ZIP16 => Some(prepare::zip_bytes(&little_endian)),
                ExrCompression::PXR24 => Some(prepare::pxr24_float_bytes(values, self.nx)),
                _ => None,
            }
        };
        let Some(prepared) = prepared else {
            return Ok(little_endian);
        };
        let deflated =
            prepare::deflate(&prepared).map_err(|e| EncodeError::Deflate(e.to_string()))?;
        Ok(if deflated.len() < little_endian.len() {
            deflated
        } else {
            little_endian
        })
    }

    /// [`BlockCodec::encode`] by the `exr` crate's own encoder (ZIP and PXR24 deflated at level
    /// 4), for `volmap bench` to compare.
    pub fn encode_with_exr_crate(
        &self,
        first_line: u64,
        values: &[f32],
    ) -> Result<Vec<u8>, String> {
        let lines = (values.len() / self.values_per_line()) as u64;
        let native: Vec<u8> = if self.half {
            values
                .iter()
                .flat_map(|&v| f16::from_f32(v).to_ne_bytes())
                .collect()
        } else {
            bytemuck::cast_slice(values).to_vec()
        };
        self.compression
            .compress_image_section_to_le(&self.header, native, self.section(first_line, lines))
            .map_err(|e| e.to_string())
    }

    /// The values of the block starting at `first_line` with `lines` lines from its stored
    /// bytes, into `out` (resized): per line, `nx` values of each channel.
    pub fn decode(
        &self,
        first_line: u64,
        lines: u64,
        stored: Vec<u8>,
        out: &mut Vec<f32>,
    ) -> Result<(), String> {
        let native = self
            .compression
            .decompress_image_section_from_le(
                &self.header,
                stored,
                self.section(first_line, lines),
                true,
            )
            .map_err(|e| e.to_string())?;
        out.clear();
        if self.half {
            out.extend(
                native
                    .chunks_exact(2)
                    .map(|b| f16::from_ne_bytes([b[0], b[1]]).to_f32()),
            );
        } else {
            out.extend(
                native
                    .chunks_exact(4)
                    .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]])),
            );
        }
        if out.len() as u64 != lines * self.values_per_line() as u64 {
            return Err(format!(
                "the block of line {first_line} decodes to {} values, not {}",
                out.len(),
                lines * self.values_per_line() as u64
            ));
        }
        Ok(())
    }
}

/// Why a block could not be encoded.
#[derive(Debug)]
pub(super) enum EncodeError {
    /// The value at this index of the block's values exceeds HALF's range.
    HalfRange(usize),
    /// Deflating the block failed.
    Deflate(String),
}

/// Compresses `values` (whole lines `nx` long in the chunk layout, from line 0) block by block as
/// `storage` says, on this thread, with volmap's encoder or the `exr` crate's: the bytes they
/// take. For `volmap bench`, which compares the two.
pub fn compress_on_one_thread(
    storage: Storage,
    nx: usize,
    values: &[f32],
    exr_crate: bool,
) -> Result<u64, String> {
    let lines = (values.len() / (CHANNELS.len() * nx)) as u64;
    let codec = BlockCodec::for_writing(nx, lines, storage);
    let block_values = codec.lines_per_block() as usize * codec.values_per_line();
    let mut bytes = 0;
    for (n, block) in values.chunks(block_values).enumerate() {
        let first_line = n as u64 * codec.lines_per_block();
        let stored = if exr_crate {
            codec.encode_with_exr_crate(first_line, block)?
        } else {
            codec.encode(block).map_err(|e| format!("{e:?}"))?
        };
        bytes += stored.len() as u64;
    }
    Ok(bytes)
}
