//! Plots: what the drawings hold, SVG that parses, PNG that decodes with the curves and text in
//! it, field slices that hold the field's values, and the deformed grid's geometry.

use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::model::grid::Grid;
use volmap::plot::{self, Color, Marker, Series, Shape};

fn series() -> Vec<Series> {
    let x: Vec<f64> = (0..50).map(|i| i as f64 * 10.0).collect();
    vec![
        Series {
            name: "predicted".into(),
            y: x.iter().map(|x| (x / 80.0).sin() * 5.0).collect(),
            x: x.clone(),
            color: Color::BLUE,
            dashed: false,
            marker: Marker::None,
            band: None,
        },
        Series {
            name: "measured".into(),
            y: x.iter().map(|x| (x / 80.0).sin() * 5.0 + 0.4).collect(),
            x,
            color: Color::RED,
            dashed: true,
            marker: Marker::None,
            band: None,
        },
    ]
}

#[test]
fn ticks_are_round_and_cover_the_range() {
    assert_eq!(
        plot::ticks(0.0, 10.0, 5),
        vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    );
    assert_eq!(plot::ticks(-0.013, 0.021, 4), vec![-0.01, 0.0, 0.01, 0.02]);
    let t = plot::ticks(3.7, 1268.9, 8);
    assert_eq!((t[0], t[1] - t[0]), (200.0, 200.0));
    assert!(*t.last().unwrap() <= 1268.9);
}

fn pixels(png: &[u8]) -> tiny_skia::Pixmap {
    tiny_skia::Pixmap::decode_png(png).unwrap()
}

fn count_colour(p: &tiny_skia::Pixmap, c: Color) -> usize {
    p.pixels()
        .iter()
        .filter(|px| {
            let u = px.demultiply();
            (u.red() as i32 - c.0 as i32).abs() < 20
                && (u.green() as i32 - c.1 as i32).abs() < 20
                && (u.blue() as i32 - c.2 as i32).abs() < 20
        })
        .count()
}

#[test]
fn a_line_chart_draws_both_curves_and_its_text_in_svg_and_png() {
    let drawing =
        plot::line_chart("Diagonal PPP", "position (mm)", "error (µm)", &series()).unwrap();
    let svg = drawing.svg().unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in [
        "Diagonal PPP",
        "position (mm)",
        "error (µm)",
        "predicted",
        "measured",
        "stroke-dasharray",
    ] {
        assert!(svg.contains(text), "{text}");
    }
    assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
    let png = pixels(&drawing.png().unwrap());
    assert_eq!(
        (png.width(), png.height()),
        (drawing.width as u32, drawing.height as u32)
    );
    assert!(count_colour(&png, Color::BLUE) > 300, "the predicted curve");
    assert!(
        count_colour(&png, Color::RED) > 150,
        "the measured curve, dashed"
    );
    // Text is drawn: dark pixels in the title's band, none in an empty corner.
    let dark_in = |x0: u32, x1: u32, y0: u32, y1: u32| {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| png.pixel(x, y).unwrap().demultiply().red() < 80)
            .count()
    };
    assert!(dark_in(350, 550, 12, 34) > 50);
    assert_eq!(dark_in(0, 40, 0, 30), 0);
}

#[test]
fn a_polar_chart_marks_its_scale() {
    let angles: Vec<f64> = (0..72).map(|i| 5.0 * i as f64).collect();
    let circle = Series {
        name: "radial deviation".into(),
        y: angles
            .iter()
            .map(|t| 0.004 * (2.0 * t.to_radians()).sin())
            .collect(),
        x: angles,
        color: Color::BLUE,
        dashed: false,
        marker: Marker::None,
        band: None,
    };
    let drawing = plot::polar_chart("XY circle", ("X", "Y"), &[circle]).unwrap();
    let svg = drawing.svg().unwrap();
    assert!(svg.contains("+X") && svg.contains("+Y"));
    assert!(svg.contains("rings every 2 µm"), "{svg}");
    assert!(svg.contains(">0 µm<") && svg.contains(">4 µm<") && svg.contains(">-4 µm<"));
    let closed = drawing.shapes.iter().any(|s| match s {
        Shape::Polyline { points, color, .. } => {
            *color == Color::BLUE && points.first() == points.last()
        }
        _ => false,
    });
    assert!(closed, "a full turn closes the curve");
}

#[test]
fn a_field_slice_holds_the_field_values() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("vmc-li2015").unwrap();
    let grid = Grid::full_travel(&machine, [7, 5, 4], [0.0; 6]).unwrap();
    let path = dir.path().join("f.exr");
    map::map_to_file(
        &machine,
        &grid,
        &Engine::Cpu,
        &path,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    let field = volmap::io::field::LoadedField::open(&path).unwrap();
    // Column order of LoadedField values: VE.X VE.Y VE.Z OE.X OE.Y OE.Z.
    let value = |i: usize, j: usize, k: usize| field.values()[i + 7 * (j + 5 * k)];
    let z_at = grid.origin_mm[2] + 2.0 * grid.spacing_mm[2];
    let slice = volmap::query::field_slice(&path, "z", Some(z_at + 1.0), "VE").unwrap();
    assert_eq!((slice.cols, slice.rows), (7, 5));
    for j in 0..5 {
        for i in 0..7 {
            let v = value(i, j, 2);
            let magnitude =
                ((v[0] as f64).powi(2) + (v[1] as f64).powi(2) + (v[2] as f64).powi(2)).sqrt();
            assert!((slice.values[j * 7 + i] - magnitude).abs() < 1e-12);
        }
    }
    // The title names the quantity as the colour bar does, whatever case it was asked in.
    let oe = volmap::query::field_slice(&path, "x", None, "oe").unwrap();
    assert!(
        oe.title.contains(": |OE| at X=") && oe.unit.contains("|OE|"),
        "{}",
        oe.title
    );
    let slice = volmap::query::field_slice(&path, "x", None, "oe.y").unwrap();
    assert!(slice.title.contains(": OE.Y at X="), "{}", slice.title);
    assert_eq!((slice.cols, slice.rows), (5, 4));
    assert_eq!(slice.values[3 * 5 + 2], value(3, 2, 3)[4] as f64);
    let error = volmap::query::field_slice(&path, "z", Some(1e6), "VE")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("outside the field's grid along Z"),
        "{error}"
    );
    let error = volmap::query::field_slice(&path, "w", None, "VE")
        .unwrap_err()
        .to_string();
    assert!(error.contains("x, y or z"), "{error}");
    let drawing = plot::colour_map(
        &slice.title,
        ("Y (mm)", "Z (mm)"),
        slice.extent,
        slice.cols,
        slice.rows,
        &slice.values,
        plot::ColourBar {
            label: &slice.unit,
            signed: slice.signed,
        },
    )
    .unwrap();
    assert!(drawing.svg().unwrap().contains("data:image/png;base64,"));
    pixels(&drawing.png().unwrap());
}

#[test]
fn the_deformed_grid_is_the_nominal_grid_plus_the_magnified_error() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let mut pose = [0.0; 6];
    pose[4] = 30.0;
    let grid = Grid::full_travel(&machine, [3, 3, 2], pose).unwrap();
    let deformed = volmap::query::deformed_grid(&machine, &grid, None).unwrap();
    // Lines along X: 3·2, along Y: 2·3, along Z: 3·3.
    assert_eq!(deformed.nominal.len(), 6 + 6 + 9);
    let twin = volmap::reference::Twin::of(&machine);
    let mut largest: f64 = 0.0;
    assert_eq!(deformed.deformed.len(), deformed.nominal.len());
    for (line, moved) in deformed.nominal.iter().zip(&deformed.deformed) {
        assert_eq!(line.len(), moved.len());
        for (p, q) in line.iter().zip(moved) {
            let mut command = pose;
            command[..3].copy_from_slice(p);
            let ve = twin.deviation(&command).volumetric_mm;
            largest = largest.max(ve.norm());
            for d in 0..3 {
                assert!((q[d] - (p[d] + deformed.scale * ve[d])).abs() < 1e-9);
            }
        }
    }
    assert_eq!(deformed.largest_mm, largest);
    let diagonal = (0..3)
        .map(|d| ((grid.dims[d] - 1) as f64 * grid.spacing_mm[d]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!((deformed.scale * largest - 0.08 * diagonal).abs() < 1e-9 * diagonal);
    let drawing =
        plot::deformed_grid("grid", "note", &deformed.nominal, &deformed.deformed).unwrap();
    pixels(&drawing.png().unwrap());
}

#[test]
fn plots_need_a_known_extension() {
    let drawing = plot::line_chart("t", "x", "y", &series()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let error = drawing
        .write(&dir.path().join("plot.jpg"))
        .unwrap_err()
        .to_string();
    assert!(error.contains(".svg or .png"), "{error}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing written"
    );
    assert!(plot::line_chart("t", "x", "y", &[]).is_err());
}
