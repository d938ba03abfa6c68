//! Field files as every reader meets them: each compression and HALF read by `info`, `sample`,
//! `features` and `plot`; a CSV table's long path; headers whose numbers are not numbers; readers
//! in bounded memory on a huge header and on a field larger than their budget; HALF's range.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use super::{refused, volmap, volmap_under};

fn map(dir: &Path, name: &str, grid: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    volmap()
        .args(["map", "--machine", "vmc-li2015", "--grid", grid])
        .args(["--device", "cpu", "--chunk-points", "500"])
        .args(extra)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    out
}

/// The rows of a CSV on standard output, as numbers (the header left out).
fn rows(csv: &[u8]) -> Vec<Vec<f64>> {
    String::from_utf8_lossy(csv)
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn info_sample_features_and_plot_read_every_compression_and_half() {
    let dir = tempfile::tempdir().unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let points = dir.path().join("p.csv");
    std::fs::write(
        &points,
        "X,Y,Z\n100,50,30\n333.3,222.2,111.1\n700,400,290\n",
    )
    .unwrap();
    let plain = map(dir.path(), "none.exr", "41x25x21", &[]);
    let sample = |field: &Path| {
        let out = volmap()
            .args(["sample", "--device", "cpu", "--field"])
            .arg(field)
            .arg("--points")
            .arg(&points)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        rows(&out.stdout)
    };
    let features = |field: &Path| {
        let json = dir.path().join("features.json");
        volmap()
            .args(["features", "--field"])
            .arg(field)
            .arg("--part")
            .arg(&example)
            .arg("--json")
            .arg(&json)
            .assert()
            .code(0);
        let rows: serde_json::Value = super::json_result(&json);
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| r["error_mm"].as_f64().unwrap())
            .collect::<Vec<f64>>()
    };
    let (plain_samples, plain_features) = (sample(&plain), features(&plain));
    // The field's largest |VE|, as `info` says it.
    let info = volmap().arg("info").arg(&plain).output().unwrap();
    let field_largest: f64 = String::from_utf8_lossy(&info.stdout)
        .lines()
        .find_map(|l| l.trim().strip_prefix("max |VE|"))
        .and_then(|l| l.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    let largest = plain_samples
        .iter()
        .flat_map(|r| r[3..].iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for (compression, half, relative) in [
        ("zip", false, 0.0),
        ("pxr24", false, 2f64.powi(-16)),
        ("none", true, 2f64.powi(-11)),
        ("zip", true, 2f64.powi(-11)),
        ("pxr24", true, 2f64.powi(-11)),
    ] {
        let mut extra = vec!["--compression", compression];
        if half {
            extra.push("--half");
        }
        let name = format!("{compression}{}.exr", if half { "-half" } else { "" });
        let field = map(dir.path(), &name, "41x25x21", &extra);
        volmap().arg("info").arg(&field).assert().success().stdout(
            predicate::str::contains("21525 points").and(predicate::str::contains(format!(
                "stored      {compression}{}",
                if half { ", HALF" } else { "" }
            ))),
        );
        // A trilinear sample blends eight stored values, each within the bound of its own.
        let samples = sample(&field);
        assert_eq!(samples.len(), plain_samples.len());
        for (got, want) in samples.iter().zip(&plain_samples) {
            assert_eq!(got.len(), want.len());
            for (g, w) in got[3..].iter().zip(&want[3..]) {
                let bound = relative * largest + if half { 2f64.powi(-25) } else { 0.0 };
                assert!((g - w).abs() <= bound + 1e-12, "{name}: {g} for {w}");
            }
        }
        // A feature's error is made of differences of values: twice the bound of each, over
        // the three components.
        let found = features(&field);
        assert_eq!(found.len(), plain_features.len());
        for (got, want) in found.iter().zip(&plain_features) {
            let bound = 6.0 * relative * field_largest + 1e-9;
            assert!((got - want).abs() <= bound, "{name}: {got} for {want}");
        }
        let svg = dir.path().join(format!("{name}.svg"));
        volmap()
            .args(["plot", "slice", "--quantity", "VE", "--field"])
            .arg(&field)
            .arg("--out")
            .arg(&svg)
            .assert()
            .success();
        assert!(std::fs::read_to_string(&svg).unwrap().contains("|VE|"));
    }
}

#[test]
fn a_machine_whose_csv_path_is_300_characters_long_gives_a_field_every_reader_reads() {
    let dir = tempfile::tempdir().unwrap();
    // A relative path of 300 characters inside the machine file's folder.
    let folders = ["a".repeat(120), "b".repeat(120)];
    let file = format!("{}.csv", "c".repeat(300 - 2 * 121 - 4));
    let relative = format!("{}/{}/{file}", folders[0], folders[1]);
    assert_eq!(relative.len(), 300);
    std::fs::create_dir_all(dir.path().join(&folders[0]).join(&folders[1])).unwrap();
    std::fs::write(
        dir.path().join(&relative),
        "X,EXX\n0,0.0\n300,0.012\n600,0.020\n",
    )
    .unwrap();
    let machine = dir.path().join("m.toml");
    std::fs::write(
        &machine,
        format!(
            "name = \"long path\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -150.0]\n\
             [axes.X]\nrange = [0.0, 600.0]\nEXX = {{ csv = \"{relative}\", column = \"EXX\" }}\n\
             [axes.Y]\nrange = [0.0, 400.0]\n[axes.Z]\nrange = [0.0, 300.0]\n"
        ),
    )
    .unwrap();
    let field = dir.path().join("f.exr");
    volmap()
        .args(["map", "--grid", "7x3x2", "--device", "cpu", "--machine"])
        .arg(&machine)
        .arg("--out")
        .arg(&field)
        .assert()
        .success();
    volmap()
        .arg("info")
        .arg(&field)
        .assert()
        .success()
        .stdout(predicate::str::contains("long path"));
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n300,0,0\n").unwrap();
    let out = volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!((rows(&out.stdout)[0][3] - 0.012).abs() < 1e-7);
    // The header keeps the table whole, its path in a value: names stay within 31 bytes.
    let file = volmap::io::field::FieldFile::open(&field).unwrap();
    assert_eq!(file.info(0).csv_files.len(), 1);
    assert_eq!(file.info(0).csv_files[0].0, relative);
    if crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v exrheader"]),
        "exrheader (Debian package openexr)",
    ) {
        let output = std::process::Command::new("exrheader")
            .arg(&field)
            .output()
            .unwrap();
        assert!(output.status.success());
        let text = String::from_utf8_lossy(&output.stdout);
        assert!(text.contains("file format version: 2, flags 0x0"), "{text}");
        assert!(text.contains(&relative), "{text}");
    }
    if crate::field::tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR"]),
        "the Python OpenEXR package",
    ) {
        let script = "import sys, OpenEXR\n\
                      h = OpenEXR.File(sys.argv[1]).header()\n\
                      print(h['volmap.csvPath.0'])\n\
                      print(all(len(k) <= 31 for k in h))\n";
        let output = std::process::Command::new("python3")
            .args(["-c", script])
            .arg(&field)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert_eq!(
            String::from_utf8_lossy(&output.stdout),
            format!("{relative}\nTrue\n")
        );
    }
}

/// `bytes` with the value of attribute `name` of type `kind` replaced by `value` (same size).
fn patched(bytes: &[u8], name: &str, kind: &str, value: &[u8]) -> Vec<u8> {
    let key = [name.as_bytes(), b"\0", kind.as_bytes(), b"\0"].concat();
    let at = bytes
        .windows(key.len())
        .position(|w| w == key.as_slice())
        .unwrap_or_else(|| panic!("{name} not in the header"))
        + key.len();
    let size = i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(size, value.len(), "{name}");
    let mut out = bytes.to_vec();
    out[at + 4..at + 4 + size].copy_from_slice(value);
    out
}

fn v3d(v: [f64; 3]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn header_numbers_that_are_not_numbers_are_refused_naming_the_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "f.exr", "5x4x3", &[]);
    let bytes = std::fs::read(&field).unwrap();
    let bad = dir.path().join("bad.exr");
    for (name, value, says) in [
        (
            "volmap.spacing",
            [200.0, f64::NAN, 150.0],
            "the step along Y is NaN",
        ),
        (
            "volmap.spacing",
            [200.0, 0.0, 150.0],
            "the step along Y is 0",
        ),
        (
            "volmap.spacing",
            [200.0, 100.0, -150.0],
            "the step along Z is -150",
        ),
        ("volmap.origin", [0.0, f64::INFINITY, 0.0], "Y = inf mm"),
        (
            "volmap.origin",
            [f64::NEG_INFINITY, 0.0, 0.0],
            "X = -inf mm",
        ),
    ] {
        std::fs::write(&bad, patched(&bytes, name, "v3d", &v3d(value))).unwrap();
        for command in [
            &["info"][..],
            &["plot", "slice", "--out", "s.svg", "--field"],
        ] {
            volmap()
                .current_dir(dir.path())
                .args(command)
                .arg(&bad)
                .assert()
                .code(2)
                .stderr(
                    predicate::str::contains(format!("attribute {name}"))
                        .and(predicate::str::contains(says)),
                );
        }
    }
    // A UINT channel is named with its type; HALF ones are read (see above).
    let uint = patched(
        &bytes,
        "channels",
        "chlist",
        &volmap::model::channels::CHANNELS
            .iter()
            .enumerate()
            .flat_map(|(n, c)| {
                let pixel: i32 = if n == 3 { 0 } else { 2 };
                [
                    c.as_bytes(),
                    b"\0",
                    &pixel.to_le_bytes(),
                    &[0; 4],
                    &1i32.to_le_bytes(),
                    &1i32.to_le_bytes(),
                ]
                .concat()
            })
            .chain([0])
            .collect::<Vec<u8>>(),
    );
    std::fs::write(&bad, uint).unwrap();
    volmap()
        .arg("info")
        .arg(&bad)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("VE.X UINT").and(predicate::str::contains("OE.X FLOAT")));
}

#[test]
fn readers_of_a_1x46340x46340_header_stay_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let field = map(dir.path(), "f.exr", "1x2x2", &[]);
    let bytes = std::fs::read(&field).unwrap();
    let n = 46340i32;
    let dims: Vec<u8> = [1, n, n]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    let window: Vec<u8> = [0, 0, 0, n * n - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    let mut huge = patched(&bytes, "volmap.dims", "v3i", &dims);
    for name in ["dataWindow", "displayWindow"] {
        huge = patched(&huge, name, "box2i", &window);
    }
    let header = huge.len() as u64 - 4 * (8 + 8 + 24);
    let lines = (n as u64) * (n as u64);
    let big = dir.path().join("big.exr");
    // A sparse file as long as the header says: its offset tables are 17 GB of zeros.
    std::fs::write(&big, &huge[..header as usize]).unwrap();
    let file = std::fs::OpenOptions::new().write(true).open(&big).unwrap();
    file.set_len(header + lines * (8 + 8 + 24)).unwrap();
    drop(file);
    volmap_under("-v 4000000")
        .arg("info")
        .arg(&big)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("outside the file's blocks"));
    volmap_under("-v 4000000")
        .args(["plot", "slice", "--normal", "x", "--out"])
        .arg(dir.path().join("s.svg"))
        .arg("--field")
        .arg(&big)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("a slice of 46340x46340 points"));
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n0,10,10\n").unwrap();
    volmap_under("-v 4000000")
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&big)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("outside the file's blocks"));
    // Cut short of what its header says, the file is refused before anything is read.
    let file = std::fs::OpenOptions::new().write(true).open(&big).unwrap();
    file.set_len(header + lines * 8).unwrap();
    drop(file);
    volmap_under("-v 4000000")
        .arg("info")
        .arg(&big)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("truncated"));
}

#[test]
fn a_field_larger_than_the_readers_memory_is_sampled_in_slabs_alike() {
    let dir = tempfile::tempdir().unwrap();
    // 30 points a line, 20 lines a plane: 14,400 bytes a plane, 40 planes.
    let field = map(dir.path(), "f.exr", "30x20x40", &["--compression", "zip"]);
    let points = dir.path().join("p.csv");
    let mut text = String::from("X,Y,Z\n");
    let mut state = 7u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..2000 {
        text.push_str(&format!(
            "{},{},{}\n",
            800.0 * next(),
            600.0 * next(),
            500.0 * next()
        ));
    }
    std::fs::write(&points, text).unwrap();
    let devices: &[&str] = if crate::common::sampler().is_some() {
        &["cpu", "gpu"]
    } else {
        &["cpu"]
    };
    for device in devices {
        let sample = |budget: Option<&str>| {
            let mut command = volmap();
            if let Some(bytes) = budget {
                command.env("VOLMAP_FIELD_MEMORY_BYTES", bytes);
            }
            let out = command
                .args(["sample", "--device", device, "--field"])
                .arg(&field)
                .arg("--points")
                .arg(&points)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            out.stdout
        };
        // Four planes a slab: ten slabs, each read once.
        assert_eq!(sample(None), sample(Some("60000")), "{device}");
    }
    // Two planes do not fit: refused, naming what would not fit.
    volmap()
        .env("VOLMAP_FIELD_MEMORY_BYTES", "20000")
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("two z planes").and(predicate::str::contains("28800 bytes")),
        );
    // features reads a field whole, within the same budget.
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    volmap()
        .env("VOLMAP_FIELD_MEMORY_BYTES", "60000")
        .args(["features", "--field"])
        .arg(&field)
        .arg("--part")
        .arg(&example)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("reading its 30x20x40 grid whole"));
}

#[test]
fn half_refuses_a_value_beyond_its_range_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("m.toml");
    std::fs::write(
        &machine,
        "name = \"big\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0.0, 600.0]\n\
         EXX = { poly = [0.0, 200.0] }\n[axes.Y]\nrange = [0.0, 400.0]\n[axes.Z]\nrange = [0.0, 300.0]\n",
    )
    .unwrap();
    let out = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--grid",
            "7x3x2",
            "--device",
            "cpu",
            "--half",
            "--machine",
        ])
        .arg(&machine)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("VE.X = 8e4 at grid point (4, 0, 0)")
                .and(predicate::str::contains("HALF"))
                .and(predicate::str::contains("leave out --half")),
        );
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n != "m.toml")
        .collect();
    assert!(left.is_empty(), "{left:?}");
    // Without --half the same map is written.
    volmap()
        .args(["map", "--grid", "7x3x2", "--device", "cpu", "--machine"])
        .arg(&machine)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
}

/// A field holding a NaN (a damaged file: volmap never writes one) was summarised and sampled
/// as NaN with exit 0.
#[test]
fn a_field_holding_a_value_that_is_not_a_number_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--device",
            "cpu",
            "--grid",
            "3x3x3",
            "--compression",
            "none",
            "--out",
            "f.exr",
        ])
        .current_dir(d)
        .assert()
        .success();
    let mut bytes = std::fs::read(d.join("f.exr")).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(d.join("c.exr"), bytes).unwrap();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n1000,600,500\n").unwrap();
    let says = ["c.exr", "VE.Z of grid point (2, 2, 2) is NaN"];
    refused(&["info", "c.exr"], d, &says);
    refused(
        &[
            "sample", "--field", "c.exr", "--points", "q.csv", "--device", "cpu",
        ],
        d,
        &says,
    );
}
