//! Plots as a person looks at them: titles inside the picture, the legend clear of the caption,
//! the deformed grid's axes named and its pose given, a curve over another still seen, the
//! targets and the ±2s bands of a positioning test.

use volmap::plot::{self, Anchor, Color, Drawing, Marker, Series, Shape};

use super::cli::volmap;

/// The box `[left, top, right, bottom]` a text takes (its advance width, one size high).
fn text_box(shape: &Shape) -> Option<(String, [f64; 4])> {
    let Shape::Text {
        x,
        y,
        text,
        size,
        anchor,
        vertical: false,
        ..
    } = shape
    else {
        return None;
    };
    let w = plot::text_width(text, *size);
    let left = match anchor {
        Anchor::Start => *x,
        Anchor::Middle => x - w / 2.0,
        Anchor::End => x - w,
    };
    Some((text.clone(), [left, y - size, left + w, y + 0.25 * size]))
}

fn texts(d: &Drawing) -> Vec<(String, [f64; 4])> {
    d.shapes.iter().filter_map(text_box).collect()
}

fn overlap(a: [f64; 4], b: [f64; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

fn curve(name: &str, y: Vec<f64>, color: Color, dashed: bool, marker: Marker) -> Series {
    Series {
        name: name.into(),
        x: (0..y.len()).map(|i| i as f64 * 250.0).collect(),
        y,
        color,
        dashed,
        marker,
        band: None,
    }
}

const LONG_TITLE: &str =
    "ISO 230-4 circular test in XY, counter-clockwise: centre (500.0, 300.0, 250.0) mm, radius 100 mm";

#[test]
fn titles_fit_inside_the_picture() {
    let angles: Vec<f64> = (0..72).map(|i| 5.0 * i as f64).collect();
    let ring = Series {
        x: angles.clone(),
        ..curve(
            "radial deviation",
            angles.iter().map(|a| 0.01 * a.to_radians().sin()).collect(),
            Color::BLUE,
            false,
            Marker::None,
        )
    };
    let polar = plot::polar_chart(LONG_TITLE, ("X", "Y"), &[ring]).unwrap();
    let line = plot::line_chart(
        &LONG_TITLE.repeat(2),
        "x",
        "y",
        &[curve("c", vec![0.0, 1.0], Color::BLUE, false, Marker::None)],
    )
    .unwrap();
    for d in [polar, line] {
        let (title, [left, _, right, _]) = texts(&d)
            .into_iter()
            .find(|(t, _)| t.starts_with(LONG_TITLE))
            .unwrap();
        assert!(
            left >= 0.0 && right <= d.width,
            "{title}: {left} to {right} of {}",
            d.width
        );
    }
    // A short title keeps its size.
    let short = plot::line_chart(
        "short",
        "x",
        "y",
        &[curve("c", vec![0.0, 1.0], Color::BLUE, false, Marker::None)],
    )
    .unwrap();
    assert!(short
        .shapes
        .iter()
        .any(|s| matches!(s, Shape::Text { text, size, .. } if text == "short" && *size == 15.0)));
}

#[test]
fn the_polar_legend_leaves_the_ring_caption_clear() {
    let angles: Vec<f64> = (0..72).map(|i| 5.0 * i as f64).collect();
    let make = |name: &str, amplitude: f64, color, dashed| Series {
        x: angles.clone(),
        ..curve(
            name,
            angles
                .iter()
                .map(|a| amplitude * (2.0 * a.to_radians()).sin())
                .collect(),
            color,
            dashed,
            Marker::None,
        )
    };
    let d = plot::polar_chart(
        "XY",
        ("X", "Y"),
        &[
            make("radial deviation, predicted", 0.01, Color::BLUE, false),
            make("radial deviation, measured", 0.02, Color::RED, true),
        ],
    )
    .unwrap();
    let all = texts(&d);
    let caption = all
        .iter()
        .find(|(t, _)| t.contains("rings every"))
        .unwrap()
        .1;
    let legend: Vec<[f64; 4]> = all
        .iter()
        .filter(|(t, _)| t.starts_with("radial deviation,") && !t.contains("rings"))
        .map(|(_, b)| *b)
        .collect();
    assert_eq!(legend.len(), 2);
    for row in legend {
        assert!(!overlap(row, caption), "{row:?} over {caption:?}");
        assert!(row[0] >= 0.0 && row[2] <= d.width);
    }
}

#[test]
fn a_curve_drawn_over_another_is_dashed_and_marks_its_targets_its_way() {
    let y = vec![0.0, 3.5, 7.0, 10.5, 14.0];
    let d = plot::line_chart(
        "positioning",
        "target X (mm)",
        "error (µm)",
        &[
            curve("↑", y.clone(), Color::BLUE, false, Marker::Up),
            curve("↓", y, Color::ORANGE, false, Marker::Down),
        ],
    )
    .unwrap();
    let curves: Vec<(Color, bool)> = d
        .shapes
        .iter()
        .filter_map(|s| match s {
            Shape::Polyline {
                points,
                color,
                dashed,
                closed: false,
                ..
            } if points.len() == 5 => Some((*color, *dashed)),
            _ => None,
        })
        .collect();
    assert_eq!(curves, [(Color::BLUE, false), (Color::ORANGE, true)]);
    // A triangle at every target: ↑ with its tip above its base, ↓ below, in the chart and
    // once each in the legend.
    let triangles = |color: Color| -> Vec<f64> {
        d.shapes
            .iter()
            .filter_map(|s| match s {
                Shape::Polyline {
                    points,
                    color: c,
                    closed: true,
                    ..
                } if *c == color => Some(points[0][1] - points[1][1]),
                _ => None,
            })
            .collect()
    };
    let (up, down) = (triangles(Color::BLUE), triangles(Color::ORANGE));
    assert_eq!((up.len(), down.len()), (6, 6));
    assert!(up.iter().all(|&tip| tip < 0.0) && down.iter().all(|&tip| tip > 0.0));
}

#[test]
fn a_band_is_drawn_at_two_s_either_side() {
    let mut measured = curve(
        "measured",
        vec![1.0, 2.0, 1.0],
        Color::RED,
        true,
        Marker::Up,
    );
    measured.band = Some(vec![0.5, 1.0, 0.25]);
    let d = plot::line_chart("band", "x", "y", &[measured]).unwrap();
    let lines: Vec<&Vec<[f64; 2]>> = d
        .shapes
        .iter()
        .filter_map(|s| match s {
            Shape::Polyline {
                points,
                color: Color::RED,
                closed: false,
                ..
            } if points.len() == 3 => Some(points),
            _ => None,
        })
        .collect();
    assert_eq!(lines.len(), 3);
    let (lower, upper, middle) = (lines[0], lines[1], lines[2]);
    for i in 0..3 {
        let below = lower[i][1] - middle[i][1];
        let above = middle[i][1] - upper[i][1];
        assert!(
            below > 0.0 && (below - above).abs() < 1e-9,
            "{i}: {below} {above}"
        );
    }
    // The half-widths keep their proportions: 0.5, 1.0, 0.25.
    let half = |i: usize| lower[i][1] - middle[i][1];
    assert!((half(1) / half(0) - 2.0).abs() < 1e-9 && (half(2) / half(0) - 0.5).abs() < 1e-9);
}

#[test]
fn the_deformed_grid_names_its_axes_and_its_pose() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("g.svg");
    volmap()
        .args([
            "plot",
            "grid",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "3x3x3",
            "--pose",
            "B=30",
        ])
        .arg("--out")
        .arg(&svg)
        .assert()
        .success();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.contains("(Hwang et al. 2014) at B=30,C=0: the workspace"),
        "{text}"
    );
    for axis in ["X", "Y", "Z"] {
        assert!(text.contains(&format!(">{axis} 0 to ")), "no {axis} label");
    }
}

#[test]
fn positioning_plots_mark_targets_and_the_measured_bands() {
    let dir = tempfile::tempdir().unwrap();
    let measured = dir.path().join("x.csv");
    let mut csv = String::from("target_mm,direction,run,deviation_mm\n");
    for run in 0..3 {
        for t in [0, 500, 1000] {
            csv += &format!("{t},+,{run},{}\n", 0.001 * run as f64);
        }
        for t in [1000, 500, 0] {
            csv += &format!("{t},-,{run},{}\n", -0.002 - 0.001 * run as f64);
        }
    }
    std::fs::write(&measured, csv).unwrap();
    let svg = dir.path().join("p.svg");
    volmap()
        .args([
            "test",
            "positioning",
            "--machine",
            "vmc-li2015",
            "--axis",
            "X",
            "--targets",
            "3",
            "--measured",
        ])
        .arg(&measured)
        .arg("--plot")
        .arg(&svg)
        .assert()
        .success();
    let text = std::fs::read_to_string(&svg).unwrap();
    // A triangle at each of 3 targets on 4 curves, and one in each of 4 legend rows.
    assert_eq!(text.matches("<polygon").count(), 16);
    assert_eq!(text.matches("(thin: ±2s)").count(), 2);
    // s over runs 0, 1, 2 µm is 1 µm: the bands lie 2 µm either side of each measured mean.
    assert_eq!(text.matches(r#"stroke-width="0.8""#).count(), 4);
}
