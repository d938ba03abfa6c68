//! Field files: written as a stream, read back by volmap and by an independent OpenEXR reader.

use exr::prelude::{read_first_flat_layer_from_file, FlatSamples, Vec2};
use volmap::engine::cpu;
use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::io::field::{FieldReader, FieldWriter};
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::poses::parse_pose;

/// What the CPU engine computes for the grid: the field file must hold exactly these values.
pub(crate) fn engine_values(
    machine: &volmap::model::Machine,
    grid: &Grid,
) -> impl Fn([usize; 3], usize) -> f32 {
    let mut values = vec![0.0f32; grid.points() as usize * CHANNELS.len()];
    cpu::CpuPlan::new(machine, grid).compute_lines(0, grid.lines(), &mut values);
    let [nx, ny, _] = grid.dims;
    move |[i, j, k], c| values[((j + k * ny) * CHANNELS.len() + c) * nx + i]
}

fn mapped(
    dir: &std::path::Path,
    dims: [usize; 3],
) -> (volmap::model::Machine, Grid, std::path::PathBuf) {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let pose = parse_pose("B=12.5,C=200", &machine).unwrap();
    let grid = Grid::full_travel(&machine, dims, pose).unwrap();
    let path = dir.join("field.exr");
    let options = MapOptions {
        chunk_points: Some(dims[0] as u64 * 3),
        check_points: 0,
        ..Default::default()
    };
    map::map_to_file(&machine, &grid, &Engine::Cpu, &path, &options, |_| {}).unwrap();
    (machine, grid, path)
}

#[test]
fn write_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [7, 5, 4];
    let (machine, grid, path) = mapped(dir.path(), dims);
    let expected = engine_values(&machine, &grid);
    let mut reader = FieldReader::open(&path).unwrap();
    let info = reader.info().clone();
    assert_eq!(info.dims, dims);
    assert_eq!(info.origin_mm, grid.origin_mm);
    assert_eq!(info.spacing_mm, grid.spacing_mm);
    assert_eq!(info.pose_deg, [0.0, 12.5, 200.0]);
    assert_eq!(info.pose_axes, "BC");
    assert_eq!(info.chain, "FYXCFZB");
    assert_eq!(info.machine_toml, machine.source.toml);
    let mut line = vec![0.0f32; CHANNELS.len() * dims[0]];
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            reader
                .read_line((j + k * dims[1]) as u64, &mut line)
                .unwrap();
            for i in 0..dims[0] {
                for c in 0..6 {
                    assert_eq!(
                        line[c * dims[0] + i],
                        expected([i, j, k], c),
                        "({i}, {j}, {k}) {}",
                        CHANNELS[c]
                    );
                }
            }
        }
    }
}

#[test]
fn an_independent_openexr_reader_sees_the_same_field() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [6, 4, 3];
    let (machine, grid, path) = mapped(dir.path(), dims);
    let expected = engine_values(&machine, &grid);
    let image = read_first_flat_layer_from_file(&path).expect("the exr crate reads the field");
    let layer = &image.layer_data;
    assert_eq!(layer.size, Vec2(dims[0], dims[1] * dims[2]));
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, CHANNELS);
    for (c, channel) in layer.channel_data.list.iter().enumerate() {
        let FlatSamples::F32(samples) = &channel.sample_data else {
            panic!("{} is not FLOAT", names[c])
        };
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    // Pixel (i, j + k·ny) holds grid point (i, j, k).
                    let pixel = samples[(j + k * dims[1]) * dims[0] + i];
                    let want = expected([i, j, k], c);
                    assert_eq!(pixel, want, "{} at ({i}, {j}, {k})", names[c]);
                }
            }
        }
    }
    let attributes: Vec<String> = image
        .attributes
        .other
        .keys()
        .chain(layer.attributes.other.keys())
        .map(|k| k.to_string())
        .collect();
    for key in [
        "volmap.dims",
        "volmap.origin",
        "volmap.spacing",
        "volmap.pose",
        "volmap.units",
        "volmap.machine",
        "volmap.machineToml",
    ] {
        assert!(
            attributes.iter().any(|a| a == key),
            "{key} missing from {attributes:?}"
        );
    }
}

#[test]
fn an_unfinished_field_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("vmc-li2015").unwrap();
    let grid = Grid::full_travel(&machine, [4, 4, 4], [0.0; 6]).unwrap();
    let path = dir.path().join("partial.exr");
    let info = map::field_info(&machine, &grid, "test");
    let mut writer = FieldWriter::create(&path, &info).unwrap();
    writer.write_lines(0, 2, &[0.0; 2 * 6 * 4]).unwrap();
    let error = writer.write_lines(5, 1, &[0.0; 24]).unwrap_err();
    assert!(error.to_string().contains("expected line 2"), "{error}");
    let incomplete = writer.finish().unwrap_err();
    assert!(
        incomplete.to_string().contains("only 2 of 16 lines"),
        "{incomplete}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "nothing may be left behind: {left:?}");
}

#[test]
fn files_that_are_not_fields_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("not.exr");
    std::fs::write(&path, b"hello").unwrap();
    let message = FieldReader::open(&path)
        .err()
        .expect("rejected")
        .to_string();
    assert!(
        message.contains("not.exr") && message.contains("not an OpenEXR file"),
        "{message}"
    );
    let (_, _, field) = mapped(dir.path(), [3, 3, 3]);
    let bytes = std::fs::read(&field).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
    let message = FieldReader::open(&path)
        .err()
        .expect("truncated")
        .to_string();
    assert!(message.contains("truncated"), "{message}");
}

/// Whether the reader `what` is there (`check` succeeds). `VOLMAP_REQUIRE_READERS` (set by CI,
/// which installs them; `VOLMAP_REQUIRE_EXR_TOOLS` is its older name) turns a missing reader into
/// a failure; elsewhere the test skips, recorded by [`crate::skips`].
pub(crate) fn tool_available(check: &mut std::process::Command, what: &str) -> bool {
    let ok = check.output().is_ok_and(|o| o.status.success());
    if !ok {
        if crate::skips::readers_required() {
            panic!(
                "VOLMAP_REQUIRE_READERS (or VOLMAP_REQUIRE_EXR_TOOLS) is set but {what} is missing"
            );
        }
        crate::skips::skipped(&format!("{what} is not installed"));
    }
    ok
}

#[test]
fn python_openexr_reads_the_field() {
    if !tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR, numpy"]),
        "the Python OpenEXR package",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let dims = [5, 4, 3];
    let (machine, grid, path) = mapped(dir.path(), dims);
    let expected = engine_values(&machine, &grid);
    let points = [[0, 0, 0], [4, 3, 2], [2, 1, 0], [1, 3, 1]];
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/read_field.py");
    let output = std::process::Command::new("python3")
        .arg(script)
        .arg(&path)
        .args(points.iter().map(|p| format!("{},{},{}", p[0], p[1], p[2])))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["dims"], serde_json::json!(dims));
    assert_eq!(json["chain"], "FYXCFZB");
    assert_eq!(json["machine"], machine.name.as_str());
    assert_eq!(json["dtype"], "float32");
    assert_eq!(json["pose"], serde_json::json!([0.0, 12.5, 200.0]));
    for d in 0..3 {
        assert_eq!(json["origin"][d].as_f64(), Some(grid.origin_mm[d]));
        assert_eq!(json["spacing"][d].as_f64(), Some(grid.spacing_mm[d]));
    }
    for (n, p) in points.iter().enumerate() {
        for (c, name) in CHANNELS.iter().enumerate() {
            assert_eq!(
                json["values"][n][name].as_f64().map(|v| v as f32),
                Some(expected(*p, c)),
                "{name} at {p:?}"
            );
        }
    }
}

#[test]
fn exrheader_reads_the_field() {
    if !tool_available(
        std::process::Command::new("sh").args(["-c", "command -v exrheader"]),
        "exrheader (Debian package openexr)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (_, _, path) = mapped(dir.path(), [3, 2, 2]);
    let output = std::process::Command::new("exrheader")
        .arg(&path)
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    for expected in [
        "VE.X, 32-bit floating-point",
        "OE.Z, 32-bit floating-point",
        "compression (type compression): none",
        "dataWindow (type box2i): (0 0) - (2 3)",
        "volmap.dims (type v3i): (3 2 2)",
        "volmap.origin (type v3d)",
        "volmap.spacing (type v3d)",
        "volmap.pose (type v3d)",
        // exrheader prints no v3d value: the same in OpenEXR's v3f, which it prints.
        "volmap.origin_mm (type v3f): (0 0 0)",
        "volmap.spacing_mm (type v3f): (400 600 500)",
        "volmap.grid (type string): \"X: 3 points from 0.0 to 800.0 mm, step 400.0 mm; Y: 2 points from 0.0 to 600.0 mm, step 600.0 mm; Z: 2 points from 0.0 to 500.0 mm, step 500.0 mm; B at 12.5 deg; C at 200.0 deg\"",
        "volmap.chain (type string): \"FYXCFZB\"",
    ] {
        assert!(text.contains(expected), "exrheader output lacks `{expected}`:\n{text}");
    }
}

/// A sweep's parts: the multi-part writer streams them in order, and the readers find them.
fn two_poses(path: &std::path::Path) -> (volmap::model::Machine, Vec<Grid>) {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let grids: Vec<Grid> = volmap::model::poses::parse_sweep("B=-45:45:90,C=30", &machine)
        .unwrap()
        .into_iter()
        .map(|pose| Grid::full_travel(&machine, [4, 3, 2], pose).unwrap())
        .collect();
    let options = MapOptions {
        chunk_points: Some(4),
        check_points: 3,
        ..Default::default()
    };
    let summary = volmap::engine::sweep::map_sweep_to_file(
        &machine,
        &grids,
        &Engine::Cpu,
        path,
        &options,
        |_| {},
    )
    .unwrap();
    assert_eq!(summary.poses.len(), 2);
    assert_eq!(summary.poses[1].name, "B=45,C=30");
    assert_eq!(summary.stats.points, 48);
    assert!(summary
        .check
        .as_ref()
        .is_some_and(|c| c.points == 6 && c.passed()));
    (machine, grids)
}

#[test]
fn a_multi_part_field_holds_each_pose_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sweep.exr");
    let (machine, grids) = two_poses(&path);
    let file = volmap::io::field::FieldFile::open(&path).unwrap();
    assert!(file.is_multipart());
    assert_eq!(file.parts(), 2);
    assert_eq!(file.pose_list(), "B=-45,C=30 B=45,C=30");
    assert_eq!(file.parts_at([0.0, 45.0, 30.0], [true; 3]), [1]);
    assert_eq!(
        file.parts_at([0.0, 45.0 + 2e-9, 30.0], [true; 3]),
        [] as [usize; 0]
    );
    assert_eq!(
        file.parts_at([0.0, 0.0, 30.0], [false, false, true]),
        [0, 1]
    );
    for (p, grid) in grids.iter().enumerate() {
        let expected = engine_values(&machine, grid);
        let mut reader = file.reader(p).unwrap();
        assert_eq!(reader.info().pose_deg, [0.0, grid.pose[4], 30.0]);
        assert_eq!(reader.info().machine_toml, machine.source.toml);
        let mut line = vec![0.0f32; CHANNELS.len() * 4];
        for k in 0..2 {
            for j in 0..3 {
                reader.read_line((j + 3 * k) as u64, &mut line).unwrap();
                for i in 0..4 {
                    for c in 0..6 {
                        assert_eq!(line[c * 4 + i], expected([i, j, k], c));
                    }
                }
            }
        }
    }
    // A reader of one field refuses a sweep, listing its poses.
    let message = FieldReader::open(&path).err().expect("refused").to_string();
    assert!(
        message.contains("holds 2 poses") && message.contains("B=-45,C=30 B=45,C=30"),
        "{message}"
    );
    let message = file
        .part_at([0.0, 10.0, 30.0], "B=10,C=30")
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("no field at the pose B=10,C=30") && message.contains("B=45,C=30"),
        "{message}"
    );
    // A truncated sweep is refused.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.exr");
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    let message = volmap::io::field::FieldFile::open(&cut)
        .err()
        .expect("truncated")
        .to_string();
    assert!(message.contains("truncated"), "{message}");
}

#[test]
fn an_unfinished_sweep_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let grid = Grid::full_travel(&machine, [2, 2, 2], [0.0; 6]).unwrap();
    let path = dir.path().join("partial.exr");
    let mut writer = volmap::io::field::PartsWriter::create(&path, 3, |p| {
        (
            format!("part {p}"),
            map::field_info(&machine, &grid, "test"),
        )
    })
    .unwrap();
    writer.write_lines(0, 0, 4, &[0.0; 4 * 6 * 2]).unwrap();
    let error = writer.write_lines(2, 0, 1, &[0.0; 12]).unwrap_err();
    assert!(
        error.to_string().contains("expected part 0, got 2"),
        "{error}"
    );
    writer.write_lines(1, 0, 1, &[0.0; 12]).unwrap();
    let error = writer.write_lines(2, 0, 1, &[0.0; 12]).unwrap_err();
    assert!(
        error.to_string().contains("expected part 1, got 2"),
        "{error}"
    );
    let incomplete = writer.finish().unwrap_err();
    assert!(
        incomplete.to_string().contains("only 5 of 12 lines"),
        "{incomplete}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "nothing may be left behind: {left:?}");
}
