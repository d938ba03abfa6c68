//! The mutations of each format (see `mutate`): what a parser of that format meets only rarely
//! from byte and line changes.

mod binary;
mod text;

use super::mutate::{Grammar, Material};
use super::rng::Rng;

/// Whether `data` reads as text (ASCII STL, not binary): valid UTF-8 with no NUL in its start.
pub fn looks_like_text(data: &[u8]) -> bool {
    let head = &data[..data.len().min(512)];
    !head.contains(&0)
        && std::str::from_utf8(head).map_or_else(|e| e.error_len().is_none(), |_| true)
}

pub fn mutation(data: &mut Vec<u8>, material: &Material, rng: &mut Rng) {
    match material.grammar {
        Grammar::Toml => text::toml(data, material, rng),
        Grammar::Csv => text::csv(data, material, rng),
        Grammar::Gcode => text::gcode(data, rng),
        Grammar::Stl if looks_like_text(data) => binary::ascii_stl(data, rng),
        Grammar::Stl => binary::binary_stl(data, rng),
        Grammar::Exr => binary::exr(data, rng),
    }
}
