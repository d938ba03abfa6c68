//! What `fit --out` and `build --out` write of the uncertainties: each estimate's `u` and the
//! covariance of the estimates, read back by `sample --exact --uncertainty` as the same map
//! uncertainty `J·C·Jᵀ` (`J` by finite differences of `sample --exact` on edited copies of the
//! written file, `C` the covariance the fit reports); and the nodes' `u` of a built table from a
//! `u_um` column of the measurements.

use std::path::{Path, PathBuf};

use toml_edit::{DocumentMut, Item};
use volmap::model::Machine;
use volmap::standards::Setup;

use super::{json_result, refused, s, succeeds};
use crate::calibrate::{squareness_measurements, thermal_measurements, THERMAL_TOML};
use crate::standards::write;

/// The header and the rows of a CSV answer of `sample`.
fn table(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Column `name` of every row.
fn column(header: &[String], rows: &[Vec<f64>], name: &str) -> Vec<f64> {
    let n = header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    rows.iter().map(|r| r[n]).collect()
}

/// The item at `keys` (`["axes", "Y", "EC0Y"]`) of a TOML document.
fn at<'a>(document: &'a DocumentMut, keys: &[&str]) -> &'a Item {
    keys.iter().fold(document.as_item(), |item, k| &item[*k])
}

fn number(item: &Item) -> f64 {
    item.as_float()
        .unwrap_or_else(|| panic!("not a float: {item}"))
}

/// `sample --exact` of `machine` at `points` (with `extra` flags): the header and rows.
fn sample(
    dir: &Path,
    machine: &Path,
    points: &Path,
    extra: &[&str],
) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut args = vec![
        "sample",
        "--exact",
        "--machine",
        s(machine),
        "--points",
        s(points),
    ];
    args.extend(extra);
    table(&succeeds(&args, dir))
}

/// The written quantities (keys to each `{ value = …, u = … }`) and their covariance `c`:
/// `sample --exact --uncertainty` of `written` at `points` gives, per component of VE,
/// `sqrt(J·C·Jᵀ)` within 1e-6 relative, `J` by central differences (step: the quantity's `u`)
/// of `sample --exact` on copies of the file with one value moved.
fn assert_reads_back(
    dir: &Path,
    written: &Path,
    quantities: &[Vec<&str>],
    c: &[Vec<f64>],
    points: &Path,
    inputs: &[&str],
) {
    assert_eq!(c.len(), quantities.len());
    let document: DocumentMut = std::fs::read_to_string(written).unwrap().parse().unwrap();
    let components = ["VE.X", "VE.Y", "VE.Z"];
    let (header, rows) = sample(
        dir,
        written,
        points,
        &super::with(inputs, &["--uncertainty"]),
    );
    let n = rows.len();
    assert!(n >= 3, "{n} points");
    // sensitivities[q][k][p]: of component k at point p to quantity q.
    let mut sensitivities = Vec::new();
    for (q, keys) in quantities.iter().enumerate() {
        let value = number(&at(&document, keys)["value"]);
        let h = c[q][q].sqrt();
        assert!(h > 0.0, "{keys:?}");
        let mut moved = Vec::new();
        for (sign, name) in [(1.0, "plus.toml"), (-1.0, "minus.toml")] {
            let mut copy = document.clone();
            let item = keys
                .iter()
                .fold(copy.as_item_mut(), |item, k| &mut item[*k]);
            item["value"] = toml_edit::value(value + sign * h);
            let path = dir.join(name);
            std::fs::write(&path, copy.to_string()).unwrap();
            let (h2, r2) = sample(dir, &path, points, inputs);
            assert_eq!(r2.len(), n);
            moved.push(components.map(|k| column(&h2, &r2, k)));
        }
        let j: Vec<Vec<f64>> = (0..3)
            .map(|k| {
                (0..n)
                    .map(|p| (moved[0][k][p] - moved[1][k][p]) / (2.0 * h))
                    .collect()
            })
            .collect();
        sensitivities.push(j);
    }
    let mut seen = 0;
    for (k, name) in components.iter().enumerate() {
        let got = column(&header, &rows, &format!("u({name})"));
        assert_eq!(got.len(), n);
        for p in 0..n {
            let mut variance = 0.0;
            for a in 0..quantities.len() {
                for b in 0..quantities.len() {
                    variance += sensitivities[a][k][p] * c[a][b] * sensitivities[b][k][p];
                }
            }
            let want = variance.max(0.0).sqrt();
            assert!(
                (got[p] - want).abs() <= 1e-6 * want + 1e-15,
                "u({name}) at point {p}: {} read back, {want} from J·C·Jᵀ",
                got[p]
            );
            if want > 1e-6 {
                seen += 1;
            }
        }
    }
    // The check sees the quantities: most components move with them by more than 1 nm.
    assert!(seen >= n, "{seen} components of {n} points above 1 nm");
}

/// The covariance `fit --json` reports, checked square and symmetric with the squares of the
/// estimates' uncertainties on its diagonal; and the estimates' names.
fn reported(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let result = json_result(path);
    let estimates = result["estimates"].as_array().unwrap();
    let names: Vec<String> = estimates
        .iter()
        .map(|e| e["name"].as_str().unwrap().to_string())
        .collect();
    let rows = result["covariance"].as_array().unwrap();
    assert_eq!(rows.len(), estimates.len());
    let c: Vec<Vec<f64>> = rows
        .iter()
        .map(|row| {
            let row = row.as_array().unwrap();
            assert_eq!(row.len(), estimates.len());
            row.iter().map(|v| v.as_f64().unwrap()).collect()
        })
        .collect();
    for (a, e) in estimates.iter().enumerate() {
        let u = e["uncertainty"].as_f64().unwrap();
        assert!(u > 0.0);
        assert!(
            (c[a][a].sqrt() - u).abs() <= 1e-12 * u,
            "{} vs {u}",
            c[a][a]
        );
        for (b, row) in c.iter().enumerate().take(a) {
            assert_eq!(c[a][b], row[a]);
        }
    }
    (names, c)
}

/// The written `[covariance]` entry of two quantities, either order.
fn covariance_of(document: &DocumentMut, a: &str, b: &str) -> f64 {
    let table = document["covariance"].as_table_like().unwrap();
    let item = table
        .get(&format!("{a} {b}"))
        .or_else(|| table.get(&format!("{b} {a}")))
        .unwrap_or_else(|| panic!("no covariance of {a} and {b}"));
    number(item)
}

/// `|got − want| ≤ 1e-11 |want|`: the file's 12 significant digits.
fn assert_close(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() <= 1e-11 * want.abs(),
        "{what}: {got} written, {want} reported"
    );
}

/// A 3-axis machine with a guessed squareness of Y (u 5 µrad) correlated with a spindle offset.
const GIVEN: &str = r#"name = "three-axis"
chain = "FYXFZ"
[axes.X]
range = [-400.0, 400.0]
EXX = { poly = [0.0, 1.0e-5] }
[axes.Y]
range = [-300.0, 300.0]
EC0Y = { value = 0.0, u = 5e-6 } # a guess before the fit
[axes.Z]
range = [-250.0, 250.0]
[spindle]
EXS = { value = 0.0, u = 1e-3 }
[covariance]
"axes.Y.EC0Y spindle.EXS" = 1e-9
"#;

/// Three squareness errors from noisy circles and diagonals: the written file carries each with
/// the reported `u` and every pair's covariance, drops the pair the base gave EC0Y (the fit
/// replaces what was known of it), keeps the spindle's `u`, and reads back as the same map
/// uncertainty.
/// `volmap fit` of `given` to `measurements` in `dir`: the fitted machine file and the JSON
/// report it writes.
fn fitted(dir: &Path, given: &Path, measurements: &Path) -> (PathBuf, PathBuf) {
    let fitted = dir.join("fitted.toml");
    let json = dir.join("fit.json");
    succeeds(
        &[
            "fit",
            "--machine",
            s(given),
            "--measurements",
            s(measurements),
            "--out",
            s(&fitted),
            "--json",
            s(&json),
        ],
        dir,
    );
    (fitted, json)
}

#[test]
fn fit_writes_u_and_covariance_that_read_back_as_the_same_map_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let given = write(&dir, "given.toml", GIVEN);
    let mut truth = Machine::from_toml(GIVEN, "truth.toml", None).unwrap();
    use volmap::model::AxisLetter::{Y, Z};
    truth.axis_mut(Y).unwrap().location[5] = 2.0e-5;
    truth.axis_mut(Z).unwrap().location[4] = -1.5e-5;
    truth.axis_mut(Z).unwrap().location[3] = 1.0e-5;
    let setup = Setup::new(&truth, "").unwrap();
    let mut rng = crate::common::Rng::new(7);
    let mut fit = String::from("estimate = [\"EC0Y\", \"EB0Z\", \"EA0Z\"]\n");
    fit += &squareness_measurements(dir.path(), &setup, 0.3e-3, &mut rng);
    let measurements = write(&dir, "fit.toml", &fit);
    let (fitted, json) = fitted(dir.path(), &given, &measurements);
    let (names, c) = reported(&json);
    assert_eq!(names, ["EC0Y", "EB0Z", "EA0Z"]);
    let text = std::fs::read_to_string(&fitted).unwrap();
    assert!(text.contains("# a guess before the fit"), "{text}");
    let document: DocumentMut = text.parse().unwrap();
    let keys = [
        ["axes", "Y", "EC0Y"],
        ["axes", "Z", "EB0Z"],
        ["axes", "Z", "EA0Z"],
    ];
    let quantities: Vec<String> = keys.iter().map(|k| k.join(".")).collect();
    for (a, k) in keys.iter().enumerate() {
        assert_close(
            number(&at(&document, k)["u"]),
            c[a][a].sqrt(),
            &quantities[a],
        );
        for b in 0..a {
            let written = covariance_of(&document, &quantities[a], &quantities[b]);
            assert!(written != 0.0);
            assert_close(written, c[a][b], "covariance");
        }
    }
    // The three pairs of estimates; the base's pair of EC0Y and EXS is gone.
    assert_eq!(document["covariance"].as_table_like().unwrap().len(), 3);
    assert_eq!(number(&at(&document, &["spindle", "EXS"])["u"]), 1e-3);
    // The map uncertainty read back: the fit's covariance and the spindle's u.
    let points = write(
        &dir,
        "points.csv",
        "X,Y,Z\n300,200,100\n-250,150,-200\n100,-280,240\n",
    );
    let mut full = vec![vec![0.0; 4]; 4];
    for a in 0..3 {
        full[a][..3].copy_from_slice(&c[a]);
    }
    full[3][3] = 1e-6;
    let mut quantities: Vec<Vec<&str>> = keys.iter().map(|k| k.to_vec()).collect();
    quantities.push(vec!["spindle", "EXS"]);
    assert_reads_back(dir.path(), &fitted, &quantities, &full, &points, &[]);
}

/// A squareness and its thermal coefficient: the coefficient's `u` inside `per_kelvin`, its
/// covariance with the value named `axes.Y.EC0Y.per_kelvin.hall`, and the map uncertainty at
/// 30 °C (the coefficient's `u` times 10 K) read back as `J·C·Jᵀ`.
#[test]
fn a_thermal_coefficient_is_written_with_its_u_and_covariance() {
    let dir = tempfile::tempdir().unwrap();
    let measurements = thermal_measurements(
        &dir,
        (2.0e-5, 1.5e-6, -1.5e-5),
        &[20.0, 26.0, 32.0],
        "\"EC0Y\", \"EC0Y.per_kelvin.hall\", \"EB0Z\"",
    );
    let given = write(&dir, "given.toml", THERMAL_TOML);
    let (fitted, json) = fitted(dir.path(), &given, &measurements);
    let (names, c) = reported(&json);
    assert_eq!(names, ["EC0Y", "EC0Y.per_kelvin.hall", "EB0Z"]);
    let document: DocumentMut = std::fs::read_to_string(&fitted).unwrap().parse().unwrap();
    let quantities = [
        vec!["axes", "Y", "EC0Y"],
        vec!["axes", "Y", "EC0Y", "per_kelvin", "hall"],
        vec!["axes", "Z", "EB0Z"],
    ];
    let names: Vec<String> = quantities.iter().map(|k| k.join(".")).collect();
    for (a, k) in quantities.iter().enumerate() {
        assert_close(number(&at(&document, k)["u"]), c[a][a].sqrt(), &names[a]);
        for b in 0..a {
            assert_close(
                covariance_of(&document, &names[a], &names[b]),
                c[a][b],
                "covariance",
            );
        }
    }
    let points = write(
        &dir,
        "points.csv",
        "X,Y,Z\n300,200,100\n-250,150,-200\n100,-280,240\n",
    );
    let hall = ["--temperatures", "hall=30"];
    assert_reads_back(dir.path(), &fitted, &quantities, &c, &points, &hall);
}

/// X measured at five positions with a `u_um` column: each node's `u` read back at the node
/// (`u_um·1e-3` mm, on VE.X for EXX and VE.Y for EYX), between nodes of a linear table
/// `sqrt((1−t)²u_i² + t²u_{i+1}²)`; a file without the column writes no `u`.
#[test]
fn build_writes_the_nodes_u_from_a_u_um_column() {
    let dir = tempfile::tempdir().unwrap();
    let u_um: [f64; 5] = [0.5, 0.8, 1.2, 0.9, 0.6];
    let mut csv = String::from("position_mm,EXX_um,EYX_um,u_um\n");
    for (k, u) in u_um.iter().enumerate() {
        csv += &format!("{},{},{},{u}\n", 250 * k, 2.0 * k as f64, -(k as f64));
    }
    let x = write(&dir, "x.csv", &csv);
    let built = dir.path().join("built.toml");
    let out = succeeds(
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            &format!("X={}", s(&x)),
            "--interp",
            "EXX=linear,EYX=linear",
            "--out",
            s(&built),
        ],
        dir.path(),
    );
    assert!(out.contains("EXX (u_um)"), "{out}");
    let document: DocumentMut = std::fs::read_to_string(&built).unwrap().parse().unwrap();
    for name in ["EXX", "EYX"] {
        let u = at(&document, &["axes", "X", name])["u"].as_array().unwrap();
        assert_eq!(u.len(), u_um.len(), "{name}");
    }
    // On vmc-li2015 (no other u) the points at the nodes, and halfway between the first two.
    let mut points = String::from("X,Y,Z\n");
    for k in 0..u_um.len() {
        points += &format!("{},300,200\n", 250 * k);
    }
    points += "125,300,200\n";
    let points = write(&dir, "points.csv", &points);
    let (header, rows) = sample(dir.path(), &built, &points, &["--uncertainty"]);
    assert_eq!(rows.len(), u_um.len() + 1);
    let halfway = 0.5 * (u_um[0] * u_um[0] + u_um[1] * u_um[1]).sqrt() * 1e-3;
    let want: Vec<f64> = u_um.iter().map(|u| u * 1e-3).chain([halfway]).collect();
    // (The machine's angles, tens of µrad, tilt each by less than 1e-9 of itself.)
    for name in ["u(VE.X)", "u(VE.Y)"] {
        let got = column(&header, &rows, name);
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-7 * w, "{name}: {g} vs {w}");
        }
    }
    // VE.Z sees them only through those angles.
    for g in column(&header, &rows, "u(VE.Z)") {
        assert!(g.abs() < 1e-3 * 1.2e-3, "{g}");
    }
    // Without the column: no u.
    let plain: String = csv
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
        .collect();
    write(&dir, "plain.csv", &plain);
    let plain_built = dir.path().join("plain.toml");
    succeeds(
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=plain.csv",
            "--out",
            s(&plain_built),
        ],
        dir.path(),
    );
    let document: DocumentMut = std::fs::read_to_string(&plain_built)
        .unwrap()
        .parse()
        .unwrap();
    assert!(at(&document, &["axes", "X", "EXX"]).get("u").is_none());
}

/// A `u_um` that is negative or not a number is refused with exit code 2, naming the file, the
/// line and the column; nothing is written.
#[test]
fn build_refuses_a_bad_u_um_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bad, says) in [
        ("negative.csv", "-0.4", "is negative"),
        ("text.csv", "abc", "is not a number"),
        ("infinite.csv", "inf", "is not a finite number"),
    ] {
        let csv = format!("position_mm,EXX_um,u_um\n0,0.0,0.5\n# a note\n500,1.0,{bad}\n");
        write(&dir, name, &csv);
        let out = dir.path().join("never.toml");
        refused(
            &[
                "build",
                "--base",
                "vmc-li2015",
                "--axis",
                &format!("X={name}"),
                "--out",
                s(&out),
            ],
            dir.path(),
            &[name, "line 4", "`u_um`", says],
        );
        assert!(!out.exists());
    }
    // A u column with no component of its kind.
    write(
        &dir,
        "angular.csv",
        "position_mm,EAX_urad,u_um\n0,0.0,0.5\n500,1.0,0.5\n",
    );
    refused(
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=angular.csv",
            "--out",
            "never.toml",
        ],
        dir.path(),
        &[
            "angular.csv",
            "line 1",
            "`u_um`",
            "no translational component",
        ],
    );
}
