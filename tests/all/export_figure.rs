//! The residual of each embedded machine against the size of its table (grid-csv points per
//! axis, LinuxCNC entries per joint, SINUMERIK, HEIDENHAIN and ISG points per table): the
//! export chapter's figure `docs/export-residual.svg`, from the values in
//! `tests/golden/export-residual.csv`. `VOLMAP_BLESS=1 cargo test export_figure` recomputes every
//! size and redraws the figure; without it a few sizes are recomputed and must equal the stored
//! values, so the figure shows what volmap computes.

use std::path::PathBuf;

use volmap::export::{self, Request, TableSize};
use volmap::io::embedded::{self, EMBEDDED};
use volmap::model::inputs::Inputs;
use volmap::plot::{self, Color, Marker, Series};

/// The figure's panels: format, table sizes, title, horizontal axis.
const PANELS: [(&str, &[usize], &str, &str); 5] = [
    (
        "grid-csv",
        &[2, 3, 4, 5, 7, 9, 13, 17, 25, 33],
        "grid-csv: trilinear 3-D grid, residual against points per axis",
        "points per axis",
    ),
    (
        "linuxcnc",
        &[2, 3, 4, 6, 8, 12, 16, 32, 64, 128, 192, 256],
        "linuxcnc: joint tables (free nodes) + matrixkins, residual against entries",
        "entries per joint",
    ),
    (
        "siemens",
        &[2, 3, 5, 9, 17, 33, 65, 129, 200],
        "siemens: MSEC + sag/cross tables (equidistant), residual against points",
        "points per table",
    ),
    (
        "heidenhain",
        &[2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64],
        "heidenhain: *.COM axis tables (free nodes), residual against points",
        "points per table",
    ),
    (
        "isg-axis",
        &[2, 3, 5, 9, 17, 33, 65],
        "isg-axis: leadscrew + plane lists (free nodes), residual against points",
        "points per axis of a list",
    ),
];

/// One export's figures: before and residual largest, residual RMS, mm.
#[derive(Debug, Clone, PartialEq)]
struct Row {
    machine: String,
    format: String,
    points: usize,
    before_mm: f64,
    residual_mm: f64,
    rms_mm: f64,
}

fn compute(machine: &str, format: &str, points: usize) -> Row {
    let m = embedded::load(machine).unwrap();
    let inputs = Inputs::default();
    let request = Request {
        machine: &m,
        inputs: &inputs,
        pose: [0.0; 6],
        size: TableSize::Points(points),
        evaluation_points: None,
        written_by: String::new(),
        file_name: None,
        tool_length_mm: None,
        // The figure shows LinuxCNC with matrixkins.
        control: (format == "linuxcnc").then(|| "2.10".into()),
        point_numbers: None,
        probe_offset_mm: None,
    };
    let r = export::export(export::format_named(format).unwrap(), &request)
        .unwrap()
        .report;
    Row {
        machine: machine.into(),
        format: format.into(),
        points,
        before_mm: r.before.max_mm,
        residual_mm: r.residual.max_mm,
        rms_mm: r.residual.rms_mm,
    }
}

fn golden() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/export-residual.csv")
}

fn read_golden() -> Vec<Row> {
    let text = std::fs::read_to_string(golden())
        .expect("golden file; create it with VOLMAP_BLESS=1 cargo test export_figure");
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Row {
                machine: f[0].into(),
                format: f[1].into(),
                points: f[2].parse().unwrap(),
                before_mm: f[3].parse().unwrap(),
                residual_mm: f[4].parse().unwrap(),
                rms_mm: f[5].parse().unwrap(),
            }
        })
        .collect()
}

fn chart(rows: &[Row], format: &str, title: &str, x_label: &str) -> plot::Drawing {
    let colours = [
        Color::BLUE,
        Color::ORANGE,
        Color::GREEN,
        Color::RED,
        Color::PURPLE,
    ];
    assert_eq!(
        EMBEDDED.len(),
        colours.len(),
        "a colour per embedded machine"
    );
    let series: Vec<Series> = EMBEDDED
        .iter()
        .zip(colours)
        .map(|((name, _), color)| {
            let mine: Vec<&Row> = rows
                .iter()
                .filter(|r| r.machine == *name && r.format == format)
                .collect();
            Series {
                name: name.to_string(),
                x: mine.iter().map(|r| r.points as f64).collect(),
                y: mine
                    .iter()
                    .map(|r| 100.0 * r.residual_mm / r.before_mm)
                    .collect(),
                color,
                dashed: false,
                marker: Marker::Up,
                band: None,
            }
        })
        .collect();
    plot::log_chart(
        title,
        x_label,
        "largest residual, % of the error before",
        &series,
        true,
    )
    .unwrap()
}

#[test]
fn residual_against_table_size_of_the_embedded_machines() {
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        let mut rows = Vec::new();
        for (format, sizes, _, _) in PANELS {
            for (machine, _) in EMBEDDED {
                rows.extend(sizes.iter().map(|&n| compute(machine, format, n)));
            }
        }
        let mut text = String::from(
            "# volmap export over the embedded machines at their default inputs, pose 0: largest |VE| before,\n# largest and RMS residual, mm (VOLMAP_BLESS=1 cargo test export_figure)\nmachine,format,points,before_mm,residual_mm,residual_rms_mm\n",
        );
        for r in &rows {
            text += &format!(
                "{},{},{},{:e},{:e},{:e}\n",
                r.machine, r.format, r.points, r.before_mm, r.residual_mm, r.rms_mm
            );
        }
        std::fs::write(golden(), text).unwrap();
    }
    let stored = read_golden();
    let figure = plot::stacked(
        PANELS
            .iter()
            .map(|(format, _, title, x_label)| chart(&stored, format, title, x_label))
            .collect(),
    );
    let svg = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("docs/export-residual.svg");
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        figure.write(&svg).unwrap();
    }
    // The figure is drawn from the stored values (a PNG of it beside the test's files to look at).
    // The folder is made by cargo where the suite is built, not where its binary is carried.
    let scratch = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    std::fs::create_dir_all(&scratch).unwrap();
    figure.write(&scratch.join("export-residual.png")).unwrap();
    assert_eq!(
        std::fs::read_to_string(&svg).unwrap(),
        figure.svg().unwrap()
    );
    assert_eq!(
        stored.len(),
        EMBEDDED.len() * PANELS.iter().map(|p| p.1.len()).sum::<usize>()
    );
    // What the figure shows: a grid's residual falls with its spacing, to a fraction of a per
    // cent; joint tables fall to the part of the correction they cannot hold.
    for (machine, _) in EMBEDDED {
        let of = |format: &str| -> Vec<&Row> {
            stored
                .iter()
                .filter(|r| r.machine == machine && r.format == format)
                .collect()
        };
        let grid = of("grid-csv");
        assert!(
            grid.windows(2).all(|w| w[1].residual_mm < w[0].residual_mm),
            "{machine}"
        );
        assert!(
            grid[grid.len() - 1].residual_mm < 0.01 * grid[0].before_mm,
            "{machine}"
        );
        for format in ["linuxcnc", "siemens", "heidenhain", "isg-axis"] {
            let tables = of(format);
            assert!(
                tables[tables.len() - 1].residual_mm <= 1.01 * tables[0].residual_mm,
                "{machine} {format}"
            );
        }
    }
    // A few sizes recomputed equal the stored values.
    for (machine, format, points) in [
        ("vmc-li2015", "grid-csv", 3),
        ("gantry-2m", "grid-csv", 9),
        ("5axis-hwang2014", "linuxcnc", 6),
        ("vmc-dobariya2015", "linuxcnc", 8),
        ("gantry-2m", "siemens", 5),
        ("vmc-li2015", "heidenhain", 4),
        ("5axis-hwang2014", "isg-axis", 3),
    ] {
        let now = compute(machine, format, points);
        let then = stored
            .iter()
            .find(|r| r.machine == machine && r.format == format && r.points == points)
            .unwrap();
        for (a, b) in [
            (now.before_mm, then.before_mm),
            (now.residual_mm, then.residual_mm),
            (now.rms_mm, then.rms_mm),
        ] {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1e-6),
                "{now:?} vs {then:?}"
            );
        }
    }
}
