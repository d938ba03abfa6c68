//! `volmap sample --exact --uncertainty` and `--uncertainty-samples`: the columns of the standard
//! uncertainty of VE, first order and by Monte Carlo; and every machine file whose uncertainties
//! cannot hold, refused naming the key.

use std::path::{Path, PathBuf};

use super::{refused, s, succeeds};

/// A 3-axis FYXFZ machine with a squareness EC0Y of u 2 µrad, the positioning of X a linear
/// table with u per node, and `extra` at the end of the file.
fn machine(dir: &Path, name: &str, x: &str, extra: &str) -> PathBuf {
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n{x}\n\
         [axes.Y]\nrange = [0.0, 400.0]\nEC0Y = {{ value = 1.8e-5, u = 2e-6 }}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n{extra}\n"
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

const TABLE: &str =
    "EXX = { table = [[0, 0.0], [200, 0.01], [400, 0.02]], u = [1e-3, 3e-3, 2e-3] }";

/// The rows of a CSV answer: header, then values by column name.
fn rows(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn value(header: &[String], row: &[String], column: &str) -> f64 {
    let n = header.iter().position(|h| h == column).unwrap();
    row[n].parse().unwrap()
}

/// On FYXFZ `VE.x = EXX(x) − y·sin EC0Y`: at x = 100 (halfway between the nodes at 0 and 200)
/// and y = 300, `u(VE.x)² = 0.25·(1e-3)² + 0.25·(3e-3)² + (300·cos(1.8e-5)·2e-6)²`; and
/// `u(VE.z) = 0`.
#[test]
fn first_order_columns_follow_the_chain() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(dir.path(), "m.toml", TABLE, "");
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "id,X,Y,Z\na,100,300,50\nb,200,0,0\n").unwrap();
    let out = succeeds(
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
    let (header, rows) = rows(&out);
    assert_eq!(
        header.join(","),
        "id,X,Y,Z,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z,u(VE.X),u(VE.Y),u(VE.Z)"
    );
    assert_eq!(rows.len(), 2);
    let squareness = 300.0 * 1.8e-5f64.cos() * 2e-6;
    let want = (0.25 * 1e-6 + 0.25 * 9e-6 + squareness * squareness).sqrt();
    let got = value(&header, &rows[0], "u(VE.X)");
    assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    assert!(value(&header, &rows[0], "u(VE.Z)").abs() < 1e-15);
    // At the node x = 200 with y = 0: its u alone.
    let got = value(&header, &rows[1], "u(VE.X)");
    assert!((got - 3e-3).abs() < 1e-12, "{got}");
}

/// Monte Carlo over 4000 machines agrees with first order within 4 of its standard errors
/// (`s/sqrt(2(N−1))`), and says how many machines and which seed.
#[test]
fn monte_carlo_columns_agree_with_first_order() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(
        dir.path(),
        "m.toml",
        TABLE,
        "[spindle]\nEXS = { value = 0.0, u = 1e-3 }\n[covariance]\n\"axes.Y.EC0Y spindle.EXS\" = -1e-9\n",
    );
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n100,300,50\n350,120,280\n").unwrap();
    let base = [
        "sample",
        "--exact",
        "--machine",
        s(&m),
        "--points",
        s(&points),
    ];
    let first = succeeds(&super::with(&base, &["--uncertainty"]), dir.path());
    let output = super::volmap()
        .args(base)
        .args(["--uncertainty-samples", "4000", "--seed", "11"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("4000 machines (seed 11)"), "{stderr}");
    let (header, first) = rows(&first);
    let (mc_header, mc) = rows(&String::from_utf8_lossy(&output.stdout));
    assert_eq!(header, mc_header);
    assert_eq!((first.len(), mc.len()), (2, 2));
    for (f, m) in first.iter().zip(&mc) {
        for column in ["u(VE.X)", "u(VE.Y)"] {
            let (want, got) = (value(&header, f, column), value(&header, m, column));
            let se = got / (2.0f64 * 3999.0).sqrt();
            assert!(
                want > 0.0 && (got - want).abs() <= 4.0 * se,
                "{column}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn uncertainty_is_refused_on_the_gpu_and_without_exact() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(dir.path(), "m.toml", TABLE, "");
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n100,300,50\n").unwrap();
    let base = [
        "sample",
        "--exact",
        "--machine",
        s(&m),
        "--points",
        s(&points),
    ];
    for flags in [&["--uncertainty"][..], &["--uncertainty-samples", "100"]] {
        let args = super::with(&super::with(&base, flags), &["--device", "gpu"]);
        refused(&args, dir.path(), &[flags[0], "CPU only"]);
    }
    refused(
        &[
            "sample",
            "--field",
            "f.exr",
            "--points",
            s(&points),
            "--uncertainty",
        ],
        dir.path(),
        &["--exact"],
    );
    refused(
        &super::with(&base, &["--uncertainty-samples", "1"]),
        dir.path(),
        &["--uncertainty-samples"],
    );
}

/// Every machine file whose uncertainties cannot hold: exit 2, the key named.
#[test]
fn bad_uncertainties_are_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.csv"),
        "x,EXX,uEXX\n0,0.0,1e-3\n200,0.01,-2e-3\n",
    )
    .unwrap();
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n100,300,50\n").unwrap();
    let cases: [(&str, &str, &[&str]); 10] = [
        (
            "EXX = { table = [[0, 0.0], [200, 0.01]], u = [1e-3] }",
            "",
            &["axes.X.EXX.u", "1 standard uncertainties for a table of 2 nodes"],
        ),
        (
            "EXX = { value = 0.0, u = -1e-3 }",
            "",
            &["axes.X.EXX.u", "negative"],
        ),
        (
            "EXX = { csv = \"t.csv\", u_column = \"u_EXX\" }",
            "",
            &["axes.X.EXX", "t.csv", "line 1", "u_EXX"],
        ),
        (
            "EXX = { csv = \"t.csv\", u_column = \"uEXX\" }",
            "",
            &["axes.X.EXX", "t.csv", "line 3", "negative"],
        ),
        (
            "",
            "[covariance]\n\"axes.Y.EC0Y axes.Z.EB0Z\" = 1e-12\n",
            &["covariance.\"axes.Y.EC0Y axes.Z.EB0Z\"", "axes.Z.EB0Z", "no error value"],
        ),
        (
            TABLE,
            "[covariance]\n\"axes.Y.EC0Y axes.X.EXX\" = 1e-12\n",
            &["covariance.\"axes.Y.EC0Y axes.X.EXX\"", "is a table"],
        ),
        (
            "EX0X = 0.001",
            "[covariance]\n\"axes.X.EX0X axes.Y.EC0Y\" = 1e-12\n",
            &["covariance.\"axes.X.EX0X axes.Y.EC0Y\"", "carries no u"],
        ),
        (
            "EX0X = { value = 0.0, u = 1e-3 }",
            "[covariance]\n\"axes.X.EX0X axes.Y.EC0Y\" = 3e-9\n",
            &["\"axes.X.EX0X axes.Y.EC0Y\"", "not positive semi-definite"],
        ),
        (
            "EX0X = { value = 0.0, u = 1e-3 }\nEY0X = { value = 0.0, u = 1e-3 }",
            "[covariance]\n\"axes.X.EX0X axes.X.EY0X\" = 1e-6\n\"axes.X.EX0X axes.Y.EC0Y\" = 2e-9\n\"axes.X.EY0X axes.Y.EC0Y\" = -2e-9\n",
            &["not positive semi-definite", "axes.X.EY0X axes.Y.EC0Y"],
        ),
        (
            "EXX = { poly = [0.0, 1e-5], u = 1e-3, u_scale = 1e-6 }",
            "",
            &["axes.X.EXX.u_scale", "goes with a table"],
        ),
    ];
    for (n, (x, extra, says)) in cases.iter().enumerate() {
        let m = machine(dir.path(), &format!("m{n}.toml"), x, extra);
        refused(
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
            says,
        );
    }
}
