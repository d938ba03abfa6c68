//! The original's and the compensated program's canonical moves side by side: which compensated
//! moves make each original move, whether they stay near its path, and where the machine model
//! puts the real tool tip at their positions.

use std::collections::HashMap;

use nalgebra::Vector3;
use volmap::model::inputs::{Approach, Inputs};
use volmap::model::Machine;
use volmap::reference::Twin;

use super::canon::{plane_axes, Kind, Move};

/// Samples of a move at most this far apart, mm (volmap's own trace step).
const STEP_MM: f64 = 0.5;

/// The first sample out of bound, in words.
pub type Miss = String;

/// The distance of `p` from the path of `o` and the fraction of `o` it is nearest to; of several
/// turns of an arc within `near_mm`, the first past `t_from` (the compensated motion goes
/// forward).
pub fn project(o: &Move, p: Vector3<f64>, t_from: f64, slack: f64, near_mm: f64) -> (f64, f64) {
    match o.kind {
        Kind::Rapid | Kind::Line => {
            let d = o.end - o.start;
            let len2 = d.norm_squared();
            if len2 == 0.0 {
                return ((p - o.end).norm(), 1.0);
            }
            let t = ((p - o.start).dot(&d) / len2).clamp(0.0, 1.0);
            ((p - o.at(t)).norm(), t)
        }
        Kind::Arc {
            centre,
            normal,
            sweep_rad,
        } => {
            let (a, b) = plane_axes(normal);
            let angle = |q: Vector3<f64>| (q[b] - centre[b]).atan2(q[a] - centre[a]);
            let turn = std::f64::consts::TAU;
            let u = (sweep_rad.signum() * (angle(p) - angle(o.start))).rem_euclid(turn);
            let mut candidates = Vec::new();
            let mut n = -1.0;
            loop {
                let t = ((u + turn * n) / sweep_rad.abs()).clamp(0.0, 1.0);
                candidates.push(((p - o.at(t)).norm(), t));
                if (u + turn * n) / sweep_rad.abs() > 1.0 {
                    break;
                }
                n += 1.0;
            }
            // Of the turns near enough (a whole circle's start and end), the first one forward.
            let mut best = candidates
                .iter()
                .copied()
                .filter(|c| c.0 <= near_mm && c.1 >= t_from - slack)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or_else(|| {
                    candidates
                        .iter()
                        .copied()
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .unwrap()
                });
            // The nearest point of a helix is not at the same angle: refine along it.
            let (mut lo, mut hi) = ((best.1 - 0.05).max(0.0), (best.1 + 0.05).min(1.0));
            for _ in 0..60 {
                let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
                if (p - o.at(m1)).norm() <= (p - o.at(m2)).norm() {
                    hi = m2;
                } else {
                    lo = m1;
                }
            }
            let t = 0.5 * (lo + hi);
            let d = (p - o.at(t)).norm();
            if d < best.0 {
                best = (d, t);
            }
            best
        }
    }
}

/// Samples of `c` past its start (fractions), at most [`STEP_MM`] apart, at least 4.
pub fn fractions(c: &Move) -> impl Iterator<Item = f64> {
    let n = ((c.length_mm() / STEP_MM).ceil() as usize).clamp(4, 20_000);
    (1..=n).map(move |i| i as f64 / n as f64)
}

/// Whether every sample of `c` lies within `bound_mm` of the path of `o`, going forward from
/// fraction `t_from` of it: the fraction reached, or the first sample out of bound.
fn fits(c: &Move, o: &Move, t_from: f64, bound_mm: f64) -> Result<f64, Miss> {
    let slack = bound_mm / o.length_mm().max(bound_mm);
    let mut t = t_from;
    for s in fractions(c) {
        let p = c.at(s);
        let (d, at) = project(o, p, t, slack, bound_mm);
        if d > bound_mm {
            return Err(format!(
                "{:.4} mm from the original's path at ({:.4}, {:.4}, {:.4}), {:.0}% along `{}` (bound {:.4} mm)",
                d,
                p[0],
                p[1],
                p[2],
                s * 100.0,
                c.canon_line.trim(),
                bound_mm
            ));
        }
        if at < t - slack {
            return Err(format!(
                "goes back along the original's path at ({:.4}, {:.4}, {:.4}), {:.0}% along `{}`",
                p[0],
                p[1],
                p[2],
                s * 100.0,
                c.canon_line.trim()
            ));
        }
        t = t.max(at);
    }
    Ok(t)
}

/// The compensated moves (a range of `comp`) that make each original move, in order: each
/// stays within `bound_mm` of the original's path going forward and the last ends within it
/// of the original's end; a compensated rapid only where the original has a rapid, one at most,
/// and a feed only where it has a feed (moves no longer than `tiny_mm`, take-ups and the
/// zero-length rapids of a cycle, aside); no compensated move left over.
pub fn pair(
    orig: &[Move],
    comp: &[Move],
    bound_mm: f64,
    tiny_mm: f64,
) -> Result<Vec<std::ops::Range<usize>>, Miss> {
    let kind_fits = |c: &Move, o: &Move| c.length_mm() <= tiny_mm || c.is_rapid() == o.is_rapid();
    let describe = |k: usize| format!("original move {} `{}`", k + 1, orig[k].canon_line.trim());
    let mut groups = Vec::with_capacity(orig.len());
    let mut j = 0;
    for (k, o) in orig.iter().enumerate() {
        let first = j;
        let near_end = |p: Vector3<f64>| (p - o.end).norm() <= bound_mm;
        let here = if j == 0 { None } else { Some(comp[j - 1].end) };
        let mut reached = o.length_mm() <= bound_mm && here.is_some_and(near_end);
        let mut t = 0.0;
        let mut rapids = 0;
        while j < comp.len() {
            let c = &comp[j];
            if reached {
                if let Some(next) = orig.get(k + 1) {
                    // A short move of this move's kind (a feed before a rapid) that goes on
                    // along it stays with it: the last piece of a split arc, tiny, fits the
                    // rapid's start too.
                    let continues = c.is_rapid() == o.is_rapid()
                        && c.is_rapid() != next.is_rapid()
                        && fits(c, o, t, bound_mm).is_ok();
                    if !continues && kind_fits(c, next) && fits(c, next, 0.0, bound_mm).is_ok() {
                        break;
                    }
                }
            }
            let fit = if kind_fits(c, o) {
                fits(c, o, t, bound_mm)
            } else {
                Err(format!(
                    "a {} `{}` where the original has a {}",
                    if c.is_rapid() { "rapid" } else { "feed" },
                    c.canon_line.trim(),
                    if o.is_rapid() { "rapid" } else { "feed" }
                ))
            };
            match fit {
                Ok(at) => {
                    t = at;
                    rapids += usize::from(c.is_rapid() && c.length_mm() > tiny_mm);
                    reached = t >= 1.0 - bound_mm / o.length_mm().max(bound_mm) && near_end(c.end);
                    j += 1;
                }
                Err(_) if reached => break,
                Err(miss) => {
                    return Err(format!(
                        "compensated move {} against {}: {miss}",
                        j + 1,
                        describe(k)
                    ))
                }
            }
        }
        if !reached {
            return Err(format!(
                "{}: the compensated moves end {:.4} mm before its end",
                describe(k),
                comp.get(j.max(1) - 1)
                    .map_or(f64::INFINITY, |c| (c.end - o.end).norm())
            ));
        }
        if rapids > 1 {
            return Err(format!(
                "{}: {rapids} compensated rapids (a rapid is not split)",
                describe(k)
            ));
        }
        groups.push(first..j);
    }
    if let Some(extra) = comp[j..].iter().find(|c| c.length_mm() > tiny_mm) {
        return Err(format!(
            "a compensated move after the original's last: `{}`",
            extra.canon_line.trim()
        ));
    }
    Ok(groups)
}

/// The machine model at each set of approach directions of X, Y, Z: the real machine where
/// the axes approach their positions that way (a reversal error applies), and the ideal one.
pub struct Model {
    machine: Machine,
    twins: HashMap<[bool; 3], Twin>,
}

impl Model {
    pub fn new(machine: &Machine) -> Model {
        Model {
            machine: machine.clone(),
            twins: HashMap::new(),
        }
    }

    fn twin(&mut self, negative: [bool; 3]) -> &Twin {
        let machine = &self.machine;
        self.twins.entry(negative).or_insert_with(|| {
            let mut inputs = Inputs::default();
            for (d, &n) in negative.iter().enumerate() {
                if n {
                    inputs.approach[d] = Approach::Negative;
                }
            }
            Twin::new(machine.at(&inputs))
        })
    }

    /// The real tool tip at machine position `q`, each axis approaching it in `directions`
    /// (negative where < 0).
    pub fn real_tip(&mut self, q: Vector3<f64>, directions: [f64; 3]) -> Vector3<f64> {
        self.twin(directions.map(|d| d < 0.0))
            .real_tip(&[q[0], q[1], q[2], 0.0, 0.0, 0.0])
    }

    /// The ideal tool tip at machine position `q`.
    pub fn ideal_tip(&mut self, q: Vector3<f64>) -> Vector3<f64> {
        self.twin([false; 3])
            .ideal_tip(&[q[0], q[1], q[2], 0.0, 0.0, 0.0])
    }

    /// The largest distance of the real tool tip from the ideal one along `moves` (sampled, both
    /// approach directions of every axis): how far a compensated position may stand from the
    /// programmed one.
    pub fn largest_error_mm(&mut self, moves: &[Move]) -> f64 {
        let mut largest: f64 = 0.0;
        for m in moves {
            for t in std::iter::once(0.0).chain(fractions(m)) {
                let q = m.at(t);
                let ideal = self.ideal_tip(q);
                for d in [[1.0; 3], [-1.0; 3]] {
                    largest = largest.max((self.real_tip(q, d) - ideal).norm());
                }
            }
        }
        largest
    }
}

/// Where the model puts the real tool tip along the compensated program: at the end of every
/// compensated move and along every feed move longer than `tiny_mm`, each axis approaching in the
/// direction it last moved in as the compensated program moves it (`+` before its first move),
/// the tip must be within `tolerance_mm` of the ideal tip's path of the original move the
/// compensated one belongs to, and at each original move's end within it of the ideal tip there.
/// `compensated[k]` says whether volmap compensates original move `k` (a rapid to a machine
/// position, G28 or G53, passes as it is).
pub fn tips(
    model: &mut Model,
    orig: &[Move],
    comp: &[Move],
    groups: &[std::ops::Range<usize>],
    compensated: &[bool],
    tolerance_mm: f64,
    tiny_mm: f64,
) -> Result<f64, Miss> {
    // The ideal tip of a 3-axis machine is the command shifted by the tool: the ideal path of a
    // move is the move shifted.
    let shift = model.ideal_tip(Vector3::zeros());
    let mut directions = [1.0; 3];
    let mut largest: f64 = 0.0;
    for (k, group) in groups.iter().enumerate() {
        let o = &orig[k];
        for (i, c) in comp[group.clone()].iter().enumerate() {
            let mut samples: Vec<f64> = vec![1.0];
            if !c.is_rapid() && c.length_mm() > tiny_mm {
                samples = fractions(c).collect();
            }
            for s in samples {
                let mut at = directions;
                for (d, step) in c.direction_at(s).into_iter().enumerate() {
                    if step != 0.0 {
                        at[d] = step;
                    }
                }
                if s == 1.0 {
                    directions = at;
                }
                // A move that stays at the original's start (a take-up, a rapid of no length)
                // is at the previous original's end: compensated only if that is.
                let at_start = k > 0
                    && o.length_mm() > tiny_mm
                    && (c.end - o.start).norm() <= tiny_mm
                    && !compensated[k - 1];
                if !compensated[k] || at_start {
                    continue;
                }
                let tip = model.real_tip(c.at(s), at) - shift;
                let last = s == 1.0 && group.start + i + 1 == group.end;
                let (miss, what) = if last {
                    ((tip - o.end).norm(), "the original's end")
                } else {
                    (
                        project(o, tip, 0.0, 1.0, tolerance_mm).0,
                        "the original's path",
                    )
                };
                largest = largest.max(miss);
                if miss > tolerance_mm {
                    return Err(format!(
                        "the real tool tip {:.5} mm from {what} (tolerance {:.5} mm), {:.0}% along `{}` (original move {} `{}`), approach {:?}",
                        miss,
                        tolerance_mm,
                        s * 100.0,
                        c.canon_line.trim(),
                        k + 1,
                        o.canon_line.trim(),
                        at
                    ));
                }
            }
        }
    }
    Ok(largest)
}
