//! `volmap budget` and `features --tolerances`: the error budget, Monte Carlo, allocation, the
//! probability that a part conforms; every bad tolerance file refused with the file and the key named.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use super::volmap;
use crate::common::gpu;

fn example(machine: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/tolerances")
        .join(format!("{machine}.toml"))
}

fn read_json(path: &Path) -> serde_json::Value {
    super::json_result(path)
}

#[test]
fn every_embedded_machine_has_an_example_tolerance_file_that_budgets() {
    for machine in [
        "vmc-li2015",
        "vmc-dobariya2015",
        "5axis-hwang2014",
        "4axis-hwang2014",
    ] {
        volmap()
            .args([
                "budget",
                "--machine",
                machine,
                "--grid",
                "5x4x3",
                "--device",
                "cpu",
            ])
            .arg("--tolerances")
            .arg(example(machine))
            .assert()
            .success()
            .stderr(predicate::str::contains("error").not())
            .stdout(
                predicate::str::contains("Error budget of")
                    .and(predicate::str::contains("total (root sum of squares")),
            );
    }
}

#[test]
fn budget_json_plot_and_monte_carlo_with_per_sample_rows() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("b.json");
    let csv = dir.path().join("samples.csv");
    let plot = dir.path().join("b.svg");
    volmap()
        .args([
            "budget",
            "--machine",
            "vmc-li2015",
            "--grid",
            "6x5x4",
            "--samples",
            "64",
            "--spec",
            "0.13",
            "--seed",
            "3",
            "--device",
            "cpu",
        ])
        .arg("--tolerances")
        .arg(example("vmc-li2015"))
        .arg("--json")
        .arg(&json)
        .arg("--per-sample")
        .arg(&csv)
        .arg("--plot")
        .arg(&plot)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("Monte Carlo: 64 machines")
                .and(predicate::str::contains("within 130.000 µm")),
        );
    let v = read_json(&json);
    let rows = v["budget"].as_array().unwrap();
    assert_eq!(rows.len(), 14);
    let max: Vec<f64> = rows
        .iter()
        .map(|r| r["max_ve_mm"].as_f64().unwrap())
        .collect();
    assert!(max.windows(2).all(|w| w[0] >= w[1]), "sorted: {max:?}");
    let total: f64 = max.iter().map(|m| m * m).sum::<f64>().sqrt();
    assert!((v["total_rss_mm"].as_f64().unwrap() - total).abs() < 1e-12);
    for key in [
        "term",
        "limit",
        "rms_ve_mm",
        "max_oe_rad",
        "max_ve_axis_mm",
        "share",
        "worst_at",
    ] {
        assert!(!rows[0][key].is_null(), "{key}");
    }
    assert_eq!(rows[0]["term"], "axes.Y.EC0Y");
    assert_eq!(rows[0]["limit"], 2e-5);
    assert_eq!(rows[0]["worst_at"]["Y"], 600.0);
    let mc = &v["monte_carlo"];
    assert_eq!(mc["samples"], 64);
    assert_eq!(mc["seed"], 3);
    for stat in ["max_ve_mm", "rms_ve_mm", "max_oe_rad"] {
        for key in ["mean", "std", "p5", "p50", "p95", "p99"] {
            assert!(mc[stat][key].as_f64().is_some(), "{stat}.{key}");
        }
        let s = &mc[stat];
        assert!(s["p5"].as_f64() <= s["p50"].as_f64() && s["p50"].as_f64() <= s["p99"].as_f64());
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 65);
    assert!(lines[0].starts_with("sample,max_ve_mm,"));
    assert!(lines[0].contains("axes.Y.EC0Y"));
    // The per-sample maxima are the ones the summary counts.
    let below = lines[1..]
        .iter()
        .filter(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap() <= 0.13)
        .count();
    let fraction = mc["within_spec"]["fraction"].as_f64().unwrap();
    assert_eq!(fraction, below as f64 / 64.0);
    let ci = mc["within_spec"]["ci95"].as_array().unwrap();
    assert!(ci[0].as_f64().unwrap() <= fraction && fraction <= ci[1].as_f64().unwrap());
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.contains("axes.Y.EC0Y") && svg.contains("machines"));
}

#[test]
fn the_gpu_and_the_cpu_draw_the_same_machines_for_the_same_seed() {
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut per_sample = Vec::new();
    for device in ["cpu", "gpu"] {
        let csv = dir.path().join(format!("{device}.csv"));
        volmap()
            .args([
                "budget",
                "--machine",
                "5axis-hwang2014",
                "--grid",
                "7x5x4",
                "--poses",
                "B=-45:45:45,C=90",
                "--samples",
                "25",
                "--seed",
                "11",
                "--device",
                device,
            ])
            .arg("--tolerances")
            .arg(example("5axis-hwang2014"))
            .arg("--per-sample")
            .arg(&csv)
            .assert()
            .success();
        per_sample.push(std::fs::read_to_string(&csv).unwrap());
    }
    let rows = |text: &str| -> Vec<Vec<f64>> {
        text.lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let (cpu, gpu) = (rows(&per_sample[0]), rows(&per_sample[1]));
    assert_eq!(cpu.len(), 25);
    assert_eq!(gpu.len(), cpu.len());
    for (c, g) in cpu.iter().zip(&gpu) {
        // Statistics to the stated tolerances; the draws identical.
        for k in [1, 2, 4, 5, 6] {
            assert!((c[k] - g[k]).abs() < 1e-6, "{c:?} vs {g:?}");
        }
        assert!((c[3] - g[3]).abs() < 1e-9);
        assert_eq!(c[12..], g[12..]);
    }
}

#[test]
fn allocation_writes_the_scaled_tolerance_file_that_meets_the_spec() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scaled.toml");
    let json = dir.path().join("a.json");
    let tolerances = dir.path().join("t.toml");
    // One squareness on an error-free gantry: max |VE| = |s|·600, s ~ U(−h, h). 90% of the
    // machines within 0.006 mm needs 0.9·h·600 = 0.006: h = 1.111e-5, a factor of 0.5556 on 2e-5.
    std::fs::write(
        &tolerances,
        "# squareness\n[axes.Y]\nEC0Y = { uniform = 2e-5 } # Y to X\n",
    )
    .unwrap();
    let machine = dir.path().join("gantry.toml");
    std::fs::write(
        &machine,
        "name = \"gantry\"\nchain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 1000.0]\n[axes.Y]\nrange = [0.0, 600.0]\n[axes.Z]\nrange = [0.0, 500.0]\n",
    )
    .unwrap();
    volmap()
        .args([
            "budget",
            "--grid",
            "3x4x2",
            "--samples",
            "4000",
            "--spec",
            "0.006",
        ])
        .args([
            "--confidence",
            "0.9",
            "--allocate",
            "--device",
            "cpu",
            "--machine",
        ])
        .arg(&machine)
        .arg("--tolerances")
        .arg(&tolerances)
        .arg("--out")
        .arg(&out)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(predicate::str::contains("largest factor"));
    let v = read_json(&json);
    let factor = v["allocation"]["factor"].as_f64().unwrap();
    // The 90th percentile of 4000 uniform draws lies within about 1% of its value.
    assert!((factor - 0.5556).abs() < 0.02, "{factor}");
    assert!(v["allocation"]["fraction"].as_f64().unwrap() >= 0.9);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("# squareness") && text.contains("# Y to X"),
        "{text}"
    );
    let width: f64 = text
        .split("uniform = ")
        .nth(1)
        .and_then(|r| r.split([' ', '}']).next())
        .unwrap()
        .parse()
        .unwrap();
    assert!((width - 2e-5 * factor).abs() < 1e-10, "{width}");
    // The scaled file meets the spec at the confidence on the same draws.
    let check = dir.path().join("check.json");
    volmap()
        .args([
            "budget",
            "--grid",
            "3x4x2",
            "--samples",
            "4000",
            "--spec",
            "0.006",
            "--device",
            "cpu",
        ])
        .arg("--machine")
        .arg(&machine)
        .arg("--tolerances")
        .arg(&out)
        .arg("--json")
        .arg(&check)
        .assert()
        .success();
    let within = read_json(&check)["monte_carlo"]["within_spec"]["fraction"]
        .as_f64()
        .unwrap();
    assert!(within >= 0.9 - 1e-3, "{within}");
}

#[test]
fn bad_tolerance_files_name_the_file_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "[axes.Y]\nEXW = { uniform = 0.001 }",
            "axes.Y.EXW",
            "not an error of this machine",
        ),
        (
            "[axes.Y]\nEXX = { uniform = 0.001 }",
            "axes.Y.EXX",
            "an error of axis X",
        ),
        (
            "[axes.B]\nEXB = { uniform = 0.001 }",
            "axes.B",
            "names no axis",
        ),
        (
            "[spindle]\nECS = { uniform = 0.001 }",
            "spindle.ECS",
            "not an error of the spindle",
        ),
        (
            "[axes.Y]\nEC0Y = { uniform = 1e-5, shape = \"line\" }",
            "axes.Y.EC0Y.shape",
            "location",
        ),
        (
            "[spindle]\nEZS = { normal = 0.001, shape = \"bow\" }",
            "spindle.EZS.shape",
            "spindle",
        ),
        (
            "[axes.Y]\nEXY = { uniform = -0.001 }",
            "axes.Y.EXY.uniform",
            "negative",
        ),
        (
            "[axes.Y]\nEXY = { normal = nan }",
            "axes.Y.EXY.normal",
            "not a finite width",
        ),
        (
            "[axes.Y]\nEXY = { normal = inf }",
            "axes.Y.EXY.normal",
            "not a finite width",
        ),
        (
            "[axes.Y]\nEXY = { triangular = 0.001 }",
            "axes.Y.EXY.triangular",
            "unknown distribution",
        ),
        (
            "[axes.Y]\nEXY = { uniform = 0.001, normal = 0.001 }",
            "axes.Y.EXY",
            "two distributions",
        ),
        (
            "[axes.Y]\nEXY = { shape = \"bow\" }",
            "axes.Y.EXY",
            "no distribution",
        ),
        (
            "[axes.Y]\nEXY = { uniform = 0.001, shape = \"arc\" }",
            "axes.Y.EXY.shape",
            "unknown shape",
        ),
        ("[axes.Y]\nEXY = 0.001", "axes.Y.EXY", "expected { uniform"),
        (
            "[axes.Y]\nEXY = { uniform = \"big\" }",
            "axes.Y.EXY.uniform",
            "expected a number",
        ),
        (
            "[tool]\nEXY = { uniform = 0.001 }",
            "tool",
            "unknown section",
        ),
        ("[axes.Y]\nEXY = { uniform = 0.001", "t.toml", ""),
        ("# nothing\n", "names no tolerance", ""),
    ];
    let path = dir.path().join("t.toml");
    for (text, key, message) in cases {
        std::fs::write(&path, text).unwrap();
        volmap()
            .args([
                "budget",
                "--machine",
                "vmc-li2015",
                "--grid",
                "3x3x3",
                "--device",
                "cpu",
            ])
            .arg("--tolerances")
            .arg(&path)
            .assert()
            .code(2)
            .stdout(predicate::str::is_empty())
            .stderr(
                predicate::str::contains("--tolerances")
                    .and(predicate::str::contains("t.toml"))
                    .and(predicate::str::contains(key))
                    .and(predicate::str::contains(message)),
            );
    }
    volmap()
        .args([
            "budget",
            "--machine",
            "vmc-li2015",
            "--device",
            "cpu",
            "--tolerances",
        ])
        .arg(dir.path().join("missing.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("missing.toml"));
}

#[test]
fn bad_budget_values_name_their_flag() {
    let tolerances = example("vmc-li2015");
    let run = |args: &[&str], flag: &str| {
        volmap()
            .args([
                "budget",
                "--machine",
                "vmc-li2015",
                "--grid",
                "3x3x3",
                "--device",
                "cpu",
            ])
            .arg("--tolerances")
            .arg(&tolerances)
            .args(args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(flag));
    };
    run(&["--samples", "10", "--spec", "-1"], "--spec");
    run(
        &[
            "--samples",
            "10",
            "--spec",
            "0.1",
            "--confidence",
            "1.5",
            "--allocate",
        ],
        "--confidence",
    );
    run(&["--samples", "0"], "--samples");
    run(&["--spec", "0.1"], "--samples");
    run(&["--samples", "10", "--allocate"], "--spec");
    run(
        &[
            "--samples",
            "10",
            "--spec",
            "0.2",
            "--allocate",
            "--allocate-terms",
            "EXW",
        ],
        "--allocate-terms",
    );
    run(&["--plot", "b.gif"], "--plot");
    run(&["--poses", "C=0:90:30"], "--poses");
    run(&["--pose", "B=10", "--poses", "B=0"], "--pose");
}

#[test]
fn features_on_sampled_machines_give_each_features_conforming_fraction() {
    let dir = tempfile::tempdir().unwrap();
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut outputs = Vec::new();
    let devices: &[&str] = if gpu().is_some() {
        &["cpu", "gpu"]
    } else {
        &["cpu"]
    };
    for device in devices {
        let json = dir.path().join(format!("{device}.json"));
        volmap()
            .args([
                "features",
                "--machine",
                "vmc-li2015",
                "--samples",
                "40",
                "--seed",
                "4",
            ])
            .args(["--device", device, "--part"])
            .arg(examples.join("li2015-part.toml"))
            .arg("--tolerances")
            .arg(example("vmc-li2015"))
            .arg("--json")
            .arg(&json)
            .assert()
            .success()
            .stdout(
                predicate::str::contains("40 machines").and(predicate::str::contains("conforming")),
            );
        outputs.push(read_json(&json));
    }
    let rows = outputs[0].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for row in rows {
        let fraction = row["conforming_fraction"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&fraction));
        assert!(row["error_p95_mm"].as_f64().unwrap() >= row["error_p50_mm"].as_f64().unwrap());
        assert_eq!(
            row["verdict"],
            if fraction >= 0.95 { "fit" } else { "unfit" }
        );
    }
    if let [cpu, gpu] = &outputs[..] {
        assert_eq!(cpu.as_array().unwrap().len(), gpu.as_array().unwrap().len());
        for (c, g) in cpu.as_array().unwrap().iter().zip(gpu.as_array().unwrap()) {
            assert_eq!(c["conforming_fraction"], g["conforming_fraction"]);
            let (a, b) = (
                c["error_p95_mm"].as_f64().unwrap(),
                g["error_p95_mm"].as_f64().unwrap(),
            );
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }
    // A tolerance no machine can hold: exit code 3, the feature unfit.
    let part = dir.path().join("part.toml");
    std::fs::write(
        &part,
        std::fs::read_to_string(examples.join("li2015-part.toml"))
            .unwrap()
            .replace("tolerance_mm = 0.05", "tolerance_mm = 0.0056"),
    )
    .unwrap();
    volmap()
        .args([
            "features",
            "--machine",
            "vmc-li2015",
            "--samples",
            "30",
            "--device",
            "cpu",
        ])
        .arg("--part")
        .arg(&part)
        .arg("--tolerances")
        .arg(example("vmc-li2015"))
        .assert()
        .code(3)
        .stdout(predicate::str::contains("unfit"));
    // Bad input: exit code 2 naming the flag.
    std::fs::write(
        dir.path().join("bad.toml"),
        "[axes.Q]\nEXQ = { uniform = 1 }",
    )
    .unwrap();
    volmap()
        .args([
            "features",
            "--machine",
            "vmc-li2015",
            "--samples",
            "3",
            "--device",
            "cpu",
        ])
        .arg("--part")
        .arg(examples.join("li2015-part.toml"))
        .arg("--tolerances")
        .arg(dir.path().join("bad.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--tolerances").and(predicate::str::contains("axes.Q")));
    volmap()
        .args([
            "features",
            "--machine",
            "vmc-li2015",
            "--device",
            "cpu",
            "--part",
        ])
        .arg(examples.join("li2015-part.toml"))
        .arg("--tolerances")
        .arg(example("vmc-li2015"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--samples"));
}
