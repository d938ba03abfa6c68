//! The pitch error compensation of a `fanuc` export as the control holds it, and what its
//! writer and reader share: the numbers of the point pool, the files' names, how a length is
//! written.

use crate::export::format::{self, Control, TableInfo};
use crate::model::inputs::Approach;
use crate::model::Command;

/// The axes' names in the files and the report.
pub const AXES: [&str; 3] = ["X", "Y", "Z"];
pub const PARAMETERS: &str = "PITCHPRM.TXT";
pub const DATA: &str = "PITCH.TXT";
pub const NOTES: &str = "NOTES.TXT";
/// Pitch error compensation data blocks are numbered from 10000 (point 0).
pub const DATA_NUMBER_BASE: i64 = 10000;
/// The point numbers the tables take when none are given: 0…1023, the pool of pitch error
/// compensation points the FANUC 0i parameter manuals give parameters 3620–3622.
pub const DEFAULT_NUMBERS: [i64; 2] = [0, 1023];
/// The largest point number volmap writes: data numbers run 10000 + point, five digits.
pub const LAST_NUMBER: i64 = 9999;
/// The notes' line that gives the reference positions, which the reader takes from it.
pub const REFERENCE_LINE: &str = "reference position (machine coordinate, parameter 1240):";

/// A length with 3 decimals (the least input increment of IS-B), `-0` written `0`.
pub fn real(v: f64) -> String {
    let text = format!("{v:.3}");
    if text == "-0.000" {
        "0.000".into()
    } else {
        text
    }
}

/// The detection unit: 1 µm (IS-B on a metric machine), mm.
pub const DETECTION_UNIT_MM: f64 = 0.001;
/// The range of one increment (the signed byte of the FOCAS pitch data), units.
pub const INCREMENT_RANGE: [i64; 2] = [-128, 127];
/// The largest magnification (3623) volmap writes.
pub const MAX_MAGNIFICATION: i64 = 100;
/// Six equal blocks of the point numbers `numbers` (first, last), one per axis and direction,
/// each at most this many numbers: X Y Z travelling + first, then X Y Z travelling −.
pub fn numbers_per_table(numbers: [i64; 2]) -> i64 {
    (numbers[1] - numbers[0] + 1) / 6
}

/// The first point number of axis `axis`'s table for travel in the positive direction (or, for
/// `negative`, of its bidirectional table) among the point numbers `numbers`.
pub fn first_number(numbers: [i64; 2], axis: usize, negative: bool) -> i64 {
    numbers[0] + (axis as i64 + if negative { 3 } else { 0 }) * numbers_per_table(numbers)
}

/// One axis's pitch error compensation as the control holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct PitchTable {
    /// 0, 1, 2: X, Y, Z (controlled axis numbers 1, 2, 3).
    pub axis: usize,
    /// The machine coordinate of the reference position, detection units.
    pub reference_units: i64,
    /// 3620, 3621, 3622.
    pub reference_number: i64,
    pub first_number: i64,
    pub last_number: i64,
    /// 3623 (1 or more).
    pub magnification: i64,
    /// 3624, detection units.
    pub interval_units: i64,
    /// The increments of points `first_number..=last_number`, units of the magnification.
    pub increments: Vec<i64>,
    /// The bidirectional table, where written.
    pub reverse: Option<ReverseTable>,
}

/// The table for travel in the negative direction of a bidirectional pitch error compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct ReverseTable {
    /// 3626: its first point number; point `first + i` goes with `first_number + i`.
    pub first_number: i64,
    /// 3627: the absolute compensation at the reference position in that direction, units of
    /// the magnification.
    pub at_reference: i64,
    pub increments: Vec<i64>,
}

/// `floor(a / b)` for `b > 0`.
pub fn floor_div(a: i64, b: i64) -> i64 {
    a.div_euclid(b)
}

/// The smallest integer at or above `a / b`, `b > 0`.
pub fn ceil_div(a: i64, b: i64) -> i64 {
    -floor_div(-a, b)
}

impl PitchTable {
    /// The grid indices the table defines: from the section below its first point to its last.
    pub fn index_range(&self) -> (i64, i64) {
        (
            self.first_number - self.reference_number - 1,
            self.last_number - self.reference_number,
        )
    }

    /// The absolute compensation at every grid index of [`PitchTable::index_range`], units of
    /// the magnification, from `increments` with `at_reference` at the reference.
    pub fn absolute(&self, increments: &[i64], at_reference: i64) -> Vec<i64> {
        let (lo, hi) = self.index_range();
        let increment =
            |j: i64| increments[(self.reference_number + j - self.first_number) as usize];
        let mut values = vec![0; (hi - lo + 1) as usize];
        values[(-lo) as usize] = at_reference;
        for j in 1..=hi {
            values[(j - lo) as usize] = values[(j - 1 - lo) as usize] + increment(j);
        }
        for j in (lo..0).rev() {
            values[(j - lo) as usize] = values[(j + 1 - lo) as usize] - increment(j + 1);
        }
        values
    }

    /// The compensation at machine coordinate `x_mm`, mm, travelling in `approach`: the
    /// staircase of the absolute values, the point at or below the position.
    pub fn compensation_mm(&self, x_mm: f64, approach: Approach) -> f64 {
        let (lo, hi) = self.index_range();
        let values = match (&self.reverse, approach) {
            (Some(r), Approach::Negative) => self.absolute(&r.increments, r.at_reference),
            _ => self.absolute(&self.increments, 0),
        };
        let position = (x_mm / DETECTION_UNIT_MM).round() as i64;
        let j = floor_div(position - self.reference_units, self.interval_units).clamp(lo, hi);
        values[(j - lo) as usize] as f64 * self.magnification as f64 * DETECTION_UNIT_MM
    }

    /// Where the first and the last point lie, mm.
    pub fn point_positions_mm(&self) -> [f64; 2] {
        [
            self.position_mm(self.first_number - self.reference_number),
            self.position_mm(self.last_number - self.reference_number),
        ]
    }

    /// The position of grid index `j`, mm.
    pub fn position_mm(&self, j: i64) -> f64 {
        (self.reference_units + j * self.interval_units) as f64 * DETECTION_UNIT_MM
    }
}

/// The pitch tables read back: what the control applies.
pub struct PitchControl {
    pub tables: Vec<PitchTable>,
}

impl Control for PitchControl {
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        for t in &self.tables {
            c[t.axis] += t.compensation_mm(target[t.axis], approach[t.axis]);
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        self.tables
            .iter()
            .map(|t| {
                let interval = t.interval_units as f64 * DETECTION_UNIT_MM;
                let reverse = match &t.reverse {
                    Some(r) => format!(
                        "; bidirectional, negative-direction points {}-{}",
                        r.first_number,
                        r.first_number + t.last_number - t.first_number
                    ),
                    None => String::new(),
                };
                let [from, to] = t.point_positions_mm();
                TableInfo {
                    name: format!("{} pitch", AXES[t.axis]),
                    size: format!(
                        "points {}-{} (reference {}) at {} to {} mm, interval {} mm, magnification {}{reverse}",
                        t.first_number,
                        t.last_number,
                        t.reference_number,
                        real(from),
                        real(to),
                        real(interval),
                        t.magnification
                    ),
                    points: (t.last_number - t.first_number + 1) as usize,
                    corrects: format::component(t.axis),
                }
            })
            .collect()
    }
}
