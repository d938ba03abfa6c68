//! The pieces of a move and the directions each is compensated for.
//!
//! Every piece is compensated for the approach the compensated motion will have, as the output
//! writes it (rounded): an axis the programmed piece moves is taken in its programmed direction,
//! an axis the program holds still in the direction of its last motion. Where the compensated
//! motion of an axis with a reversal error runs against that (an axis the program holds still
//! that the correction moves back, as a straightness error along another axis does; a move
//! shorter than the change of its correction), the piece is compensated for the other direction
//! if its motion then goes that way; where neither direction is consistent (a reversal error that
//! puts the tip ahead of the command on the way back) the piece keeps the programmed one and is
//! counted. Where the directions of a reversing axis change, a take-up piece first moves the
//! command from the point compensated for the old directions to the same point compensated for
//! the new ones (the tip stays while the command crosses the reversal).

use super::block::{Block, Split, MAX_PIECES};
use super::error::{NcError, NcOption};
use super::program::approach::{key, moving, Segment, MOVES};
use super::program::modal::Directions;
use super::program::toolpath::{lerp, Toolpath};
use super::report::Report;
use crate::model::inputs::Approach;

/// Where the output has the tool: its last point and the directions it approached it in.
#[derive(Debug, Clone, Copy)]
pub(super) struct Walk {
    pub(super) at: [f64; 6],
    pub(super) directions: Directions,
}

/// A piece decided: the take-up before it (where the directions of a reversing axis change),
/// its compensated end, the directions it is compensated for, and whether its written motion
/// runs against them (no direction was consistent).
#[derive(Debug, Clone, Copy)]
pub(super) struct Piece {
    pub(super) take_up: Option<[f64; 6]>,
    pub(super) end: [f64; 6],
    pub(super) directions: Directions,
    pub(super) against: bool,
}

fn opposite(a: Approach) -> Approach {
    match a {
        Approach::Positive => Approach::Negative,
        Approach::Negative => Approach::Positive,
    }
}

/// Whether a written motion `delta` runs against `direction`.
fn runs_against(delta: f64, direction: Approach) -> bool {
    match direction {
        Approach::Positive => delta < -MOVES,
        Approach::Negative => delta > MOVES,
    }
}

impl Block<'_> {
    /// The piece of `along` from fraction `ta` to `tb`, starting where `walk` is: `programmed`
    /// gives the directions of the axes the programmed piece moves; a take-up is added where the
    /// directions change and `take_ups` allows it (not on a rapid, whose path the control does
    /// not hold).
    pub(super) fn piece(
        &self,
        along: &Toolpath,
        (ta, tb): (f64, f64),
        programmed: &Directions,
        walk: &Walk,
        take_ups: bool,
    ) -> Result<Piece, NcError> {
        let (pa, pb) = (along.at(ta), along.at(tb));
        let moves = moving(&pa, &pb);
        let first: Directions = std::array::from_fn(|d| {
            if moves[d] {
                programmed[d]
            } else {
                walk.directions[d]
            }
        });
        let candidate = self.candidate((&pa, &pb), first, walk, take_ups)?;
        let wrong = self.against_axes(walk, &candidate);
        if !wrong.contains(&true) {
            return Ok(candidate);
        }
        let flipped = std::array::from_fn(|d| {
            if wrong[d] {
                opposite(first[d])
            } else {
                first[d]
            }
        });
        let other = self.candidate((&pa, &pb), flipped, walk, take_ups)?;
        if !self.against_axes(walk, &other).contains(&true) {
            return Ok(other);
        }
        Ok(Piece {
            against: true,
            ..candidate
        })
    }

    /// The piece to `pb` compensated for `directions`, with its take-up at `pa`.
    fn candidate(
        &self,
        (pa, pb): (&[f64; 6], &[f64; 6]),
        directions: Directions,
        walk: &Walk,
        take_ups: bool,
    ) -> Result<Piece, NcError> {
        let reversing = self.kin.reversing();
        let take_up = if take_ups && key(&directions, reversing) != key(&walk.directions, reversing)
        {
            let mut t = self.compensate_point(pa, &directions)?;
            // A reversing axis that keeps its direction is held where a take-up would move it
            // back by the change of a cross-axis correction (micrometres at most): moving it
            // would reverse it too.
            let (tw, aw) = (self.written(&t), self.written(&walk.at));
            for d in 0..6 {
                if reversing[d]
                    && directions[d] == walk.directions[d]
                    && runs_against(tw[d] - aw[d], directions[d])
                {
                    t[d] = walk.at[d];
                }
            }
            let tw = self.written(&t);
            (0..3).any(|d| (tw[d] - aw[d]).abs() > MOVES).then_some(t)
        } else {
            None
        };
        Ok(Piece {
            take_up,
            end: self.compensate_point(pb, &directions)?,
            directions,
            against: false,
        })
    }

    /// The reversing axes whose written motion along `piece` (its take-up, then to its end)
    /// runs against the directions it is compensated for.
    fn against_axes(&self, walk: &Walk, piece: &Piece) -> [bool; 6] {
        let reversing = self.kin.reversing();
        let a = self.written(&walk.at);
        let m = piece.take_up.map_or(a, |t| self.written(&t));
        let b = self.written(&piece.end);
        std::array::from_fn(|d| {
            reversing[d]
                && (runs_against(m[d] - a[d], piece.directions[d])
                    || runs_against(b[d] - m[d], piece.directions[d]))
        })
    }

    /// The pieces of one segment of a feed move, from where `walk` is: bisected until the real
    /// tip along each straight piece stays within the tolerance of the intended path at the same
    /// fraction (or the pieces are 2⁻²⁴ of the segment).
    pub(super) fn walk_segment(
        &self,
        along: &Toolpath,
        segment: &Segment,
        walk: &mut Walk,
        pieces: &mut Vec<[f64; 6]>,
        report: &mut Report,
    ) -> Result<(), Split> {
        let (t0, t1) = segment.t;
        let finest = (t1 - t0) / f64::from(1 << 24);
        let mut stack = vec![(t0, t1)];
        // Which tolerance split the last piece: the one a move of too many pieces is blamed on.
        let mut splitting = NcOption::ChordTolerance;
        while let Some((ta, tb)) = stack.pop() {
            let piece = self
                .piece(along, (ta, tb), &segment.directions, walk, true)
                .map_err(Split::Point)?;
            let start = piece.take_up.unwrap_or(walk.at);
            let worst = self.chord_error(along, (ta, tb), (start, piece.end), &piece.directions);
            if pieces.len() >= MAX_PIECES {
                return Err(Split::Pieces(splitting));
            }
            let angle = self.chord_angle(
                &|t| along.at(t),
                (ta, tb),
                (start, piece.end),
                &piece.directions,
            );
            let within_angle = angle
                <= self.angle_allowed(
                    (start, piece.end),
                    (along.at(ta), along.at(tb)),
                    &piece.directions,
                );
            if (worst <= self.tolerance && within_angle) || tb - ta <= finest {
                report.largest_error_after_mm = report.largest_error_after_mm.max(worst);
                report.largest_orientation_error_after_rad =
                    report.largest_orientation_error_after_rad.max(angle);
                self.accept(&piece, walk, pieces);
            } else {
                splitting = if worst > self.tolerance {
                    NcOption::ChordTolerance
                } else {
                    NcOption::AngularTolerance
                };
                let tm = 0.5 * (ta + tb);
                stack.push((tm, tb));
                stack.push((ta, tm));
            }
        }
        Ok(())
    }

    /// Takes `piece` into `pieces` (its take-up first) and moves `walk` to its end.
    pub(super) fn accept(&self, piece: &Piece, walk: &mut Walk, pieces: &mut Vec<[f64; 6]>) {
        if let Some(t) = piece.take_up {
            pieces.push(t);
            self.take_ups.set(self.take_ups.get() + 1);
        }
        if piece.against {
            self.against.set(self.against.get() + 1);
        }
        pieces.push(piece.end);
        *walk = Walk {
            at: piece.end,
            directions: piece.directions,
        };
    }

    /// The largest distance of the real tip along the straight piece from `a` to `b` as written
    /// (rounded), approached in `directions`, from the intended path at the same fraction of `[ta, tb]`.
    fn chord_error(
        &self,
        intended: &Toolpath,
        (ta, tb): (f64, f64),
        (a, b): ([f64; 6], [f64; 6]),
        directions: &Directions,
    ) -> f64 {
        // The piece as the output writes it: the error after rounding.
        let (a, b) = (self.written(&a), self.written(&b));
        let length = (0..3).map(|d| (b[d] - a[d]).powi(2)).sum::<f64>().sqrt();
        let n = ((length / 0.5).ceil() as usize).clamp(8, 64);
        (1..n)
            .map(|k| {
                let s = k as f64 / n as f64;
                let commanded: [f64; 6] = std::array::from_fn(|d| lerp(a[d], b[d], s));
                self.kin.miss(
                    &self.command(&commanded),
                    &self.command(&intended.at(lerp(ta, tb, s))),
                    directions,
                )
            })
            .fold(0.0, f64::max)
    }
}
