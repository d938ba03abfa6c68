//! VTK XML files for ParaView (and VTK's own readers): a part's mesh with a scalar per vertex
//! (PolyData, `.vtp`) and a field or a slice of it on its grid (ImageData, `.vti`).
//!
//! Both are written in VTK's "appended raw" encoding: the XML header lists every array with its
//! byte offset into one binary block at the end, where each array is an 8-byte length and its
//! little-endian values. All the lengths are known before any value is, so a field's arrays can
//! be filled chunk by chunk as the map computes them: the writer seeks to where each chunk's
//! values go, and memory holds no more than the chunk.

use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

use nalgebra::Vector3;

use super::atomic::{write_atomically, AtomicFile};
use super::field::FieldInfo;
use super::FileError;
use crate::model::channels::CHANNELS;

/// A data array as the XML header announces it: its VTK type, name, components and number of
/// tuples.
#[derive(Debug, Clone)]
pub struct ArraySpec {
    pub name: String,
    pub components: usize,
    pub tuples: u64,
    kind: Kind,
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Float32,
    Float64,
    Int64,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Float32 => "Float32",
            Kind::Float64 => "Float64",
            Kind::Int64 => "Int64",
        }
    }

    fn bytes(self) -> u64 {
        match self {
            Kind::Float32 => 4,
            Kind::Float64 | Kind::Int64 => 8,
        }
    }
}

impl ArraySpec {
    /// An array of 32-bit floats, `components` per point.
    pub fn float32(name: &str, components: usize, tuples: u64) -> ArraySpec {
        ArraySpec {
            name: name.to_string(),
            components,
            tuples,
            kind: Kind::Float32,
        }
    }

    fn value_bytes(&self) -> u64 {
        self.tuples * self.components as u64 * self.kind.bytes()
    }

    /// The `<DataArray>` element pointing at `offset` in the appended block.
    fn element(&self, offset: u64) -> String {
        format!(
            "<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"appended\" offset=\"{offset}\"/>",
            self.kind.name(),
            xml_escape(&self.name),
            self.components
        )
    }
}

fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The offsets of arrays laid one after another in the appended block.
fn offsets(arrays: &[&ArraySpec]) -> Vec<u64> {
    let mut next = 0;
    arrays
        .iter()
        .map(|a| {
            let at = next;
            next += 8 + a.value_bytes();
            at
        })
        .collect()
}

const OPEN: &str = "<?xml version=\"1.0\"?>\n";
const APPENDED: &str = "  <AppendedData encoding=\"raw\">\n   _";
const CLOSE: &[u8] = b"\n  </AppendedData>\n</VTKFile>\n";

fn file_element(kind: &str) -> String {
    format!("<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n")
}

fn write_values<T: Copy, const N: usize>(
    out: &mut dyn Write,
    values: impl Iterator<Item = T>,
    bytes: impl Fn(T) -> [u8; N],
) -> std::io::Result<()> {
    for v in values {
        out.write_all(&bytes(v))?;
    }
    Ok(())
}

/// Writes a triangle mesh as VTK XML PolyData with `values` (one per vertex) as its point data
/// array `name`, the active scalars ParaView colours by; whole or not at all.
pub fn write_poly_data(
    path: &Path,
    vertices: &[Vector3<f64>],
    triangles: &[[u32; 3]],
    name: &str,
    values: &[f32],
) -> Result<(), FileError> {
    assert_eq!(values.len(), vertices.len(), "one value per vertex");
    let (n, t) = (vertices.len() as u64, triangles.len() as u64);
    let scalar = ArraySpec::float32(name, 1, n);
    let points = ArraySpec {
        name: "Points".into(),
        components: 3,
        tuples: n,
        kind: Kind::Float64,
    };
    let connectivity = ArraySpec {
        name: "connectivity".into(),
        components: 1,
        tuples: 3 * t,
        kind: Kind::Int64,
    };
    let polygon_ends = ArraySpec {
        name: "offsets".into(),
        tuples: t,
        ..connectivity.clone()
    };
    let at = offsets(&[&scalar, &points, &connectivity, &polygon_ends]);
    let header = format!(
        "{OPEN}{}  <PolyData>\n    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{t}\">\n      <PointData Scalars=\"{}\">\n        {}\n      </PointData>\n      <Points>\n        {}\n      </Points>\n      <Polys>\n        {}\n        {}\n      </Polys>\n    </Piece>\n  </PolyData>\n{APPENDED}",
        file_element("PolyData"),
        xml_escape(name),
        scalar.element(at[0]),
        points.element(at[1]),
        connectivity.element(at[2]),
        polygon_ends.element(at[3]),
    );
    write_atomically(path, |out| {
        out.write_all(header.as_bytes())?;
        out.write_all(&scalar.value_bytes().to_le_bytes())?;
        write_values(out, values.iter().copied(), f32::to_le_bytes)?;
        out.write_all(&points.value_bytes().to_le_bytes())?;
        let coordinates = vertices.iter().flat_map(|v| [v.x, v.y, v.z]);
        write_values(out, coordinates, f64::to_le_bytes)?;
        out.write_all(&connectivity.value_bytes().to_le_bytes())?;
        let corners = triangles.iter().flatten().map(|&i| i as i64);
        write_values(out, corners, i64::to_le_bytes)?;
        out.write_all(&polygon_ends.value_bytes().to_le_bytes())?;
        write_values(out, (1..=t as i64).map(|k| 3 * k), i64::to_le_bytes)?;
        out.write_all(CLOSE)
    })
}

/// The grid of an ImageData file: the index range along X, Y and Z (a slice has one index
/// along its normal), the position of index 0 and the step, mm.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageGrid {
    pub extent: [[usize; 2]; 3],
    pub origin_mm: [f64; 3],
    pub spacing_mm: [f64; 3],
}

impl ImageGrid {
    /// The points of the grid, X varying fastest, then Y, then Z (VTK's order, and the field's).
    pub fn points(&self) -> u64 {
        self.extent
            .iter()
            .map(|[lo, hi]| (hi - lo + 1) as u64)
            .product()
    }
}

/// Writes `values` (X varying fastest, then Y, then Z) on `grid` as VTK XML ImageData with the
/// one point data array `name`, the active scalars; whole or not at all.
pub fn write_image(
    path: &Path,
    grid: &ImageGrid,
    name: &str,
    values: &[f64],
) -> Result<(), FileError> {
    assert_eq!(values.len() as u64, grid.points(), "one value per point");
    let array = ArraySpec::float32(name, 1, grid.points());
    let mut writer = ImageWriter::create(path, grid, &[array])?;
    writer.write(0, 0, values.iter().map(|&v| v as f32))?;
    writer.finish()
}

/// Streams VTK XML ImageData into a temporary file renamed into place by [`ImageWriter::finish`]:
/// the header and each array's length first, then the values of any range of points of any
/// array in any order, each written where it belongs.
pub struct ImageWriter {
    out: AtomicFile,
    /// Where each array's values begin in the file, and its components.
    arrays: Vec<(u64, usize)>,
    /// Values written per array, to tell a finished file from an incomplete one.
    written: Vec<u64>,
    expected: Vec<u64>,
    bytes: Vec<u8>,
}

impl ImageWriter {
    /// Starts writing `path`: point data `arrays` on `grid` (the first array the active scalars
    /// or vectors, by its components).
    pub fn create(
        path: &Path,
        grid: &ImageGrid,
        arrays: &[ArraySpec],
    ) -> Result<ImageWriter, FileError> {
        let extent: Vec<String> = grid
            .extent
            .iter()
            .flat_map(|[lo, hi]| [lo.to_string(), hi.to_string()])
            .collect();
        let extent = extent.join(" ");
        let triple = |v: [f64; 3]| format!("{} {} {}", v[0], v[1], v[2]);
        let refs: Vec<&ArraySpec> = arrays.iter().collect();
        let at = offsets(&refs);
        let active = match arrays.first() {
            Some(a) if a.components == 3 => format!(" Vectors=\"{}\"", xml_escape(&a.name)),
            Some(a) => format!(" Scalars=\"{}\"", xml_escape(&a.name)),
            None => String::new(),
        };
        let elements: String = arrays
            .iter()
            .zip(&at)
            .map(|(a, &o)| format!("        {}\n", a.element(o)))
            .collect();
        let header = format!(
            "{OPEN}{}  <ImageData WholeExtent=\"{extent}\" Origin=\"{}\" Spacing=\"{}\" Direction=\"1 0 0 0 1 0 0 0 1\">\n    <Piece Extent=\"{extent}\">\n      <PointData{active}>\n{elements}      </PointData>\n      <CellData>\n      </CellData>\n    </Piece>\n  </ImageData>\n{APPENDED}",
            file_element("ImageData"),
            triple(grid.origin_mm),
            triple(grid.spacing_mm),
        );
        let mut out = AtomicFile::create(path, 1 << 20)?;
        let start = header.len() as u64;
        let result = (|| -> std::io::Result<()> {
            out.write_all(header.as_bytes())?;
            for (a, &o) in arrays.iter().zip(&at) {
                out.seek(SeekFrom::Start(start + o))?;
                out.write_all(&a.value_bytes().to_le_bytes())?;
            }
            let end = start
                + at.last().map_or(0, |&o| o)
                + arrays.last().map_or(0, |a| 8 + a.value_bytes());
            out.seek(SeekFrom::Start(end))?;
            out.write_all(CLOSE)
        })();
        result.map_err(|e| out.error(e))?;
        Ok(ImageWriter {
            out,
            arrays: arrays
                .iter()
                .zip(&at)
                .map(|(a, &o)| (start + o + 8, a.components))
                .collect(),
            written: vec![0; arrays.len()],
            expected: arrays.iter().map(|a| a.tuples).collect(),
            bytes: Vec::new(),
        })
    }

    /// Writes the values of array `array` for the points from `first_point` on: `values` holds
    /// the components of each point in turn.
    pub fn write(
        &mut self,
        array: usize,
        first_point: u64,
        values: impl Iterator<Item = f32>,
    ) -> Result<(), FileError> {
        let (start, components) = self.arrays[array];
        self.bytes.clear();
        self.bytes.extend(values.flat_map(f32::to_le_bytes));
        let result = self
            .out
            .seek(SeekFrom::Start(start + first_point * components as u64 * 4))
            .and_then(|_| self.out.write_all(&self.bytes));
        result.map_err(|e| self.out.error(e))?;
        self.written[array] += (self.bytes.len() / 4 / components) as u64;
        Ok(())
    }

    /// Puts the file in place once every point of every array was written.
    pub fn finish(self) -> Result<(), FileError> {
        if self.written != self.expected {
            return Err(self.out.error(std::io::Error::other(format!(
                "{:?} values written of {:?}",
                self.written, self.expected
            ))));
        }
        self.out.commit()
    }
}

/// A field streamed into VTK XML ImageData as the map computes it: the grid of the field (origin
/// and spacing in mm), the point data arrays `VE` (mm) and `OE` (rad), three components each,
/// filled chunk by chunk of whole grid lines in the layout of [`CHANNELS`].
pub struct FieldImage {
    writer: ImageWriter,
    nx: usize,
}

/// The field's arrays: VE first (the active vectors ParaView colours by), then OE; each with
/// the [`CHANNELS`] index of its X component.
const FIELD_ARRAYS: [(&str, usize); 2] = [("VE", 3), ("OE", 0)];

impl FieldImage {
    /// Starts writing `path` for the field of `info`.
    pub fn create(path: &Path, info: &FieldInfo) -> Result<FieldImage, FileError> {
        let [nx, ny, nz] = info.dims;
        let grid = ImageGrid {
            extent: [[0, nx - 1], [0, ny - 1], [0, nz - 1]],
            origin_mm: info.origin_mm,
            spacing_mm: info.spacing_mm,
        };
        let points = grid.points();
        let arrays: Vec<ArraySpec> = FIELD_ARRAYS
            .iter()
            .map(|(name, _)| ArraySpec::float32(name, 3, points))
            .collect();
        Ok(FieldImage {
            writer: ImageWriter::create(path, &grid, &arrays)?,
            nx,
        })
    }

    /// Writes `lines` grid lines from `first_line`: `data` holds, per line, `nx` values of each
    /// channel of [`CHANNELS`] in turn.
    pub fn write_lines(
        &mut self,
        first_line: u64,
        lines: u64,
        data: &[f32],
    ) -> Result<(), FileError> {
        let nx = self.nx;
        let per_line = CHANNELS.len() * nx;
        let data = &data[..lines as usize * per_line];
        for (array, &(_, first_channel)) in FIELD_ARRAYS.iter().enumerate() {
            let values = data.chunks_exact(per_line).flat_map(|line| {
                (0..nx).flat_map(move |i| (0..3).map(move |c| line[(first_channel + c) * nx + i]))
            });
            self.writer.write(array, first_line * nx as u64, values)?;
        }
        Ok(())
    }

    /// Puts the file in place once every line was written.
    pub fn finish(self) -> Result<(), FileError> {
        self.writer.finish()
    }
}
