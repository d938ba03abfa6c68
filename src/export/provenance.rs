//! What an export leaves, written where its tables are kept: the residual, the error before,
//! what the format cannot hold, beside the header's machine, inputs, pose, tool and volmap's
//! version, so that a table found on a control years later says where it came from. Comments
//! at the end of a one-file format's file where the format has a comment syntax
//! ([`Format::comment_prefix`]); a report file in a folder format's folder.

use super::error::ExportError;
use super::format::{Control, Format, Layout, WrittenFile};
use super::{Fitting, Report};
use crate::model::inputs::Approach;

/// The report file a folder format's folder gets.
pub const REPORT_FILE: &str = "volmap-report.txt";

fn um(mm: f64) -> String {
    format!("{:.3} um", mm * 1e3)
}

fn at(p: [f64; 3]) -> String {
    format!("X={:.3} Y={:.3} Z={:.3}", p[0], p[1], p[2])
}

/// The report's figures in plain lines (ASCII, for every control's files).
pub fn report_lines(r: &Report) -> Vec<String> {
    let mut lines = Vec::new();
    lines.push(format!("format: {} ({})", r.format, r.controller));
    let [nx, ny, nz] = r.grid.points;
    lines.push(format!(
        "residual measured on {nx} x {ny} x {nz} points over the travels at the pose"
    ));
    lines.push(format!(
        "error before: largest {}, RMS {} (largest at {})",
        um(r.before.max_mm),
        um(r.before.rms_mm),
        at(r.before.at_mm)
    ));
    lines.push(format!(
        "residual with these tables: largest {}, RMS {} (largest at {})",
        um(r.residual.max_mm),
        um(r.residual.rms_mm),
        at(r.residual.at_mm)
    ));
    lines.push(format!(
        "less a work offset: largest {} before, {} after",
        um(r.before_offset_free.max_mm),
        um(r.residual_offset_free.max_mm)
    ));
    lines.push(format!("holds: {}", r.holds));
    if r.not_held.is_empty() {
        lines.push("cannot hold: nothing of this machine's correction at the pose".into());
    }
    for n in &r.not_held {
        lines.push(format!(
            "cannot hold: {} {} of the {} it causes alone",
            n.error,
            um(n.not_held_mm),
            um(n.alone_mm)
        ));
    }
    if let Some(u) = &r.uncertainty {
        lines.extend(u.tables.iter().map(super::uncertainty::comment_line));
        lines.push(if u.within_u {
            format!(
                "the residual ({}) is within the largest node U ({}): the residual is below what the measurements can know",
                um(r.residual.max_mm),
                um(u.u_expanded_mm)
            )
        } else {
            format!(
                "the residual ({}) is beyond the largest node U ({})",
                um(r.residual.max_mm),
                um(u.u_expanded_mm)
            )
        });
    }
    lines
}

/// Adds the report `lines` to a one-file format's file as comments at its end (its header
/// already says where it came from; nothing where the format has no comments), or returns the
/// report file of a folder format's folder, `header` first (beside the control's files, which
/// it does not read).
pub fn attach(
    format: &dyn Format,
    files: &mut [WrittenFile],
    header: &[String],
    lines: &[String],
) -> Option<WrittenFile> {
    match format.spec().layout {
        Layout::File => {
            if let (Some(prefix), Some(file)) = (format.comment_prefix(), files.first_mut()) {
                for line in lines {
                    file.text += &format!("{prefix}{line}\n");
                }
            }
            None
        }
        Layout::Folder => Some(WrittenFile {
            name: REPORT_FILE.into(),
            text: header
                .iter()
                .chain(lines)
                .map(|l| format!("{l}\n"))
                .collect(),
        }),
    }
}

/// Reads `files` (with the report) back and checks that the control does what it did with the
/// files without it: the same tables, the same command at every target of `targets`.
pub fn check_read_back(
    format: &dyn Format,
    files: &[WrittenFile],
    fitting: &Fitting,
    before: &dyn Control,
    targets: &[[f64; 3]],
    approach: &[Approach; 6],
) -> Result<(), ExportError> {
    let name = format.spec().name;
    let changed = || ExportError::ReportChangesTables { format: name };
    let again = format.read_for(files, fitting)?;
    if again.tables() != before.tables() {
        return Err(changed());
    }
    for t in targets {
        let mut command = fitting.pose;
        command[..3].copy_from_slice(t);
        if again.command(&command, approach) != before.command(&command, approach) {
            return Err(changed());
        }
    }
    Ok(())
}
