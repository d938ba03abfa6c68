//! `fanuc`: FANUC pitch error compensation, one table per linear axis (X, Y, Z), as the control's
//! parameters 3620–3624 (3626/3627 for bidirectional pitch error compensation) and its pitch
//! error compensation data, in the punch format of the Series 30i family (0i-D/F, 30i/31i/32i/
//! 35i).
//!
//! How the control applies a table (FANUC parameter manuals, pitch error compensation; see
//! `docs` for what is confirmed):
//! - the compensation points lie at equal intervals `d` (3624) from the reference position
//!   `x_ref` (its machine coordinate, parameter 1240); point number `n` is at
//!   `x_ref + (n − R)·d`, `R` the reference point's number (3620), and holds the INCREMENT of
//!   the compensation over the interval that ends at it, in detection units × the magnification
//!   (3623);
//! - the compensation at grid index `j` (position `x_ref + j·d`) is the sum of the increments
//!   from the reference out to it: `A(0) = 0`, `A(j) = Σ v_{R+1..R+j}` for `j > 0`,
//!   `A(j) = −Σ v_{R+j+1..R}` for `j < 0`; it is zero at the reference by construction;
//! - an increment is output as the axis reaches its point (and taken back as it leaves it in
//!   the negative direction): between points the compensation is a STAIRCASE, the value of the
//!   point at or below the position; beyond the outermost points their value holds.
//!
//! The values are the command correction (added to the command, `−error` to first order), at
//! the compensation points, less the correction at the reference position (the table is zero
//! there), in whole detection units (1 µm, IS-B): what a laser calibration zeroed at the
//! reference position would enter. The correction at the reference position itself is a shift
//! of the whole axis no pitch table holds; it stays in the residual and the notes say how large. A bidirectional table (3605#0 = 1) holds a second set of increments
//! for travel in the negative direction from 3626 on, and 3627 the absolute compensation at
//! the reference position in that direction.

use super::fitting::Fitting;
use super::format::{
    Control, Format, Layout, Limits, Nodes, Structure, TableInfo, Term, WrittenFile,
};
use super::ExportError;
use crate::model::inputs::Approach;
use crate::model::Command;

#[path = "fanuc_text.rs"]
mod text;

pub use text::read_tables;

pub struct FanucPitch;

/// The detection unit: 1 µm (IS-B on a metric machine), mm.
pub const DETECTION_UNIT_MM: f64 = 0.001;
/// The range of one increment (the signed byte of the FOCAS pitch data), units.
pub const INCREMENT_RANGE: [i64; 2] = [-128, 127];
/// The largest magnification (3623) volmap writes.
pub const MAX_MAGNIFICATION: i64 = 100;
/// Compensation point numbers per axis and direction (between 3621 and 3622).
pub const NUMBERS_PER_TABLE: i64 = 128;

/// The first point number of axis `axis`'s table for travel in the positive direction (or, for
/// `negative`, of its bidirectional table): blocks of 128 numbers in the pool 0…1023, X Y Z
/// positive from 0, X Y Z negative from 384.
pub fn first_number(axis: usize, negative: bool) -> i64 {
    axis as i64 * NUMBERS_PER_TABLE + if negative { 3 * NUMBERS_PER_TABLE } else { 0 }
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
fn floor_div(a: i64, b: i64) -> i64 {
    a.div_euclid(b)
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
                    name: format!("{} pitch", text::AXES[t.axis]),
                    size: format!(
                        "points {}-{} (reference {}) at {} to {} mm, interval {} mm, magnification {}{reverse}",
                        t.first_number,
                        t.last_number,
                        t.reference_number,
                        text::real(from),
                        text::real(to),
                        text::real(interval),
                        t.magnification
                    ),
                    points: (t.last_number - t.first_number + 1) as usize,
                }
            })
            .collect()
    }
}

impl Format for FanucPitch {
    fn name(&self) -> &'static str {
        "fanuc"
    }

    fn title(&self) -> &'static str {
        "FANUC pitch error compensation (parameters 3620-3627, pitch error data)"
    }

    fn layout(&self) -> Layout {
        Layout::Folder
    }

    fn limits(&self) -> Limits {
        Limits {
            nodes: Nodes::Equidistant,
            min_points: 2,
            max_points: NUMBERS_PER_TABLE as usize,
            min_spacing_mm: 1.0,
            default_points: 41,
            source: "FANUC pitch error compensation: 128 compensation points per axis, volmap's block of the 1024-point pool",
        }
    }

    fn structure(&self) -> Structure {
        Structure::Additive([
            [Term::Curve, Term::None, Term::None],
            [Term::None, Term::Curve, Term::None],
            [Term::None, Term::None, Term::Curve],
        ])
    }

    fn holds(&self) -> &'static str {
        "pitch error compensation holds each linear axis's positioning error along its own travel (per direction where bidirectional), as whole-µm steps at the compensation points, zero at the reference position; no straightness, squareness or angular error's effect on another axis"
    }

    fn uses_direction(&self) -> bool {
        true
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([self.limits().default_points; 3]);
        let mut tables = Vec::new();
        let mut at_reference_mm = Vec::new();
        for (axis, &n) in points.iter().enumerate() {
            let (table, offset) = fit_table(fitting, axis, n, spacing_mm)?;
            tables.push(table);
            at_reference_mm.push(offset);
        }
        Ok(text::write_files(fitting, &tables, &at_reference_mm))
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(PitchControl {
            tables: read_tables(files)?,
        }))
    }
}

/// The interval, detection units, that puts at most `n` points (grid positions whose interval
/// reaches into the travel) over `[lo, hi]` from the reference `reference`: the smallest.
fn interval_for(lo: i64, hi: i64, reference: i64, n: usize) -> i64 {
    let count = |d: i64| floor_div(hi - reference, d) - floor_div(lo - reference, d) + 1;
    let (mut small, mut large) = (1, (hi - lo).max(1));
    if count(small) <= n as i64 {
        return small;
    }
    // count(large) is 1 or 2, and `n` is at least 2.
    while large - small > 1 {
        let mid = (small + large) / 2;
        if count(mid) <= n as i64 {
            large = mid;
        } else {
            small = mid;
        }
    }
    large
}

/// Fits and quantises the table of `axis` with `n` points (or at `spacing_mm`); with the
/// correction at the reference position travelling +, mm, which the table leaves.
fn fit_table(
    fitting: &Fitting,
    axis: usize,
    n: usize,
    spacing_mm: Option<f64>,
) -> Result<(PitchTable, f64), ExportError> {
    let units = |mm: f64| (mm / DETECTION_UNIT_MM).round() as i64;
    let [lo_mm, hi_mm] = fitting.ranges[axis];
    let (lo, hi) = (units(lo_mm), units(hi_mm));
    // The reference position: machine coordinate 0, or the end of the travel nearest to it.
    let reference = 0_i64.clamp(lo, hi);
    let interval = match spacing_mm {
        Some(s) => units(s).max(1),
        None => interval_for(lo, hi, reference, n),
    };
    let j_lo = floor_div(lo - reference, interval);
    let j_hi = floor_div(hi - reference, interval);
    let first = j_lo + 1;
    let (first, last) = (first.min(0), j_hi.max(1));
    let count = last - first + 1;
    if count > NUMBERS_PER_TABLE {
        let limits = FanucPitch.limits();
        return Err(ExportError::TooManyPoints {
            format: "fanuc",
            axis: format!(
                " along {} ({} compensation points at {} mm from the reference position at {} mm)",
                text::AXES[axis],
                count,
                text::real(interval as f64 * DETECTION_UNIT_MM),
                text::real(reference as f64 * DETECTION_UNIT_MM)
            ),
            points: count as usize,
            max: limits.max_points,
            limits_from: limits.source,
        });
    }
    let base = first_number(axis, false);
    let mut table = PitchTable {
        axis,
        reference_units: reference,
        reference_number: base - first,
        first_number: base,
        last_number: base + count - 1,
        magnification: 1,
        interval_units: interval,
        increments: Vec::new(),
        reverse: None,
    };
    // The correction the table should hold at each grid index with its interval reaching into
    // the travel (positions before the travel's start taken at the start).
    let positions: Vec<f64> = (j_lo..=j_hi)
        .map(|j| table.position_mm(j).clamp(lo_mm, hi_mm))
        .collect();
    let along = |approach: Approach| -> Result<Vec<f64>, ExportError> {
        let field = fitting.field_approaching(axis, approach)?;
        let mut terms = [[Term::None; 3]; 3];
        terms[axis][axis] = Term::Curve;
        let mut at: [Vec<f64>; 3] = Default::default();
        at[axis] = positions.clone();
        Ok(fitting.additive(&field, terms, at)?.table(axis, axis))
    };
    let mut forward = along(Approach::Positive)?;
    let mut backward = along(Approach::Negative)?;
    let (lo_j, hi_j) = table.index_range();
    let at_ref = (-j_lo) as usize;
    // Zero at the reference position travelling +, as the control holds it (the reference
    // return defines the position there): the correction there is a shift of the whole axis,
    // which no pitch table holds; travelling −, the table holds the difference from it.
    let at_reference_mm = forward[at_ref];
    for v in forward.iter_mut().chain(backward.iter_mut()) {
        *v -= at_reference_mm;
    }
    for magnification in 1..=MAX_MAGNIFICATION {
        let unit = DETECTION_UNIT_MM * magnification as f64;
        let quantise = |values: &[f64]| -> Vec<i64> {
            values.iter().map(|v| (v / unit).round() as i64).collect()
        };
        let (plus, minus) = (quantise(&forward), quantise(&backward));
        let bidirectional = plus != minus;
        // Point number `first + i` holds `A(j) − A(j − 1)`, `j = first + i − R`; indices beyond
        // the travel repeat the nearest value inside it (no increment).
        let increments = |a: &[i64]| -> Vec<i64> {
            let value = |j: i64| a[(j.clamp(j_lo, j_hi) - j_lo) as usize];
            (0..count)
                .map(|i| {
                    let j = table.first_number + i - table.reference_number;
                    debug_assert!((lo_j + 1..=hi_j).contains(&j));
                    value(j) - value(j - 1)
                })
                .collect()
        };
        let (inc_plus, inc_minus) = (increments(&plus), increments(&minus));
        let fits = |v: &[i64]| {
            v.iter()
                .all(|x| (INCREMENT_RANGE[0]..=INCREMENT_RANGE[1]).contains(x))
        };
        if !fits(&inc_plus) || (bidirectional && !fits(&inc_minus)) {
            continue;
        }
        table.magnification = magnification;
        table.increments = inc_plus;
        if bidirectional {
            table.reverse = Some(ReverseTable {
                first_number: first_number(axis, true),
                at_reference: minus[at_ref],
                increments: inc_minus,
            });
        }
        return Ok((table, at_reference_mm));
    }
    Err(ExportError::Unrepresentable {
        format: "fanuc",
        message: format!(
            "the {} correction changes by more than {} units of {} µm over one {} mm interval",
            text::AXES[axis],
            INCREMENT_RANGE[1],
            MAX_MAGNIFICATION,
            text::real(interval as f64 * DETECTION_UNIT_MM)
        ),
    })
}
