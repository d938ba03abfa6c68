//! The grid of commanded positions a map covers: the linear axes X, Y, Z over a regular grid,
//! every rotary axis at a fixed pose.
//!
//! Point `(i, j, k)` commands `X = origin_x + i·spacing_x`, `Y = origin_y + j·spacing_y`,
//! `Z = origin_z + k·spacing_z`. Points are numbered `p = i + nx·(j + ny·k)`; a *line* is the
//! `nx` points of one `(j, k)`, numbered `line = j + ny·k` (the EXR scanline of that line).

use crate::error::input_errors;
use crate::model::{AxisLetter, Command, Machine};

#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error("`{0}`: expected NXxNYxNZ with positive integers, e.g. 64x64x64")]
    Syntax(String),
    #[error("{axis} has {n} points but the machine has no {axis} axis: use 1")]
    AbsentAxis { axis: AxisLetter, n: usize },
    /// A grid beyond [`MAX_AXIS_POINTS`] along an axis or [`MAX_LINES`] lines: `what` says
    /// which, and what to use instead.
    #[error("{grid} is more than a map can hold: {what}")]
    TooLarge { grid: String, what: String },
    #[error("`{0}`: expected LETTER=DEGREES pairs separated by commas, e.g. B=30,C=-45")]
    PoseSyntax(String),
    #[error("`{0}`: expected LETTER=DEGREES or LETTER=START:STOP:STEP separated by commas, e.g. B=-90:90:15,C=0:345:15")]
    SweepSyntax(String),
    #[error("`{sweep}` has more than {most} poses")]
    SweepSize { sweep: String, most: usize },
    #[error("{axis} is {what}")]
    PoseAxis { axis: String, what: String },
}

input_errors!(GridError);

#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Points along X, Y, Z.
    pub dims: [usize; 3],
    /// Commanded X, Y, Z of point (0, 0, 0), mm.
    pub origin_mm: [f64; 3],
    /// Step between neighbouring points, mm (0 along a dimension of one point).
    pub spacing_mm: [f64; 3],
    /// Commanded position of every axis that is not a grid dimension: degrees for A B C (index by
    /// [`AxisLetter::index`]; the X Y Z entries are unused).
    pub pose: Command,
}

/// The most points a map takes along each of X, Y and Z. Both engines tabulate every axis at
/// every value of its grid coordinate once per map (a GPU in one buffer and one dispatch of the
/// axis pass): 2^18 keeps those tables within what every adapter offers (a 128 MiB buffer, 65,535
/// workgroups: 96 bytes an entry, 3·2^18 entries) and the CPU engine's within 64 MiB an axis, so
/// no grid inside the limit fails on one engine and maps on the other.
pub const MAX_AXIS_POINTS: usize = 1 << 18;

/// The most lines (`NY·NZ`) a map takes: an EXR data window is addressed with i32.
pub const MAX_LINES: u64 = i32::MAX as u64;

/// The chunks of whole lines a map is computed in, `(first line, lines)`, each of at most
/// `lines_per_chunk` lines: computed as they are asked for, never held as a list (a grid of 2^31
/// lines in chunks of one line is 2^31 chunks).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunks {
    lines_per_chunk: u64,
    total: u64,
}

impl Chunks {
    pub fn len(&self) -> usize {
        self.total.div_ceil(self.lines_per_chunk) as usize
    }

    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// Chunk `n`: its first line and its lines.
    pub fn get(&self, n: usize) -> (u64, u64) {
        let first = n as u64 * self.lines_per_chunk;
        (first, self.lines_per_chunk.min(self.total - first))
    }

    /// The lines of the largest chunk (the first).
    pub fn most_lines(&self) -> u64 {
        self.lines_per_chunk.min(self.total)
    }

    pub fn iter(self) -> impl ExactSizeIterator<Item = (u64, u64)> {
        (0..self.len()).map(move |n| self.get(n))
    }
}

impl Grid {
    /// A grid spanning the full travel of each linear axis of `machine`. A linear axis the
    /// machine lacks must have one point, at 0.
    pub fn full_travel(
        machine: &Machine,
        dims: [usize; 3],
        pose: Command,
    ) -> Result<Grid, GridError> {
        let mut origin_mm = [0.0; 3];
        let mut spacing_mm = [0.0; 3];
        for (d, letter) in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z]
            .into_iter()
            .enumerate()
        {
            match machine.axis(letter) {
                Some(axis) => {
                    origin_mm[d] = axis.range[0];
                    if dims[d] > 1 {
                        spacing_mm[d] = (axis.range[1] - axis.range[0]) / (dims[d] - 1) as f64;
                    }
                }
                None if dims[d] != 1 => {
                    return Err(GridError::AbsentAxis {
                        axis: letter,
                        n: dims[d],
                    })
                }
                None => {}
            }
        }
        check_size(dims)?;
        Ok(Grid {
            dims,
            origin_mm,
            spacing_mm,
            pose,
        })
    }

    pub fn points(&self) -> u64 {
        self.dims.iter().map(|&n| n as u64).product()
    }

    pub fn lines(&self) -> u64 {
        self.dims[1] as u64 * self.dims[2] as u64
    }

    /// Chunks of whole lines, `(first line, lines)`, each of at most `max_points` points (at
    /// least one line).
    pub fn chunks(&self, max_points: u64) -> Chunks {
        Chunks {
            lines_per_chunk: (max_points / self.dims[0] as u64).max(1),
            total: self.lines(),
        }
    }

    /// Every commanded position `axis` takes on this grid: the grid values along its dimension
    /// for X, Y, Z, the pose for a rotary axis.
    pub fn axis_positions(&self, axis: AxisLetter) -> Vec<f64> {
        if axis.is_linear() {
            let d = axis.direction_index();
            (0..self.dims[d])
                .map(|v| self.origin_mm[d] + v as f64 * self.spacing_mm[d])
                .collect()
        } else {
            vec![self.pose[axis.index()]]
        }
    }

    /// `(i, j, k)` of point number `p`.
    pub fn indices(&self, p: u64) -> [usize; 3] {
        let nx = self.dims[0] as u64;
        let ny = self.dims[1] as u64;
        [
            (p % nx) as usize,
            ((p / nx) % ny) as usize,
            (p / (nx * ny)) as usize,
        ]
    }

    /// The commanded positions of all axes at grid point `(i, j, k)`.
    pub fn command(&self, ijk: [usize; 3]) -> Command {
        let mut c = self.pose;
        for d in 0..3 {
            c[d] = self.origin_mm[d] + ijk[d] as f64 * self.spacing_mm[d];
        }
        c
    }
}

/// Refuses dimensions beyond [`MAX_AXIS_POINTS`] along an axis or [`MAX_LINES`] lines, before
/// anything is tabulated, allocated or written.
pub fn check_size(dims: [usize; 3]) -> Result<(), GridError> {
    let too_large = |what: String| GridError::TooLarge {
        grid: dims_text(dims),
        what,
    };
    for (d, letter) in ["X", "Y", "Z"].into_iter().enumerate() {
        if dims[d] > MAX_AXIS_POINTS {
            return Err(too_large(format!(
                "{} points along {letter}, more than the limit of {MAX_AXIS_POINTS} along each axis: use at most {MAX_AXIS_POINTS}",
                dims[d]
            )));
        }
    }
    let lines = dims[1] as u64 * dims[2] as u64;
    if lines > MAX_LINES {
        return Err(too_large(format!(
            "{lines} lines (NY·NZ), more than the limit of {MAX_LINES}: use fewer points along Y or Z"
        )));
    }
    Ok(())
}

/// Grid dimensions as [`parse_dims`] reads them, `NXxNYxNZ`.
pub fn dims_text(dims: [usize; 3]) -> String {
    format!("{}x{}x{}", dims[0], dims[1], dims[2])
}

/// Parses `NXxNYxNZ`.
pub fn parse_dims(text: &str) -> Result<[usize; 3], GridError> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let dims: Vec<usize> = parts
        .iter()
        .map(|p| p.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| GridError::Syntax(text.to_string()))?;
    match dims[..] {
        [nx, ny, nz] if nx > 0 && ny > 0 && nz > 0 => Ok([nx, ny, nz]),
        _ => Err(GridError::Syntax(text.to_string())),
    }
}
