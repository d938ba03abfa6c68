//! STL reading (ASCII and binary), PLY and VTK PolyData writing, read back as MeshLab and
//! ParaView users read them.

use nalgebra::Vector3;
use volmap::io::mesh::{Mesh, MeshError};

/// A unit tetrahedron as corner triples.
fn tetrahedron() -> Vec<[Vector3<f64>; 3]> {
    let p = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(10.0, 0.0, 0.0),
        Vector3::new(0.0, 20.0, 0.0),
        Vector3::new(0.0, 0.0, 5.5),
    ];
    vec![
        [p[0], p[2], p[1]],
        [p[0], p[1], p[3]],
        [p[1], p[2], p[3]],
        [p[2], p[0], p[3]],
    ]
}

fn binary_stl(triangles: &[[Vector3<f64>; 3]]) -> Vec<u8> {
    let mut bytes = b"solid but binary: headers may start like ASCII".to_vec();
    bytes.resize(80, b' ');
    bytes.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        bytes.extend_from_slice(&[0u8; 12]);
        for c in t {
            for v in c.iter() {
                bytes.extend_from_slice(&(*v as f32).to_le_bytes());
            }
        }
        bytes.extend_from_slice(&[0u8; 2]);
    }
    bytes
}

fn ascii_stl(triangles: &[[Vector3<f64>; 3]]) -> String {
    let mut text = String::from("solid part\n");
    for t in triangles {
        text.push_str("  facet normal 0 0 0\n    outer loop\n");
        for c in t {
            text.push_str(&format!("      vertex {} {} {}\n", c.x, c.y, c.z));
        }
        text.push_str("    endloop\n  endfacet\n");
    }
    text.push_str("endsolid part\n");
    text
}

#[test]
fn ascii_and_binary_stl_give_the_same_indexed_mesh() {
    let t = tetrahedron();
    let from_binary = Mesh::parse_stl(&binary_stl(&t), "b.stl").unwrap();
    let from_ascii = Mesh::parse_stl(ascii_stl(&t).as_bytes(), "a.stl").unwrap();
    assert_eq!(from_binary, from_ascii);
    assert_eq!(from_ascii.vertices.len(), 4, "shared corners are merged");
    assert_eq!(from_ascii.triangles.len(), 4);
    assert_eq!(from_ascii.triangles[1], [0, 2, 3]);
}

#[test]
fn bad_meshes_are_clear_errors() {
    let mut t = tetrahedron();
    t[2][2] = t[2][0] + (t[2][1] - t[2][0]) * 0.5; // a corner on the opposite edge: zero area
    let degenerate = Mesh::parse_stl(ascii_stl(&t).as_bytes(), "d.stl").unwrap_err();
    assert!(
        matches!(degenerate, MeshError::Degenerate { triangle: 2, .. }),
        "{degenerate}"
    );
    let mut truncated = binary_stl(&tetrahedron());
    truncated.truncate(truncated.len() - 7);
    let message = Mesh::parse_stl(&truncated, "t.stl")
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("t.stl") && message.contains("announces 4 triangles"),
        "{message}"
    );
    let bad_vertex = ascii_stl(&tetrahedron()).replacen("vertex 10 0 0", "vertex 10 zero 0", 1);
    let message = Mesh::parse_stl(bad_vertex.as_bytes(), "v.stl")
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("v.stl: line 6") && message.contains("three finite numbers"),
        "{message}"
    );
    let message = Mesh::parse_stl(b"solid empty\nendsolid empty\n", "e.stl")
        .unwrap_err()
        .to_string();
    assert!(message.contains("holds no triangle"), "{message}");
    let missing = Mesh::read_stl(std::path::Path::new("/nonexistent/part.stl"))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("/nonexistent/part.stl"), "{missing}");
}

#[test]
fn ply_holds_the_vertices_faces_and_the_scalar() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::from_triangles(&tetrahedron(), "t").unwrap();
    let values = [0.001f32, -0.002, 0.0005, 0.003];
    let path = dir.path().join("deviation.ply");
    mesh.write_ply(&path, "deviation_mm", &values).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(
        header.contains("element vertex 4\n")
            && header.contains("property float quality\nproperty float deviation_mm\n")
            && header.contains("element face 4\n")
    );
    let body = &bytes[end..];
    assert_eq!(body.len(), 4 * 20 + 4 * 13);
    let float = |k: usize| f32::from_le_bytes(body[4 * k..4 * k + 4].try_into().unwrap());
    // Vertices in order of first use: the second is the first triangle's second corner.
    assert_eq!(
        [float(5), float(6), float(7), float(8), float(9)],
        [0.0, 20.0, 0.0, -0.002, -0.002]
    );
    let face = &body[80 + 13..80 + 26];
    assert_eq!(face[0], 3);
    assert_eq!(i32::from_le_bytes(face[5..9].try_into().unwrap()), 2);
    assert!(!dir.path().join("deviation.ply.part").exists());
}

#[test]
fn plyfile_sees_the_deviation_as_quality() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::from_triangles(&tetrahedron(), "t").unwrap();
    let values = [0.001f32, -0.002, 0.0005, 0.003];
    let path = dir.path().join("deviation.ply");
    mesh.write_ply(&path, "deviation_mm", &values).unwrap();
    let Some(json) = crate::vtk::python_read("plyfile", "read_ply.py", &path) else {
        return;
    };
    assert_eq!(
        json["properties"],
        serde_json::json!(["x", "y", "z", "quality", "deviation_mm"])
    );
    for name in ["quality", "deviation_mm"] {
        let got: Vec<f32> = json["vertex"][name]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap() as f32)
            .collect();
        assert_eq!(got, values, "{name}");
    }
    // Vertices in order of first use: triangle 0 is corners 0, 2, 1 of the tetrahedron.
    assert_eq!(json["faces"][0], serde_json::json!([0, 1, 2]));
    assert_eq!(json["vertex"]["y"][1], 20.0);
}

#[test]
fn vtk_reads_the_poly_data_with_the_deviation_as_its_scalars() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::from_triangles(&tetrahedron(), "t").unwrap();
    let values = [0.001f32, -0.002, 0.0005, 0.003];
    let path = dir.path().join("deviation.vtp");
    mesh.write_vtp(&path, "deviation_mm", &values).unwrap();
    assert!(!dir.path().join(".deviation.vtp.part").exists());
    let Some(json) = crate::vtk::python_read("vtk", "read_vtk.py", &path) else {
        return;
    };
    assert_eq!(json["points"], 4);
    assert_eq!(json["cells"], 4);
    assert_eq!(json["active"], "deviation_mm");
    let got: Vec<f32> = json["arrays"]["deviation_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    assert_eq!(got, values);
    // The corners exactly (f64), in order of first use: (0,0,0), (0,20,0), (10,0,0), (0,0,5.5).
    assert_eq!(
        json["coordinates"],
        serde_json::json!([
            [0.0, 0.0, 0.0],
            [0.0, 20.0, 0.0],
            [10.0, 0.0, 0.0],
            [0.0, 0.0, 5.5]
        ])
    );
    assert_eq!(
        json["polygons"],
        serde_json::json!([[0, 1, 2], [0, 2, 3], [2, 1, 3], [1, 0, 3]])
    );
}

/// A part whose mesh is /dev/zero read 512 MiB of zeros before the limit refused it (up to a
/// second under load): a device's binary header says how much follows, and no more is read.
#[cfg(unix)]
#[test]
fn an_endless_device_as_a_mesh_is_read_no_further_than_its_header() {
    let error = volmap::io::mesh::Mesh::read_stl(std::path::Path::new("/dev/zero"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        error.starts_with("/dev/zero")
            && error.ends_with("the header announces 0 triangles (84 bytes) but more follow"),
        "{error}"
    );
}
