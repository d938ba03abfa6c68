//! Every chart of any finite values is a drawing of finite coordinates with short labels, and a
//! chart of a value that is not a number is refused: the ranges of f64 from subnormal to the
//! largest, degenerate ranges, huge spans.

use volmap::plot::{self, Bar, Color, Drawing, Marker, PlotError, Series, Shape};

/// Value sets from the edges of f64.
fn extremes() -> Vec<Vec<f64>> {
    vec![
        vec![0.0, 5e-324, 1e-323],
        vec![0.0, 0.0, 0.0],
        vec![-f64::MAX, 0.0, f64::MAX],
        vec![1e300, 1e300 * (1.0 + 1e-15), 1e300],
        vec![-1e-310, 2e-310, 1e-309],
        vec![1e15, 1e15 + 0.125, 1e15 + 0.25],
        vec![-3.0, 7.5, 1e-9],
    ]
}

/// The drawing's coordinates all finite and inside a band around its canvas, its numeric labels
/// short, and its SVG free of NaN.
fn assert_drawable(d: &Drawing, what: &str) {
    d.check_finite().unwrap_or_else(|e| panic!("{what}: {e}"));
    let inside = |x: f64, y: f64| x.abs() <= 10.0 * d.width && y.abs() <= 10.0 * d.height;
    assert!(!d.shapes.is_empty(), "{what}");
    for shape in &d.shapes {
        match shape {
            Shape::Polyline { points, .. } => {
                assert!(
                    points.iter().all(|p| inside(p[0], p[1])),
                    "{what}: {points:?}"
                )
            }
            Shape::Rect { x, y, w, h, .. } | Shape::Image { x, y, w, h, .. } => {
                assert!(inside(*x, *y) && inside(*w, *h), "{what}: {x} {y} {w} {h}")
            }
            Shape::Text { x, y, text, .. } => {
                assert!(inside(*x, *y), "{what}: `{text}` at {x} {y}");
                if text.parse::<f64>().is_ok() {
                    assert!(text.chars().count() <= 16, "{what}: label `{text}`");
                }
            }
        }
    }
    let svg = d.svg().unwrap();
    assert!(!svg.contains("NaN"), "{what}");
}

fn series(x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        name: "s".into(),
        x,
        y,
        color: Color::BLUE,
        dashed: false,
        marker: Marker::Up,
        band: None,
    }
}

#[test]
fn charts_of_any_finite_values_are_drawn_finite() {
    for xs in extremes() {
        for ys in extremes() {
            let what = format!("{xs:?} / {ys:?}");
            let s = [series(xs.clone(), ys.clone())];
            assert_drawable(&plot::line_chart("t", "x", "y", &s).unwrap(), &what);
            let angles = vec![0.0, 120.0, 240.0];
            let polar = [series(angles, ys.clone())];
            assert_drawable(&plot::polar_chart("t", ("X", "Y"), &polar).unwrap(), &what);
            let histogram = plot::histogram("t", "x", &ys, 20, Some((xs[1], "spec"))).unwrap();
            assert_drawable(&histogram, &what);
            let (lo, hi) = (xs[0].min(xs[2]), xs[0].max(xs[2]));
            for signed in [false, true] {
                let bar = plot::ColourBar {
                    label: "mm",
                    signed,
                };
                let map = plot::colour_map("t", ("x", "y"), (lo, hi, ys[0], ys[2]), 3, 1, &ys, bar)
                    .unwrap();
                assert_drawable(&map, &what);
            }
        }
        let bars: Vec<Bar> = xs
            .iter()
            .map(|&value| Bar {
                label: "b".into(),
                value,
                note: String::new(),
            })
            .collect();
        let what = format!("bars {xs:?}");
        assert_drawable(
            &plot::bar_chart("t", "x", &bars, Some((xs[2], "total"))).unwrap(),
            &what,
        );
    }
}

#[test]
fn a_deformed_grid_of_huge_finite_coordinates_is_drawn_finite() {
    for scale in [1e-300, 1.0, 1e300, f64::MAX / 4.0] {
        let nominal = vec![vec![[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0]]];
        let deformed = vec![vec![[0.0, 0.0, 0.0], [1000.0 + scale, -scale, scale]]];
        let d = plot::deformed_grid("t", "n", &nominal, &deformed).unwrap();
        assert_drawable(&d, &format!("{scale}"));
    }
}

#[test]
fn charts_of_values_that_are_not_numbers_are_refused() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let s = [series(vec![0.0, 1.0], vec![0.0, bad])];
        let refused = |r: Result<Drawing, PlotError>| matches!(r, Err(PlotError::NotFinite(_)));
        assert!(refused(plot::line_chart("t", "x", "y", &s)));
        assert!(refused(plot::polar_chart("t", ("X", "Y"), &s)));
        assert!(refused(plot::histogram("t", "x", &[0.0, bad], 10, None)));
        let bars = [Bar {
            label: "b".into(),
            value: bad,
            note: String::new(),
        }];
        assert!(refused(plot::bar_chart("t", "x", &bars, None)));
        assert!(refused(plot::colour_map(
            "t",
            ("x", "y"),
            (0.0, 1.0, 0.0, 1.0),
            2,
            1,
            &[0.0, bad],
            plot::ColourBar {
                label: "mm",
                signed: true,
            }
        )));
        let grid = vec![vec![[0.0, 0.0, 0.0], [bad, 0.0, 0.0]]];
        assert!(refused(plot::deformed_grid("t", "n", &grid, &grid)));
    }
}
