//! Reading volmap's VTK and PLY files with the Python packages users read them with (VTK's own,
//! which ParaView is built on, and plyfile), through the scripts in `tests/python/`.

use std::path::Path;

use predicates::prelude::*;

use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::io::field::FieldReader;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::poses::parse_pose;

/// Runs `tests/python/SCRIPT FILE` and parses what it prints; `None` (the test skips) where the
/// Python package `package` (`vtk` or `plyfile`) is missing, unless `VOLMAP_REQUIRE_READERS`
/// makes that a failure.
pub(crate) fn python_read(package: &str, script: &str, file: &Path) -> Option<serde_json::Value> {
    // VTK's readers only: the whole `vtk` module would want a display library for rendering.
    let module = if package == "vtk" {
        "vtkmodules.vtkIOXML"
    } else {
        package
    };
    if !crate::field::tool_available(
        std::process::Command::new("python3").args(["-c", &format!("import {module}, numpy")]),
        &format!("the Python {package} package"),
    ) {
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let output = std::process::Command::new("python3")
        .arg(script)
        .arg(file)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Some(serde_json::from_slice(&output.stdout).unwrap())
}

/// The values of point data array `name` as f32, one row of components per point.
fn array(json: &serde_json::Value, name: &str) -> Vec<Vec<f32>> {
    json["arrays"][name]
        .as_array()
        .unwrap_or_else(|| panic!("no array {name} in {json}"))
        .iter()
        .map(|v| match v.as_array() {
            Some(row) => row.iter().map(|c| c.as_f64().unwrap() as f32).collect(),
            None => vec![v.as_f64().unwrap() as f32],
        })
        .collect()
}

#[test]
fn a_map_writes_its_field_as_vtk_image_data_chunk_by_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let pose = parse_pose("B=12.5,C=200", &machine).unwrap();
    let dims = [5, 4, 3];
    let grid = Grid::full_travel(&machine, dims, pose).unwrap();
    let vti = dir.path().join("field.vti");
    // Chunks of two grid lines: the arrays are filled out of order, a piece of each per chunk.
    let options = MapOptions {
        chunk_points: Some(2 * dims[0] as u64),
        vtk_image: Some(vti.clone()),
        ..Default::default()
    };
    let exr = dir.path().join("field.exr");
    map::map_to_file(&machine, &grid, &Engine::Cpu, &exr, &options, |_| {}).unwrap();
    assert!(!dir.path().join(".field.vti.part").exists());
    let expected = crate::field::engine_values(&machine, &grid);
    let Some(json) = python_read("vtk", "read_vtk.py", &vti) else {
        return;
    };
    assert_eq!(json["extent"], serde_json::json!([0, 4, 0, 3, 0, 2]));
    for d in 0..3 {
        assert_eq!(json["origin"][d].as_f64(), Some(grid.origin_mm[d]));
        assert_eq!(json["spacing"][d].as_f64(), Some(grid.spacing_mm[d]));
    }
    assert_eq!(json["points"], 60);
    assert_eq!(json["active"], "VE");
    let (ve, oe) = (array(&json, "VE"), array(&json, "OE"));
    assert_eq!((ve.len(), oe.len()), (60, 60));
    // VTK's point order: X fastest, then Y, then Z.
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = i + dims[0] * (j + dims[1] * k);
                for c in 0..3 {
                    assert_eq!(oe[p][c], expected([i, j, k], c), "OE {c} at {i},{j},{k}");
                    assert_eq!(
                        ve[p][c],
                        expected([i, j, k], 3 + c),
                        "VE {c} at {i},{j},{k}"
                    );
                }
            }
        }
    }
}

#[test]
fn plot_slice_writes_the_plane_as_vtk_image_data() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("f.exr");
    crate::cli::volmap()
        .args(["map", "--grid", "4x3x5", "--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    let vti = dir.path().join("s.vti");
    crate::cli::volmap()
        .args(["plot", "slice", "--normal", "y", "--at", "0", "--field"])
        .arg(&field)
        .arg("--out")
        .arg(&vti)
        .assert()
        .success();
    let mut reader = FieldReader::open(&field).unwrap();
    let info = reader.info().clone();
    let [nx, ny, nz] = info.dims;
    let Some(json) = python_read("vtk", "read_vtk.py", &vti) else {
        return;
    };
    // The plane Y = 0 is the first along Y: one index there, the whole grid along X and Z.
    assert_eq!(
        json["extent"],
        serde_json::json!([0, nx - 1, 0, 0, 0, nz - 1])
    );
    for d in 0..3 {
        assert_eq!(json["origin"][d].as_f64(), Some(info.origin_mm[d]));
        assert_eq!(json["spacing"][d].as_f64(), Some(info.spacing_mm[d]));
    }
    assert_eq!(json["active"], "VE_magnitude_mm");
    let values = array(&json, "VE_magnitude_mm");
    assert_eq!(values.len(), nx * nz);
    let mut line = vec![0.0f32; CHANNELS.len() * nx];
    for k in 0..nz {
        reader.read_line((k * ny) as u64, &mut line).unwrap();
        for i in 0..nx {
            let ve = (3..6)
                .map(|c| (line[c * nx + i] as f64).powi(2))
                .sum::<f64>()
                .sqrt();
            assert_eq!(values[k * nx + i][0], ve as f32, "at i={i}, k={k}");
        }
    }
}

#[test]
fn vti_outputs_are_refused_where_they_cannot_be_written() {
    let dir = tempfile::tempdir().unwrap();
    crate::cli::volmap()
        .args(["map", "--grid", "3x3x3", "--device", "cpu", "--vti"])
        .arg(dir.path().join("f.vtk"))
        .arg("--out")
        .arg(dir.path().join("f.exr"))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--vti").and(predicates::str::contains(".vti")));
    crate::cli::volmap()
        .args([
            "map",
            "--machine",
            "5axis-hwang2014",
            "--grid",
            "3x3x3",
            "--device",
            "cpu",
            "--poses",
            "B=0:30:30",
            "--vti",
        ])
        .arg(dir.path().join("f.vti"))
        .arg("--out")
        .arg(dir.path().join("f.exr"))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--poses"));
    assert!(!dir.path().join("f.exr").exists() && !dir.path().join("f.vti").exists());
}
