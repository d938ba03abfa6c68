//! Part files (with their meshes), STL meshes, points CSV.

use std::io::BufReader;

use volmap::io::mesh::Mesh;
use volmap::io::points::PointReader;
use volmap::part::{self, ErrorSource, PartFile};
use volmap::query::{sample_exact_within, Outside};

use super::machine::{as_strs, names};
use super::{read, Context, Outcome, Target, Verdict};
use crate::material::Grammar;

const PART_WORDS: &[&str] = &[
    "name",
    "placement",
    "zero_mm",
    "rotation_deg",
    "pose_deg",
    "cutter",
    "radius_mm",
    "length_mm",
    "sampling",
    "spacing_mm",
    "features",
    "kind",
    "end_milled_plane",
    "flank_milled_plane",
    "rib_height",
    "hole",
    "parallel_hole",
    "hole_position",
    "rib_position",
    "profile",
    "corner_mm",
    "size_mm",
    "start_mm",
    "direction_deg",
    "depth_mm",
    "normal_left",
    "centre_mm",
    "diameter_mm",
    "datum",
    "datums",
    "tolerance_mm",
    "mesh",
    "evaluation",
    "best_fit",
    "nominal",
    "ply",
    "vtp",
    "axis",
    "angle_deg",
];

pub const PART: Target = Target {
    name: "part",
    about: "part files (TOML) with their STL meshes: `PartFile::read`, every cutter position its features imply, and the features evaluated on the f64 reference of `vmc-li2015`",
    grammar: Grammar::Toml,
    words: PART_WORDS,
    run: part_file,
};

fn part_file(cx: &mut Context, input: &[u8]) -> Verdict {
    let paths = cx.write("part.toml", input)?;
    let names = names(&paths);
    let files = as_strs(&names);
    let file = paths[0].display().to_string();
    let part = read!(PartFile::read(&paths[0]), &files);
    read!(part::cutter_positions(&part, &file), &files);
    let machine = cx.machine("vmc-li2015");
    read!(
        part::evaluate(&part, ErrorSource::Exact(machine), &file),
        &files
    );
    Ok(Outcome::Accepted)
}

const STL_WORDS: &[&str] = &[
    "solid", "endsolid", "facet", "normal", "outer", "loop", "vertex", "endloop", "endfacet",
];

pub const STL: Target = Target {
    name: "stl",
    about: "STL meshes, binary and ASCII: `Mesh::parse_stl` (as `Mesh::read_stl` after its bounded read)",
    grammar: Grammar::Stl,
    words: STL_WORDS,
    run: stl,
};

fn stl(_cx: &mut Context, input: &[u8]) -> Verdict {
    let mesh = read!(Mesh::parse_stl(input, "mesh.stl"), &["mesh.stl"]);
    std::hint::black_box(mesh);
    Ok(Outcome::Accepted)
}

const POINTS_WORDS: &[&str] = &["X", "Y", "Z", "A", "B", "C", "x", "y", "z", "id", "note"];

pub const POINTS: Target = Target {
    name: "points",
    about: "points CSV (`sample --points`): `PointReader` in batches of 7, each batch sampled exactly on `5axis-hwang2014` with positions beyond the travel refused",
    grammar: Grammar::Csv,
    words: POINTS_WORDS,
    run: points,
};

fn points(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "points.csv";
    let mut reader = read!(PointReader::new(BufReader::new(input), FILE), &[FILE]);
    let machine = cx.machine("5axis-hwang2014");
    read!(
        volmap::query::check_exact_columns(machine, reader.columns(), FILE),
        &[FILE]
    );
    loop {
        let batch = read!(reader.next_batch(7), &[FILE]);
        if batch.points.is_empty() {
            return Ok(Outcome::Accepted);
        }
        read!(
            sample_exact_within(machine, &batch.points, FILE, Outside::Error),
            &[FILE]
        );
    }
}
