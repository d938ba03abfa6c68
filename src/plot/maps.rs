//! Pictures of a field: colour maps of a slice with a scale bar, the isometric deformed grid.

use super::axis::{drawable, finite_range, fraction, is_wide, tick_label, ticks};
use super::charts::{MARGIN_BOTTOM, MARGIN_LEFT, MARGIN_TOP};
use super::{Anchor, Color, Drawing, PlotError, Shape};

/// A perceptually ordered colour scale (viridis, sampled), `t` in [0, 1].
pub fn colour(t: f64) -> [u8; 3] {
    const STOPS: [[u8; 3]; 9] = [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f64;
    let k = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - k as f64;
    std::array::from_fn(|c| {
        (STOPS[k][c] as f64 * (1.0 - f) + STOPS[k + 1][c] as f64 * f).round() as u8
    })
}

/// A colour map of `values` (`rows × cols`, row 0 at `extent.2`, the low end of the vertical
/// axis) over `extent = (x_lo, x_hi, y_lo, y_hi)`, with a scale bar in `unit`.
pub fn colour_map(
    title: &str,
    labels: (&str, &str),
    extent: (f64, f64, f64, f64),
    cols: usize,
    rows: usize,
    values: &[f64],
    unit: &str,
) -> Result<Drawing, PlotError> {
    let [e0, e1, e2, e3] = [extent.0, extent.1, extent.2, extent.3];
    if values
        .iter()
        .chain(&[e0, e1, e2, e3])
        .any(|v| !v.is_finite())
    {
        return Err(PlotError::NotFinite(title.into()));
    }
    let (lo, hi) =
        finite_range(values.iter().copied()).ok_or_else(|| PlotError::Empty(title.into()))?;
    let width = 900.0;
    let (x0, y1) = (MARGIN_LEFT, MARGIN_TOP);
    let available = (width - MARGIN_LEFT - 160.0, 540.0);
    // Spans in halves; a picture longer than 1000:1 is drawn at 1000:1, and one with an axis of
    // one point (or of a span f64 does not resolve) square, so that its values show.
    let half = |a: f64, b: f64| (b / 2.0 - a / 2.0).abs();
    let aspect = if is_wide((e0.min(e1), e0.max(e1))) && is_wide((e2.min(e3), e2.max(e3))) {
        (half(e0, e1) / half(e2, e3)).clamp(1e-3, 1e3)
    } else {
        1.0
    };
    let (w, h) = if available.0 / available.1 > aspect {
        (available.1 * aspect, available.1)
    } else {
        (available.0, available.0 / aspect)
    };
    let y0 = y1 + h;
    // The colours run over the values' range; all values alike take the lowest colour.
    let range = value_range(lo, hi);
    let rgb: Vec<[u8; 3]> = (0..rows)
        .rev()
        .flat_map(|r| (0..cols).map(move |c| (r, c)))
        .map(|(r, c)| colour(fraction(values[r * cols + c], range)))
        .collect();
    let mut d = Drawing::new(width, y0 + MARGIN_BOTTOM);
    d.title(title);
    d.shapes.push(Shape::Image {
        x: x0,
        y: y1,
        w,
        h,
        cols,
        rows,
        rgb,
    });
    d.shapes.push(Shape::Rect {
        x: x0,
        y: y1,
        w,
        h,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    // An axis of one grid point: one tick, in the middle of the picture.
    let axis_ticks = |a: f64, b: f64| {
        if is_wide((a, b)) {
            (ticks(a, b, 6), (a, b))
        } else {
            (vec![a], drawable((a, a)))
        }
    };
    let (xt, x_range) = axis_ticks(e0, e1);
    let (yt, y_range) = axis_ticks(e2, e3);
    let step = |t: &[f64]| if t.len() > 1 { t[1] - t[0] } else { 1.0 };
    for &t in &xt {
        let x = x0 + fraction(t, x_range) * w;
        d.line(vec![[x, y0], [x, y0 + 5.0]], Color::BLACK, 1.0, false);
        d.text(x, y0 + 18.0, tick_label(t, step(&xt)), 11.0, Anchor::Middle);
    }
    for &t in &yt {
        let y = y0 - fraction(t, y_range) * h;
        d.line(vec![[x0 - 5.0, y], [x0, y]], Color::BLACK, 1.0, false);
        d.text(
            x0 - 8.0,
            y + 4.0,
            tick_label(t, step(&yt)),
            11.0,
            Anchor::End,
        );
    }
    d.text(x0 + w / 2.0, y0 + 40.0, labels.0, 13.0, Anchor::Middle);
    d.shapes.push(Shape::Text {
        x: 22.0,
        y: y1 + h / 2.0,
        text: labels.1.into(),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    scale_bar(&mut d, [x0 + w + 40.0, y1, h], (lo, hi), unit);
    Ok(d)
}

/// The range a colour map's colours run over: its values' range, or where that is too narrow to
/// tell apart, one from the lowest value up (every value the lowest colour).
fn value_range(lo: f64, hi: f64) -> (f64, f64) {
    let top = lo + lo.abs().max(1.0);
    if is_wide((lo, hi)) {
        (lo, hi)
    } else if top.is_finite() {
        (lo, top)
    } else {
        (lo / 2.0, lo)
    }
}

/// The scale bar of a colour map: the colour ramp from `lo` to `hi` at `[x, top, height]`, with
/// round values marked and the unit above.
fn scale_bar(d: &mut Drawing, [bx, top, h]: [f64; 3], (lo, hi): (f64, f64), unit: &str) {
    let bw = 22.0;
    let range = value_range(lo, hi);
    let ramp: Vec<[u8; 3]> = (0..256).rev().map(|k| colour(k as f64 / 255.0)).collect();
    d.shapes.push(Shape::Image {
        x: bx,
        y: top,
        w: bw,
        h,
        cols: 1,
        rows: 256,
        rgb: ramp,
    });
    d.shapes.push(Shape::Rect {
        x: bx,
        y: top,
        w: bw,
        h,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    let bt = if is_wide((lo, hi)) {
        ticks(lo, hi, 6)
    } else {
        vec![lo]
    };
    let step = if bt.len() > 1 { bt[1] - bt[0] } else { 1.0 };
    for &t in &bt {
        let y = top + h - fraction(t, range) * h;
        d.line(
            vec![[bx + bw, y], [bx + bw + 5.0, y]],
            Color::BLACK,
            1.0,
            false,
        );
        d.text(
            bx + bw + 8.0,
            y + 4.0,
            tick_label(t, step),
            11.0,
            Anchor::Start,
        );
    }
    d.text(bx, top - 10.0, unit, 12.0, Anchor::Start);
}

/// An isometric view of the workspace grid, nominal (grey) and displaced by the magnified error
/// (colour): `nominal[n]` and `deformed[n]` are the same grid line, points in mm.
pub fn deformed_grid(
    title: &str,
    note: &str,
    nominal: &[Vec<[f64; 3]>],
    deformed: &[Vec<[f64; 3]>],
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
    if nominal
        .iter()
        .chain(deformed)
        .flatten()
        .flatten()
        .any(|v| !v.is_finite())
    {
        return Err(PlotError::NotFinite(title.into()));
    }
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
    let scale =
        ((width - 80.0) / 2.0 / x_half.max(5e-10)).min((height - 140.0) / 2.0 / y_half.max(5e-10));
    let ox = width / 2.0 - scale * (x_lo / 2.0 + x_hi / 2.0);
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
    axis_labels(&mut d, nominal, to_canvas);
    d.text(width / 2.0, height - 40.0, note, 12.0, Anchor::Middle);
    d.text(width / 2.0, height - 20.0, "grey dashed: nominal grid; blue: the tool tip's actual positions, error magnified (isometric view, z up)", 11.0, Anchor::Middle);
    Ok(d)
}

/// Names the axes along the nominal grid's edges: X along the lower right front edge, Y along the
/// lower left, Z up the left edge, each with its range in mm.
fn axis_labels(
    d: &mut Drawing,
    nominal: &[Vec<[f64; 3]>],
    to_canvas: impl Fn(&[f64; 3]) -> [f64; 2],
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
        z[0] - 12.0,
        z[1] + 4.0,
        format!("Z {}", range(2)),
        13.0,
        Anchor::End,
    );
}
