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
    #[error("{0} is more than a map can hold (at most 2^21 points along X and 2^31 - 1 along Y times Z)")]
    TooLarge(String),
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

/// The largest line (points along X) a map accepts: one line must fit in one GPU chunk.
pub const MAX_LINE_POINTS: usize = 1 << 21;

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
        // An EXR data window is addressed with i32: ny·nz lines at most 2^31 − 1.
        if dims[0] > MAX_LINE_POINTS || (dims[1] as u64) * (dims[2] as u64) > i32::MAX as u64 {
            return Err(GridError::TooLarge(dims_text(dims)));
        }
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
    pub fn chunks(&self, max_points: u64) -> Vec<(u64, u64)> {
        let lines_per_chunk = (max_points / self.dims[0] as u64).max(1);
        let total = self.lines();
        (0..total.div_ceil(lines_per_chunk))
            .map(|c| {
                let first = c * lines_per_chunk;
                (first, lines_per_chunk.min(total - first))
            })
            .collect()
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
