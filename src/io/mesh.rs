//! Triangle meshes of parts: STL in (ASCII and binary), PLY out with a scalar per vertex (for
//! MeshLab to colour; ParaView's reader drops such properties and opens the `.vtp` of
//! [`Mesh::write_vtp`] instead), as the large-part profile checks of the feature queries need.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;

use super::atomic::write_atomically;
use super::{read_bytes, FileError, SourceKind};
use crate::error::excerpt;
use crate::error::{Classify, ErrorKind};

/// What is wrong with a mesh file, or why the PLY could not be written.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{path}: line {line}: {message}")]
    Ascii {
        path: String,
        line: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Binary { path: String, message: String },
    #[error("{path}: triangle {triangle} is degenerate (its corners are collinear or coincide)")]
    Degenerate { path: String, triangle: usize },
    #[error("{path}: holds no triangle")]
    Empty { path: String },
}

impl Classify for MeshError {
    fn kind(&self) -> ErrorKind {
        match self {
            MeshError::File(e) => e.kind(),
            _ => ErrorKind::Input,
        }
    }
}

/// An indexed triangle mesh, mm. Corners shared by triangles are one vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<Vector3<f64>>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Builds the indexed mesh from corner triples, merging corners with identical coordinates.
    /// Triangles of zero area are an error naming their index (from 0).
    pub fn from_triangles(triangles: &[[Vector3<f64>; 3]], path: &str) -> Result<Mesh, MeshError> {
        if triangles.is_empty() {
            return Err(MeshError::Empty {
                path: path.to_string(),
            });
        }
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut mesh = Mesh {
            vertices: Vec::new(),
            triangles: Vec::with_capacity(triangles.len()),
        };
        for (n, corners) in triangles.iter().enumerate() {
            let area2 = (corners[1] - corners[0])
                .cross(&(corners[2] - corners[0]))
                .norm();
            let scale = (corners[1] - corners[0])
                .norm()
                .max((corners[2] - corners[0]).norm());
            if area2.is_nan() || area2 <= 1e-12 * scale * scale {
                return Err(MeshError::Degenerate {
                    path: path.to_string(),
                    triangle: n,
                });
            }
            let mut ids = [0u32; 3];
            for (id, corner) in ids.iter_mut().zip(corners) {
                let key = [corner.x.to_bits(), corner.y.to_bits(), corner.z.to_bits()];
                *id = *index.entry(key).or_insert_with(|| {
                    mesh.vertices.push(*corner);
                    (mesh.vertices.len() - 1) as u32
                });
            }
            mesh.triangles.push(ids);
        }
        Ok(mesh)
    }

    /// Reads an STL file, binary or ASCII (told apart by the binary layout's exact size).
    pub fn read_stl(path: &Path) -> Result<Mesh, MeshError> {
        let shown = path.display().to_string();
        if !std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
            return Mesh::parse_stl(&read_bytes(path, SourceKind::Mesh)?, &shown);
        }
        // A device or a pipe has no size to check ahead; a binary header says how much
        // follows, so an endless one (/dev/zero) is read no further than that.
        use std::io::Read;
        let file = super::source::open_stream(path)?;
        let mut head = Vec::with_capacity(84);
        (&file)
            .take(84)
            .read_to_end(&mut head)
            .map_err(|e| FileError::read(path, e))?;
        let text = super::source::without_byte_order_mark(&head);
        if head.len() < 84 || text.trim_ascii_start().starts_with(b"solid") {
            let bytes = super::source::read_rest(file, path, SourceKind::Mesh, head)?;
            return Mesh::parse_stl(&bytes, &shown);
        }
        let count = u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64;
        let expected = 84 + 50 * count;
        if expected > SourceKind::Mesh.limit_bytes() {
            return Err(FileError::too_large(path, SourceKind::Mesh).into());
        }
        let mut bytes = head;
        bytes.reserve_exact((expected - 84 + 1) as usize);
        (&file)
            .take(expected - 84 + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| FileError::read(path, e))?;
        if bytes.len() as u64 > expected {
            return Err(MeshError::Binary {
                path: shown,
                message: format!(
                    "the header announces {count} triangles ({expected} bytes) but more follow"
                ),
            });
        }
        Mesh::parse_stl(&bytes, &shown)
    }

    pub fn parse_stl(bytes: &[u8], path: &str) -> Result<Mesh, MeshError> {
        let binary_count = bytes
            .get(80..84)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        let is_binary = binary_count.is_some_and(|n| bytes.len() == 84 + 50 * n);
        // ASCII STL saved by an editor may start with a UTF-8 byte-order mark.
        let text = super::source::without_byte_order_mark(bytes);
        if is_binary || !text.trim_ascii_start().starts_with(b"solid") {
            return Mesh::parse_binary(bytes, path);
        }
        match std::str::from_utf8(text) {
            Ok(text) => Mesh::parse_ascii(text, path),
            // Binary headers may begin with `solid` too: not text, so binary it is.
            Err(_) => Mesh::parse_binary(bytes, path),
        }
    }

    fn parse_binary(bytes: &[u8], path: &str) -> Result<Mesh, MeshError> {
        let error = |message: String| MeshError::Binary {
            path: path.to_string(),
            message,
        };
        if bytes.len() < 84 {
            return Err(error(format!(
                "{} bytes: too short for a binary STL (84-byte header)",
                bytes.len()
            )));
        }
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if bytes.len() != 84 + 50 * count {
            return Err(error(format!(
                "the header announces {count} triangles ({} bytes) but the file has {} bytes",
                84 + 50 * count,
                bytes.len()
            )));
        }
        let mut triangles = Vec::with_capacity(count);
        for (n, record) in bytes[84..].chunks_exact(50).enumerate() {
            let f = |k: usize| {
                f32::from_le_bytes([
                    record[4 * k],
                    record[4 * k + 1],
                    record[4 * k + 2],
                    record[4 * k + 3],
                ]) as f64
            };
            let corner = |c: usize| Vector3::new(f(3 + 3 * c), f(4 + 3 * c), f(5 + 3 * c));
            let corners = [corner(0), corner(1), corner(2)];
            if corners.iter().any(|c| !c.iter().all(|v| v.is_finite())) {
                return Err(error(format!(
                    "triangle {n} has a coordinate that is not finite"
                )));
            }
            triangles.push(corners);
        }
        Mesh::from_triangles(&triangles, path)
    }

    fn parse_ascii(text: &str, path: &str) -> Result<Mesh, MeshError> {
        let error = |line: usize, message: String| MeshError::Ascii {
            path: path.to_string(),
            line,
            message,
        };
        let mut triangles = Vec::new();
        let mut corners: Vec<Vector3<f64>> = Vec::new();
        let mut in_facet = false;
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let words: Vec<&str> = raw.split_whitespace().collect();
            match words.first().copied() {
                None | Some("solid") | Some("endsolid") | Some("outer") | Some("endloop") => {}
                Some("facet") => {
                    if in_facet {
                        return Err(error(line, "`facet` inside a facet".into()));
                    }
                    in_facet = true;
                    corners.clear();
                }
                Some("vertex") => {
                    if !in_facet {
                        return Err(error(line, "`vertex` outside a facet".into()));
                    }
                    let values: Vec<f64> = words[1..]
                        .iter()
                        .map(|w| w.parse::<f64>().ok().filter(|v| v.is_finite()))
                        .collect::<Option<_>>()
                        .filter(|v: &Vec<f64>| v.len() == 3)
                        .ok_or_else(|| {
                            error(
                                line,
                                format!(
                                    "expected `vertex x y z` with three finite numbers, found `{}`",
                                    excerpt(raw.trim())
                                ),
                            )
                        })?;
                    corners.push(Vector3::new(values[0], values[1], values[2]));
                }
                Some("endfacet") => {
                    if corners.len() != 3 {
                        return Err(error(
                            line,
                            format!("a facet has {} vertices, not 3", corners.len()),
                        ));
                    }
                    triangles.push([corners[0], corners[1], corners[2]]);
                    in_facet = false;
                }
                Some(other) => return Err(error(line, format!("unexpected `{}`", excerpt(other)))),
            }
        }
        if in_facet {
            return Err(error(
                text.lines().count(),
                "the file ends inside a facet".into(),
            ));
        }
        Mesh::from_triangles(&triangles, path)
    }

    /// Writes the mesh as binary little-endian PLY with a scalar per vertex, whole or not at all:
    /// the scalar twice, as `quality` (the one vertex property MeshLab colours by) and under
    /// `property`, its name with its unit, for other readers.
    pub fn write_ply(&self, path: &Path, property: &str, values: &[f32]) -> Result<(), MeshError> {
        assert_eq!(values.len(), self.vertices.len(), "one value per vertex");
        write_atomically(path, |out| {
            write!(
                out,
                "ply\nformat binary_little_endian 1.0\ncomment written by volmap\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float quality\nproperty float {property}\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
                self.vertices.len(),
                self.triangles.len()
            )?;
            for (v, value) in self.vertices.iter().zip(values) {
                for c in [v.x as f32, v.y as f32, v.z as f32, *value, *value] {
                    out.write_all(&c.to_le_bytes())?;
                }
            }
            for t in &self.triangles {
                out.write_all(&[3u8])?;
                for &i in t {
                    out.write_all(&(i as i32).to_le_bytes())?;
                }
            }
            Ok(())
        })?;
        Ok(())
    }

    /// Writes the mesh as VTK XML PolyData with `values` as the point data array `property`,
    /// which ParaView colours by; whole or not at all.
    pub fn write_vtp(&self, path: &Path, property: &str, values: &[f32]) -> Result<(), MeshError> {
        super::vtk::write_poly_data(path, &self.vertices, &self.triangles, property, values)?;
        Ok(())
    }
}
