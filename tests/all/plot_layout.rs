//! Plots that do not mislead: every kind of plot, drawn as the commands draw it, keeps its text on
//! the canvas and its legend off its curves (checked on the drawing's layout, and rendered to
//! PNG); the checker finds a label moved off the canvas and a legend moved over a curve. Signed
//! values take a diverging colour scale centred on zero, magnitudes viridis; a colour map's cells
//! are centred on their grid points.

use volmap::plot::{self, Bar, Color, ColourBar, Drawing, LayoutProblem, Marker, Series, Shape};

use super::cli::{s, volmap};

/// The drawing's layout has no problem, and it renders.
fn assert_clear(d: &Drawing, what: &str) {
    let problems = d.layout().problems();
    assert!(problems.is_empty(), "{what}: {problems:#?}");
    d.png().unwrap_or_else(|e| panic!("{what}: {e}"));
}

fn series(name: &str, x: &[f64], y: &[f64], color: Color) -> Series {
    Series {
        name: name.into(),
        x: x.to_vec(),
        y: y.to_vec(),
        color,
        dashed: false,
        marker: Marker::Up,
        band: None,
    }
}

/// A histogram as `budget --samples --spec --plot` draws it, the spec at the right end.
fn budget_histogram() -> Drawing {
    let values: Vec<f64> = (0..300)
        .map(|i| 120.0 + 20.0 * ((i as f64 * 0.37).sin() * 0.5 + 0.5))
        .collect();
    plot::histogram(
        "max |VE| of 300 machines built to the tolerances",
        "max |VE| over the grid, µm",
        &values,
        30,
        Some((150.0, "spec 150.00 µm")),
    )
    .unwrap()
}

/// The export sweep's chart: the largest residual and the RMS falling over decades.
fn sweep_chart(points: &[f64]) -> Drawing {
    let largest: Vec<f64> = points.iter().map(|n| 300.0 / (n - 1.0).powi(2)).collect();
    let rms: Vec<f64> = largest.iter().map(|v| 0.7 * v).collect();
    plot::log_chart(
        "grid-csv residual of 3-axis VMC (Li et al. 2015, Table 3) against table size",
        "points per table",
        "residual (µm)",
        &[
            series("residual, largest", points, &largest, Color::RED),
            series("residual, RMS", points, &rms, Color::BLUE),
        ],
        true,
    )
    .unwrap()
}

#[test]
fn the_checker_finds_a_label_off_the_canvas_and_a_legend_over_a_curve() {
    let mut histogram = budget_histogram();
    assert_clear(&histogram, "histogram");
    // The spec's label moved back to where it was clipped: starting right of the line.
    for shape in &mut histogram.shapes {
        if let Shape::Text {
            x, text, anchor, ..
        } = shape
        {
            if text.starts_with("spec") {
                *x = histogram.width - 40.0;
                *anchor = plot::Anchor::Start;
            }
        }
    }
    let problems = histogram.layout().problems();
    assert!(
        matches!(&problems[..], [LayoutProblem::TextOutside { text, .. }] if text == "spec 150.00 µm"),
        "{problems:?}"
    );
    // The legend moved over the red curve's first segment.
    let mut sweep = sweep_chart(&[2.0, 3.0, 5.0, 9.0, 17.0]);
    assert_clear(&sweep, "sweep");
    let red = sweep.layout().curves[0].clone();
    let [l, t, r, b] = sweep.legends[0];
    let (dx, dy) = (red[0][0] + 20.0 - l, red[0][1] - t);
    sweep.legends[0] = [l + dx, t + dy, r + dx, b + dy];
    let problems = sweep.layout().problems();
    assert!(
        matches!(
            problems[..],
            [LayoutProblem::LegendOverCurve { curve: 0, .. }]
        ),
        "{problems:?}"
    );
}

#[test]
fn every_kind_of_chart_keeps_its_text_inside_and_its_legend_off_its_curves() {
    let x: Vec<f64> = (0..=40).map(|i| i as f64 * 4.0).collect();
    // Curves through the top left, through both top corners, and through every corner.
    let falling: Vec<f64> = x.iter().map(|x| 500.0 - 2.0 * x).collect();
    let valley: Vec<f64> = x.iter().map(|x| (x - 80.0).powi(2) / 10.0).collect();
    let zigzag: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, _)| if i % 2 == 0 { 0.0 } else { 100.0 })
        .collect();
    for (what, y) in [
        ("falling", &falling),
        ("valley", &valley),
        ("zigzag", &zigzag),
    ] {
        let d = plot::line_chart(
            &format!("Tool-tip deviation along a program, {what}"),
            "distance along the path (mm)",
            "deviation (µm)",
            &[
                series("as programmed", &x, y, Color::RED),
                series("compensated", &x, &vec![1.0; x.len()], Color::BLUE),
            ],
        )
        .unwrap();
        assert_clear(&d, what);
        assert_eq!(d.legends.len(), 1, "{what}");
    }
    let angles: Vec<f64> = (0..72).map(|i| 5.0 * i as f64).collect();
    let ring = |amplitude: f64| -> Vec<f64> {
        angles
            .iter()
            .map(|a| amplitude * (2.0 * a.to_radians()).sin())
            .collect()
    };
    let polar = plot::polar_chart(
        "ISO 230-4 circular test in XY, counter-clockwise: centre (500.0, 300.0, 250.0) mm, radius 100 mm",
        ("X", "Y"),
        &[
            series("radial deviation, predicted", &angles, &ring(0.01), Color::BLUE),
            series("radial deviation, measured", &angles, &ring(0.02), Color::RED),
        ],
    )
    .unwrap();
    assert_clear(&polar, "polar");
    for signed in [false, true] {
        let values: Vec<f64> = (0..35).map(|i| (i as f64 - 17.0) * 1.3e-6).collect();
        let map = plot::colour_map(
            "5-axis FYXCFZB (Hwang et al. 2014): OE.Z at Z=250.0 mm",
            ("X (mm)", "Y (mm)"),
            (0.0, 800.0, 0.0, 600.0),
            7,
            5,
            &values,
            ColourBar {
                label: "OE.Z (rad)",
                signed,
            },
        )
        .unwrap();
        assert_clear(&map, "colour map");
    }
    let nominal = vec![
        vec![[0.0, 0.0, 0.0], [800.0, 0.0, 0.0]],
        vec![[0.0, 0.0, 0.0], [0.0, 600.0, 0.0]],
        vec![[0.0, 0.0, 0.0], [0.0, 0.0, 500.0]],
    ];
    let deformed: Vec<Vec<[f64; 3]>> = nominal
        .iter()
        .map(|l| l.iter().map(|p| [p[0] + 20.0, p[1], p[2] - 10.0]).collect())
        .collect();
    let grid = plot::deformed_grid(
        "5-axis FYXCFZB (Hwang et al. 2014) at B=0,C=0: the workspace deformed by its volumetric error",
        "error magnified 1595×; largest |VE| 56.1 µm",
        &nominal,
        &deformed,
    )
    .unwrap();
    assert_clear(&grid, "deformed grid");
    let bars: Vec<Bar> = (0..14)
        .map(|i| Bar {
            label: format!("axes.Y.EC{i}Y"),
            value: 12.0 - 0.7 * i as f64,
            note: format!("{:.2} µm, {:.1}%", 12.0 - 0.7 * i as f64, 28.5),
        })
        .collect();
    let budget = plot::stacked(vec![
        plot::bar_chart(
            "Error budget of 3-axis VMC (Li et al. 2015, Table 3): max |VE| of each term alone at its limit",
            "max |VE|, µm (a term's share is its square's part of the sum of squares)",
            &bars,
            Some((22.49, "RSS 22.49 µm")),
        )
        .unwrap(),
        budget_histogram(),
    ]);
    assert_clear(&budget, "budget");
    // The spec left of every machine: its label still inside.
    let left = plot::histogram("h", "x", &[120.0, 130.0], 10, Some((0.0, "spec 0.00 µm"))).unwrap();
    assert_clear(&left, "spec at the left");
    for points in [
        &[2.0, 3.0, 5.0, 9.0, 17.0][..],
        &[2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0],
    ] {
        assert_clear(&sweep_chart(points), "sweep");
    }
}

#[test]
fn a_legend_every_corner_of_which_has_a_curve_goes_below_the_chart() {
    let x: Vec<f64> = (0..=60).map(f64::from).collect();
    let zigzag: Vec<f64> = (0..=60).map(|i| (i % 2) as f64).collect();
    let d = plot::line_chart("zigzag", "x", "y", &[series("z", &x, &zigzag, Color::RED)]).unwrap();
    assert_clear(&d, "zigzag");
    // Below the plotting area (which ends 60 px above the chart's first height, 540).
    assert!(
        d.legends[0][1] > 540.0 && d.legends[0][3] <= d.height,
        "{:?}",
        d.legends
    );
}

/// The colour map's picture: its columns, rows and pixels.
fn image(d: &Drawing) -> (f64, f64, usize, usize, Vec<[u8; 3]>) {
    d.shapes
        .iter()
        .find_map(|s| match s {
            Shape::Image {
                w,
                h,
                cols,
                rows,
                rgb,
                ..
            } => Some((*w, *h, *cols, *rows, rgb.clone())),
            _ => None,
        })
        .unwrap()
}

#[test]
fn signed_values_diverge_about_zero_and_magnitudes_run_up_viridis() {
    let values = [-2.0, 0.0, 1.0];
    let map = |signed| {
        plot::colour_map(
            "t",
            ("x", "y"),
            (0.0, 100.0, 0.0, 0.0),
            3,
            1,
            &values,
            ColourBar {
                label: "VE.X (mm)",
                signed,
            },
        )
        .unwrap()
    };
    let signed = map(true);
    let (_, _, cols, _, rgb) = image(&signed);
    // Half cells: point 0, 1, 1, 2 across. −2 is the scale's end (±max|v| = ±2), 0 white.
    assert_eq!(cols, 4);
    assert_eq!(rgb[0], plot::diverging(0.0));
    assert_eq!(rgb[1], [247, 247, 247]);
    assert_eq!(rgb[3], plot::diverging(0.75));
    assert!(
        rgb[3][0] > rgb[3][2] && rgb[0][2] > rgb[0][0],
        "red above zero, blue below"
    );
    let labels: Vec<String> = signed
        .layout()
        .texts
        .iter()
        .map(|t| t.text.clone())
        .collect();
    for tick in ["-2", "0", "2"] {
        assert!(labels.iter().any(|l| l == tick), "{tick}: {labels:?}");
    }
    let (_, _, _, _, rgb) = image(&map(false));
    assert_eq!((rgb[0], rgb[3]), (plot::colour(0.0), plot::colour(1.0)));
}

#[test]
fn each_cell_is_centred_on_its_grid_point() {
    // Points at x = 0, 50, 100 and y = 0, 50: cells 25 mm either side, the outer ones cut at the
    // travel's ends, so the axes are the travel.
    let values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    let d = plot::colour_map(
        "t",
        ("X (mm)", "Y (mm)"),
        (0.0, 100.0, 0.0, 50.0),
        3,
        2,
        &values,
        ColourBar {
            label: "|VE| (mm)",
            signed: false,
        },
    )
    .unwrap();
    let (w, h, cols, rows, rgb) = image(&d);
    assert_eq!((cols, rows), (4, 2));
    let at = |r: usize, c: usize| rgb[r * cols + c];
    let colour = |v: f64| plot::colour((v - 1.0) / 5.0);
    // Row 0 of the picture is the top: y = 50.
    assert_eq!(
        [at(0, 0), at(0, 1), at(0, 2), at(0, 3)],
        [colour(4.0), colour(5.0), colour(5.0), colour(6.0)]
    );
    assert_eq!(at(1, 0), colour(1.0));
    // The x axis's ticks (below the picture, which starts 50 px down) run over the travel: 0 at
    // its left edge, 100 at its right, 60 at 60% across.
    let layout = d.layout();
    let tick = |label: &str| {
        let b = layout
            .texts
            .iter()
            .find(|t| t.text == label && t.bounds[1] > 50.0 + h)
            .unwrap()
            .bounds;
        (b[0] + b[2]) / 2.0
    };
    let left = tick("0");
    assert!(
        (tick("100") - left - w).abs() < 1.5,
        "{} {left} {w}",
        tick("100")
    );
    assert!((tick("60") - left - 0.6 * w).abs() < 1.5);
    assert!((w / h - 2.0).abs() < 1e-9, "{w} {h}");
}

#[test]
fn the_commands_draw_their_plots_clear() {
    // A debug build (the tests') refuses to write a plot whose layout has a problem, so each
    // command's success is its plot's check.
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let field = out("f.exr");
    let runs: Vec<Vec<String>> = vec![
        vec![
            "map",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "9x7x5",
            "--device",
            "cpu",
            "--out",
            &field,
        ],
        vec![
            "plot",
            "slice",
            "--field",
            &field,
            "--quantity",
            "oe",
            "--out",
            &out("oe.png"),
            "--out",
            &out("oe.svg"),
        ],
        vec![
            "plot",
            "slice",
            "--field",
            &field,
            "--quantity",
            "ve.x",
            "--normal",
            "y",
            "--out",
            &out("vex.png"),
            "--out",
            &out("vex.svg"),
        ],
        vec![
            "plot",
            "grid",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "3x3x3",
            "--out",
            &out("grid.png"),
        ],
        vec![
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--points",
            "8",
            "--plot",
            &out("circular.png"),
        ],
        vec![
            "test",
            "positioning",
            "--machine",
            "vmc-li2015",
            "--axis",
            "X",
            "--plot",
            &out("positioning.png"),
        ],
        vec![
            "test",
            "diagonal",
            "--machine",
            "vmc-li2015",
            "--diagonal",
            "PPP",
            "--plot",
            &out("diagonal.png"),
        ],
        vec![
            "test",
            "rtest",
            "--machine",
            "5axis-hwang2014",
            "--axis",
            "C",
            "--plot",
            &out("rtest.png"),
        ],
        vec![
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "grid-csv",
            "--sweep-points",
            "2,3,5,9,17",
            "--plot",
            &out("sweep.png"),
        ],
        vec![
            "export",
            "--machine",
            "gantry-2m",
            "--format",
            "linuxcnc",
            "--sweep-points",
            "2,4,8,16,64",
            "--plot",
            &out("joints.png"),
        ],
    ]
    .into_iter()
    .map(|args| args.into_iter().map(String::from).collect())
    .collect();
    for args in &runs {
        let output = volmap().args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{args:?}: {stderr}");
    }
    // The budget's histogram with its spec at the right end.
    let tolerances = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/tolerances/vmc-li2015.toml");
    let budget = dir.path().join("budget.png");
    volmap()
        .args([
            "budget",
            "--machine",
            "vmc-li2015",
            "--grid",
            "6x5x4",
            "--samples",
            "64",
        ])
        .args([
            "--spec",
            "0.15",
            "--device",
            "cpu",
            "--tolerances",
            s(&tolerances),
        ])
        .arg("--plot")
        .arg(&budget)
        .assert()
        .success();
    // The title and the colour bar name the quantity alike.
    let oe = std::fs::read_to_string(dir.path().join("oe.svg")).unwrap();
    assert!(
        oe.contains(": |OE| at Z=") && oe.contains(">|OE| (rad)<"),
        "{oe}"
    );
    let vex = std::fs::read_to_string(dir.path().join("vex.svg")).unwrap();
    assert!(
        vex.contains(": VE.X at Y=") && vex.contains(">VE.X (mm)<"),
        "{vex}"
    );
}
