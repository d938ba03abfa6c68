//! Colour maps of a field's slice with a scale bar: viridis for magnitudes, a diverging scale
//! about zero for signed values.

use super::axis::{drawable, finite_range, fraction, is_wide, tick_label, ticks};
use super::charts::{MARGIN_BOTTOM, MARGIN_LEFT, MARGIN_TOP};
use super::{Anchor, Color, Drawing, PlotError, Shape};

/// A perceptually ordered colour scale (viridis, sampled), `t` in [0, 1]: for magnitudes.
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
    interpolate(&STOPS, t)
}

/// A diverging colour scale, `t` in [0, 1]: dark blue at 0 through white at ½ (zero) to dark red
/// at 1 (ColorBrewer's RdBu reversed, as matplotlib's RdBu_r): for signed values, so that a sign
/// reads as a hue and zero as white.
pub fn diverging(t: f64) -> [u8; 3] {
    const STOPS: [[u8; 3]; 11] = [
        [5, 48, 97],
        [33, 102, 172],
        [67, 147, 195],
        [146, 197, 222],
        [209, 229, 240],
        [247, 247, 247],
        [253, 219, 199],
        [244, 165, 130],
        [214, 96, 77],
        [178, 24, 43],
        [103, 0, 31],
    ];
    interpolate(&STOPS, t)
}

/// The colour at `t` in [0, 1] of evenly spaced stops, linearly between them.
fn interpolate(stops: &[[u8; 3]], t: f64) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (stops.len() - 1) as f64;
    let k = (t.floor() as usize).min(stops.len() - 2);
    let f = t - k as f64;
    std::array::from_fn(|c| {
        (stops[k][c] as f64 * (1.0 - f) + stops[k + 1][c] as f64 * f).round() as u8
    })
}

/// A colour map's scale bar: its label (the quantity and unit), and whether the values are
/// signed (a channel: the diverging scale about zero, limits ±max|v|) or a magnitude (viridis
/// from the smallest value to the largest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourBar<'a> {
    pub label: &'a str,
    pub signed: bool,
}

/// The colour at a fraction (0 to 1) of a colour bar's range.
type ColourAt = fn(f64) -> [u8; 3];

impl ColourBar<'_> {
    /// The range the colours run over, and the colour at a fraction of it.
    fn scale(&self, lo: f64, hi: f64) -> ((f64, f64), ColourAt) {
        if self.signed {
            (symmetric(lo, hi), diverging)
        } else {
            (value_range(lo, hi), colour)
        }
    }
}

/// `±max|v|` over values from `lo` to `hi`, so that zero is the middle colour; ±1 where every
/// value is zero (all white).
fn symmetric(lo: f64, hi: f64) -> (f64, f64) {
    let most = lo.abs().max(hi.abs());
    if is_wide((-most, most)) {
        (-most, most)
    } else {
        (-1.0, 1.0)
    }
}

/// The cells of an axis of `n` grid points drawn in halves: cell `k` of `2(n − 1)` is half a
/// spacing wide and shows point `(k + 1) / 2`, so each point's cell is centred on it and the two
/// outer ones, half as wide, end at the travel's ends; one point is one cell.
fn half_cells(n: usize) -> (usize, impl Fn(usize) -> usize) {
    let halves = if n > 1 { 2 * (n - 1) } else { 1 };
    (
        halves,
        move |k: usize| if n > 1 { k.div_ceil(2) } else { 0 },
    )
}

/// A colour map of `values` (`rows × cols` grid points, row 0 at `extent.2`, the low end of the
/// vertical axis) over `extent = (x_lo, x_hi, y_lo, y_hi)`, the positions of the first and last
/// points, with a scale bar. Each point colours the cell about it (half a spacing either side),
/// the outer cells cut at the extent: the axes are the travel, and a value sits where it was
/// computed.
pub fn colour_map(
    title: &str,
    labels: (&str, &str),
    extent: (f64, f64, f64, f64),
    cols: usize,
    rows: usize,
    values: &[f64],
    bar: ColourBar,
) -> Result<Drawing, PlotError> {
    let [e0, e1, e2, e3] = [extent.0, extent.1, extent.2, extent.3];
    if values
        .iter()
        .chain(&[e0, e1, e2, e3])
        .any(|v| !v.is_finite())
    {
        return Err(PlotError::NotFinite(title.into()));
    }
    if cols == 0 || rows == 0 || values.len() != cols * rows {
        return Err(PlotError::Empty(format!(
            "{title}: {} values for {cols} × {rows} points",
            values.len()
        )));
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
    // A magnitude's colours run over its values' range (all values alike take the lowest); a
    // signed value's over ±max|v|, white at zero.
    let (range, paint) = bar.scale(lo, hi);
    let (across, col_of) = half_cells(cols);
    let (up, row_of) = half_cells(rows);
    let rgb: Vec<[u8; 3]> = (0..up)
        .rev()
        .flat_map(|r| (0..across).map(move |c| (r, c)))
        .map(|(r, c)| paint(fraction(values[row_of(r) * cols + col_of(c)], range)))
        .collect();
    let mut d = Drawing::new(width, y0 + MARGIN_BOTTOM);
    d.title(title);
    d.shapes.push(Shape::Image {
        x: x0,
        y: y1,
        w,
        h,
        cols: across,
        rows: up,
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
    scale_bar(&mut d, [x0 + w + 40.0, y1, h], (lo, hi), bar);
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

/// The scale bar of a colour map: the colour ramp over the map's range at `[x, top, height]`,
/// with round values marked (zero among them where the values are signed) and the label above.
fn scale_bar(d: &mut Drawing, [bx, top, h]: [f64; 3], (lo, hi): (f64, f64), bar: ColourBar) {
    let bw = 22.0;
    let (range, paint) = bar.scale(lo, hi);
    let ramp: Vec<[u8; 3]> = (0..256).rev().map(|k| paint(k as f64 / 255.0)).collect();
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
    let bt = if bar.signed {
        ticks(range.0, range.1, 6)
    } else if is_wide((lo, hi)) {
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
    d.text(bx, top - 10.0, bar.label, 12.0, Anchor::Start);
}
