//! The parts of several sweep files (the shards of `map --poses … --shard K/M`) put into one
//! multi-part field, in the order given: the file one run over every pose writes.

use std::path::Path;

use super::{FieldError, FieldFile, PartsWriter, WriteTimes};

/// Lines read and written at once.
const LINES_PER_CHUNK: u64 = 256;

/// Writes every part of `files`, in order, into `out` (a temporary file renamed into place),
/// stored as the first part is. The files must be sweeps (multi-part) of one machine, grid and
/// evaluation inputs, stored alike, with no pose twice. `on_progress(lines written)`.
pub fn merge_parts(
    files: &[FieldFile],
    out: &Path,
    mut on_progress: impl FnMut(u64),
) -> Result<WriteTimes, FieldError> {
    let first = files.first().ok_or_else(|| FieldError::NotOneSweep {
        path: out.display().to_string(),
        what: "no field files to merge".into(),
    })?;
    let refuse = |file: &FieldFile, what: String| FieldError::NotOneSweep {
        path: file.path().display().to_string(),
        what,
    };
    let reference = first.info(0);
    let storage = first.stored(0).ok_or_else(|| {
        refuse(
            first,
            format!(
                "stored as {}, which volmap does not write",
                first.storage(0)
            ),
        )
    })?;
    let mut parts: Vec<(usize, usize)> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (f, file) in files.iter().enumerate() {
        if !file.is_multipart() {
            return Err(refuse(
                file,
                "a field of one pose (`map` without --poses), not the parts of a sweep".into(),
            ));
        }
        for p in 0..file.parts() {
            let info = file.info(p);
            let differs = [
                ("machine", info.machine_toml != reference.machine_toml),
                (
                    "grid",
                    (info.dims, info.origin_mm, info.spacing_mm)
                        != (reference.dims, reference.origin_mm, reference.spacing_mm),
                ),
                ("evaluation inputs", info.inputs != reference.inputs),
                ("storage", file.stored(p) != Some(storage)),
            ];
            if let Some((what, _)) = differs.iter().find(|d| d.1) {
                return Err(refuse(
                    file,
                    format!(
                        "part {} has another {what} than {}'s first: merge the shards of one sweep only",
                        file.name(p),
                        first.path().display()
                    ),
                ));
            }
            let name = file.name(p);
            if names.contains(&name) {
                return Err(refuse(
                    file,
                    format!("pose {name} is in an earlier file too: a shard given twice?"),
                ));
            }
            names.push(name);
            parts.push((f, p));
        }
    }
    let mut writer = PartsWriter::create_stored(
        out,
        parts.len(),
        |n| {
            let (f, p) = parts[n];
            (names[n].clone(), files[f].info(p))
        },
        storage,
    )?;
    let mut written = 0;
    for (n, &(f, p)) in parts.iter().enumerate() {
        let mut reader = files[f].reader(p)?;
        let mut failed = None;
        reader.for_each_chunk(LINES_PER_CHUNK, |first_line, lines, data| {
            if failed.is_none() {
                failed = writer.write_lines(n, first_line, lines, data).err();
                written += lines;
                on_progress(written);
            }
        })?;
        if let Some(error) = failed {
            return Err(error);
        }
    }
    writer.finish()
}
