//! The approach direction of every axis along a program (docs/model.md, "Evaluation inputs"): the
//! direction an axis moves in on a move, or at a point of an arc; an axis that does not move
//! keeps the direction of its last move.
//!
//! Directions are those of the programmed path, in commanded positions (`+` where the command
//! increases). A straight move has one direction per axis. On an arc the two axes of its plane
//! turn where the tangent is parallel to one of them (at 0°, 90°, 180°, 270° about the centre):
//! the arc is cut there into segments along which every axis keeps its direction, and a turning
//! point belongs to the segment that arrives at it (the axis reached it moving the old way; it
//! leaves it the new way). Segments whose directions differ only in axes without a reversal
//! error are one segment: the model gives them the same errors.

use super::modal::Directions;
use super::toolpath::Toolpath;
use crate::model::inputs::{Approach, Dependent};
use crate::model::perturbation::ErrorTarget;

/// A program axis moves on a piece where it changes by more than this (mm, degrees).
pub(in crate::nc) const MOVES: f64 = 1e-9;

/// The axes that have a reversal error (`reverse`) in any of their component errors: only their
/// directions change the model.
pub(in crate::nc) fn reversing_axes(dependent: &[Dependent]) -> [bool; 6] {
    let mut reversing = [false; 6];
    for d in dependent {
        if let (ErrorTarget::Component { axis, .. }, Some(_)) = (d.target, &d.reverse) {
            reversing[axis.index()] = true;
        }
    }
    reversing
}

/// The directions of `directions` the model sees: one bit per reversing axis approaching `−`.
pub(in crate::nc) fn key(directions: &Directions, reversing: &[bool; 6]) -> usize {
    (0..6)
        .filter(|&d| reversing[d] && directions[d] == Approach::Negative)
        .fold(0, |k, d| k | 1 << d)
}

/// The direction of a change `delta` of a program axis; `previous` where it does not move.
fn direction_of(delta: f64, previous: Approach) -> Approach {
    if delta > MOVES {
        Approach::Positive
    } else if delta < -MOVES {
        Approach::Negative
    } else {
        previous
    }
}

/// The directions of the straight motion from `from` to `to`.
pub(in crate::nc) fn line_directions(
    from: &[f64; 6],
    to: &[f64; 6],
    previous: &Directions,
) -> Directions {
    std::array::from_fn(|d| direction_of(to[d] - from[d], previous[d]))
}

/// A piece of a move, `t` from `t.0` to `t.1`, along which every axis keeps its direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::nc) struct Segment {
    pub(in crate::nc) t: (f64, f64),
    /// The directions along it (those at its end where axes without a reversal error turn
    /// inside it).
    pub(in crate::nc) directions: Directions,
}

/// The fractions of an arc where an axis of its plane turns, strictly inside it (not within
/// 1e-9 of an end), increasing.
fn turning_fractions(start_angle: f64, sweep: f64) -> Vec<f64> {
    let quarter = std::f64::consts::FRAC_PI_2;
    let (lo, hi) = if sweep > 0.0 {
        (start_angle, start_angle + sweep)
    } else {
        (start_angle + sweep, start_angle)
    };
    let mut fractions: Vec<f64> = ((lo / quarter).ceil() as i64..=(hi / quarter).floor() as i64)
        .map(|k| (k as f64 * quarter - start_angle) / sweep)
        .filter(|t| *t > 1e-9 && *t < 1.0 - 1e-9)
        .collect();
    fractions.sort_by(f64::total_cmp);
    fractions
}

/// The directions of the motion along `path` at fraction `t` (inside a segment: not at a
/// turning point); axes that do not move keep `previous`.
fn directions_at(path: &Toolpath, t: f64, previous: &Directions) -> Directions {
    match *path {
        Toolpath::Line { from, to } => line_directions(&from, &to, previous),
        Toolpath::Arc {
            from,
            to,
            plane,
            start_angle,
            sweep,
            radii,
            ..
        } => {
            let mut velocity: [f64; 6] = std::array::from_fn(|d| to[d] - from[d]);
            let (s, c) = (start_angle + sweep * t).sin_cos();
            let r = radii[0] + (radii[1] - radii[0]) * t;
            let dr = radii[1] - radii[0];
            velocity[plane.u] = -r * s * sweep + dr * c;
            velocity[plane.v] = r * c * sweep + dr * s;
            std::array::from_fn(|d| {
                let v = velocity[d];
                if d == plane.u || d == plane.v {
                    // Inside a segment the tangent has a definite sign on the plane's axes.
                    if v > 0.0 {
                        Approach::Positive
                    } else if v < 0.0 {
                        Approach::Negative
                    } else {
                        previous[d]
                    }
                } else {
                    direction_of(v, previous[d])
                }
            })
        }
    }
}

/// The segments of a move along `path` in which no reversing axis turns, with their
/// directions; `previous` are the directions before the move.
pub(in crate::nc) fn segments(
    path: &Toolpath,
    previous: &Directions,
    reversing: &[bool; 6],
) -> Vec<Segment> {
    let mut cuts = vec![0.0];
    if let Toolpath::Arc {
        start_angle, sweep, ..
    } = *path
    {
        cuts.extend(turning_fractions(start_angle, sweep));
    }
    cuts.push(1.0);
    let mut segments: Vec<Segment> = Vec::with_capacity(cuts.len() - 1);
    let mut last = *previous;
    for pair in cuts.windows(2) {
        let directions = directions_at(path, 0.5 * (pair[0] + pair[1]), &last);
        last = directions;
        match segments.last_mut() {
            Some(s) if key(&s.directions, reversing) == key(&directions, reversing) => {
                s.t.1 = pair[1];
                s.directions = directions;
            }
            _ => segments.push(Segment {
                t: (pair[0], pair[1]),
                directions,
            }),
        }
    }
    segments
}

/// The segment a fraction `t` of the move lies in: a turning point belongs to the segment that
/// arrives at it.
pub(in crate::nc) fn segment_at(segments: &[Segment], t: f64) -> &Segment {
    segments
        .iter()
        .find(|s| t <= s.t.1)
        .unwrap_or_else(|| segments.last().expect("a move has a segment"))
}

/// The axes that move from `a` to `b`.
pub(in crate::nc) fn moving(a: &[f64; 6], b: &[f64; 6]) -> [bool; 6] {
    std::array::from_fn(|d| (b[d] - a[d]).abs() > MOVES)
}
