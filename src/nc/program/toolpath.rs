//! The intended path of a move: straight, or an arc (helical where the third axis moves), as a
//! function of the fraction of the move.

use super::modal::{Motion, Plane, State, MM_PER_INCH};
use super::parse::Line;
use crate::nc::error::NcError;

/// The intended path of a move, `t` from 0 to 1, in program coordinates (mm, degrees).
#[derive(Debug, Clone, Copy)]
pub(in crate::nc) enum Toolpath {
    Line {
        from: [f64; 6],
        to: [f64; 6],
    },
    Arc {
        from: [f64; 6],
        to: [f64; 6],
        plane: Plane,
        centre: [f64; 2],
        start_angle: f64,
        sweep: f64,
        radii: [f64; 2],
    },
}

pub(in crate::nc) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

impl Toolpath {
    pub(in crate::nc) fn at(&self, t: f64) -> [f64; 6] {
        match *self {
            Toolpath::Line { from, to } => std::array::from_fn(|d| lerp(from[d], to[d], t)),
            Toolpath::Arc {
                from,
                to,
                plane,
                centre,
                start_angle,
                sweep,
                radii,
            } => {
                let mut p: [f64; 6] = std::array::from_fn(|d| lerp(from[d], to[d], t));
                let (s, c) = (start_angle + sweep * t).sin_cos();
                let r = lerp(radii[0], radii[1], t);
                p[plane.u] = centre[0] + r * c;
                p[plane.v] = centre[1] + r * s;
                p
            }
        }
    }

    pub(in crate::nc) fn length(&self) -> f64 {
        match *self {
            Toolpath::Line { from, to } => (0..3)
                .map(|d| (to[d] - from[d]).powi(2))
                .sum::<f64>()
                .sqrt(),
            Toolpath::Arc {
                from,
                to,
                plane,
                sweep,
                radii,
                ..
            } => {
                let planar = sweep.abs() * 0.5 * (radii[0] + radii[1]);
                planar.hypot(to[plane.w] - from[plane.w])
            }
        }
    }
}

pub(in crate::nc) fn angle_of(p: &[f64; 6], plane: Plane, centre: [f64; 2]) -> f64 {
    (p[plane.v] - centre[1]).atan2(p[plane.u] - centre[0])
}

/// The arc from `from` to `to` about `centre` in `plane`, in the direction of `motion`; a full
/// turn where the ends coincide. `None` where an end sits on the centre.
pub(in crate::nc) fn arc_through(
    from: [f64; 6],
    to: [f64; 6],
    plane: Plane,
    centre: [f64; 2],
    motion: Motion,
) -> Option<Toolpath> {
    let r0 = (from[plane.u] - centre[0]).hypot(from[plane.v] - centre[1]);
    let r1 = (to[plane.u] - centre[0]).hypot(to[plane.v] - centre[1]);
    if r0 < 1e-9 || r1 < 1e-9 {
        return None;
    }
    let a0 = angle_of(&from, plane, centre);
    let a1 = angle_of(&to, plane, centre);
    let tau = std::f64::consts::TAU;
    let same = (from[plane.u] - to[plane.u]).hypot(from[plane.v] - to[plane.v]) < 1e-9;
    let sweep = match motion {
        Motion::CounterClockwise => {
            let s = (a1 - a0).rem_euclid(tau);
            if same || s < 1e-12 {
                tau
            } else {
                s
            }
        }
        _ => {
            let s = (a1 - a0).rem_euclid(tau) - tau;
            if same || s > -1e-12 {
                -tau
            } else {
                s
            }
        }
    };
    Some(Toolpath::Arc {
        from,
        to,
        plane,
        centre,
        start_angle: a0,
        sweep,
        radii: [r0, r1],
    })
}

/// The intended arc of a G2/G3 block: centre from I/J/K (from the start) or R.
/// Whether an R arc of radius `r` (negative: more than 180°) reaches across `chord` as volmap
/// reads it: R at least half the chord, short of it by no more than the rounding of written
/// numbers allows (1e-6 of R² in R² − chord²/4).
pub(in crate::nc) fn radius_reaches(r: f64, chord: f64) -> bool {
    let r = r.abs();
    r * r - chord * chord / 4.0 >= -1e-6 * r * r.max(1.0)
}

pub(in crate::nc) fn arc_path(
    line: &Line,
    state: &State,
    start: [f64; 6],
    end: [f64; 6],
    path: &str,
) -> Result<Toolpath, NcError> {
    let plane = state.plane;
    let scale = if state.inch { MM_PER_INCH } else { 1.0 };
    let offsets: Vec<Option<f64>> = plane
        .centre
        .iter()
        .map(|&c| line.word(c).map(|w| w.value * scale))
        .collect();
    let centre = if let Some(r) = line.word('R') {
        let r = r.value * scale;
        let (du, dv) = (end[plane.u] - start[plane.u], end[plane.v] - start[plane.v]);
        let chord = du.hypot(dv);
        if chord < 1e-9 {
            return Err(NcError::line(
                path,
                line.number,
                "an R arc cannot be a full circle: give its centre with I, J, K".into(),
            ));
        }
        let h2 = r * r - chord * chord / 4.0;
        if !radius_reaches(r, chord) {
            return Err(NcError::line(
                path,
                line.number,
                format!(
                    "radius R{} is shorter than half the chord ({:.4} mm)",
                    r / scale,
                    chord / 2.0
                ),
            ));
        }
        let h = h2.max(0.0).sqrt();
        let left = [-dv / chord, du / chord];
        // Counter-clockwise arcs of at most 180° (R > 0) turn about a centre left of the chord.
        let side = if state.motion == Motion::CounterClockwise {
            1.0
        } else {
            -1.0
        } * r.signum();
        let mid = [start[plane.u] + du / 2.0, start[plane.v] + dv / 2.0];
        [mid[0] + side * h * left[0], mid[1] + side * h * left[1]]
    } else if offsets.iter().any(Option::is_some) {
        [
            start[plane.u] + offsets[0].unwrap_or(0.0),
            start[plane.v] + offsets[1].unwrap_or(0.0),
        ]
    } else {
        return Err(NcError::line(
            path,
            line.number,
            format!(
                "an arc (G{}) needs its centre ({} {}) or its radius (R)",
                state.motion.code(),
                plane.centre[0],
                plane.centre[1]
            ),
        ));
    };
    let arc = arc_through(start, end, plane, centre, state.motion).ok_or_else(|| {
        NcError::line(
            path,
            line.number,
            "the arc's start or end lies on its centre".into(),
        )
    })?;
    if let Toolpath::Arc { radii, .. } = arc {
        if (radii[0] - radii[1]).abs() > 1e-3 * scale.max(1.0) + 1e-6 * radii[0] {
            return Err(NcError::line(
                path,
                line.number,
                format!("the arc's end is not on its circle: radius {:.4} at the start, {:.4} at the end (mm)", radii[0], radii[1]),
            ));
        }
    }
    Ok(arc)
}
