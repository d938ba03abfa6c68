//! Charts built from shapes: curves over an axis with round ticks, ballbar polar plots.

use super::axis::{drawable, finite_range, fraction, padded, round_step, tick_label, ticks};
use super::{Anchor, Color, Drawing, PlotError, Shape};

/// One curve of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub color: Color,
    pub dashed: bool,
    /// A mark at every point (the targets of a positioning test).
    pub marker: Marker,
    /// Half-widths of a band about the curve at each point (ISO 230-2's ±2s, a prediction's
    /// ± U), drawn as thin lines above and below it (inside and outside it on a polar chart).
    pub band: Option<Vec<f64>>,
}

/// The mark drawn at each point of a curve: triangles pointing the way the axis approached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    None,
    Up,
    Down,
}

/// A triangle of `size` px about `[x, y]`, pointing up or down.
pub(super) fn marker_shape(
    marker: Marker,
    [x, y]: [f64; 2],
    size: f64,
    color: Color,
) -> Option<Shape> {
    let tip = match marker {
        Marker::None => return None,
        Marker::Up => -1.0,
        Marker::Down => 1.0,
    };
    Some(Shape::Polyline {
        points: vec![
            [x, y + tip * size],
            [x - 0.87 * size, y - 0.5 * tip * size],
            [x + 0.87 * size, y - 0.5 * tip * size],
        ],
        color,
        width: 1.5,
        dashed: false,
        closed: true,
    })
}

/// Whether `b` is drawn on top of `a`: the same positions and values within a hair of the scale.
fn coincide(a: &Series, b: &Series, (lo, hi): (f64, f64)) -> bool {
    a.x == b.x
        && a.y.len() == b.y.len()
        && a.y
            .iter()
            .zip(&b.y)
            .all(|(&p, &q)| (fraction(p, (lo, hi)) - fraction(q, (lo, hi))).abs() <= 2e-3)
}

/// Every value of every series (positions, values, bands) a finite number; a chart of others is
/// refused.
fn check_finite(title: &str, series: &[Series]) -> Result<(), PlotError> {
    for s in series {
        let band = s.band.iter().flatten();
        if s.x.iter().chain(&s.y).chain(band).any(|v| !v.is_finite()) {
            return Err(PlotError::NotFinite(format!("{title}: `{}`", s.name)));
        }
    }
    Ok(())
}

/// Every value of every series with its band's edges: what a chart's scale must hold.
fn banded(series: &[Series]) -> impl Iterator<Item = f64> + '_ {
    series.iter().flat_map(|s| {
        let band = s.band.clone().unwrap_or_default();
        s.y.iter()
            .zip(band.into_iter().chain(std::iter::repeat(0.0)))
            .flat_map(|(&y, b)| [y - b, y + b])
            .collect::<Vec<_>>()
    })
}

pub(super) const MARGIN_LEFT: f64 = 80.0;
pub(super) const MARGIN_RIGHT: f64 = 30.0;
pub(super) const MARGIN_TOP: f64 = 50.0;
pub(super) const MARGIN_BOTTOM: f64 = 60.0;

/// The legend's rows from `(x, y)` down, framed; the frame, `[x, y, w, h]`.
pub(super) fn legend(d: &mut Drawing, series: &[Series], x: f64, y: f64) -> [f64; 4] {
    let (w, h) = legend_size(series);
    let frame = [x - 6.0, y - 16.0, w, h];
    // A white frame: the curves pass behind the legend, not through its words.
    d.shapes.push(Shape::Rect {
        x: frame[0],
        y: frame[1],
        w: frame[2],
        h: frame[3],
        fill: Some(Color(255, 255, 255)),
        stroke: Some(Color::LIGHT),
    });
    d.legends
        .push([frame[0], frame[1], frame[0] + frame[2], frame[1] + frame[3]]);
    for (n, s) in series.iter().enumerate() {
        let row = y + 18.0 * n as f64;
        d.line(
            vec![[x, row - 4.0], [x + 24.0, row - 4.0]],
            s.color,
            2.0,
            s.dashed,
        );
        d.shapes
            .extend(marker_shape(s.marker, [x + 12.0, row - 4.0], 4.0, s.color));
        d.text(x + 30.0, row, s.name.clone(), 12.0, Anchor::Start);
    }
    frame
}

/// The legend's size, `(w, h)`, as [`legend`] frames it.
fn legend_size(series: &[Series]) -> (f64, f64) {
    let wide = series
        .iter()
        .map(|s| 30.0 + super::text_width(&s.name, 12.0))
        .fold(0.0, f64::max);
    (wide + 12.0, 18.0 * series.len() as f64 + 6.0)
}

/// The legend in the first corner of the plotting area `[left, top, right, bottom]` that no
/// curve drawn so far passes through (with room for a marker and the line's width); where every
/// corner has a curve, below the chart, the drawing made taller for it. A legend over a curve
/// would hide the data it names.
pub(super) fn place_legend(
    d: &mut Drawing,
    series: &[Series],
    [left, top, right, bottom]: [f64; 4],
) {
    if series.is_empty() {
        return;
    }
    let (w, h) = legend_size(series);
    let clear = 8.0;
    // Frames' top-left corners: top left, top right, bottom left, bottom right, top and bottom
    // middle.
    let middle = (left + right - w) / 2.0;
    let corners = [
        (left + 8.0, top + 8.0),
        (right - w - 8.0, top + 8.0),
        (left + 8.0, bottom - h - 8.0),
        (right - w - 8.0, bottom - h - 8.0),
        (middle, top + 8.0),
        (middle, bottom - h - 8.0),
    ];
    let fits = |&(x, y): &(f64, f64)| x >= left && x + w <= right && y >= top && y + h <= bottom;
    let curves = d.curve_points();
    let free = corners.iter().filter(|c| fits(c)).find(|&&(x, y)| {
        super::layout::first_crossing(
            &curves,
            [x - clear, y - clear, x + w + clear, y + h + clear],
        )
        .is_none()
    });
    let (x, y) = match free {
        Some(&corner) => corner,
        None => {
            let y = d.height + 4.0;
            d.height += h + 12.0;
            (left, y)
        }
    };
    // legend() draws its frame from 6 px left of and 16 px above its first row's sample.
    legend(d, series, x + 6.0, y + 16.0);
}

/// Curves over a common x axis, with round ticks, a grid, axis labels and a legend.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<Drawing, PlotError> {
    check_finite(title, series)?;
    let (width, height) = (900.0, 540.0);
    let xr = finite_range(series.iter().flat_map(|s| s.x.iter().copied()))
        .ok_or_else(|| PlotError::Empty(title.into()))?;
    let yr = padded(finite_range(banded(series)).ok_or_else(|| PlotError::Empty(title.into()))?);
    let xr = drawable(xr);
    let (x0, x1) = (MARGIN_LEFT, width - MARGIN_RIGHT);
    let (y0, y1) = (height - MARGIN_BOTTOM, MARGIN_TOP);
    let sx = |x: f64| x0 + fraction(x, xr) * (x1 - x0);
    let sy = |y: f64| y0 + fraction(y, yr) * (y1 - y0);
    let mut d = Drawing::new(width, height);
    d.title(title);
    let xt = ticks(xr.0, xr.1, 8);
    let yt = ticks(yr.0, yr.1, 6);
    let step = |t: &[f64]| if t.len() > 1 { t[1] - t[0] } else { 1.0 };
    for &t in &xt {
        d.line(vec![[sx(t), y0], [sx(t), y1]], Color::LIGHT, 1.0, false);
        d.text(
            sx(t),
            y0 + 18.0,
            tick_label(t, step(&xt)),
            11.0,
            Anchor::Middle,
        );
    }
    for &t in &yt {
        d.line(vec![[x0, sy(t)], [x1, sy(t)]], Color::LIGHT, 1.0, false);
        d.text(
            x0 - 6.0,
            sy(t) + 4.0,
            tick_label(t, step(&yt)),
            11.0,
            Anchor::End,
        );
    }
    d.shapes.push(Shape::Rect {
        x: x0,
        y: y1,
        w: x1 - x0,
        h: y0 - y1,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    d.text(
        (x0 + x1) / 2.0,
        height - 18.0,
        x_label,
        13.0,
        Anchor::Middle,
    );
    d.shapes.push(Shape::Text {
        x: 22.0,
        y: (y0 + y1) / 2.0,
        text: y_label.into(),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    // A curve drawn exactly over an earlier one is dashed, so both show (with their markers).
    let mut shown: Vec<Series> = series.to_vec();
    for n in 1..shown.len() {
        if series[..n]
            .iter()
            .any(|earlier| coincide(earlier, &series[n], yr))
        {
            shown[n].dashed = true;
        }
    }
    for s in &shown {
        let points: Vec<[f64; 2]> =
            s.x.iter()
                .zip(&s.y)
                .map(|(&x, &y)| [sx(x), sy(y)])
                .collect();
        if let Some(band) = &s.band {
            for side in [-1.0, 1.0] {
                let edge = s.x.iter().zip(&s.y).zip(band);
                let edge = edge
                    .map(|((&x, &y), b)| [sx(x), sy(y + side * b)])
                    .collect();
                d.curve(edge, s.color, 0.8, false);
            }
        }
        d.curve(points.clone(), s.color, 2.0, s.dashed);
        for p in points {
            d.shapes.extend(marker_shape(s.marker, p, 5.0, s.color));
        }
    }
    place_legend(&mut d, &shown, [x0, y1, x1, y0]);
    Ok(d)
}

/// A ballbar plot: each curve's radial deviation (`y`, mm) drawn around a circle at its angle
/// (`x`, degrees from the plane's first axis towards its second, counter-clockwise), magnified
/// so the band shows; rings mark the scale.
pub fn polar_chart(
    title: &str,
    plane: (&str, &str),
    series: &[Series],
) -> Result<Drawing, PlotError> {
    check_finite(title, series)?;
    let (width, height) = (720.0, 760.0);
    let (lo, hi) = finite_range(banded(series)).ok_or_else(|| PlotError::Empty(title.into()))?;
    // Rings every `step` mm from below the smallest deviation to above the largest (spans in
    // halves, so that none overflows; at most 64 rings).
    let half_span = (hi / 2.0 - lo / 2.0)
        .max(hi.abs().max(lo.abs()) * 0.1)
        .max(5e-7);
    let step = Some(round_step(half_span / 2.0))
        .filter(|s| s.is_normal())
        .unwrap_or(half_span);
    let inner = (lo / step).floor() * step - step;
    let outer = (hi / step).ceil() * step + step;
    let (inner, outer) = if inner.is_finite() && outer.is_finite() {
        (inner, outer)
    } else {
        (lo, hi)
    };
    let (cx, cy) = (width / 2.0, 60.0 + (height - 100.0) / 2.0);
    let (r_in, r_out) = (120.0, (height - 160.0) / 2.0);
    let radius = |dev: f64| r_in + fraction(dev, drawable((inner, outer))) * (r_out - r_in);
    let at = |angle: f64, dev: f64| {
        let (s, c) = angle.to_radians().sin_cos();
        [cx + radius(dev) * c, cy - radius(dev) * s]
    };
    let mut d = Drawing::new(width, height);
    d.title(title);
    let rings = ((outer / 2.0 - inner / 2.0) / step * 2.0)
        .round()
        .clamp(0.0, 64.0) as i64;
    for k in 0..=rings {
        let dev = inner + k as f64 * step;
        if dev.is_nan() || dev > outer {
            break;
        }
        let ring: Vec<[f64; 2]> = (0..=180).map(|a| at(2.0 * a as f64, dev)).collect();
        let nominal = dev.abs() < 1e-9 * step;
        d.line(
            ring,
            if nominal { Color::GREY } else { Color::LIGHT },
            if nominal { 1.5 } else { 1.0 },
            false,
        );
        let label = at(84.0, dev);
        d.text(
            label[0] + 2.0,
            label[1] - 3.0,
            format!("{} µm", tick_label(dev * 1000.0, step * 1000.0)),
            10.0,
            Anchor::Start,
        );
    }
    for a in (0..360).step_by(30) {
        let (p, q) = (at(a as f64, inner), at(a as f64, outer));
        d.line(vec![p, q], Color::LIGHT, 1.0, false);
    }
    let (first, second) = plane;
    let end = at(0.0, outer);
    d.text(
        end[0] + 8.0,
        end[1] + 4.0,
        format!("+{first}"),
        13.0,
        Anchor::Start,
    );
    let top = at(90.0, outer);
    d.text(
        top[0],
        top[1] - 14.0,
        format!("+{second}"),
        13.0,
        Anchor::Middle,
    );
    for s in series {
        let full_turn =
            s.x.first()
                .zip(s.x.last())
                .is_some_and(|(a, b)| (b - a).abs() >= 300.0);
        // The curve through `r(a)` at each angle, closed where it goes all the way round.
        let around = |r: &dyn Fn(usize) -> f64| {
            let mut points: Vec<[f64; 2]> =
                s.x.iter().enumerate().map(|(n, &a)| at(a, r(n))).collect();
            if full_turn && !points.is_empty() {
                points.push(points[0]);
            }
            points
        };
        if let Some(band) = &s.band {
            for side in [-1.0, 1.0] {
                let edge = around(&|n| s.y[n] + side * band.get(n).copied().unwrap_or(0.0));
                d.curve(edge, s.color, 0.8, false);
            }
        }
        d.curve(around(&|n| s.y[n]), s.color, 2.0, s.dashed);
    }
    d.text(
        width / 2.0,
        height - 46.0,
        format!(
            "radial deviation, rings every {} µm (grey: the nominal circle)",
            tick_label(step * 1000.0, step * 1000.0)
        ),
        12.0,
        Anchor::Middle,
    );
    // Top left, clear of the rings and of the caption below them.
    legend(&mut d, series, 16.0, 62.0);
    Ok(d)
}
