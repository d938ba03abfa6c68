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

use super::read::read_tables;
use super::tables::{
    ceil_div, first_number, floor_div, numbers_per_table, real, PitchControl, PitchTable,
    ReverseTable, AXES, DEFAULT_NUMBERS, DETECTION_UNIT_MM, INCREMENT_RANGE, LAST_NUMBER,
    MAX_MAGNIFICATION,
};
use super::write::write_files;
use crate::export::error::ExportError;
use crate::export::fitting::{Fitting, Structure, Term};
use crate::export::format::{Control, Format, Layout, Limits, Nodes, Spec, WrittenFile};
use crate::model::inputs::Approach;

pub struct FanucPitch;

const SPEC: Spec = Spec {
    name: "fanuc",
    title: "FANUC pitch error compensation (parameters 3620-3627, pitch error data)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Equidistant,
        min_points: 2,
        max_points: ((LAST_NUMBER + 1) / 6) as usize,
        min_spacing_mm: 1.0,
        default_points: 41,
        source: "FANUC pitch error compensation: a sixth of the point numbers given (default 0-1023, the pool of the 0i parameter manuals) per axis and direction",
    },
    structure: Structure::Additive([
        [Term::Curve, Term::None, Term::None],
        [Term::None, Term::Curve, Term::None],
        [Term::None, Term::None, Term::Curve],
    ]),
    holds: "pitch error compensation holds each linear axis's positioning error along its own travel (per direction where bidirectional), as whole-µm steps at the compensation points, zero at the reference position; no straightness, squareness or angular error's effect on another axis",
    uses_direction: true,
};

impl Format for FanucPitch {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn numbers_points(&self) -> bool {
        true
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([SPEC.limits.default_points; 3]);
        let numbers = fitting.point_numbers.unwrap_or(DEFAULT_NUMBERS);
        check_numbers(numbers)?;
        let mut tables = Vec::new();
        let mut at_reference_mm = Vec::new();
        for (axis, &n) in points.iter().enumerate() {
            let (table, offset) = fit_table(fitting, numbers, axis, n, spacing_mm)?;
            tables.push(table);
            at_reference_mm.push(offset);
        }
        Ok(write_files(fitting, &tables, &at_reference_mm))
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

/// Point numbers `numbers` (first, last) within 0…[`LAST_NUMBER`], a sixth of them two or more.
fn check_numbers(numbers: [i64; 2]) -> Result<(), ExportError> {
    let [first, last] = numbers;
    let why = if first < 0 || last > LAST_NUMBER {
        format!("they must lie within 0-{LAST_NUMBER} (data numbers 10000 + point)")
    } else if numbers_per_table(numbers) < SPEC.limits.min_points as i64 {
        format!(
            "six tables (X, Y, Z each way) need at least {} numbers",
            6 * SPEC.limits.min_points
        )
    } else {
        return Ok(());
    };
    Err(ExportError::BadPointNumbers { first, last, why })
}

/// The interval, detection units, that puts at most `n` points over `[lo, hi]` from the
/// reference `reference`, the first at or below the travel's start and the last at or beyond its
/// end (so `n` points from the start span the travel in `n − 1` intervals): the smallest.
fn interval_for(lo: i64, hi: i64, reference: i64, n: usize) -> i64 {
    let count = |d: i64| ceil_div(hi - reference, d) - floor_div(lo - reference, d) + 1;
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
    numbers: [i64; 2],
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
    // The last point at or beyond the end of the travel: the table spans it.
    let j_hi = ceil_div(hi - reference, interval);
    let first = j_lo + 1;
    let (first, last) = (first.min(0), j_hi.max(1));
    let count = last - first + 1;
    let per_table = numbers_per_table(numbers);
    if count > per_table {
        let limits = SPEC.limits;
        return Err(ExportError::TooManyPoints {
            format: SPEC.name,
            axis: format!(
                " along {} ({} compensation points at {} mm from the reference position at {} mm)",
                AXES[axis],
                count,
                real(interval as f64 * DETECTION_UNIT_MM),
                real(reference as f64 * DETECTION_UNIT_MM)
            ),
            points: count.to_string(),
            max: per_table as usize,
            limits_from: limits.source,
        });
    }
    let base = first_number(numbers, axis, false);
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
                first_number: first_number(numbers, axis, true),
                at_reference: minus[at_ref],
                increments: inc_minus,
            });
        }
        return Ok((table, at_reference_mm));
    }
    Err(ExportError::Unrepresentable {
        format: SPEC.name,
        message: format!(
            "the {} correction changes by more than {} units of {} µm over one {} mm interval",
            AXES[axis],
            INCREMENT_RANGE[1],
            MAX_MAGNIFICATION,
            real(interval as f64 * DETECTION_UNIT_MM)
        ),
    })
}
