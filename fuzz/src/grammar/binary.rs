//! The mutations of the binary formats and of ASCII STL: counts, floats and doubles that
//! break readers, triangles repeated or made degenerate, OpenEXR attributes renamed, retyped,
//! resized, dropped or repeated, offsets out of the file.

use crate::material::{interesting_number, lines, range, with_line_end};
use crate::rng::Rng;

const INTERESTING_U32: &[u32] = &[
    0,
    1,
    2,
    3,
    4,
    7,
    8,
    16,
    255,
    256,
    0x7fff,
    0x8000,
    0xffff,
    0x1_0000,
    46340,
    46341,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
    0x1000_0000,
    0x4000_0000,
];
const INTERESTING_F32: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::MAX,
    f32::MIN,
    f32::MIN_POSITIVE,
    1e-45,
    65536.0,
    65535.9,
    1e9,
    -1e9,
    1e20,
    16_777_216.0,
    0.5,
];
const INTERESTING_F64: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN,
    5e-324,
    1e-300,
    1e300,
    1e9,
    65536.0,
    0.001,
    1e-9,
];

fn put(data: &mut Vec<u8>, at: usize, bytes: &[u8]) {
    if at + bytes.len() > data.len() {
        data.resize(at + bytes.len(), 0);
    }
    data[at..at + bytes.len()].copy_from_slice(bytes);
}

/// A number of 4 or 8 bytes that breaks readers: a count, a float, a double, an offset.
fn interesting_word(rng: &mut Rng, size: usize) -> Vec<u8> {
    match (size, rng.below(3)) {
        (8, 0) => rng.pick(INTERESTING_F64).to_le_bytes().to_vec(),
        (8, 1) => (*rng.pick(INTERESTING_U32) as u64).to_le_bytes().to_vec(),
        (8, _) => rng
            .pick(&[u64::MAX, 1 << 63, (1 << 63) - 1, 1 << 32, 1 << 40])
            .to_le_bytes()
            .to_vec(),
        (_, 0) => rng.pick(INTERESTING_F32).to_le_bytes().to_vec(),
        (_, 1) => rng.pick(INTERESTING_U32).to_le_bytes().to_vec(),
        _ => (-(*rng.pick(INTERESTING_U32) as i64) as i32)
            .to_le_bytes()
            .to_vec(),
    }
}

pub(super) fn binary_stl(data: &mut Vec<u8>, rng: &mut Rng) {
    let triangles = data.len().saturating_sub(84) / 50;
    match rng.below(5) {
        0 => {
            // The count: interesting, or one off the triangles there are.
            let count = if rng.one_in(2) {
                *rng.pick(INTERESTING_U32)
            } else {
                (triangles as u32)
                    .wrapping_add(rng.below(3) as u32)
                    .wrapping_sub(1)
            };
            put(data, 80, &count.to_le_bytes());
        }
        1 if triangles > 0 => {
            // A vertex coordinate or normal.
            let t = rng.below(triangles);
            let value = rng.pick(INTERESTING_F32).to_le_bytes();
            put(data, 84 + 50 * t + 4 * rng.below(12), &value);
        }
        2 if triangles > 0 => {
            // A triangle repeated, or made degenerate (two vertices alike).
            let t = rng.below(triangles);
            let start = 84 + 50 * t;
            let triangle = data[start..start + 50].to_vec();
            if rng.one_in(2) {
                let times = rng.size(&[1, 2, 10], &[100, 5000]);
                data.splice(start..start, triangle.repeat(times));
            } else {
                let vertex = triangle[12..24].to_vec();
                put(data, start + 24, &vertex);
            }
            let count = (data.len().saturating_sub(84) / 50) as u32;
            put(data, 80, &count.to_le_bytes());
        }
        3 => {
            // The length made that of the count, or cut inside a triangle.
            let len =
                84 + 50 * rng.below(triangles + 2) + if rng.one_in(2) { 0 } else { rng.below(50) };
            data.resize(len, 0);
        }
        _ => {
            let at = rng.below(data.len().max(4) / 4) * 4;
            let word = interesting_word(rng, 4);
            put(data, at, &word);
        }
    }
}

pub(super) fn ascii_stl(data: &mut Vec<u8>, rng: &mut Rng) {
    let lines = lines(data);
    match rng.below(3) {
        0 => {
            // A facet repeated.
            if let Some(start) = find(data, b"facet") {
                if let Some(end) = find(&data[start..], b"endfacet") {
                    let facet = data[start..start + end + 8].to_vec();
                    let times = rng.size(&[1, 2, 10], &[1000]);
                    let mut copies = Vec::new();
                    for _ in 0..times {
                        copies.extend_from_slice(&facet);
                        copies.push(b'\n');
                    }
                    data.splice(start..start, copies);
                }
            }
        }
        1 => {
            // A vertex line with numbers that break meshes.
            let mut line = b"vertex ".to_vec();
            for n in 0..3 {
                if n > 0 {
                    line.push(b' ');
                }
                line.extend(interesting_number(b"", rng));
            }
            line.push(b'\n');
            let at = lines.get(rng.below(lines.len().max(1))).map_or(0, |l| l.0);
            data.splice(at..at, line);
        }
        _ => {
            let keyword: &[u8] = rng.pick::<&[u8]>(&[
                &b"solid"[..],
                b"endsolid",
                b"facet normal 0 0 1",
                b"outer loop",
                b"endloop",
                b"endfacet",
                b"vertex 0 0 0",
            ]);
            let at = lines.get(rng.below(lines.len().max(1))).map_or(0, |l| l.0);
            data.splice(at..at, with_line_end(keyword));
        }
    }
}

fn find(data: &[u8], needle: &[u8]) -> Option<usize> {
    data.windows(needle.len()).position(|w| w == needle)
}

/// An OpenEXR header's attributes: `(name start, size field offset, value start, value end)`,
/// in the order of the file, across the headers of a multi-part file; and where the headers end.
fn exr_attributes(data: &[u8]) -> (Vec<(usize, usize, usize, usize)>, usize) {
    let mut out = Vec::new();
    let mut at = 8;
    let text_end = |from: usize| {
        data.get(from..)?
            .iter()
            .position(|&b| b == 0)
            .map(|p| from + p)
    };
    let mut empty_headers = 0;
    while at < data.len() && empty_headers < 2 {
        let Some(name_end) = text_end(at) else { break };
        if name_end == at {
            // The end of one header (and of all, at a second in a row).
            at += 1;
            empty_headers += 1;
            continue;
        }
        empty_headers = 0;
        let Some(type_end) = text_end(name_end + 1) else {
            break;
        };
        let size_at = type_end + 1;
        let Some(size) = data.get(size_at..size_at + 4) else {
            break;
        };
        let size = u32::from_le_bytes(size.try_into().unwrap()) as usize;
        let value_start = size_at + 4;
        let value_end = value_start.saturating_add(size).min(data.len());
        out.push((at, size_at, value_start, value_end));
        at = value_end;
    }
    (out, at)
}

/// The names of attributes readers look for, and types they may find.
const EXR_NAMES: &[&str] = &[
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "name",
    "type",
    "chunkCount",
    "version",
    "volmap.dims",
    "volmap.origin",
    "volmap.spacing",
    "volmap.pose",
    "volmap.poseAxes",
    "volmap.machine",
    "volmap.chain",
    "volmap.csv.x.csv",
    "volmap.reference_C",
];
const EXR_TYPES: &[&str] = &[
    "chlist",
    "compression",
    "box2i",
    "box2f",
    "lineOrder",
    "float",
    "double",
    "int",
    "string",
    "v2f",
    "v3i",
    "v3d",
    "v3f",
    "stringvector",
];

pub(super) fn exr(data: &mut Vec<u8>, rng: &mut Rng) {
    let (attributes, headers_end) = exr_attributes(data);
    match rng.below(8) {
        0 | 1 if !attributes.is_empty() => {
            // A number inside an attribute's value.
            let &(_, _, start, end) = rng.pick(&attributes);
            if end > start {
                let size = if (end - start) % 8 == 0 && rng.one_in(2) {
                    8
                } else {
                    4
                };
                let slots = ((end - start) / size).max(1);
                let at = start + size * rng.below(slots);
                let word = interesting_word(rng, size);
                put(data, at, &word);
            }
        }
        2 if !attributes.is_empty() => {
            // An attribute's size.
            let &(_, size_at, _, end) = rng.pick(&attributes);
            let size = if rng.one_in(2) {
                *rng.pick(INTERESTING_U32)
            } else {
                (end - size_at - 4) as u32 ^ (1 << rng.below(8))
            };
            put(data, size_at, &size.to_le_bytes());
        }
        3 if !attributes.is_empty() => {
            // An attribute renamed, retyped, dropped or repeated.
            let &(name_at, size_at, _, end) = rng.pick(&attributes);
            match rng.below(4) {
                0 => {
                    let name_end =
                        name_at + data[name_at..].iter().position(|&b| b == 0).unwrap_or(0);
                    let new = rng.pick(EXR_NAMES).as_bytes().to_vec();
                    data.splice(name_at..name_end, new);
                }
                1 => {
                    let name_end =
                        name_at + data[name_at..].iter().position(|&b| b == 0).unwrap_or(0);
                    let type_end = size_at - 1;
                    if name_end < type_end {
                        let new = rng.pick(EXR_TYPES).as_bytes().to_vec();
                        data.splice(name_end + 1..type_end, new);
                    }
                }
                2 => {
                    data.drain(name_at..end);
                }
                _ => {
                    let copy = data[name_at..end].to_vec();
                    let &(other, _, _, _) = rng.pick(&attributes);
                    data.splice(other..other, copy);
                }
            }
        }
        4 if headers_end + 8 <= data.len() => {
            // An entry of the offset table, or of a block's header after it.
            let slots = (data.len() - headers_end) / 8;
            let at = headers_end + 8 * rng.below(slots.clamp(1, 64));
            let word = interesting_word(rng, 8);
            put(data, at, &word);
        }
        5 => {
            // The version field: single part, multi-part, long names, tiles.
            let flags: u32 = *rng.pick(&[2, 0x202, 0x402, 0x1002, 0x802, 0x1402, 0xffff_ffff]);
            put(data, 4, &flags.to_le_bytes());
        }
        6 => {
            let (start, end) = range(data, rng);
            let at = rng.below(data.len() + 1);
            let copy = data[start..end].to_vec();
            data.splice(at..at, copy);
        }
        _ => {
            let at = rng.below(data.len().max(1));
            let size = if rng.one_in(2) { 8 } else { 4 };
            let word = interesting_word(rng, size);
            put(data, at, &word);
        }
    }
}
