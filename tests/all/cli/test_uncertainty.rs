//! `volmap test` with the machine's uncertainties: every predicted curve carries its standard
//! uncertainty per position and every figure its own (first order, on the machine moved by ±u
//! along each direction of the covariance), printed as `± U` (k = 2), written to `--json` as
//! `predicted_u` and `predicted_u_mm`, and drawn in the plots as thin lines at predicted ± U.
//!
//! The machine: FYXFZ (X-Y table under a Z head, tool 100 mm below the spindle). With a
//! squareness `EC0Y = v` alone the tip is `x·x̂ + Rz(v)·(y·ŷ + (z − 100)·ẑ)`, so
//! `VE = (−y·sin v, y·(cos v − 1), 0)`.

use std::path::{Path, PathBuf};

use super::{json_result, s, volmap};

const V_RAD: f64 = 1.8e-5;
const U_RAD: f64 = 2e-6;

/// The machine with `x` and `y` in its axes' sections.
fn machine(dir: &Path, name: &str, x: &str, y: &str) -> PathBuf {
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n{x}\n[axes.Y]\nrange = [0.0, 400.0]\n{y}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n"
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The machine with the squareness `EC0Y = { value = V_RAD, u = U_RAD }` (exact without `u`).
fn squareness(dir: &Path, with_u: bool) -> PathBuf {
    let value = if with_u {
        format!("EC0Y = {{ value = {V_RAD:e}, u = {U_RAD:e} }}")
    } else {
        format!("EC0Y = {V_RAD:e}")
    };
    let name = if with_u { "u.toml" } else { "exact.toml" };
    machine(dir, name, "", &value)
}

/// Runs `volmap test ARGS --json` (and `--plot` each of `plots`) in `dir`: its standard output
/// and the report's result.
fn test(dir: &Path, args: &[&str], plots: &[&str]) -> (String, serde_json::Value) {
    let json = dir.join(format!("{}.json", plots.first().unwrap_or(&"test")));
    let mut command = volmap();
    command.current_dir(dir).arg("test").args(args);
    for plot in plots {
        command.args(["--plot", plot]);
    }
    let output = command.arg("--json").arg(&json).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{args:?}: {stderr}");
    (
        String::from_utf8_lossy(&output.stdout).into_owned(),
        json_result(&json),
    )
}

fn numbers(value: &serde_json::Value) -> Vec<f64> {
    value
        .as_array()
        .unwrap_or_else(|| panic!("not an array: {value}"))
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

/// The figure `name` of a result.
fn figure<'a>(result: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    result["figures"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == name)
        .unwrap_or_else(|| panic!("no figure {name}"))
}

/// The thin lines of a plot (the bands' edges are drawn 0.8 px wide).
fn thin_lines(svg: &Path) -> usize {
    std::fs::read_to_string(svg)
        .unwrap()
        .matches(r#"stroke-width="0.8""#)
        .count()
}

/// A plot as written: an SVG with no NaN in it that names the band in its legend (or, without
/// `u`, does not), and a PNG.
fn assert_plots(dir: &Path, svg: &str, png: &str, banded: bool) {
    super::assert_finite_svg(&dir.join(svg));
    let text = std::fs::read_to_string(dir.join(svg)).unwrap();
    assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    assert_eq!(text.contains("± U (k = 2)"), banded, "{svg}");
    let png = std::fs::read(dir.join(png)).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{png:?}");
}

/// The XY face diagonal from `(0, 0, 150)` to `(500, 400, 150)`, direction `d = (a, b, 0)`: at
/// distance `s` the tip has moved `y = s·b` in Y, so the displacement error is
/// `D(s) = (VE(s) − VE(0))·d = s·b·(−a·sin v + b·(cos v − 1))`, linear in the quantity `v` with
/// sensitivity `∂D/∂v = −s·b·(a·cos v + b·sin v)`: `u(D(s)) = s·b·|a·cos v + b·sin v|·u`. The
/// figure D (the range of a monotonic curve) is `|D(L)|`, its `u` the end's.
#[test]
fn a_diagonal_carries_the_band_of_a_squareness() {
    let dir = tempfile::tempdir().unwrap();
    let path = squareness(dir.path(), true);
    let args = [
        "diagonal",
        "--machine",
        s(&path),
        "--from",
        "0,0,150",
        "--to",
        "500,400,150",
        "--points",
        "11",
    ];
    let (stdout, result) = test(dir.path(), &args, &["d.svg", "d.png"]);
    let length = (500f64.powi(2) + 400f64.powi(2)).sqrt();
    let (a, b) = (500.0 / length, 400.0 / length);
    let sensitivity = |s: f64| s * b * (a * V_RAD.cos() + b * V_RAD.sin());
    let positions = numbers(&result["positions"]);
    let predicted = numbers(&result["predicted"][0]);
    let u = result["predicted_u"].as_array().unwrap();
    assert_eq!(u.len(), 1, "one curve");
    let u = numbers(&u[0]);
    assert_eq!(positions.len(), 11);
    assert_eq!(predicted.len(), 11);
    assert_eq!(u.len(), 11);
    for (n, &s) in positions.iter().enumerate() {
        let d = s * b * (-a * V_RAD.sin() + b * (V_RAD.cos() - 1.0));
        assert!(
            (predicted[n] - d).abs() < 1e-9,
            "D({s}) {} vs {d}",
            predicted[n]
        );
        let expected = sensitivity(s) * U_RAD;
        assert!(
            (u[n] - expected).abs() < 1e-9,
            "u(D({s})) {} vs {expected}",
            u[n]
        );
    }
    assert!(u[10] > 1e-4, "the band is there: {}", u[10]);
    let d = figure(&result, "D");
    let u_d = d["predicted_u_mm"].as_f64().unwrap();
    let expected = sensitivity(length) * U_RAD;
    assert!((u_d - expected).abs() < 1e-9, "u(D) {u_d} vs {expected}");
    // The text prints U = 2u in µm beside the figure.
    let shown = format!("± {:.3}", 2.0 * expected * 1000.0);
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("D "))
        .unwrap_or_else(|| panic!("no row of D in {stdout}"));
    assert!(row.contains(&shown), "`{shown}` not in `{row}`");
    assert!(stdout.contains("k = 2"), "{stdout}");
    // The report with its u fields keeps to the schema (where Python's jsonschema is at hand).
    if let Some(output) = super::json::validated("test", &[dir.path().join("d.svg.json")]) {
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    assert_plots(dir.path(), "d.svg", "d.png", true);
    // The band is two thin lines more than the plot of the exact machine has.
    let exact = squareness(dir.path(), false);
    let mut exact_args = args;
    exact_args[2] = s(&exact);
    test(dir.path(), &exact_args, &["e.svg", "e.png"]);
    assert_plots(dir.path(), "e.svg", "e.png", false);
    assert_eq!(
        thin_lines(&dir.path().join("d.svg")),
        thin_lines(&dir.path().join("e.svg")) + 2
    );
}

/// Positioning of X over a linear table `EXX` whose nodes are the targets (0, 125, …, 500 mm):
/// the laser along X reads `EXX(t) − EXX(0)` (zeroed at the first target), so with independent
/// nodes `u(t_i) = sqrt(u_i² + u_0²)` and `u(t_0) = 0`, in both directions.
#[test]
fn positioning_over_a_table_carries_its_nodes_u() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = [0.0, 125.0, 250.0, 375.0, 500.0];
    let u_mm: [f64; 5] = [0.5e-3, 1e-3, 1.5e-3, 0.7e-3, 2.5e-3];
    let table: Vec<String> = nodes
        .iter()
        .zip([0.0, 0.004, 0.006, 0.005, 0.012])
        .map(|(q, v)| format!("[{q}, {v}]"))
        .collect();
    let u_list: Vec<String> = u_mm.iter().map(|u| format!("{u:e}")).collect();
    let x = format!(
        "EXX = {{ table = [{}], interp = \"linear\", u = [{}] }}",
        table.join(", "),
        u_list.join(", ")
    );
    let path = machine(dir.path(), "table.toml", &x, "");
    let (stdout, result) = test(
        dir.path(),
        &[
            "positioning",
            "--machine",
            s(&path),
            "--axis",
            "X",
            "--targets",
            "5",
        ],
        &["p.svg", "p.png"],
    );
    let positions = numbers(&result["positions"]);
    assert_eq!(positions.len(), nodes.len());
    for (p, q) in positions.iter().zip(nodes) {
        assert!((p - q).abs() < 1e-9, "target {p} vs node {q}");
    }
    let curves = result["predicted_u"].as_array().unwrap();
    assert_eq!(curves.len(), 2, "↑ and ↓");
    for curve in curves {
        let u = numbers(curve);
        assert_eq!(u.len(), nodes.len());
        assert!(u[0].abs() < 1e-12, "zeroed at the first target: {}", u[0]);
        for i in 1..nodes.len() {
            let expected = (u_mm[i].powi(2) + u_mm[0].powi(2)).sqrt();
            assert!(
                (u[i] - expected).abs() < 1e-9,
                "node {i}: {} vs {expected}",
                u[i]
            );
        }
    }
    // Every figure has its u; the accuracy A spans the curve, so it moves with the nodes.
    for f in result["figures"].as_array().unwrap() {
        assert!(f["predicted_u_mm"].as_f64().unwrap() >= 0.0, "{f}");
    }
    assert!(figure(&result, "A")["predicted_u_mm"].as_f64().unwrap() > 1e-4);
    assert!(stdout.contains("predicted µm ± U"), "{stdout}");
    assert_plots(dir.path(), "p.svg", "p.png", true);
}

/// A circle of radius r about the middle of the travel in XY: the squareness draws
/// `dr(θ) = −(v·r/2)·sin 2θ`, so `u(dr(θ)) = (r/2)·|sin 2θ|·u`, and G (the range of the radial
/// deviation from the least-squares circle, which `sin 2θ` leaves as it is) is
/// `(v·r/2)·(max sin 2θ − min sin 2θ)` over the angles run (36 of them, 10° apart: not 45°, so
/// `cos 10°·v·r`), its `u` the same with `u` for `v`; to first order, within the terms in
/// `v·u·r` (4e-9 mm here).
#[test]
fn a_circle_carries_the_band_of_a_squareness_and_g_its_u() {
    let dir = tempfile::tempdir().unwrap();
    let path = squareness(dir.path(), true);
    let r = 100.0;
    let (_, result) = test(
        dir.path(),
        &[
            "circular",
            "--machine",
            s(&path),
            "--plane",
            "XY",
            "--radius",
            "100",
            "--points",
            "36",
        ],
        &["c.svg", "c.png"],
    );
    let angles = numbers(&result["positions"]);
    let curves = result["predicted_u"].as_array().unwrap();
    assert_eq!(curves.len(), 1);
    let u = numbers(&curves[0]);
    assert_eq!(angles.len(), 36);
    assert_eq!(u.len(), 36);
    for (t, u) in angles.iter().zip(&u) {
        let expected = r / 2.0 * (2.0 * t.to_radians()).sin().abs() * U_RAD;
        assert!((u - expected).abs() < 2e-8, "θ = {t}: {u} vs {expected}");
    }
    assert!(u.iter().any(|&u| u > 5e-5), "{u:?}");
    let sin_2t: Vec<f64> = angles
        .iter()
        .map(|t| (2.0 * t.to_radians()).sin())
        .collect();
    let spread = sin_2t.iter().copied().fold(f64::MIN, f64::max)
        - sin_2t.iter().copied().fold(f64::MAX, f64::min);
    let expected = r / 2.0 * spread * U_RAD;
    let u_g = figure(&result, "G")["predicted_u_mm"].as_f64().unwrap();
    assert!(u_g > 0.0);
    assert!((u_g - expected).abs() < 2e-8, "u(G) {u_g} vs {expected}");
    assert_plots(dir.path(), "c.svg", "c.png", true);
}

/// A machine without any `u`: no band anywhere, the report as before.
#[test]
fn a_machine_without_u_has_no_band() {
    let dir = tempfile::tempdir().unwrap();
    let path = squareness(dir.path(), false);
    for args in [
        vec!["circular", "--plane", "XY", "--points", "24"],
        vec!["diagonal", "--diagonal", "XY-PP"],
        vec!["positioning", "--axis", "Y"],
    ] {
        let mut args = args;
        args.extend(["--machine", s(&path)]);
        let (stdout, result) = test(dir.path(), &args, &[]);
        assert!(result.get("predicted_u").is_none(), "{args:?}: {result}");
        let figures = result["figures"].as_array().unwrap();
        assert!(!figures.is_empty());
        for f in figures {
            assert!(f.get("predicted_mm").is_some(), "{f}");
            assert!(f.get("predicted_u_mm").is_none(), "{args:?}: {f}");
        }
        assert!(!stdout.contains('±'), "{args:?}: {stdout}");
    }
}
