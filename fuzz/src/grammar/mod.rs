//! The mutations of each format (see `mutate`): what a parser of that format meets only rarely
//! from byte and line changes.

mod binary;
mod text;

use super::material::{looks_like_text, Grammar, Material};
use super::rng::Rng;

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
