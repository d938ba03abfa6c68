//! Bar charts: an error budget as horizontal bars, one per term, and the histogram of a statistic
//! over sampled machines with a specification marked; drawings stacked one above the other.

use super::axis::{fraction, is_wide, tick_label, ticks};
use super::{Anchor, Color, Drawing, PlotError, Shape};

/// One bar: its label on the left, its length, and a note written after it.
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub note: String,
}

const WIDTH: f64 = 900.0;
const ROW: f64 = 24.0;

/// Horizontal bars from zero, largest scale at the longest bar, labels on the left and each
/// bar's note at its end; a dashed line may mark a value (a total).
pub fn bar_chart(
    title: &str,
    x_label: &str,
    bars: &[Bar],
    marker: Option<(f64, &str)>,
) -> Result<Drawing, PlotError> {
    if bars.is_empty() {
        return Err(PlotError::Empty(title.into()));
    }
    let values = bars.iter().map(|b| b.value).chain(marker.map(|m| m.0));
    if let Some(bar) = bars.iter().find(|b| !b.value.is_finite()) {
        return Err(PlotError::NotFinite(format!("{title}: `{}`", bar.label)));
    }
    if marker.is_some_and(|m| !m.0.is_finite()) {
        return Err(PlotError::NotFinite(title.into()));
    }
    let longest = values.fold(0.0f64, f64::max);
    let label_width = bars
        .iter()
        .map(|b| super::text_width(&b.label, 12.0))
        .fold(80.0f64, f64::max)
        + 16.0;
    let (x0, x1) = (label_width, WIDTH - 190.0);
    let y1 = 56.0;
    let y0 = y1 + ROW * bars.len() as f64 + 8.0;
    let height = y0 + 64.0;
    let top = if longest > 0.0 { longest } else { 1.0 };
    let xt = ticks(0.0, top, 6);
    let scale_end = xt.last().copied().filter(|&t| t >= top).unwrap_or(top);
    let step = if xt.len() > 1 { xt[1] - xt[0] } else { top };
    let sx = |v: f64| x0 + v / scale_end * (x1 - x0);
    let mut d = Drawing::new(WIDTH, height);
    d.title(title);
    for &t in &xt {
        d.line(vec![[sx(t), y0], [sx(t), y1]], Color::LIGHT, 1.0, false);
        d.text(sx(t), y0 + 16.0, tick_label(t, step), 11.0, Anchor::Middle);
    }
    for (n, bar) in bars.iter().enumerate() {
        let y = y1 + 8.0 + ROW * n as f64;
        d.text(x0 - 8.0, y + 13.0, bar.label.clone(), 12.0, Anchor::End);
        let w = (sx(bar.value.max(0.0)) - x0).max(1.0);
        d.shapes.push(Shape::Rect {
            x: x0,
            y,
            w,
            h: ROW - 8.0,
            fill: Some(Color::BLUE),
            stroke: None,
        });
        d.text(
            x0 + w + 6.0,
            y + 13.0,
            bar.note.clone(),
            11.0,
            Anchor::Start,
        );
    }
    if let Some((value, label)) = marker {
        d.line(
            vec![[sx(value), y0], [sx(value), y1 - 6.0]],
            Color::RED,
            1.5,
            true,
        );
        d.text(sx(value), y1 - 10.0, label, 11.0, Anchor::Middle);
    }
    d.line(vec![[x0, y0], [x0, y1]], Color::BLACK, 1.0, false);
    d.line(vec![[x0, y0], [x1, y0]], Color::BLACK, 1.0, false);
    d.text((x0 + x1) / 2.0, y0 + 40.0, x_label, 13.0, Anchor::Middle);
    Ok(d)
}

/// The histogram of `values` in about `bins` round bins, with a dashed line at `marker` (a
/// specification) and the count on the vertical axis.
pub fn histogram(
    title: &str,
    x_label: &str,
    values: &[f64],
    bins: usize,
    marker: Option<(f64, &str)>,
) -> Result<Drawing, PlotError> {
    if values
        .iter()
        .chain(marker.as_ref().map(|m| &m.0))
        .any(|v| !v.is_finite())
    {
        return Err(PlotError::NotFinite(title.into()));
    }
    let finite = values.to_vec();
    let (lo, hi) = finite
        .iter()
        .chain(marker.as_ref().map(|m| &m.0))
        .fold(None, |acc: Option<(f64, f64)>, &v| match acc {
            None => Some((v, v)),
            Some((a, b)) => Some((a.min(v), b.max(v))),
        })
        .ok_or_else(|| PlotError::Empty(title.into()))?;
    let bins = bins.max(1);
    let span = if is_wide((lo, hi)) {
        hi - lo
    } else {
        lo.abs().max(1e-6)
    };
    // Bins of a round width, starting at a multiple of it (a span beyond f64: in halves).
    let width = ticks(0.0, span, bins)
        .get(1)
        .copied()
        .unwrap_or(span / bins as f64);
    let width = if width.is_normal() {
        width
    } else {
        hi / bins as f64 - lo / bins as f64
    };
    let start = (lo / width).floor() * width;
    let count = ((hi / 2.0 - start / 2.0) / width * 2.0)
        .floor()
        .clamp(0.0, 4.0 * bins as f64 + 4.0) as usize
        + 1;
    // Bin edges in halves, so that none overflows; round bins that would end beyond f64 give
    // way to `bins` bins from the smallest value to the largest.
    let half_end = |start: f64, width: f64, count: usize| start / 2.0 + width / 2.0 * count as f64;
    let (start, width, count) =
        if start.is_finite() && half_end(start, width, count).abs() <= f64::MAX / 2.0 {
            (start, width, count)
        } else {
            (lo, hi / bins as f64 - lo / bins as f64, bins)
        };
    let edge = |b: usize| (half_end(start, width, b) * 2.0).clamp(-f64::MAX, f64::MAX);
    let mut counts = vec![0usize; count];
    for v in &finite {
        let b = (((v - start) / width).floor() as usize).min(count - 1);
        counts[b] += 1;
    }
    let most = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    let (height, left, right, top, bottom) = (480.0, 80.0, 30.0, 50.0, 60.0);
    let (x0, x1) = (left, WIDTH - right);
    let (y0, y1) = (height - bottom, top);
    let end = edge(count);
    let sx = |v: f64| x0 + fraction(v, (start, end)) * (x1 - x0);
    // Headroom above the tallest bin, for the marker's label.
    let y_top = most * 1.1;
    let yt = ticks(0.0, y_top, 5);
    let sy = |c: f64| y0 - c / y_top * (y0 - y1);
    let mut d = Drawing::new(WIDTH, height);
    d.title(title);
    for &t in &yt {
        d.line(vec![[x0, sy(t)], [x1, sy(t)]], Color::LIGHT, 1.0, false);
        d.text(x0 - 6.0, sy(t) + 4.0, tick_label(t, 1.0), 11.0, Anchor::End);
    }
    for (b, &c) in counts.iter().enumerate() {
        let (left_edge, right_edge) = (edge(b), edge(b + 1));
        d.shapes.push(Shape::Rect {
            x: sx(left_edge),
            y: sy(c as f64),
            w: sx(right_edge) - sx(left_edge),
            h: y0 - sy(c as f64),
            fill: Some(Color::BLUE),
            stroke: Some(Color(255, 255, 255)),
        });
    }
    let xt = ticks(start, end, 8);
    let step = if xt.len() > 1 { xt[1] - xt[0] } else { width };
    for &t in &xt {
        d.line(
            vec![[sx(t), y0], [sx(t), y0 + 4.0]],
            Color::BLACK,
            1.0,
            false,
        );
        d.text(sx(t), y0 + 18.0, tick_label(t, step), 11.0, Anchor::Middle);
    }
    if let Some((value, label)) = marker {
        d.line(
            vec![[sx(value), y0], [sx(value), y1]],
            Color::RED,
            1.5,
            true,
        );
        // Right of the line, or left of it where the label would leave the picture.
        let x = sx(value);
        if x + 4.0 + super::text_width(label, 11.0) <= WIDTH - 4.0 {
            d.text(x + 4.0, y1 + 14.0, label, 11.0, Anchor::Start);
        } else {
            d.text(x - 4.0, y1 + 14.0, label, 11.0, Anchor::End);
        }
    }
    d.line(vec![[x0, y0], [x1, y0]], Color::BLACK, 1.0, false);
    d.line(vec![[x0, y0], [x0, y1]], Color::BLACK, 1.0, false);
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
        text: "machines".into(),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    Ok(d)
}

/// The drawings one above the other, as wide as the widest.
pub fn stacked(drawings: Vec<Drawing>) -> Drawing {
    let width = drawings.iter().map(|d| d.width).fold(0.0, f64::max);
    let mut out = Drawing::new(width, 0.0);
    for d in drawings {
        let (dy, first) = (out.height, out.shapes.len());
        out.curves.extend(d.curves.iter().map(|n| n + first));
        out.legends
            .extend(d.legends.iter().map(|&[l, t, r, b]| [l, t + dy, r, b + dy]));
        out.shapes
            .extend(d.shapes.into_iter().map(|s| shifted(s, dy)));
        out.height += d.height;
    }
    out
}

fn shifted(mut shape: Shape, dy: f64) -> Shape {
    match &mut shape {
        Shape::Polyline { points, .. } => points.iter_mut().for_each(|p| p[1] += dy),
        Shape::Rect { y, .. } | Shape::Text { y, .. } | Shape::Image { y, .. } => *y += dy,
    }
    shape
}
