//! Where a drawing puts things, for checking that a plot reads: the box each text's glyphs take
//! (measured in the embedded font, as PNG draws them), the legends' frames and the curves' lines.
//! [`Layout::problems`] finds text reaching outside the canvas and legends over a curve.

use super::{font, text_width, Anchor, Drawing, Shape};

/// A text and the box its glyphs take, `[left, top, right, bottom]` in pixels (y down).
#[derive(Debug, Clone, PartialEq)]
pub struct TextBox {
    pub text: String,
    pub bounds: [f64; 4],
}

/// A drawing's texts, legends and curves.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub width: f64,
    pub height: f64,
    pub texts: Vec<TextBox>,
    /// Legend frames, `[left, top, right, bottom]`.
    pub legends: Vec<[f64; 4]>,
    /// Each curve's points, in pixels.
    pub curves: Vec<Vec<[f64; 2]>>,
}

/// What makes a plot mislead or hide something.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutProblem {
    #[error("`{text}` reaches outside the {width}×{height} canvas: {bounds:?}")]
    TextOutside {
        text: String,
        bounds: [f64; 4],
        width: f64,
        height: f64,
    },
    #[error("the legend at {legend:?} covers curve {curve} (near {at:?})")]
    LegendOverCurve {
        legend: [f64; 4],
        curve: usize,
        at: [f64; 2],
    },
}

/// The box the glyphs of a text shape take; `None` for other shapes.
fn text_box(shape: &Shape) -> Option<TextBox> {
    let Shape::Text {
        x,
        y,
        text,
        size,
        anchor,
        vertical,
        ..
    } = shape
    else {
        return None;
    };
    let shift = match anchor {
        Anchor::Start => 0.0,
        Anchor::Middle => -text_width(text, *size) / 2.0,
        Anchor::End => -text_width(text, *size),
    };
    // Along the baseline u, above it v: the ink of every glyph, as png.rs places it.
    let (mut u0, mut u1, mut v0, mut v1) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64, 0.0f64);
    let mut pen = shift;
    for c in text.chars() {
        let m = font().metrics(c, *size as f32);
        if m.width > 0 && m.height > 0 {
            u0 = u0.min(pen + m.xmin as f64);
            u1 = u1.max(pen + m.xmin as f64 + m.width as f64);
            v0 = v0.min(m.ymin as f64);
            v1 = v1.max((m.ymin + m.height as i32) as f64);
        }
        pen += m.advance_width as f64;
    }
    if !u0.is_finite() {
        // No ink (spaces): the advance along the baseline.
        (u0, u1) = (shift, pen);
    }
    let bounds = if *vertical {
        // Turned 90° counter-clockwise about (x, y): u runs up, v runs left.
        [x - v1, y - u1, x - v0, y - u0]
    } else {
        [x + u0, y - v1, x + u1, y - v0]
    };
    Some(TextBox {
        text: text.clone(),
        bounds,
    })
}

/// Whether the segment `a`–`b` meets the rectangle `[left, top, right, bottom]` (Liang–Barsky):
/// the point where it does.
fn segment_meets(a: [f64; 2], b: [f64; 2], r: [f64; 4]) -> Option<[f64; 2]> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a[0] - r[0]),
        (dx, r[2] - a[0]),
        (-dy, a[1] - r[1]),
        (dy, r[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then(|| [a[0] + t0 * dx, a[1] + t0 * dy])
}

/// Where any of `curves` passes through `frame`: the curve's index and a point there.
pub(super) fn first_crossing(curves: &[&[[f64; 2]]], frame: [f64; 4]) -> Option<(usize, [f64; 2])> {
    curves.iter().enumerate().find_map(|(n, points)| {
        let hit = match points {
            [] => None,
            [p] => segment_meets(*p, *p, frame),
            _ => points
                .windows(2)
                .find_map(|w| segment_meets(w[0], w[1], frame)),
        };
        hit.map(|at| (n, at))
    })
}

impl Drawing {
    /// The drawing's texts with their boxes, its legends and its curves.
    pub fn layout(&self) -> Layout {
        Layout {
            width: self.width,
            height: self.height,
            texts: self.shapes.iter().filter_map(text_box).collect(),
            legends: self.legends.clone(),
            curves: self.curve_points().into_iter().map(<[_]>::to_vec).collect(),
        }
    }

    /// The points of every curve drawn so far.
    pub(super) fn curve_points(&self) -> Vec<&[[f64; 2]]> {
        self.curves
            .iter()
            .filter_map(|&n| match self.shapes.get(n) {
                Some(Shape::Polyline { points, .. }) => Some(points.as_slice()),
                _ => None,
            })
            .collect()
    }
}

impl Layout {
    /// Every text reaching outside the canvas and every legend a curve passes through.
    pub fn problems(&self) -> Vec<LayoutProblem> {
        let mut out = Vec::new();
        for t in &self.texts {
            let [left, top, right, bottom] = t.bounds;
            if left < 0.0 || top < 0.0 || right > self.width || bottom > self.height {
                out.push(LayoutProblem::TextOutside {
                    text: t.text.clone(),
                    bounds: t.bounds,
                    width: self.width,
                    height: self.height,
                });
            }
        }
        let curves: Vec<&[[f64; 2]]> = self.curves.iter().map(Vec::as_slice).collect();
        for &legend in &self.legends {
            if let Some((curve, at)) = first_crossing(&curves, legend) {
                out.push(LayoutProblem::LegendOverCurve { legend, curve, at });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::Color;

    #[test]
    fn a_label_past_the_edge_and_a_legend_over_a_curve_are_found() {
        let mut d = Drawing::new(200.0, 100.0);
        d.text(100.0, 50.0, "inside", 12.0, Anchor::Middle);
        assert!(d.layout().problems().is_empty());
        // Anchored at its start 20 px from the right edge: its glyphs run past it.
        d.text(180.0, 50.0, "spec 150.00 µm", 11.0, Anchor::Start);
        // Turned up the left edge: its glyphs lie left of x = 5.
        d.shapes.push(Shape::Text {
            x: 5.0,
            y: 50.0,
            text: "count".into(),
            size: 13.0,
            anchor: Anchor::Middle,
            color: Color::BLACK,
            vertical: true,
        });
        d.curve(vec![[0.0, 90.0], [200.0, 10.0]], Color::RED, 2.0, false);
        d.legends.push([10.0, 10.0, 60.0, 30.0]);
        d.legends.push([120.0, 20.0, 190.0, 40.0]);
        let problems = d.layout().problems();
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(
            matches!(&problems[0], LayoutProblem::TextOutside { text, .. } if text.starts_with("spec"))
        );
        assert!(matches!(&problems[1], LayoutProblem::TextOutside { text, .. } if text == "count"));
        assert!(
            matches!(problems[2], LayoutProblem::LegendOverCurve { legend, curve: 0, .. } if legend[0] == 120.0)
        );
    }

    #[test]
    fn text_boxes_hold_the_glyphs() {
        let mut d = Drawing::new(300.0, 100.0);
        d.text(100.0, 50.0, "Tg", 20.0, Anchor::End);
        let [left, top, right, bottom] = d.layout().texts[0].bounds;
        assert!(right <= 100.0 && right > 95.0, "{right}");
        assert!(
            left < right - 15.0 && top < 40.0 && bottom > 50.0,
            "{left} {top} {bottom}"
        );
        assert_eq!(
            segment_meets([0.0, 0.0], [10.0, 0.0], [2.0, -1.0, 3.0, 1.0]),
            Some([2.0, 0.0])
        );
        assert_eq!(
            segment_meets([0.0, 5.0], [10.0, 5.0], [2.0, -1.0, 3.0, 1.0]),
            None
        );
    }
}
