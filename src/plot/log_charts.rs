//! Curves over decades: the y axis in log10 (and the x axis too where asked), ticks at 1, 2 and
//! 5 × 10ⁿ (decades only over more than three), the legend in a corner no curve passes through
//! (below the chart where each has one). For quantities that fall by orders of magnitude (a
//! residual against a table's size).

use super::axis::{finite_range, tick_label, ticks};
use super::charts::{
    marker_shape, place_legend, Series, MARGIN_BOTTOM, MARGIN_LEFT, MARGIN_RIGHT, MARGIN_TOP,
};
use super::{Anchor, Color, Drawing, PlotError, Shape};

/// Ticks of a log10 axis over `[lo, hi]` (log10 values): `(log10 v, v)`.
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let mantissas: &[f64] = if hi - lo > 3.0 {
        &[1.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    let mut out = Vec::new();
    for k in (lo.floor() as i32)..=(hi.ceil() as i32) {
        for m in mantissas {
            let v = m * 10f64.powi(k);
            let at = v.log10();
            if at >= lo - 1e-12 && at <= hi + 1e-12 {
                out.push((at, v));
            }
        }
    }
    out
}

/// A tick value of a log axis in plain decimals: `0.005`, `20`.
fn log_label(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else {
        let decimals = (-v.log10()).ceil().max(0.0) as usize;
        format!("{v:.decimals$}")
    }
}

/// `[lo, hi]` widened by 5 % each side (half a decade about a single value).
fn widened((lo, hi): (f64, f64)) -> (f64, f64) {
    if hi - lo > 1e-12 {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        (lo - 0.5, hi + 0.5)
    }
}

/// Curves with a log10 y axis (and a log10 x axis with `log_x`); points that a log axis cannot
/// show (zero or negative) are left out.
pub fn log_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_x: bool,
) -> Result<Drawing, PlotError> {
    let (width, height) = (900.0, 540.0);
    let tx = |x: f64| if log_x { x.log10() } else { x };
    let shown: Vec<Vec<[f64; 2]>> = series
        .iter()
        .map(|s| {
            s.x.iter()
                .zip(&s.y)
                .filter(|(&x, &y)| y > 0.0 && (!log_x || x > 0.0))
                .map(|(&x, &y)| [tx(x), y.log10()])
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .collect()
        })
        .collect();
    let empty = || PlotError::Empty(title.into());
    let xr = finite_range(shown.iter().flatten().map(|p| p[0])).ok_or_else(empty)?;
    let yr = widened(finite_range(shown.iter().flatten().map(|p| p[1])).ok_or_else(empty)?);
    let xr = if xr.1 > xr.0 { xr } else { widened(xr) };
    let (x0, x1) = (MARGIN_LEFT, width - MARGIN_RIGHT);
    let (y0, y1) = (height - MARGIN_BOTTOM, MARGIN_TOP);
    let sx = |x: f64| x0 + (x - xr.0) / (xr.1 - xr.0) * (x1 - x0);
    let sy = |y: f64| y0 + (y - yr.0) / (yr.1 - yr.0) * (y1 - y0);
    let mut d = Drawing::new(width, height);
    d.title(title);
    let x_ticks: Vec<(f64, String)> = if log_x {
        log_ticks(xr.0, xr.1)
            .into_iter()
            .map(|(at, v)| (at, log_label(v)))
            .collect()
    } else {
        let t = ticks(xr.0, xr.1, 8);
        let step = if t.len() > 1 { t[1] - t[0] } else { 1.0 };
        t.iter().map(|&v| (v, tick_label(v, step))).collect()
    };
    for (at, label) in x_ticks {
        d.line(vec![[sx(at), y0], [sx(at), y1]], Color::LIGHT, 1.0, false);
        d.text(sx(at), y0 + 18.0, label, 11.0, Anchor::Middle);
    }
    for (at, v) in log_ticks(yr.0, yr.1) {
        d.line(vec![[x0, sy(at)], [x1, sy(at)]], Color::LIGHT, 1.0, false);
        d.text(x0 - 6.0, sy(at) + 4.0, log_label(v), 11.0, Anchor::End);
    }
    d.shapes.push(Shape::Rect {
        x: x0,
        y: y1,
        w: x1 - x0,
        h: y0 - y1,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    let x_words = if log_x {
        format!("{x_label} (log scale)")
    } else {
        x_label.to_string()
    };
    d.text(
        (x0 + x1) / 2.0,
        height - 18.0,
        x_words,
        13.0,
        Anchor::Middle,
    );
    d.shapes.push(Shape::Text {
        x: 22.0,
        y: (y0 + y1) / 2.0,
        text: format!("{y_label} (log scale)"),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    let pixels: Vec<Vec<[f64; 2]>> = shown
        .iter()
        .map(|points| points.iter().map(|p| [sx(p[0]), sy(p[1])]).collect())
        .collect();
    for (s, points) in series.iter().zip(&pixels) {
        d.curve(points.clone(), s.color, 2.0, s.dashed);
        for &p in points {
            d.shapes.extend(marker_shape(s.marker, p, 5.0, s.color));
        }
    }
    place_legend(&mut d, series, [x0, y1, x1, y0]);
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_are_one_two_five_or_decades() {
        let t: Vec<f64> = log_ticks(2f64.log10(), 256f64.log10())
            .iter()
            .map(|t| t.1)
            .collect();
        assert_eq!(t, [2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0]);
        let t: Vec<f64> = log_ticks(-3.2, 1.9).iter().map(|t| t.1).collect();
        assert_eq!(t, [0.001, 0.01, 0.1, 1.0, 10.0]);
        assert_eq!(log_label(0.005), "0.005");
        assert_eq!(log_label(20.0), "20");
    }
}
