//! Field files (OpenEXR, single and multi-part).

use volmap::io::field::{FieldFile, LoadedField};

use super::{read, Context, Outcome, Target, Verdict};
use crate::material::Grammar;

pub const FIELD: Target = Target {
    name: "field",
    about: "field files (OpenEXR, single and multi-part, every storage): `FieldFile::open`, each part's header and inputs, its first, middle and last lines, and the part read whole (`LoadedField::open_part`) and sampled at the middle of its grid",
    grammar: Grammar::Exr,
    words: &[],
    run: field,
};

/// The most parts of one file read (each read costs a pass over its lines).
const PARTS_READ: usize = 4;

fn field(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "field.exr";
    let paths = cx.write(FILE, input)?;
    let file = read!(FieldFile::open(&paths[0]), &[FILE]);
    for part in 0..file.parts().min(PARTS_READ) {
        let info = file.info(part);
        std::hint::black_box((file.name(part), file.inputs(part), file.pose_deg(part)));
        let mut reader = read!(file.reader(part), &[FILE]);
        let lines = reader.lines();
        let mut values = vec![0f32; 6 * info.dims[0]];
        let mut wanted = vec![0, lines / 2, lines.saturating_sub(1)];
        wanted.dedup();
        for line in wanted.into_iter().filter(|&l| l < lines) {
            read!(reader.read_line(line, &mut values), &[FILE]);
        }
        let loaded = read!(LoadedField::open_part(&file, part), &[FILE]);
        let mut middle = [0.0; 6];
        for (d, m) in middle.iter_mut().take(3).enumerate() {
            *m = info.origin_mm[d]
                + info.spacing_mm[d] * (info.dims[d].saturating_sub(1)) as f64 / 2.0;
        }
        middle[3..].copy_from_slice(&info.pose_deg);
        let _ = std::hint::black_box(loaded.sample(&middle));
    }
    Ok(Outcome::Accepted)
}
