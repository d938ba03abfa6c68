//! The residual of each embedded machine against the size of its table (grid-csv points per
//! axis, LinuxCNC entries per joint, SINUMERIK, HEIDENHAIN and ISG points per table): the
//! export chapter's figure `docs/export-residual.svg`, from the values in
//! `tests/golden/export-residual.csv`. `VOLMAP_BLESS=1 cargo test export_figure` recomputes every
//! size and redraws the figure; without it a few sizes are recomputed and must equal the stored
//! values, so the figure shows what volmap computes.

use std::path::PathBuf;

use rayon::prelude::*;

use volmap::export::{self, Request, TableSize};
use volmap::io::embedded::{self, EMBEDDED};
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
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

/// Whether a stored row is cheap enough to recompute on every run: a 3-D grid of up to 9 points
/// per axis (about half a second each in the test profile). Larger grids take 1 to 7 s, and every
/// row of the table formats 3 to 9 s (their fit averages over an 11³ grid and is checked).
fn cheap(format: &str, points: usize) -> bool {
    format == "grid-csv" && points <= 9
}

/// The stored rows [`cheap`] chooses: 6 sizes of the 5 machines.
const CHEAP_ROWS: usize = 30;

/// One row of each table format, recomputed although not cheap, so that every kind of row is
/// compared with the file.
const SPOT_ROWS: [(&str, &str, usize); 4] = [
    ("vmc-dobariya2015", "linuxcnc", 8),
    ("gantry-2m", "siemens", 5),
    ("vmc-li2015", "heidenhain", 4),
    ("5axis-hwang2014", "isg-axis", 3),
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
    compute_for(&embedded::load(machine).unwrap(), machine, format, points)
}

/// [`compute`] for the machine `m`, named `machine` in the row.
fn compute_for(m: &Machine, machine: &str, format: &str, points: usize) -> Row {
    let inputs = Inputs::default();
    let request = Request {
        machine: m,
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
        // One-axis tables hold the positioning errors and part of the rest: they take something
        // off beyond two points on every machine (joint tables: below).
        for format in ["siemens", "heidenhain", "isg-axis"] {
            let tables = of(format);
            assert!(
                tables[tables.len() - 1].residual_mm < tables[0].residual_mm,
                "{machine} {format}"
            );
        }
    }
}

/// Every stored row that is cheap to compute ([`cheap`]), and one row of each table format
/// ([`SPOT_ROWS`]), is recomputed and must equal the stored value. The rest rest on the same code
/// at another size, on what the tests assert of their shape (each grid row below the one before,
/// the joint tables' fall and flats, the flats equal to a residual computed again, below), and on
/// `VOLMAP_BLESS=1`, which recomputes them all.
#[test]
fn the_stored_rows_that_are_cheap_are_recomputed() {
    let stored = read_golden();
    let chosen: Vec<&Row> = stored
        .iter()
        .filter(|r| {
            cheap(&r.format, r.points)
                || SPOT_ROWS.contains(&(r.machine.as_str(), r.format.as_str(), r.points))
        })
        .collect();
    assert_eq!(
        chosen.len(),
        CHEAP_ROWS + SPOT_ROWS.len(),
        "rows recomputed"
    );
    let again: Vec<Row> = chosen
        .par_iter()
        .map(|r| compute(&r.machine, &r.format, r.points))
        .collect();
    assert_eq!(again.len(), chosen.len());
    for (now, then) in again.iter().zip(&chosen) {
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

/// The embedded machine `name` with the errors of its axes that `keep` refuses taken out of its
/// file (and its spindle's errors unless `keep("spindle")`).
fn edited(name: &str, keep: impl Fn(&str) -> bool) -> Machine {
    let text = EMBEDDED.iter().find(|(n, _)| *n == name).unwrap().1;
    let mut file: toml::Table = text.parse().unwrap();
    let axes = file["axes"].as_table_mut().unwrap();
    let mut kept = 0;
    for (_, axis) in axes.iter_mut() {
        let axis = axis.as_table_mut().unwrap();
        axis.retain(|key, _| !key.starts_with('E') || keep(key));
        kept += axis.keys().filter(|k| k.starts_with('E')).count();
    }
    assert!(kept > 0, "{name}: an error kept");
    if !keep("spindle") {
        file.remove("spindle");
    }
    Machine::from_toml(&toml::to_string(&file).unwrap(), name, None).unwrap()
}

/// A positioning error: the error of an axis along itself (`EXX`, `EYY`, `EZZ`).
fn positioning(key: &str) -> bool {
    matches!(key, "EXX" | "EYY" | "EZZ")
}

/// LinuxCNC's joint tables hold, per joint, its correction along its own axis as a function of
/// its own position, linearly interpolated between entries (matrixkins adds one linear map of X,
/// Y, Z). Where that correction curves, more entries must help: linear interpolation leaves an
/// error that goes as the square of the spacing, so doubling the entries cuts it by 4 (by more
/// than 3 asserted, for the free nodes' placement). `vmc-dobariya2015`'s errors are all
/// positioning tables, so its residual is that part alone. Where the positioning errors are
/// straight lines (`vmc-li2015` and `gantry-2m`: EXX, EYY, EZZ are first-degree polynomials),
/// two entries already hold them exactly, and the residual is flat from two entries at what the
/// same machine leaves without its positioning errors: the part no joint table holds.
#[test]
fn joint_tables_fall_with_the_square_of_their_spacing_or_are_flat_at_what_none_holds() {
    let stored = read_golden();
    let linuxcnc = |machine: &str| -> Vec<&Row> {
        stored
            .iter()
            .filter(|r| r.machine == machine && r.format == "linuxcnc")
            .collect()
    };
    let sizes = PANELS[1].1;
    assert_eq!(PANELS[1].0, "linuxcnc");
    let curved = linuxcnc("vmc-dobariya2015");
    assert_eq!(curved.len(), sizes.len());
    let mut doublings = 0;
    for a in &curved {
        if let Some(b) = curved.iter().find(|b| b.points == 2 * a.points) {
            doublings += 1;
            assert!(
                b.residual_mm < a.residual_mm / 3.0,
                "{} entries: {} mm, {}: {} mm",
                a.points,
                a.residual_mm,
                b.points,
                b.residual_mm
            );
        }
    }
    assert_eq!(doublings, 9);

    for machine in ["vmc-li2015", "gantry-2m"] {
        let flat = linuxcnc(machine);
        assert_eq!(flat.len(), sizes.len());
        let rest = edited(machine, |key| !positioning(key));
        let not_held = compute_for(&rest, machine, "linuxcnc", 2).residual_mm;
        assert!(
            not_held > 0.1 * flat[0].before_mm,
            "{machine}: {not_held} mm"
        );
        // Flat: every size leaves what two entries leave, to a millionth.
        for r in &flat {
            assert!(
                (r.residual_mm - flat[0].residual_mm).abs() <= 1e-6 * flat[0].residual_mm,
                "{machine}, {} entries: {} mm, 2 entries: {} mm",
                r.points,
                r.residual_mm,
                flat[0].residual_mm
            );
        }
        // At what no table holds, to 10 nm: the positioning errors (20 µm) move the rest only
        // through second-order terms (times angular errors of tens of µrad: nanometres).
        assert!(
            (flat[0].residual_mm - not_held).abs() <= 1e-5,
            "{machine}: {} mm, without its positioning errors {not_held} mm",
            flat[0].residual_mm
        );
        // The positioning errors alone (tens of µm): two entries leave under a nanometre of them.
        let alone = compute_for(&edited(machine, positioning), machine, "linuxcnc", 2);
        assert!(alone.before_mm > 0.01, "{machine}: {alone:?}");
        assert!(alone.residual_mm < 1e-6, "{machine}: {alone:?}");
    }
}
