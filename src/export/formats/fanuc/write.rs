//! The text of a `fanuc` export: the parameter record (`N<no>Q1A<axis>P<v>` blocks between `%`
//! lines), the pitch error compensation data (`N1<point>P<increment>` blocks, point number +
//! 10000), and the notes a user reads before loading them.

use std::collections::BTreeMap;

use super::tables::{
    real, PitchTable, ReverseTable, AXES, DATA, DATA_NUMBER_BASE, DETECTION_UNIT_MM, NOTES,
    PARAMETERS, REFERENCE_LINE,
};
use crate::export::fitting::Fitting;
use crate::export::format::WrittenFile;

/// The three files of an export of `tables`.
/// `at_reference_mm`: per table, the correction at the reference position the table leaves.
pub fn write_files(
    fitting: &Fitting,
    tables: &[PitchTable],
    at_reference_mm: &[f64],
) -> Vec<WrittenFile> {
    vec![
        WrittenFile {
            name: PARAMETERS.into(),
            text: parameters_text(tables),
        },
        WrittenFile {
            name: DATA.into(),
            text: data_text(tables),
        },
        WrittenFile {
            name: NOTES.into(),
            text: notes_text(fitting, tables, at_reference_mm),
        },
    ]
}

/// An axis-type parameter block: `N0<no>Q1A<axis>P<value>…` over `values` (axis, value).
fn block(number: u32, values: &[(usize, String)]) -> String {
    let mut line = format!("N{number:05}Q1");
    for (axis, value) in values {
        line += &format!("A{}P{value}", axis + 1);
    }
    line + "\n"
}

fn parameters_text(tables: &[PitchTable]) -> String {
    let each = |f: &dyn Fn(&PitchTable) -> String| -> Vec<(usize, String)> {
        tables.iter().map(|t| (t.axis, f(t))).collect()
    };
    let mut text = String::from("%\n");
    text += &block(3620, &each(&|t| t.reference_number.to_string()));
    text += &block(3621, &each(&|t| t.first_number.to_string()));
    text += &block(3622, &each(&|t| t.last_number.to_string()));
    text += &block(3623, &each(&|t| t.magnification.to_string()));
    text += &block(
        3624,
        &each(&|t| real(t.interval_units as f64 * DETECTION_UNIT_MM)),
    );
    let reverse: Vec<(usize, &ReverseTable)> = tables
        .iter()
        .filter_map(|t| t.reverse.as_ref().map(|r| (t.axis, r)))
        .collect();
    if !reverse.is_empty() {
        let values = |f: &dyn Fn(&ReverseTable) -> i64| -> Vec<(usize, String)> {
            reverse
                .iter()
                .map(|(a, r)| (*a, f(r).to_string()))
                .collect()
        };
        text += &block(3626, &values(&|r| r.first_number));
        text += &block(3627, &values(&|r| r.at_reference));
    }
    text + "%\n"
}

fn data_text(tables: &[PitchTable]) -> String {
    let mut points: BTreeMap<i64, i64> = BTreeMap::new();
    for t in tables {
        for (i, v) in t.increments.iter().enumerate() {
            points.insert(t.first_number + i as i64, *v);
        }
        if let Some(r) = &t.reverse {
            for (i, v) in r.increments.iter().enumerate() {
                points.insert(r.first_number + i as i64, *v);
            }
        }
    }
    let mut text = String::from("%\n");
    for (n, v) in points {
        text += &format!("N{}P{v}\n", DATA_NUMBER_BASE + n);
    }
    text + "%\n"
}

fn notes_text(fitting: &Fitting, tables: &[PitchTable], at_reference_mm: &[f64]) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("{line}\n");
    }
    text += "format: volmap fanuc, FANUC pitch error compensation\n\n";
    text += &format!(
        "{REFERENCE_LINE} {} mm\n",
        tables
            .iter()
            .map(|t| format!(
                "{}={}",
                AXES[t.axis],
                real(t.reference_units as f64 * DETECTION_UNIT_MM)
            ))
            .collect::<Vec<_>>()
            .join(" ")
    );
    text += "  (the tables are anchored there: the control's reference position of each axis must be at this\n";
    text += "  machine coordinate, and volmap's commanded positions must be the control's machine coordinates)\n\n";
    text += "files:\n";
    text += &format!("  {PARAMETERS}  parameters 3620-3624 (3626, 3627 for bidirectional tables), axis 1 = X, 2 = Y, 3 = Z\n");
    text += &format!(
        "  {DATA}     pitch error compensation data, N(10000 + point number) P(increment)\n\n"
    );
    text += "values: the CORRECTION (added to the command, minus the error to first order) at the compensation\n";
    text += "  points less the correction at the reference position, as increments from point to point in\n";
    text += "  detection units (1 um, IS-B) x the magnification 3623; zero at the reference position travelling +\n";
    text += "  (3627 gives it travelling - on a bidirectional table). Between points the control applies a\n";
    text += "  staircase (the value of the point at or below the position); the residual volmap reports is for\n";
    text += "  that staircase.\n\n";
    for (t, offset) in tables.iter().zip(at_reference_mm) {
        let [from, to] = t.point_positions_mm();
        let interval = t.interval_units as f64 * DETECTION_UNIT_MM;
        text += &format!(
            "{} (axis {}): 3620 = {}, 3621 = {}, 3622 = {}, 3623 = {}, 3624 = {} mm: points at {} to {} mm\n",
            AXES[t.axis],
            t.axis + 1,
            t.reference_number,
            t.first_number,
            t.last_number,
            t.magnification,
            real(interval),
            real(from),
            real(to),
        );
        text += &format!(
            "  interval {} mm: the control takes it where the rapid traverse rate is at most {:.0} mm/min (interval >= rate / 7500)\n",
            real(interval),
            interval * 7500.0
        );
        text += &format!(
            "  the correction at the reference position, {:.1} um, is a shift of the whole axis the table\n  cannot hold (zero there by construction): it stays in the residual (a work offset takes it)\n",
            offset / DETECTION_UNIT_MM
        );
        if let Some(r) = &t.reverse {
            text += &format!(
                "  bidirectional: set 3605#0 = 1; 3626 = {}, 3627 = {} (the compensation at the reference position travelling -)\n",
                r.first_number, r.at_reference
            );
        }
    }
    text += "\nloading (check every step against the control's parameter manual first):\n";
    text += "  1. Compare PITCHPRM.TXT with a parameter backup of this control: the axis numbers, the point\n";
    text += "     numbers (volmap uses 0-383 travelling +, 384-767 travelling -; they must not clash with a\n";
    text += "     rotary axis's table), and the data form of 3624 (a real number in mm on the Series 30i\n";
    text += "     family; an integer in the least input increment on the Series 16i/18i/21i and 0i-A/B/C,\n";
    text += "     whose records carry no Q1).\n";
    text += "  2. With parameter write enabled, read PITCHPRM.TXT in (EDIT mode, memory card) or key in the\n";
    text += "     values; for bidirectional tables set 3605#0 = 1 by hand (a bit parameter: volmap does not\n";
    text += "     write its other bits). Turn the power off and on.\n";
    text += "  3. Read PITCH.TXT in on the pitch error compensation screen (or key in the increments).\n";
    text +=
        "  4. Return every axis to its reference position: the compensation acts from then on.\n";
    text += "  5. Check one point with a laser before use: a positive value moves the axis further in +.\n";
    text
}
