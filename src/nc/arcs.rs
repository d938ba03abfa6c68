//! Arcs that stay arcs: where one arc through the compensated ends does not keep the real tool tip
//! within the chord tolerance, the arc is split into compensated ARC pieces, each a circle through
//! the compensated start, middle and end of its piece of the intended arc, bisected until the real
//! tip along every piece, as written (rounded end points and centre words), stays within the
//! tolerance of the intended path at the same fraction. Neighbouring pieces share their
//! compensated end points, so the correction is continuous along the path. A piece is a straight
//! G1 piece only where no arc fits (a take-up at a reversal, or a piece whose circle turns the
//! wrong way).

use std::f64::consts::{FRAC_PI_2, PI};

use super::block::{Block, Split, MAX_PIECES};
use super::error::NcOption;
use super::program::approach::{key, segments, Segment};
use super::program::modal::{Directions, Motion, Plane};
use super::program::toolpath::{arc_through, lerp, radius_reaches, Toolpath};
use super::report::Report;
use super::walk::{Piece, Walk};
use super::write::as_written;

/// The largest sweep of an added arc piece: its R word (where the program uses R) stays positive
/// and well conditioned (see `radius_sign`).
const MAX_SWEEP_RAD: f64 = FRAC_PI_2;

/// Arc pieces of a move: the index in the move's pieces of each piece written as an arc, with its
/// centre (program coordinates of the plane, mm).
pub(super) type ArcPieces = Vec<(usize, [f64; 2])>;

/// The centre of the circle through `a`, `b`, `c` in `plane`; `None` where they are (nearly) on
/// one line.
fn circumcentre(a: &[f64; 6], b: &[f64; 6], c: &[f64; 6], plane: Plane) -> Option<[f64; 2]> {
    let (bx, by) = (b[plane.u] - a[plane.u], b[plane.v] - a[plane.v]);
    let (cx, cy) = (c[plane.u] - a[plane.u], c[plane.v] - a[plane.v]);
    let d = 2.0 * (bx * cy - by * cx);
    let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
    if d.abs() <= 1e-12 * scale || scale == 0.0 {
        return None;
    }
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    Some([
        a[plane.u] + (cy * b2 - by * c2) / d,
        a[plane.v] + (bx * c2 - cx * b2) / d,
    ])
}

/// The centre a control computes for an R arc from `from` to `to` (R < 0: more than 180°); none
/// where R does not reach across the chord.
pub(super) fn centre_from_radius(
    from: &[f64; 6],
    to: &[f64; 6],
    plane: Plane,
    r: f64,
    motion: Motion,
) -> Option<[f64; 2]> {
    let (du, dv) = (to[plane.u] - from[plane.u], to[plane.v] - from[plane.v]);
    let chord = du.hypot(dv);
    // A radius that does not reach across the chord (a half circle whose written R rounded
    // below its written ends' distance) is an arc the reader refuses: none.
    if chord < 1e-9 || !radius_reaches(r, chord) {
        return None;
    }
    let h = (r * r - chord * chord / 4.0).max(0.0).sqrt();
    let left = [-dv / chord, du / chord];
    let side = if motion == Motion::CounterClockwise {
        1.0
    } else {
        -1.0
    } * r.signum();
    let mid = [from[plane.u] + du / 2.0, from[plane.v] + dv / 2.0];
    Some([mid[0] + side * h * left[0], mid[1] + side * h * left[1]])
}

/// The sign of the R word of an arc from `from` to `to` (as written) about `centre`: negative
/// where the arc turns more than half a turn, as a control reads R < 0. Each arc written by R
/// takes its own: a piece of an arc programmed with R < 0 turns less than half a turn, and an
/// arc near a half turn may cross it once its ends and centre are corrected.
pub(super) fn radius_sign(
    (from, to): (&[f64; 6], &[f64; 6]),
    plane: Plane,
    centre: [f64; 2],
    motion: Motion,
) -> f64 {
    match arc_through(*from, *to, plane, centre, motion) {
        Some(arc) if sweep_of(&arc).abs() > PI => -1.0,
        _ => 1.0,
    }
}

/// The sweep of an arc path (0 for a line).
fn sweep_of(path: &Toolpath) -> f64 {
    match *path {
        Toolpath::Arc { sweep, .. } => sweep,
        Toolpath::Line { .. } => 0.0,
    }
}

impl Block<'_> {
    /// A length in the plane as the output writes it (rounded to its decimals).
    fn written_length(&self, v: f64) -> f64 {
        as_written(v, 0, self.inch, self.options)
    }

    /// The arc the control runs for an arc from `from` to `to` about `centre`, as the output
    /// writes it: rounded ends, and the centre from the rounded centre words (I J K relative to
    /// the written start, or R where the block uses R).
    pub(super) fn written_arc(
        &self,
        (from, to): (&[f64; 6], &[f64; 6]),
        plane: Plane,
        centre: [f64; 2],
        motion: Motion,
    ) -> Option<Toolpath> {
        let (a, b) = (self.written(from), self.written(to));
        let centre = if self.radius_words {
            let r = (b[plane.u] - centre[0]).hypot(b[plane.v] - centre[1]);
            let sign = radius_sign((&a, &b), plane, centre, motion);
            centre_from_radius(&a, &b, plane, sign * self.written_length(r), motion)?
        } else {
            [
                a[plane.u] + self.written_length(centre[0] - a[plane.u]),
                a[plane.v] + self.written_length(centre[1] - a[plane.v]),
            ]
        };
        arc_through(a, b, plane, centre, motion)
    }

    /// Whether the axes with a reversal error keep `directions` all along the arc `written`: a
    /// written arc that crosses a turning point its intended piece only reaches would reverse
    /// an axis the piece was not compensated for.
    pub(super) fn keeps_directions(&self, written: &Toolpath, directions: &Directions) -> bool {
        let reversing = self.kin.reversing();
        match segments(written, directions, reversing).as_slice() {
            [one] => key(&one.directions, reversing) == key(directions, reversing),
            _ => false,
        }
    }

    /// The largest distance of the real tip along `commanded`, approached in `directions`, from
    /// the intended path at the same fraction of `[ta, tb]` (sampled every 0.25 mm, 16 to 128
    /// points).
    pub(super) fn path_error(
        &self,
        intended: &Toolpath,
        (ta, tb): (f64, f64),
        commanded: &Toolpath,
        directions: &Directions,
    ) -> f64 {
        let n = ((commanded.length() / 0.25).ceil() as usize).clamp(16, 128);
        (1..n)
            .map(|k| {
                let s = k as f64 / n as f64;
                self.kin.miss(
                    &self.command(&commanded.at(s)),
                    &self.command(&intended.at(lerp(ta, tb, s))),
                    directions,
                )
            })
            .fold(0.0, f64::max)
    }

    /// The piece of the intended arc from `ta` to `tb` run as an arc through its compensated
    /// start, middle and end: its centre and the largest distance of the real tip along it as
    /// written. `None` where no arc fits (the points on a line, or the circle turning otherwise
    /// than the piece).
    fn arc_piece(
        &self,
        along: &Toolpath,
        (ta, tb): (f64, f64),
        start: &[f64; 6],
        piece: &Piece,
        motion: Motion,
    ) -> Option<([f64; 2], f64)> {
        let Toolpath::Arc { plane, sweep, .. } = *along else {
            return None;
        };
        let wanted = sweep * (tb - ta);
        if wanted.abs() > MAX_SWEEP_RAD + 1e-9 {
            return None;
        }
        let middle = self
            .compensate_point(&along.at(0.5 * (ta + tb)), &piece.directions)
            .ok()?;
        let centre = circumcentre(start, &middle, &piece.end, plane)?;
        let written = self.written_arc((start, &piece.end), plane, centre, motion)?;
        if (sweep_of(&written) - wanted).abs() > 0.25 * wanted.abs()
            || !self.keeps_directions(&written, &piece.directions)
        {
            return None;
        }
        Some((
            centre,
            self.path_error(along, (ta, tb), &written, &piece.directions),
        ))
    }

    /// The first pieces to try of a segment `[t0, t1]` of an arc, last first: where an end of
    /// it is a turning point (its tangent parallel to an axis), a short edge there, short enough
    /// for a straight piece (its sagitta a quarter of the tolerance), so that the arc pieces stay
    /// clear of the turning point: an arc through compensated points turns a little before or
    /// after it, and would reverse the axis inside the piece.
    fn edges_first(&self, along: &Toolpath, (t0, t1): (f64, f64)) -> Vec<(f64, f64)> {
        let Toolpath::Arc {
            start_angle,
            sweep,
            radii,
            ..
        } = *along
        else {
            return vec![(t0, t1)];
        };
        let turning = |t: f64| {
            let quarters = (start_angle + sweep * t) / FRAC_PI_2;
            (quarters - quarters.round()).abs() < 1e-9
        };
        let edge_rad = (2.0 * self.tolerance / radii[0].max(radii[1])).sqrt();
        let edge = (edge_rad / sweep.abs()).min(0.25 * (t1 - t0));
        let lead = if turning(t0) { edge } else { 0.0 };
        let trail = if turning(t1) { edge } else { 0.0 };
        let mut stack = Vec::new();
        if trail > 0.0 {
            stack.push((t1 - trail, t1));
        }
        stack.push((t0 + lead, t1 - trail));
        if lead > 0.0 {
            stack.push((t0, t0 + lead));
        }
        stack
    }

    /// The pieces of one segment of an arc move, from where `walk` is: arc pieces (see the
    /// module's documentation) where they fit, straight ones where only they do, bisected until
    /// each stays within the tolerance (or is 2⁻²⁴ of the segment).
    pub(super) fn arc_segment(
        &self,
        along: &Toolpath,
        segment: &Segment,
        motion: Motion,
        walk: &mut Walk,
        (pieces, arcs): (&mut Vec<[f64; 6]>, &mut ArcPieces),
        report: &mut Report,
    ) -> Result<(), Split> {
        let (t0, t1) = segment.t;
        let finest = (t1 - t0) / f64::from(1 << 24);
        let mut stack = self.edges_first(along, (t0, t1));
        while let Some((ta, tb)) = stack.pop() {
            if pieces.len() >= MAX_PIECES {
                return Err(Split::Pieces(NcOption::ChordTolerance));
            }
            let piece = self
                .piece(along, (ta, tb), &segment.directions, walk, true)
                .map_err(Split::Point)?;
            let start = piece.take_up.unwrap_or(walk.at);
            let arc = self.arc_piece(along, (ta, tb), &start, &piece, motion);
            let line = Toolpath::Line {
                from: self.written(&start),
                to: self.written(&piece.end),
            };
            let (centre, worst) = match arc {
                Some((centre, worst)) if worst <= self.tolerance => (Some(centre), worst),
                _ => (
                    None,
                    self.path_error(along, (ta, tb), &line, &piece.directions),
                ),
            };
            if worst <= self.tolerance || tb - ta <= finest {
                report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
                self.accept(&piece, walk, pieces);
                if let Some(c) = centre {
                    arcs.push((pieces.len() - 1, c));
                }
            } else {
                let tm = 0.5 * (ta + tb);
                stack.push((tm, tb));
                stack.push((ta, tm));
            }
        }
        Ok(())
    }
}
