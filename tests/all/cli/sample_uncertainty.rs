//! The readers of a field's part of uncertainties (`map --uncertainty`): `sample --field` adds
//! the columns u(VE.X), u(VE.Y), u(VE.Z) interpolated in it, as `sample --exact --uncertainty`
//! computes them; `plot slice --quantity u` draws |u(VE)| or one channel's u.

use std::path::{Path, PathBuf};

use super::{json_result, refused, s, succeeds, volmap};

/// The standard uncertainty of the squareness EC0Y, rad.
const U_EC0Y_RAD: f64 = 2e-6;

/// A 3-axis FYXFZ machine (X 0 to 500, Y 0 to 400, Z 0 to 300 mm) whose one uncertain value
/// is a squareness: `VE.x = −y·sin EC0Y`, so `u(VE.X) = |y|·cos(EC0Y)·u(EC0Y)`, linear in y,
/// and u(VE.Y) = u(VE.Z) = 0.
fn machine(dir: &Path) -> PathBuf {
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n\
         [axes.Y]\nrange = [0.0, 400.0]\nEC0Y = {{ value = 1.8e-5, u = {U_EC0Y_RAD:e} }}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n"
    );
    let path = dir.join("u.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Maps the machine on a 5×5×4 grid (nodes every 125, 100 and 100 mm) on the CPU, with
/// `extra` flags, into `name`.
fn map(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let m = machine(dir);
    let out = dir.join(name);
    let mut args = vec![
        "map",
        "--machine",
        s(&m),
        "--grid",
        "5x5x4",
        "--device",
        "cpu",
        "--out",
        s(&out),
    ];
    args.extend_from_slice(extra);
    succeeds(&args, dir);
    out
}

/// The header and the rows of a CSV answer.
fn rows(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

/// The value of `column` in `row`.
fn value(header: &[String], row: &[String], column: &str) -> f64 {
    let n = header.iter().position(|h| h == column).unwrap();
    row[n].parse().unwrap()
}

/// Positions between the grid's nodes along every axis, `(id, x, y, z)`.
const OFF_NODES: [(&str, f64, f64, f64); 4] = [
    ("a", 130.0, 150.0, 70.0),
    ("b", 310.0, 275.5, 222.0),
    ("c", 499.0, 399.0, 1.0),
    ("d", 62.5, 37.25, 250.0),
];

fn points_csv(dir: &Path, extra: &str) -> PathBuf {
    let mut text = String::from("id,X,Y,Z\n");
    for (id, x, y, z) in OFF_NODES {
        text.push_str(&format!("{id},{x},{y},{z}\n"));
    }
    text.push_str(extra);
    let path = dir.join("p.csv");
    std::fs::write(&path, text).unwrap();
    path
}

/// The devices the field is sampled on: the CPU always, the GPU where an adapter exists.
fn devices() -> Vec<&'static str> {
    let mut devices = vec!["cpu"];
    if crate::common::sampler().is_some() {
        devices.push("gpu");
    }
    devices
}

#[test]
fn sample_field_interpolates_the_uncertainties_as_derived_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "u.exr", &["--uncertainty"]);
    let points = points_csv(dir.path(), "");
    let exact = succeeds(
        &[
            "sample",
            "--exact",
            "--machine",
            s(&machine(dir.path())),
            "--points",
            s(&points),
            "--uncertainty",
        ],
        dir.path(),
    );
    let (exact_header, exact_rows) = rows(&exact);
    assert_eq!(exact_rows.len(), OFF_NODES.len());
    for device in devices() {
        let out = succeeds(
            &[
                "sample",
                "--device",
                device,
                "--field",
                s(&field),
                "--points",
                s(&points),
            ],
            dir.path(),
        );
        let (header, found) = rows(&out);
        // The columns `sample --exact --uncertainty` writes, in its order.
        assert_eq!(header, exact_header, "{device}");
        assert_eq!(found.len(), OFF_NODES.len(), "{device}");
        for ((row, exact), (id, _, y, _)) in found.iter().zip(&exact_rows).zip(OFF_NODES) {
            assert_eq!(row[0], id);
            // u is linear in y here: trilinear interpolation between the nodes is exact.
            let by_hand = y.abs() * 1.8e-5f64.cos() * U_EC0Y_RAD;
            let u_x = value(&header, row, "u(VE.X)");
            assert!(
                (u_x - by_hand).abs() < 1e-6,
                "{device} {id}: {u_x} vs {by_hand}"
            );
            for column in ["u(VE.X)", "u(VE.Y)", "u(VE.Z)"] {
                let (u, reference) = (
                    value(&header, row, column),
                    value(&exact_header, exact, column),
                );
                assert!(
                    (u - reference).abs() < 1e-6,
                    "{device} {id} {column}: field {u}, exact {reference}"
                );
            }
        }
    }
}

#[test]
fn positions_outside_answer_nan_uncertainties_or_are_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "u.exr", &["--uncertainty"]);
    let points = points_csv(dir.path(), "far,600,100,100\n");
    let sample = |outside: &str| {
        succeeds(
            &[
                "sample",
                "--device",
                "cpu",
                "--outside",
                outside,
                "--field",
                s(&field),
                "--points",
                s(&points),
            ],
            dir.path(),
        )
    };
    let (header, nan) = rows(&sample("nan"));
    assert_eq!(nan.len(), OFF_NODES.len() + 1);
    let far = &nan[OFF_NODES.len()];
    assert_eq!(far[0], "far");
    for column in ["VE.X", "u(VE.X)", "u(VE.Y)", "u(VE.Z)"] {
        assert!(value(&header, far, column).is_nan(), "{column}: {far:?}");
    }
    // The positions inside keep their u.
    assert!(value(&header, &nan[0], "u(VE.X)") > 0.0, "{:?}", nan[0]);
    let (skip_header, skipped) = rows(&sample("skip"));
    assert_eq!(skip_header, header);
    assert_eq!(skipped.len(), OFF_NODES.len());
    assert_eq!(skipped, nan[..OFF_NODES.len()].to_vec());
}

#[test]
fn a_field_without_uncertainties_samples_no_u_columns() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "plain.exr", &[]);
    let points = points_csv(dir.path(), "");
    let report = dir.path().join("r.json");
    let out = succeeds(
        &[
            "sample",
            "--device",
            "cpu",
            "--field",
            s(&field),
            "--points",
            s(&points),
            "--json",
            s(&report),
        ],
        dir.path(),
    );
    let (header, found) = rows(&out);
    assert_eq!(
        header.join(","),
        "id,X,Y,Z,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z",
        "{out}"
    );
    assert_eq!(found.len(), OFF_NODES.len());
    for row in &found {
        assert_eq!(row.len(), header.len(), "{row:?}");
    }
    assert!(json_result(&report)["uncertainty"].is_null());
    if let Some(output) = super::json::validated("sample", &[report]) {
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stdout)
        );
    }
}

#[test]
fn the_report_records_the_fields_method() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(
        dir.path(),
        "mc.exr",
        &["--uncertainty-samples", "200", "--seed", "3"],
    );
    let points = points_csv(dir.path(), "");
    let report = dir.path().join("r.json");
    let csv = dir.path().join("s.csv");
    let stdout = succeeds(
        &[
            "sample",
            "--device",
            "cpu",
            "--field",
            s(&field),
            "--points",
            s(&points),
            "--out",
            s(&csv),
            "--json",
            s(&report),
        ],
        dir.path(),
    );
    assert!(
        stdout.contains("with the uncertainty of VE it holds"),
        "{stdout}"
    );
    let result = json_result(&report);
    let method = result["uncertainty"]["method"].as_str().unwrap();
    assert!(method.contains("200 draws, seed 3"), "{method}");
    assert_eq!(result["uncertainty"]["from"], "field");
    let (header, found) = rows(&std::fs::read_to_string(&csv).unwrap());
    assert_eq!(found.len(), OFF_NODES.len());
    assert!(header.iter().any(|h| h == "u(VE.X)"), "{header:?}");
    // The report keeps to its schema (docs/schema/sample.json).
    if let Some(output) = super::json::validated("sample", &[report]) {
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stdout)
        );
    }
}

#[test]
fn a_field_read_in_slabs_samples_the_same_uncertainties() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "u.exr", &["--uncertainty"]);
    let points = points_csv(dir.path(), "");
    let run = |memory: Option<&str>| {
        let mut command = volmap();
        command
            .args(["sample", "--device", "cpu", "--field"])
            .arg(&field)
            .arg("--points")
            .arg(&points);
        if let Some(bytes) = memory {
            command.env("VOLMAP_FIELD_MEMORY_BYTES", bytes);
        }
        let output = command.output().unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout).unwrap()
    };
    let whole = run(None);
    // Two z planes of 5×5 points at 24 bytes: slabs of two planes, three of them.
    let slabs = run(Some("1200"));
    let (header, found) = rows(&whole);
    assert_eq!(found.len(), OFF_NODES.len());
    assert!(header.iter().any(|h| h == "u(VE.Z)"), "{header:?}");
    assert_eq!(slabs, whole);
}

/// A sweep holds a part of uncertainties per pose: each point is sampled in its own pose's.
#[test]
fn a_sweep_samples_the_uncertainties_of_each_points_pose() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("machines/5axis-hwang2014.toml"),
    )
    .unwrap();
    assert!(text.contains("\nEXS = 0.001\n"), "the machine file changed");
    let m = dir.path().join("h.toml");
    std::fs::write(
        &m,
        text.replacen(
            "\nEXS = 0.001\n",
            "\nEXS = { value = 0.001, u = 1e-3 }\n",
            1,
        ),
    )
    .unwrap();
    let field = dir.path().join("sweep.exr");
    succeeds(
        &[
            "map",
            "--machine",
            s(&m),
            "--grid",
            "4x4x3",
            "--poses",
            "B=0:30:30",
            "--device",
            "cpu",
            "--uncertainty",
            "--out",
            s(&field),
        ],
        dir.path(),
    );
    // Grid nodes (trilinear interpolation gives the node's value), each at both poses.
    let info = volmap::io::field::FieldFile::open(&field).unwrap().info(0);
    let node = |ijk: [usize; 3]| -> [f64; 3] {
        std::array::from_fn(|d| info.origin_mm[d] + ijk[d] as f64 * info.spacing_mm[d])
    };
    let nodes = [node([0, 0, 0]), node([3, 1, 2]), node([1, 3, 1])];
    let mut text = String::from("X,Y,Z,B\n");
    for b in [0, 30] {
        for [x, y, z] in nodes {
            text.push_str(&format!("{x},{y},{z},{b}\n"));
        }
    }
    let points = dir.path().join("p.csv");
    std::fs::write(&points, text).unwrap();
    let sampled = succeeds(
        &[
            "sample",
            "--device",
            "cpu",
            "--field",
            s(&field),
            "--points",
            s(&points),
        ],
        dir.path(),
    );
    let exact = succeeds(
        &[
            "sample",
            "--exact",
            "--machine",
            s(&m),
            "--points",
            s(&points),
            "--uncertainty",
        ],
        dir.path(),
    );
    let ((header, found), (exact_header, expected)) = (rows(&sampled), rows(&exact));
    assert_eq!(found.len(), 2 * nodes.len());
    assert_eq!(expected.len(), found.len());
    for (row, exact) in found.iter().zip(&expected) {
        for column in ["u(VE.X)", "u(VE.Y)", "u(VE.Z)"] {
            let (u, reference) = (
                value(&header, row, column),
                value(&exact_header, exact, column),
            );
            assert!(
                (u - reference).abs() < 1e-6,
                "{row:?} {column}: field {u}, exact {reference}"
            );
        }
    }
    // The poses' uncertainties differ (the spindle's offset turns with B): the part matters.
    let u_x = |row: &Vec<String>| value(&header, row, "u(VE.X)");
    assert!(
        (u_x(&found[0]) - u_x(&found[nodes.len()])).abs() > 1e-5,
        "{found:?}"
    );
}

#[test]
fn plot_slice_draws_the_uncertainty_of_ve() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "u.exr", &["--uncertainty"]);
    let svg = dir.path().join("u.svg");
    let png = dir.path().join("u.png");
    succeeds(
        &[
            "plot",
            "slice",
            "--field",
            s(&field),
            "--quantity",
            "u",
            "--out",
            s(&svg),
            "--out",
            s(&png),
        ],
        dir.path(),
    );
    let drawn = std::fs::read_to_string(&svg).unwrap();
    assert!(drawn.contains("u(VE) (mm)"), "the colour bar's label");
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
    super::assert_finite_svg(&svg);
    // The plane's values: |u(VE)| = y·u(EC0Y) at every node (u(VE.Y) = u(VE.Z) = 0).
    let slice = volmap::query::field_slice(&field, "z", None, "u").unwrap();
    assert_eq!((slice.cols, slice.rows), (5, 5));
    assert_eq!(slice.values.len(), 25);
    assert!(!slice.signed);
    for (n, v) in slice.values.iter().enumerate() {
        let y = (n / slice.cols) as f64 * 100.0;
        assert!((v - y * U_EC0Y_RAD).abs() < 1e-6, "node {n}: {v}");
    }
    let channel = volmap::query::field_slice(&field, "x", None, "U(ve.x)").unwrap();
    assert_eq!(channel.unit, "u(VE.X) (mm)");
    assert_eq!(channel.values.len(), 5 * 4);
    for (n, v) in channel.values.iter().enumerate() {
        let y = (n % channel.cols) as f64 * 100.0;
        assert!((v - y * U_EC0Y_RAD).abs() < 1e-6, "node {n}: {v}");
    }
}

#[test]
fn plot_slice_of_u_without_uncertainties_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "plain.exr", &[]);
    let out = dir.path().join("u.svg");
    for quantity in ["u", "u(OE.Z)"] {
        refused(
            &[
                "plot",
                "slice",
                "--field",
                s(&field),
                "--quantity",
                quantity,
                "--out",
                s(&out),
            ],
            dir.path(),
            &["--quantity", "plain.exr", "--uncertainty"],
        );
        assert!(!out.exists());
    }
    refused(
        &[
            "plot",
            "slice",
            "--field",
            s(&field),
            "--quantity",
            "u(VE.W)",
            "--out",
            s(&out),
        ],
        dir.path(),
        &["--quantity", "u(VE.X)"],
    );
}
