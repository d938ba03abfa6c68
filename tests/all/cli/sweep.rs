//! Five-axis maps over the rotary axes: `volmap map --poses` writes one multi-part field, one part
//! per pose, each the field `map --pose` writes alone, and `info` summarises it; exrheader and
//! Python OpenEXR open it; bad sweeps are refused naming `--poses`. The other readers of a sweep
//! are with their commands (`sample`, `plot`, `features`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use exr::meta::attribute::AttributeValue;
use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};
use predicates::prelude::*;
use volmap::io::field::{FieldFile, FieldReader};

use super::volmap;

pub(super) const MACHINE: &str = "5axis-hwang2014";
pub(super) const GRID: &str = "5x4x3";
/// 12 poses: B −90, 0, 90 and C 0, 90, 180, 270, C varying fastest.
const SWEEP: &str = "B=-90:90:90,C=0:270:90";

/// The part names of [`SWEEP`], in order.
fn sweep_names() -> Vec<String> {
    let mut names = Vec::new();
    for b in [-90, 0, 90] {
        for c in [0, 90, 180, 270] {
            names.push(format!("B={b},C={c}"));
        }
    }
    names
}

/// Runs `volmap map` on the test machine and grid with `args`, into `out`; returns stdout.
pub(super) fn map(args: &[&str], device: &str, out: &Path) -> String {
    let output = volmap()
        .args([
            "map",
            "--machine",
            MACHINE,
            "--grid",
            GRID,
            "--device",
            device,
        ])
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

/// A sweep of [`SWEEP`] mapped on the CPU into `dir/sweep.exr`.
pub(super) fn swept(dir: &Path) -> PathBuf {
    let path = dir.join("sweep.exr");
    map(&["--poses", SWEEP], "cpu", &path);
    path
}

/// One layer (part) as the exr crate reads it: name, custom attributes, size, channels.
struct Layer {
    name: Option<String>,
    attributes: HashMap<String, AttributeValue>,
    size: (usize, usize),
    channels: Vec<(String, Vec<f32>)>,
}

/// Every layer of a field file, read by the exr crate (an independent OpenEXR reader).
fn layers(path: &Path) -> Vec<Layer> {
    let image = read_all_flat_layers_from_file(path).expect("the exr crate reads the file");
    image
        .layer_data
        .iter()
        .map(|layer| Layer {
            name: layer.attributes.layer_name.as_ref().map(|n| n.to_string()),
            attributes: image
                .attributes
                .other
                .iter()
                .chain(&layer.attributes.other)
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect(),
            size: (layer.size.0, layer.size.1),
            channels: layer
                .channel_data
                .list
                .iter()
                .map(|c| {
                    let FlatSamples::F32(samples) = &c.sample_data else {
                        panic!("{} is not FLOAT", c.name)
                    };
                    (c.name.to_string(), samples.clone())
                })
                .collect(),
        })
        .collect()
}

/// Every part of a sweep equals the single-pose map of its pose: values, attributes, size.
fn parts_equal_single_pose_maps(device: &str, sweep: &str, names: &[String]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sweep.exr");
    let stdout = map(&["--poses", sweep], device, &path);
    assert!(
        stdout.contains(&format!("{} parts, one per pose", names.len())),
        "{stdout}"
    );
    let parts = layers(&path);
    let got: Vec<String> = parts.iter().map(|l| l.name.clone().unwrap()).collect();
    assert_eq!(
        got, names,
        "the parts are named by their poses, in sweep order"
    );
    let file = FieldFile::open(&path).unwrap();
    assert!(file.is_multipart());
    for (p, name) in names.iter().enumerate() {
        let single = dir.path().join(format!("single-{p}.exr"));
        map(&["--pose", name], device, &single);
        let alone = layers(&single);
        assert_eq!(alone.len(), 1);
        assert_eq!(alone[0].name, None, "a single-pose field has no part name");
        assert_eq!(parts[p].size, alone[0].size, "{name}");
        assert_eq!(parts[p].attributes, alone[0].attributes, "{name}");
        assert_eq!(parts[p].channels.len(), 6);
        assert_eq!(alone[0].channels.len(), 6);
        for ((c, values), (c_alone, values_alone)) in
            parts[p].channels.iter().zip(&alone[0].channels)
        {
            assert_eq!(c, c_alone);
            // The same engine on the same grid: the same values, bit for bit.
            assert_eq!(values, values_alone, "{name} {c}");
        }
        let info = FieldReader::open(&single).unwrap().info().clone();
        assert_eq!(file.info(p), info, "{name}");
        assert_eq!(file.name(p), *name);
    }
}

#[test]
fn a_sweeps_parts_equal_single_pose_maps_on_the_cpu() {
    parts_equal_single_pose_maps("cpu", SWEEP, &sweep_names());
}

#[test]
fn a_sweeps_parts_equal_single_pose_maps_on_the_gpu() {
    if crate::common::gpu().is_none() {
        return;
    }
    let names: Vec<String> = ["B=-90,C=0", "B=-90,C=180", "B=90,C=0", "B=90,C=180"]
        .map(String::from)
        .to_vec();
    parts_equal_single_pose_maps("gpu", "B=-90:90:180,C=0:180:180", &names);
}

#[test]
fn parts_are_named_by_pose_the_last_axis_varying_fastest() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.exr");
    // Written C first: C is then the slower axis; names still list B before C.
    map(&["--poses", "C=0:90:90, B=-45:45:45"], "cpu", &path);
    let names: Vec<String> = layers(&path).into_iter().map(|l| l.name.unwrap()).collect();
    assert_eq!(
        names,
        [
            "B=-45,C=0",
            "B=0,C=0",
            "B=45,C=0",
            "B=-45,C=90",
            "B=0,C=90",
            "B=45,C=90"
        ]
    );
    // One value per axis, an axis not written at 0: one part.
    map(&["--poses", "B=12.5"], "cpu", &path);
    let file = FieldFile::open(&path).unwrap();
    assert!(file.is_multipart());
    assert_eq!(file.parts(), 1);
    assert_eq!(file.name(0), "B=12.5,C=0");
    assert_eq!(file.pose_deg(0), [0.0, 12.5, 0.0]);
    // A sweep of one pose reads as a single field.
    let reader = FieldReader::open(&path).unwrap();
    assert_eq!(reader.info().pose_deg, [0.0, 12.5, 0.0]);
}

#[test]
fn the_map_summary_gives_the_worst_pose_and_each_poses_largest_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.exr");
    let stdout = map(&["--poses", SWEEP, "--check", "5"], "cpu", &path);
    assert!(
        stdout.contains("60 points at each of 12 poses, 720 points"),
        "{stdout}"
    );
    assert!(stdout.contains("check       60 points"), "{stdout}");
    assert!(stdout.contains(": ok"), "{stdout}");
    let rows: Vec<(String, f64)> = stdout
        .lines()
        .filter_map(|l| {
            let mut words = l.split_whitespace();
            let name = words.next()?;
            let max = words.next()?.parse::<f64>().ok()?;
            name.starts_with("B=").then(|| (name.to_string(), max))
        })
        .collect();
    assert_eq!(
        rows.iter().map(|r| r.0.clone()).collect::<Vec<_>>(),
        sweep_names()
    );
    let worst = rows
        .iter()
        .fold(&rows[0], |w, r| if r.1 > w.1 { r } else { w });
    assert!(
        stdout.contains(&format!("worst pose  {}\n", worst.0)),
        "{stdout}"
    );
    // info reads the same summary back from the file.
    let info = volmap().arg("info").arg(&path).output().unwrap();
    assert!(info.status.success());
    let info = String::from_utf8(info.stdout).unwrap();
    assert!(info.contains("12 parts, one per pose"), "{info}");
    assert!(
        info.contains(&format!("worst pose  {}\n", worst.0)),
        "{info}"
    );
    for line in stdout.lines().filter(|l| l.trim_start().starts_with("B=")) {
        assert!(info.contains(line), "info lacks `{line}`:\n{info}");
    }
}

#[test]
fn bad_sweeps_exit_2_naming_poses() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let cases: [(&str, &str, &str); 10] = [
        (
            MACHINE,
            "B",
            "expected LETTER=DEGREES or LETTER=START:STOP:STEP",
        ),
        (MACHINE, "", "expected LETTER=DEGREES"),
        (MACHINE, "B=-90:90", "START:STOP:STEP"),
        (MACHINE, "B=-90:90:0", "the step must be positive"),
        (MACHINE, "B=-90:90:-15", "the step must be positive"),
        (MACHINE, "B=-120:90:15", "outside its range"),
        (MACHINE, "X=0:100:10", "a linear axis"),
        (MACHINE, "A=0:90:45", "not an axis of this machine"),
        (MACHINE, "B=0:90:x", "not a number of degrees"),
        ("vmc-li2015", "C=0:90:45", "not an axis of this machine"),
    ];
    for (machine, sweep, message) in cases {
        volmap()
            .args([
                "map",
                "--device",
                "cpu",
                "--grid",
                "3x3x3",
                "--machine",
                machine,
            ])
            .arg(format!("--poses={sweep}"))
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(
                predicate::str::contains("error: --poses").and(predicate::str::contains(message)),
            );
    }
    volmap()
        .args([
            "map",
            "--machine",
            MACHINE,
            "--poses",
            "B=0:90:45",
            "--pose",
            "B=0",
        ])
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--poses").and(predicate::str::contains("--pose")));
    assert!(!out.exists());
}

#[test]
fn exrheader_lists_the_parts() {
    if !crate::field::tool_available(
        std::process::Command::new("sh").args(["-c", "command -v exrheader"]),
        "exrheader (Debian package openexr)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let output = std::process::Command::new("exrheader")
        .arg(&field)
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    for (p, name) in sweep_names().iter().enumerate() {
        assert!(text.contains(&format!(" part {p}:")), "part {p}:\n{text}");
        assert!(
            text.contains(&format!("name (type string): \"{name}\"")),
            "{name}:\n{text}"
        );
    }
    assert_eq!(
        text.matches("type (type string): \"scanlineimage\"")
            .count(),
        12
    );
    assert_eq!(text.matches("chunkCount (type int): 12").count(), 12);
    assert_eq!(text.matches("volmap.dims (type v3i): (5 4 3)").count(), 12);
    assert!(text.contains("B at 90.0 deg; C at 270.0 deg"), "{text}");
}

#[test]
fn python_openexr_reads_a_part() {
    if !crate::field::tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR, numpy"]),
        "the Python OpenEXR package",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let file = FieldFile::open(&field).unwrap();
    let part = 6; // B=0,C=180
    let mut reader = file.reader(part).unwrap();
    let mut line = vec![0.0f32; 6 * 5];
    let points = [[0, 0, 0], [4, 3, 2], [2, 1, 0]];
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/read_parts.py");
    let output = std::process::Command::new("python3")
        .arg(script)
        .arg(&field)
        .arg("B=0,C=180")
        .args(points.iter().map(|p| format!("{},{},{}", p[0], p[1], p[2])))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["parts"], serde_json::json!(sweep_names()));
    assert_eq!(json["dims"], serde_json::json!([5, 4, 3]));
    assert_eq!(json["pose"], serde_json::json!([0.0, 0.0, 180.0]));
    assert_eq!(json["dtype"], "float32");
    for (n, &[i, j, k]) in points.iter().enumerate() {
        reader.read_line((j + 4 * k) as u64, &mut line).unwrap();
        for (c, name) in volmap::model::channels::CHANNELS.iter().enumerate() {
            assert_eq!(
                json["values"][n][name].as_f64().map(|v| v as f32),
                Some(line[c * 5 + i]),
                "{name} at {i},{j},{k}"
            );
        }
    }
}
