//! Answers at arbitrary commanded positions: VE and OE interpolated in a field or computed exactly
//! ([`sample_field`], [`sample_exact`]; [`sample_fields`] in the parts of a sweep, each point in
//! the part of its pose), a plane of a field for a colour map ([`field_slice`]), the
//! workspace grid deformed by its error ([`deformed_grid`]).

mod deformed;
mod sample;
mod sampler;
mod slice;

pub use deformed::{deformed_grid, DeformedGrid};
pub use sample::{
    check_exact_columns, open_sampler, sample_exact, sample_exact_within, sample_field,
    sample_field_gpu, sample_field_gpu_within, sample_field_within, Outside,
};
pub use sampler::{sample_fields, FieldSampler, SampledField};
pub use slice::{field_slice, field_slice_at_pose, FieldSlice, Quantity};

use crate::error::{shown, Classify, ErrorKind};
use crate::gpu::GpuError;
use crate::io::field::FieldError;
use crate::io::points::PointsError;

/// Why a query could not be answered.
#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    #[error(transparent)]
    Points(#[from] PointsError),
    #[error("{path}: line {line}: {axis}={} lies outside the field's grid ({lo} to {hi}); a field is not extrapolated", shown(*.value))]
    Outside {
        path: String,
        line: usize,
        axis: char,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(
        "{path}: line {line}: {axis}={}°, but the field holds the pose {axis}={field}° only", shown(*.value)
    )]
    Pose {
        path: String,
        line: usize,
        axis: char,
        value: f64,
        field: f64,
    },
    #[error("{path}: line {line}: {field} holds no field at the pose {pose}; its poses: {poses}")]
    NoPose {
        path: String,
        line: usize,
        pose: String,
        field: String,
        poses: String,
    },
    #[error(
        "{path}: line {line}: {pose} matches {count} poses of {field}: add the column {missing}"
    )]
    PartialPose {
        path: String,
        line: usize,
        pose: String,
        count: usize,
        field: String,
        missing: String,
    },
    #[error("{path}: line {line}: column {axis}: the machine (chain {chain}) has no {axis} axis")]
    NoAxis {
        path: String,
        line: usize,
        axis: char,
        chain: String,
    },
    #[error("{path}: line {line}: {axis}={} lies outside the machine's travel ({lo} to {hi})", shown(*.value))]
    OutsideTravel {
        path: String,
        line: usize,
        axis: char,
        value: f64,
        lo: f64,
        hi: f64,
    },
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("no GPU adapter found")]
    NoAdapter,
    #[error("normal `{0}`: x, y or z")]
    SliceNormal(String),
    #[error("quantity `{0}`: {choices}", choices = slice::Quantity::choices())]
    SliceQuantity(String),
    #[error("{axis}={at} mm is outside the field's grid along {axis} ({lo} to {hi})")]
    SliceOutside {
        axis: char,
        at: f64,
        lo: f64,
        hi: f64,
    },
    #[error("a deformed grid of {grid} lines draws {} points, more than the limit of {}", crate::limits::count_words(.points.count), .points.limit)]
    DrawnPoints {
        grid: String,
        points: crate::limits::TooMany,
    },
    #[error("a grid of {0} points has no line to draw: it needs two points or more along an axis")]
    NoGridLine(String),
    #[error("a magnification of {0}: it must be a finite number above zero, and the error it magnifies must stay a finite number")]
    Scale(f64),
    /// The machine's error at a position is not a finite number.
    #[error("{0} is not a finite number: check the machine's error values")]
    NotFinite(String),
}

impl Classify for QueryError {
    fn kind(&self) -> ErrorKind {
        match self {
            QueryError::Field(e) => e.kind(),
            QueryError::Gpu(e) => e.kind(),
            QueryError::NoAdapter => ErrorKind::Work,
            _ => ErrorKind::Input,
        }
    }
}
