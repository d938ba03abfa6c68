//! `volmap map`, `info`, `machines` and `bench`: fields written and summarised, bad input refused.

use predicates::prelude::*;

use std::path::Path;

use super::{s, volmap};

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
            .and(predicate::str::contains("pose B=30.000° C=45.000°"))
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
fn a_unit_mistake_is_bad_input_on_every_device() {
    // 5° written as rad: the machine file is refused naming the key before any device computes,
    // so the GPU and the CPU engine answer alike.
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("degrees.toml");
    std::fs::write(
        &machine,
        "name = \"5 degrees written as rad\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0, 100]\n[axes.Y]\nrange = [0, 100]\nEC0Y = 5.0\n[axes.Z]\nrange = [0, 100]\n",
    )
    .unwrap();
    let gpu = super::super::common::gpu().is_some();
    let devices: &[&str] = if gpu { &["gpu", "cpu"] } else { &["cpu"] };
    for device in devices {
        volmap()
            .args(["map", "--grid", "4x4x4", "--device", device, "--machine"])
            .arg(&machine)
            .arg("--out")
            .arg(dir.path().join("f.exr"))
            .assert()
            .code(2)
            .stderr(
                predicate::str::contains("degrees.toml: axes.Y.EC0Y")
                    .and(predicate::str::contains("5.0000 rad")),
            );
    }
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
            "--runs",
            "3",
            "--json",
        ])
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("f64 reference, 1 thread")
                .and(predicate::str::contains("CPU engine"))
                .and(predicate::str::contains(
                    "disk ceiling (field writer, none)",
                ))
                .and(predicate::str::contains("map to EXR, CPU engine, pxr24"))
                .and(predicate::str::contains("map to EXR, f64 reference")),
        );
    let report: serde_json::Value = super::json_result(&json);
    let machines = report["machines"].as_array().unwrap();
    assert_eq!(machines.len(), 2);
    for m in machines {
        let paths = m["paths"].as_array().unwrap();
        assert_eq!(paths[0]["ratio_to_reference"].as_f64(), Some(1.0));
        assert!(m["disk_mb_per_s"].as_f64().unwrap() > 0.0);
        for p in paths {
            // Every figure the median of its runs, with its spread.
            let (median, spread) = (p["mpts_per_s"].as_f64().unwrap(), &p["spread"]);
            assert_eq!(spread["runs"], 3, "{p}");
            assert!(median > 0.0, "{p}");
            assert!(p["mpts_per_s_min"].as_f64().unwrap() <= median, "{p}");
            assert!(p["mpts_per_s_max"].as_f64().unwrap() >= median, "{p}");
            let seconds = |key: &str| spread[key].as_f64().unwrap();
            assert!(seconds("min") <= seconds("q1") && seconds("q1") <= seconds("median"));
            assert!(seconds("median") <= seconds("q3") && seconds("q3") <= seconds("max"));
            assert_eq!(seconds("median"), p["seconds"].as_f64().unwrap());
        }
        // The disk ceiling, and every map held against it with its file and stage shares.
        let path = |name: &str| {
            paths
                .iter()
                .find(|p| p["path"] == name)
                .unwrap_or_else(|| panic!("no {name} in {paths:?}"))
        };
        assert_eq!(
            path("disk ceiling (field writer, none)")["fraction_of_disk"].as_f64(),
            Some(1.0)
        );
        let mut engines = vec!["CPU engine"];
        if report["adapter"].is_string() {
            engines.push("GPU");
        }
        for engine in engines {
            let mut sizes = Vec::new();
            for compression in ["none", "zip", "pxr24"] {
                let map = path(&format!("map to EXR, {engine}, {compression}"));
                assert!(map["fraction_of_disk"].as_f64().unwrap() > 0.0, "{map}");
                sizes.push(map["file_bytes"].as_u64().unwrap());
                let stages = &map["stages"];
                for stage in ["engine", "handoff", "waiting", "compress", "write", "sync"] {
                    let share = stages[stage].as_f64().unwrap();
                    assert!((0.0..=1.0).contains(&share), "{stage}: {map}");
                }
                assert_eq!(stages["device"].is_number(), engine == "GPU", "{map}");
                assert_eq!(stages["readback"].is_number(), engine == "GPU", "{map}");
            }
            assert!(sizes[2] < sizes[0], "pxr24 is smaller than none: {sizes:?}");
        }
        let gpu_paths = paths
            .iter()
            .filter(|p| p["path"].as_str().unwrap().starts_with("GPU"))
            .count();
        // With an adapter the GPU paths are there, each with its fraction of the ceiling.
        // Monte Carlo is measured on the CPU engine always, on the GPU where there is one.
        let monte_carlo: Vec<&str> = paths
            .iter()
            .map(|p| p["path"].as_str().unwrap())
            .filter(|p| p.contains("Monte Carlo"))
            .collect();
        assert!(monte_carlo
            .iter()
            .any(|p| p.starts_with("CPU engine Monte Carlo")));
        // The map's uncertainty, first order and Monte Carlo, on every engine measured: the
        // bench gives each axis's six component errors a u.
        let axes = m["chain"]
            .as_str()
            .unwrap()
            .chars()
            .filter(|c| "XYZABC".contains(*c))
            .count();
        let mut u_engines = vec!["CPU engine"];
        if report["adapter"].is_string() {
            u_engines.push("GPU");
        }
        for engine in u_engines {
            for method in [
                format!("first order, {} quantities", 6 * axes),
                format!("Monte Carlo, {} draws", volmap::bench::BENCH_DRAWS),
            ] {
                let row = path(&format!("{engine} map uncertainty, {method}"));
                assert_eq!(row["points"].as_u64(), Some(16 * 8 * 4), "{row}");
                assert!(row["fraction_of_ceiling"].is_null(), "{row}");
            }
        }
        let passes = &m["uncertainty_passes_per_quantity"];
        assert_eq!(passes.is_number(), report["adapter"].is_string(), "{m}");
        if report["adapter"].is_string() {
            assert!(passes.as_f64().unwrap() > 0.0, "{m}");
            assert_eq!(gpu_paths, 6);
            assert!(monte_carlo.iter().any(|p| p.starts_with("GPU Monte Carlo")));
            assert!(paths
                .iter()
                .filter(|p| p["path"].as_str().unwrap().starts_with("GPU"))
                .filter(|p| !p["path"].as_str().unwrap().contains("map uncertainty"))
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
fn a_chunk_below_a_grid_line_maps_one_line_per_chunk_on_every_device() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = super::super::common::gpu().is_some();
    let devices: &[&str] = if gpu { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        let whole = dir.path().join(format!("{device}-whole.exr"));
        let one = dir.path().join(format!("{device}-one.exr"));
        for (path, chunk) in [(&whole, None), (&one, Some("1"))] {
            let mut cmd = volmap();
            cmd.args([
                "map", "--grid", "8x6x5", "--check", "30", "--device", device,
            ])
            .arg("--out")
            .arg(path);
            if let Some(c) = chunk {
                cmd.args(["--chunk-points", c]);
            }
            cmd.assert()
                .success()
                .stdout(predicate::str::contains(": ok"));
        }
        let sample = |field: &Path| {
            let points = dir.path().join("p.csv");
            std::fs::write(&points, "X,Y,Z\n0,0,0\n571.4,240,375\n1000,600,500\n").unwrap();
            let output = volmap()
                .args([
                    "sample",
                    "--device",
                    "cpu",
                    "--points",
                    s(&points),
                    "--field",
                    s(field),
                ])
                .output()
                .unwrap();
            assert!(output.status.success());
            String::from_utf8(output.stdout).unwrap()
        };
        assert_eq!(sample(&whole), sample(&one), "{device}");
    }
}

#[test]
fn a_gpu_map_without_a_window_system_prints_no_error() {
    if super::super::common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = volmap()
        .args(["map", "--grid", "8x8x8", "--device", "gpu", "--out"])
        .arg(dir.path().join("f.exr"))
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .output()
        .unwrap();
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.to_lowercase().contains("error"), "{stderr}");
}

#[test]
fn bench_holds_a_machine_with_errors_of_other_axes_against_its_plain_counterpart() {
    // gantry-2m: a roll of X with Y, a sag of Y with Z. Its counterpart reads its own axes only:
    // EAX the same polynomial of X's position, EZY the table of Y without the table of Y and Z.
    let machine = volmap::io::embedded::load("gantry-2m").unwrap();
    let plain = volmap::bench::plain_counterpart(&machine);
    assert!(machine.has_cross_axis_errors() && !plain.has_cross_axis_errors());
    let x = plain.axis(volmap::model::AxisLetter::X).unwrap();
    let y = plain.axis(volmap::model::AxisLetter::Y).unwrap();
    let (eax, ezy) = (
        x.components[3].as_ref().unwrap(),
        y.components[2].as_ref().unwrap(),
    );
    for q in [0.0, 700.0, 2000.0] {
        assert!(
            (eax.eval(q) - (4.0e-6 - 4.0e-9 * q)).abs() < 1e-18,
            "EAX at {q}"
        );
    }
    // The table of Y alone: 0.008 at its middle node; the table of Y and Z gave -0.012 more at Z 0.
    assert!((ezy.eval(1000.0) - 0.008).abs() < 1e-15);
    let on_y_and_z = machine
        .axis(volmap::model::AxisLetter::Y)
        .unwrap()
        .components[2]
        .as_ref()
        .unwrap()
        .eval_at(1000.0, &[0.0, 1000.0, 0.0, 0.0, 0.0, 0.0]);
    assert!((on_y_and_z - (0.008 - 0.012)).abs() < 1e-15);

    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    volmap()
        .args(["bench", "--machines", "gantry-2m", "--grid", "8x6x4"])
        .args(["--reference-points", "50", "--runs", "2", "--json"])
        .arg(&json)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "against the same machine with plain tables",
        ));
    let report: serde_json::Value = super::json_result(&json);
    let m = &report["machines"][0];
    let names: Vec<&str> = m["paths"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["path"].as_str().unwrap())
        .collect();
    let mut expected = vec!["CPU engine, f64", "CPU engine Monte Carlo"];
    if report["adapter"].is_string() {
        expected.extend([
            "GPU map passes + readback",
            "map to EXR, GPU, none",
            "GPU Monte Carlo",
        ]);
    }
    if report["adapter"].is_string() {
        // Its kernel held against the write-only kernel of the same dispatch.
        let paths = m["paths"].as_array().unwrap();
        let fraction = |name: &str| {
            paths
                .iter()
                .find(|p| p["path"] == name)
                .unwrap_or_else(|| panic!("no {name} in {names:?}"))["fraction_of_ceiling"]
                .as_f64()
                .unwrap()
        };
        assert_eq!(fraction("GPU write-only kernel (ceiling)"), 1.0);
        assert!(fraction("GPU kernel") > 0.0);
    }
    let ratios = m["against_plain"].as_array().unwrap();
    assert_eq!(ratios.len(), expected.len(), "{ratios:?}");
    for stem in expected {
        let own = names
            .iter()
            .filter(|n| n.starts_with(stem) && !n.ends_with("(plain tables)"))
            .count();
        let plain = names
            .iter()
            .filter(|n| n.starts_with(stem) && n.ends_with("(plain tables)"))
            .count();
        assert_eq!((own, plain), (1, 1), "{stem} in {names:?}");
        let ratio = ratios
            .iter()
            .find(|r| r["path"].as_str().unwrap().starts_with(stem))
            .unwrap_or_else(|| panic!("no ratio for {stem}: {ratios:?}"));
        assert!(ratio["ratio"].as_f64().unwrap() > 0.0, "{ratio}");
    }
}

#[test]
fn a_field_larger_than_the_free_space_is_refused_and_a_device_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("huge.exr");
    // 16384 x 16384 x 8192 points: 52.8 TB of FLOAT values, 3.3 TB at the least compressed.
    for compression in ["none", "pxr24"] {
        volmap()
            .args([
                "map",
                "--grid",
                "16384x16384x8192",
                "--compression",
                compression,
                "--out",
            ])
            .arg(&out)
            .assert()
            .code(2)
            .stderr(
                predicates::str::starts_with(format!(
                    "error: --out {}: the field needs ",
                    out.display()
                ))
                .and(predicates::str::contains(" free")),
            );
        assert!(!out.exists());
    }
    // A device is written directly, whatever its name.
    #[cfg(unix)]
    volmap()
        .args(["map", "--grid", "8x8x8", "--out", "/dev/null"])
        .assert()
        .success()
        .stdout(predicates::str::contains("field       /dev/null"));
}
