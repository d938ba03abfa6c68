//! The `volmap` binary as a user runs it.

use assert_cmd::Command;
use predicates::prelude::*;

fn volmap() -> Command {
    Command::cargo_bin("volmap").unwrap()
}

#[test]
fn machines_lists_the_embedded_machines() {
    volmap().arg("machines").assert().success().stdout(
        predicate::str::contains("vmc-li2015")
            .and(predicate::str::contains("FYXCFZB"))
            .and(predicate::str::contains("4axis-hwang2014"))
            .and(predicate::str::contains("vmc-dobariya2015")),
    );
}

#[test]
fn map_check_and_info_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "9x7x5",
            "--pose",
            "B=30,C=45",
            "--device",
            "cpu",
            "--check",
            "20",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("315 points")
                .and(predicate::str::contains("max |VE|"))
                .and(predicate::str::contains("RMS |VE|"))
                .and(predicate::str::contains("Mpts/s"))
                .and(predicate::str::contains("check       20 points"))
                .and(predicate::str::contains(": ok")),
        );
    volmap().arg("info").arg(&out).assert().success().stdout(
        predicate::str::contains("FYXCFZB")
            .and(predicate::str::contains("pose B=30° C=45°"))
            .and(predicate::str::contains("315 points")),
    );
}

#[test]
fn map_defaults_write_volmap_field_exr() {
    let dir = tempfile::tempdir().unwrap();
    volmap()
        .current_dir(dir.path())
        .args(["map", "--grid", "4x4x4", "--device", "cpu"])
        .assert()
        .success()
        .stdout(predicate::str::contains("3-axis VMC (Li et al. 2015"));
    assert!(dir.path().join("volmap-field.exr").exists());
}

#[test]
fn the_auto_device_maps_on_whatever_there_is() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("auto.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "4axis-hwang2014",
            "--grid",
            "6x6x3",
            "--pose",
            "C=90",
            "--check",
            "30",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success()
        .stdout(predicate::str::contains(": ok"));
}

#[test]
fn bad_machine_files_exit_2_naming_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("broken.toml");
    std::fs::write(&machine, "name = \"m\"\nchain = \"FXFZ\"\n[axes.X]\nrange = [0, 100]\nEXX = nan\n[axes.Z]\nrange = [0, 10]\n").unwrap();
    volmap()
        .args(["map", "--device", "cpu", "--machine"])
        .arg(&machine)
        .arg("--out")
        .arg(dir.path().join("x.exr"))
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("broken.toml")
                .and(predicate::str::contains("axes.X.EXX"))
                .and(predicate::str::contains("not a finite number")),
        );
    assert!(!dir.path().join("x.exr").exists());
}

#[test]
fn bad_command_line_values_exit_2() {
    let cases: [(&[&str], &str); 6] = [
        (&["--grid", "10x10"], "--grid"),
        (&["--grid", "0x4x4"], "--grid"),
        (
            &["--machine", "5axis-hwang2014", "--pose", "B=200"],
            "outside its range",
        ),
        (&["--pose", "C=10"], "not an axis of this machine"),
        (&["--machine", "nonexistent"], "no embedded machine"),
        (&["--out", "field.png"], ".exr"),
    ];
    for (args, message) in cases {
        volmap()
            .arg("map")
            .args(["--device", "cpu"])
            .args(args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(message));
    }
    volmap()
        .args(["map", "--device", "quantum"])
        .assert()
        .code(2);
}

#[test]
fn info_on_a_file_that_is_not_a_field_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.exr");
    std::fs::write(&path, "text").unwrap();
    volmap()
        .arg("info")
        .arg(&path)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("x.exr"));
}

#[test]
fn without_an_adapter_auto_says_so_once_and_maps_on_the_cpu() {
    // WGPU_BACKEND=gl names a backend this build does not have: no adapter.
    let dir = tempfile::tempdir().unwrap();
    let assert = volmap()
        .env("WGPU_BACKEND", "gl")
        .args(["map", "--grid", "5x4x3", "--check", "10", "--out"])
        .arg(dir.path().join("cpu.exr"))
        .assert()
        .success()
        .stdout(predicate::str::contains("CPU, f64 (").and(predicate::str::contains(": ok")));
    let stderr = String::from_utf8_lossy(&assert.get_output().stderr).into_owned();
    assert_eq!(
        stderr.matches("no GPU adapter found").count(),
        1,
        "{stderr}"
    );
    volmap()
        .env("WGPU_BACKEND", "gl")
        .args(["map", "--grid", "5x4x3", "--device", "gpu", "--out"])
        .arg(dir.path().join("gpu.exr"))
        .assert()
        .code(1)
        .stderr(predicate::str::contains("no GPU adapter found"));
}

#[test]
fn a_unit_mistake_the_gpu_refuses_points_to_the_cpu_engine() {
    // The library says why (error rotations beyond the kernels' series); the command line adds
    // the flag that maps such a machine anyway.
    if super::common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("degrees.toml");
    std::fs::write(
        &machine,
        "name = \"5 degrees written as rad\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0, 100]\n[axes.Y]\nrange = [0, 100]\nEC0Y = 5.0\n[axes.Z]\nrange = [0, 100]\n",
    )
    .unwrap();
    volmap()
        .args(["map", "--grid", "4x4x4", "--device", "gpu", "--machine"])
        .arg(&machine)
        .arg("--out")
        .arg(dir.path().join("f.exr"))
        .assert()
        .code(1)
        .stderr(
            predicate::str::contains("below 0.1 rad").and(predicate::str::contains("--device cpu")),
        );
}

#[test]
fn bench_prints_a_table_and_writes_json() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    volmap()
        .args([
            "bench",
            "--machines",
            "vmc-li2015,5axis-hwang2014",
            "--grid",
            "16x8x4",
            "--reference-points",
            "50",
            "--json",
        ])
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("f64 reference, 1 thread")
                .and(predicate::str::contains("CPU engine"))
                .and(predicate::str::contains("EXR write"))
                .and(predicate::str::contains("map to EXR, f64 reference")),
        );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let machines = report["machines"].as_array().unwrap();
    assert_eq!(machines.len(), 2);
    for m in machines {
        let paths = m["paths"].as_array().unwrap();
        assert_eq!(paths[0]["ratio_to_reference"].as_f64(), Some(1.0));
        for p in paths {
            assert!(p["mpts_per_s"].as_f64().unwrap() > 0.0, "{p}");
        }
        let gpu_paths = paths
            .iter()
            .filter(|p| p["path"].as_str().unwrap().starts_with("GPU"))
            .count();
        // With an adapter the GPU paths are there, each with its fraction of the ceiling.
        if report["adapter"].is_string() {
            assert_eq!(gpu_paths, 3);
            assert!(paths
                .iter()
                .filter(|p| p["path"].as_str().unwrap().starts_with("GPU"))
                .all(|p| p["fraction_of_ceiling"].is_number()));
            let ceiling = paths
                .iter()
                .find(|p| p["path"].as_str().unwrap().contains("write-only"))
                .unwrap();
            assert_eq!(ceiling["fraction_of_ceiling"].as_f64(), Some(1.0));
            for key in ["kernel_tiling", "ceiling_tiling"] {
                let tiling = m[key].as_str().unwrap();
                assert!(tiling.ends_with("per invocation"), "{key}: {tiling}");
            }
        } else {
            assert_eq!(gpu_paths, 0);
            assert!(m["kernel_tiling"].is_null() && m["ceiling_tiling"].is_null());
        }
    }
}

#[test]
fn sample_from_a_field_and_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "5x5x5",
            "--device",
            "cpu",
            "--out",
        ])
        .arg(&field)
        .assert()
        .success();
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n500,300,250\n0,0,0\n").unwrap();
    let out = dir.path().join("s.csv");
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("X,Y,Z,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z"));
    assert_eq!(lines.count(), 2);
    volmap()
        .args(["sample", "--exact", "--machine", "vmc-li2015", "--points"])
        .arg(&points)
        .assert()
        .success()
        .stdout(
            predicate::str::starts_with("X,Y,Z,VE.X").and(predicate::str::contains("500,300,250,")),
        );
    std::fs::write(&points, "X,Y,Z\n5000,0,0\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2: X=5000 lies outside"));
    volmap()
        .args(["sample", "--points"])
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--field"));
}

#[test]
fn exact_samples_take_the_pose_from_the_columns_or_from_pose() {
    let dir = tempfile::tempdir().unwrap();
    let with_columns = dir.path().join("a.csv");
    let without = dir.path().join("b.csv");
    std::fs::write(&with_columns, "X,Y,Z,B,C\n100,200,300,30,60\n").unwrap();
    std::fs::write(&without, "X,Y,Z\n100,200,300\n").unwrap();
    let run = |points: &std::path::Path, pose: &str| {
        let output = volmap()
            .args([
                "sample",
                "--exact",
                "--machine",
                "5axis-hwang2014",
                "--pose",
                pose,
                "--points",
            ])
            .arg(points)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let text = String::from_utf8(output.stdout).unwrap();
        let row: Vec<String> = text
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .map(str::to_string)
            .collect();
        row[row.len() - 6..].to_vec()
    };
    assert_eq!(run(&with_columns, ""), run(&without, "B=30,C=60"));
    assert_ne!(run(&without, ""), run(&without, "B=30,C=60"));
}

#[test]
fn features_rate_the_machine_from_the_model_or_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let example =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let json = dir.path().join("rows.json");
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&example)
        .arg("--json")
        .arg(&json)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("pocket floor").and(predicate::str::contains("inspect")));
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for row in rows {
        for key in [
            "name",
            "kind",
            "error_mm",
            "tolerance_mm",
            "safety",
            "verdict",
            "worst_point",
        ] {
            assert!(row.get(key).is_some(), "{key} missing in {row}");
        }
        let error = row["error_mm"].as_f64().unwrap();
        assert!(error > 0.0 && error < 0.1, "{row}");
    }

    // The same from a field over the part's region: close to the exact figures.
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "101x61x51",
            "--device",
            "cpu",
            "--out",
        ])
        .arg(&field)
        .assert()
        .success();
    let from_field = dir.path().join("field.json");
    volmap()
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&example)
        .arg("--json")
        .arg(&from_field)
        .assert()
        .code(0);
    let field_rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&from_field).unwrap()).unwrap();
    for (exact, sampled) in rows.iter().zip(field_rows.as_array().unwrap()) {
        let (e, s) = (
            exact["error_mm"].as_f64().unwrap(),
            sampled["error_mm"].as_f64().unwrap(),
        );
        assert!(
            (e - s).abs() < 0.05 * e + 1e-5,
            "{}: {e} exact, {s} from the field",
            exact["name"]
        );
    }

    // A tighter tolerance makes the machine unfit: exit code 3.
    let tight = dir.path().join("tight.toml");
    std::fs::write(
        &tight,
        std::fs::read_to_string(&example)
            .unwrap()
            .replace("tolerance_mm = 0.05", "tolerance_mm = 0.001"),
    )
    .unwrap();
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&tight)
        .assert()
        .code(3)
        .stdout(predicate::str::contains("unfit"));
    // A part beyond the mapped grid is an error naming the feature.
    let far = dir.path().join("far.toml");
    std::fs::write(
        &far,
        std::fs::read_to_string(&example).unwrap().replace(
            "zero_mm = [200.0, 150.0, 300.0]",
            "zero_mm = [900.0, 150.0, 300.0]",
        ),
    )
    .unwrap();
    volmap()
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&far)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("feature `pocket floor`")
                .and(predicate::str::contains("outside the mapped grid")),
        );
}

#[test]
fn sample_on_the_gpu_agrees_with_the_cpu_and_needs_an_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("field.exr");
    volmap()
        .args(["map", "--grid", "9x8x7", "--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    let points = dir.path().join("points.csv");
    std::fs::write(&points, "X,Y,Z\n10,20,30\n312.5,4.25,17\n0,0,0\n").unwrap();
    let sample = |device: &str| {
        let output = volmap()
            .args(["sample", "--device", device, "--field"])
            .arg(&field)
            .arg("--points")
            .arg(&points)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8(output.stdout).unwrap()
    };
    let on_cpu = sample("cpu");
    if super::common::sampler().is_some() {
        let on_gpu = sample("gpu");
        let rows = |text: &str| -> Vec<Vec<f64>> {
            text.lines()
                .skip(1)
                .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
                .collect()
        };
        let (a, b) = (rows(&on_cpu), rows(&on_gpu));
        assert_eq!(a.len(), 3);
        assert_eq!(on_cpu.lines().next(), on_gpu.lines().next());
        for (x, y) in a.iter().zip(&b) {
            for (u, v) in x.iter().zip(y) {
                assert!(
                    (u - v).abs() <= 1e-6 * u.abs().max(1e-6),
                    "{on_cpu}\n{on_gpu}"
                );
            }
        }
    }
    volmap()
        .env("WGPU_BACKEND", "gl")
        .args(["sample", "--device", "gpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(1)
        .stderr(predicate::str::contains("no GPU adapter found"));
}

#[test]
fn standard_tests_print_figures_compare_measurements_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    volmap()
        .args(["test", "positioning", "--axis", "X", "--targets", "6"])
        .assert()
        .success()
        .stdout(
            predicate::str::contains("ISO 230-2 positioning of X (6 targets, 5 runs each way)")
                .and(predicate::str::contains("A↑"))
                .and(predicate::str::contains(
                    "mean bidirectional positioning error",
                )),
        );
    // A measured circle: predicted and measured side by side, both plots and the JSON.
    let measured = dir.path().join("xy.csv");
    let mut text = String::from("angle_deg,deviation_um\n");
    for i in 0..36 {
        text += &format!("{},{}\n", 10 * i, (i as f64 / 3.0).sin());
    }
    std::fs::write(&measured, text).unwrap();
    let (svg, png, json) = (
        dir.path().join("c.svg"),
        dir.path().join("c.png"),
        dir.path().join("c.json"),
    );
    volmap()
        .args([
            "test",
            "circular",
            "--plane",
            "XY",
            "--radius",
            "100",
            "--measured",
        ])
        .arg(&measured)
        .arg("--plot")
        .arg(&svg)
        .arg("--plot")
        .arg(&png)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("measured µm")
                .and(predicate::str::contains("largest |measured − predicted|"))
                .and(predicate::str::contains("circular deviation")),
        );
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("radial deviation, measured"));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["positions"].as_array().unwrap().len(), 36);
    assert_eq!(report["figures"][0]["name"], "G");
    // Bad input: exit code 2 with the reason; nothing written.
    volmap()
        .args(["test", "diagonal", "--from", "0,0,0", "--to", "2000,0,0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("outside the travel of X"));
    volmap()
        .args(["test", "circular", "--plane", "XY", "--plot"])
        .arg(dir.path().join("c.gif"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains(".svg or .png"));
    volmap()
        .args(["test", "rtest", "--axis", "C"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("has no C axis"));
}

#[test]
fn build_and_fit_write_machine_files_that_map() {
    let dir = tempfile::tempdir().unwrap();
    let x = dir.path().join("x.csv");
    std::fs::write(
        &x,
        "position_mm,EXX_um,EBX_urad\n0,0,0\n250,3,1\n500,5,1.5\n750,6,1\n1000,6.5,0\n",
    )
    .unwrap();
    let built = dir.path().join("built.toml");
    volmap()
        .args(["build", "--base", "vmc-li2015", "--axis"])
        .arg(format!("X={}", x.display()))
        .arg("--out")
        .arg(&built)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("EXX").and(predicate::str::contains("best at leave-one-out")),
        );
    volmap()
        .args(["map", "--grid", "4x3x3", "--device", "cpu", "--machine"])
        .arg(&built)
        .arg("--out")
        .arg(dir.path().join("built.exr"))
        .assert()
        .success();
    // A circle measured on the built machine, fitted for the XY squareness.
    let circle = dir.path().join("xy.csv");
    let output = volmap()
        .args([
            "test", "circular", "--plane", "XY", "--points", "24", "--json",
        ])
        .arg(dir.path().join("xy.json"))
        .arg("--machine")
        .arg(&built)
        .output()
        .unwrap();
    assert!(output.status.success());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("xy.json")).unwrap())
            .unwrap();
    let mut text = String::from("angle_deg,deviation_mm\n");
    for (a, r) in report["positions"]
        .as_array()
        .unwrap()
        .iter()
        .zip(report["predicted"][0].as_array().unwrap())
    {
        text += &format!("{},{}\n", a, r);
    }
    std::fs::write(&circle, text).unwrap();
    let measurements = dir.path().join("fit.toml");
    std::fs::write(
        &measurements,
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 24\ncsv = \"xy.csv\"\n",
    )
    .unwrap();
    let fitted = dir.path().join("fitted.toml");
    volmap()
        .args(["fit", "--machine", "vmc-li2015", "--measurements"])
        .arg(&measurements)
        .arg("--out")
        .arg(&fitted)
        .assert()
        .success()
        .stdout(predicate::str::contains("EC0Y").and(predicate::str::contains("uncertainty")));
    volmap()
        .args(["info"])
        .arg(dir.path().join("built.exr"))
        .assert()
        .success();
    assert!(volmap::model::Machine::from_path(&fitted).is_ok());
    volmap()
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "Q=x.csv",
            "--out",
        ])
        .arg(dir.path().join("never.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("AXIS=FILE.csv"));
    assert!(!dir.path().join("never.toml").exists());
}

#[test]
fn plot_commands_write_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("f.exr");
    volmap()
        .args(["map", "--grid", "9x8x7", "--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    let (svg, png) = (dir.path().join("s.svg"), dir.path().join("s.png"));
    volmap()
        .args([
            "plot",
            "slice",
            "--normal",
            "y",
            "--quantity",
            "VE.Z",
            "--field",
        ])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .arg("--out")
        .arg(&png)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&svg)
        .unwrap()
        .contains("VE.Z at Y="));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let grid = dir.path().join("g.svg");
    volmap()
        .args([
            "plot",
            "grid",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "3x3x3",
            "--out",
        ])
        .arg(&grid)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&grid)
        .unwrap()
        .contains("error magnified"));
    volmap()
        .args(["plot", "slice", "--quantity", "speed", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--quantity speed"));
}

#[test]
fn compensate_writes_a_new_program_and_never_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dobariya2015");
    let out = dir.path().join("compensated.nc");
    let json = dir.path().join("report.json");
    volmap()
        .args(["compensate", "--machine"])
        .arg(example.join("machine.toml"))
        .arg("--program")
        .arg(example.join("test-piece.nc"))
        .args(["--work-offset", "G54=0,0,10", "--out"])
        .arg(&out)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("largest correction")
                .and(predicate::str::contains("blocks changed"))
                .and(predicate::str::contains("mm before")),
        );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("N60 X39.8168 F200 (SLOT ALONG X: 30 MM BETWEEN ITS CENTRES)"),
        "{text}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(report["largest_error_after_mm"].as_f64().unwrap() <= 1e-3);
    // The input is never the output.
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X20\n").unwrap();
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&program)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("never writes over it"));
    assert_eq!(
        std::fs::read_to_string(&program).unwrap(),
        "G0 X10 Y10 Z10\nG1 X20\n"
    );
    // A bad program: the line and the reason, exit 2, nothing written.
    std::fs::write(&program, "G0 X10 Y10 Z10\nG2 X20 Y20\n").unwrap();
    let never = dir.path().join("never.nc");
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "p.nc: line 2: an arc (G2) needs its centre",
        ));
    std::fs::write(&program, [0u8, 159, 146, 150]).unwrap();
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not a text file"));
    assert!(!never.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        3,
        "no temporary files left"
    );
}
