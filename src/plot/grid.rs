//! The isometric view of a workspace grid deformed by its magnified error (Hwang et al., Fig. 9).

use super::axis::tick_label;
use super::{Anchor, Color, Drawing, PlotError};

/// An isometric view of the workspace grid, nominal (grey) and displaced by the magnified error
/// (colour): `nominal[n]` and `deformed[n]` are the same grid line, points in mm.
pub fn deformed_grid(
    title: &str,
    note: &str,
    nominal: &[Vec<[f64; 3]>],
    deformed: &[Vec<[f64; 3]>],
) -> Result<Drawing, PlotError> {
    if nominal
        .iter()
        .chain(deformed)
        .flatten()
        .flatten()
        .any(|v| !v.is_finite())
    {
        return Err(PlotError::NotFinite(title.into()));
    }
    // The axes' labels stand beside the grid's edges: where one would leave the canvas, the grid
    // is drawn again narrower by as much on that side.
    let mut pad = [0.0, 0.0];
    let mut d = draw(title, note, nominal, deformed, pad)?;
    for _ in 0..4 {
        let layout = d.layout();
        let over = layout.texts.iter().fold([0.0f64, 0.0f64], |o, t| {
            [o[0].max(-t.bounds[0]), o[1].max(t.bounds[2] - d.width)]
        });
        if over[0] <= 0.0 && over[1] <= 0.0 {
            break;
        }
        pad = [
            pad[0] + over[0].max(0.0) + 4.0,
            pad[1] + over[1].max(0.0) + 4.0,
        ];
        d = draw(title, note, nominal, deformed, pad)?;
    }
    Ok(d)
}

/// The deformed grid drawn with `pad = [left, right]` pixels more margin.
fn draw(
    title: &str,
    note: &str,
    nominal: &[Vec<[f64; 3]>],
    deformed: &[Vec<[f64; 3]>],
    [pad_left, pad_right]: [f64; 2],
) -> Result<Drawing, PlotError> {
    let (width, height) = (900.0, 760.0);
    // Isometric projection: x to the right and down, y to the left and down, z up.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    // In halves: no sum of two finite coordinates overflows.
    let project = |p: &[f64; 3]| {
        [
            (p[0] / 2.0 - p[1] / 2.0) * c,
            -(p[0] / 2.0 + p[1] / 2.0) * s - p[2] / 2.0,
        ]
    };
    let all = nominal.iter().chain(deformed).flatten().map(project);
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for [x, y] in all {
        x_lo = x_lo.min(x);
        x_hi = x_hi.max(x);
        y_lo = y_lo.min(y);
        y_hi = y_hi.max(y);
    }
    if !x_lo.is_finite() {
        return Err(PlotError::Empty(title.into()));
    }
    // Pixels per projected half-mm, the picture centred: spans and middles in halves again.
    let (x_half, y_half) = (x_hi / 2.0 - x_lo / 2.0, y_hi / 2.0 - y_lo / 2.0);
    let room = (width - 80.0 - pad_left - pad_right).max(100.0);
    let scale = (room / 2.0 / x_half.max(5e-10)).min((height - 140.0) / 2.0 / y_half.max(5e-10));
    let ox = 40.0 + pad_left + room / 2.0 - scale * (x_lo / 2.0 + x_hi / 2.0);
    let oy = 60.0 + (height - 140.0) / 2.0 - scale * (y_lo / 2.0 + y_hi / 2.0);
    let to_canvas = |p: &[f64; 3]| {
        let [x, y] = project(p);
        [ox + scale * x, oy + scale * y]
    };
    let mut d = Drawing::new(width, height);
    d.title(title);
    for line in nominal {
        d.line(line.iter().map(to_canvas).collect(), Color::GREY, 1.0, true);
    }
    for line in deformed {
        d.line(
            line.iter().map(to_canvas).collect(),
            Color::BLUE,
            1.5,
            false,
        );
    }
    axis_labels(&mut d, nominal, to_canvas, ox + scale * x_lo);
    d.text(width / 2.0, height - 40.0, note, 12.0, Anchor::Middle);
    d.text(width / 2.0, height - 20.0, "grey dashed: nominal grid; blue: the tool tip's actual positions, error magnified (isometric view, z up)", 11.0, Anchor::Middle);
    Ok(d)
}

/// Names the axes along the nominal grid's edges: X along the lower right front edge, Y along the
/// lower left, Z by the left edge, left of `left` (the drawing's leftmost line, which the deformed
/// grid may be) so that no line crosses it; each with its range in mm.
fn axis_labels(
    d: &mut Drawing,
    nominal: &[Vec<[f64; 3]>],
    to_canvas: impl Fn(&[f64; 3]) -> [f64; 2],
    left: f64,
) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in nominal.iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !lo[0].is_finite() {
        return;
    }
    let mid = |k: usize| lo[k] / 2.0 + hi[k] / 2.0;
    let range = |k: usize| {
        format!(
            "{} to {} mm",
            tick_label(lo[k], 1.0),
            tick_label(hi[k], 1.0)
        )
    };
    let x = to_canvas(&[mid(0), lo[1], lo[2]]);
    d.text(
        x[0] + 14.0,
        x[1] + 22.0,
        format!("X {}", range(0)),
        13.0,
        Anchor::Start,
    );
    let y = to_canvas(&[lo[0], mid(1), lo[2]]);
    d.text(
        y[0] - 14.0,
        y[1] + 22.0,
        format!("Y {}", range(1)),
        13.0,
        Anchor::End,
    );
    let z = to_canvas(&[lo[0], hi[1], mid(2)]);
    d.text(
        z[0].min(left) - 12.0,
        z[1] + 4.0,
        format!("Z {}", range(2)),
        13.0,
        Anchor::End,
    );
}
