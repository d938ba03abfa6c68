//! One block being compensated: its points compensated (the tool tip, and where the orientation
//! is compensated the tool axis too, see `orientation`) as the output writes them, and the tool
//! axis's error measured along what it writes. The pieces of its moves are in `walk` and `arcs`.

use std::cell::Cell;

use super::error::NcError;
use super::kinematics::{beyond_travel, Kinematics};
use super::options::Options;
use super::program::modal::Directions;
use super::program::tcpm::Tcpm;
use super::report::{OrientationLeft, Report};
use super::tcpm;
use super::write::as_written;
use crate::model::Command;

/// The most pieces one move is split into.
pub(super) const MAX_PIECES: usize = crate::limits::MAX_PIECES_PER_MOVE as usize;

/// One block being compensated: the line its errors name, the active work offset, the machine
/// of the active tool, how the output writes numbers, and the largest correction made so far.
pub(super) struct Block<'a> {
    pub(super) path: &'a str,
    pub(super) line: usize,
    offset: [f64; 6],
    pub(super) kin: &'a Kinematics,
    /// The chord tolerance, mm.
    pub(super) tolerance: f64,
    pub(super) inch: bool,
    /// The block gives its arc's centre by R: added arc pieces do too.
    pub(super) radius_words: bool,
    pub(super) options: &'a Options,
    largest_correction: Cell<f64>,
    /// Take-ups added at reversals, and pieces whose compensated motion runs against the
    /// directions they were compensated for.
    pub(super) take_ups: Cell<usize>,
    pub(super) against: Cell<usize>,
    /// Axes standing at a machine position (G53) that the block does not name: the output
    /// writes no word for them, so they are not corrected (their error stays, and is measured).
    pub(super) held: [bool; 6],
    /// Where the bound on the rotary correction held back a point's orientation correction:
    /// the largest angle it left between the real and the intended tool axis (rad).
    pub(super) orientation_left: Cell<Option<f64>>,
    /// The largest rotary correction made so far (degrees, the two axes as a vector).
    pub(super) largest_rotary_correction: Cell<f64>,
    /// Tool-centre-point control in force: program points are tool tips the control solves with
    /// its nominal kinematics (`tcpm`).
    pub(super) tcpm: Option<Tcpm>,
}

/// Why a move could not be split: too many pieces, or a point that does not compensate.
pub(super) enum Split {
    /// More than [`MAX_PIECES`]: the tolerance that kept splitting the move (chord or angular).
    Pieces(super::error::NcOption),
    Point(NcError),
}

impl<'a> Block<'a> {
    /// The block on `line` of `path`, with the active work offset and the machine of the active
    /// tool, written in inch where `inch` (its arcs with R where `radius_words`).
    pub(super) fn new(
        path: &'a str,
        line: usize,
        offset: [f64; 6],
        kin: &'a Kinematics,
        inch: bool,
        radius_words: bool,
        options: &'a Options,
    ) -> Block<'a> {
        Block {
            path,
            line,
            offset,
            kin,
            tolerance: options.chord_tolerance_mm,
            inch,
            radius_words,
            options,
            largest_correction: Cell::new(0.0),
            take_ups: Cell::new(0),
            against: Cell::new(0),
            held: [false; 6],
            orientation_left: Cell::new(None),
            largest_rotary_correction: Cell::new(0.0),
            tcpm: None,
        }
    }

    /// The largest correction of a point made so far (X, Y, Z, mm).
    pub(super) fn largest_correction(&self) -> f64 {
        self.largest_correction.get()
    }

    /// A point as the output writes it (rounded).
    pub(super) fn written(&self, p: &[f64; 6]) -> [f64; 6] {
        let w = std::array::from_fn(|d| as_written(p[d], d, self.inch, self.options));
        if self.tcpm != Some(Tcpm::Vector) {
            return w;
        }
        let solved = tcpm::written_rotaries(self.kin, p, self.options);
        std::array::from_fn(|d| if d < 3 { w[d] } else { solved[d] })
    }

    /// The machine command of a point in program coordinates.
    pub(super) fn command(&self, p: &[f64; 6]) -> Command {
        tcpm::command_of(self.kin, self.tcpm.is_some(), &self.offset, p)
    }

    /// Every axis of the command of `p` within its travel.
    fn check_travel(&self, p: &[f64; 6], what: &str) -> Result<(), NcError> {
        match beyond_travel(self.kin.machine(), &self.command(p)) {
            Some((axis, value)) => Err(NcError::line(
                self.path,
                self.line,
                format!(
                    "{what}: {}={} (machine) lies outside the travel of {} ({} to {})",
                    axis.letter,
                    crate::limits::number_words(value),
                    axis.letter,
                    axis.range[0],
                    axis.range[1]
                ),
            )),
            None => Ok(()),
        }
    }

    /// The program point whose real tool tip, approaching in `directions`, lands on the ideal
    /// tool tip of `p`.
    pub(super) fn compensate_point(
        &self,
        p: &[f64; 6],
        directions: &Directions,
    ) -> Result<[f64; 6], NcError> {
        self.check_travel(p, "the programmed point")?;
        let c = if self.angular_tolerance().is_some() {
            self.compensate_pose(&self.command(p), directions)?
        } else {
            self.kin
                .compensate(&self.command(p), directions)
                .ok_or_else(|| {
                    NcError::line(
                        self.path,
                        self.line,
                        "the compensation does not converge at this point".into(),
                    )
                })?
        };
        let solved = if self.angular_tolerance().is_some() {
            6
        } else {
            3
        };
        let mut compensated = *p;
        let point = match self.tcpm {
            Some(_) => self.kin.tcpm_point(&c, &self.offset),
            None => std::array::from_fn(|d| c[d] - self.offset[d]),
        };
        for d in (0..solved).filter(|&d| !self.held[d]) {
            compensated[d] = point[d];
        }
        self.check_travel(&compensated, "the compensated point")?;
        let correction = (0..3)
            .map(|d| (compensated[d] - p[d]).powi(2))
            .sum::<f64>()
            .sqrt();
        self.largest_correction
            .set(self.largest_correction.get().max(correction));
        Ok(compensated)
    }

    /// The compensated command of a programmed command `q` with its rotary axes solved too (as
    /// far as the bound on the rotary correction reaches; what it leaves is kept).
    pub(super) fn compensate_pose(
        &self,
        q: &Command,
        directions: &Directions,
    ) -> Result<Command, NcError> {
        let pose = self
            .kin
            .compensate_pose(q, directions, self.options.max_rotary_correction_deg)
            .map_err(|_| {
                NcError::line(
                    self.path,
                    self.line,
                    "the tool tip and axis cannot both be reached here: the orientation compensation does not converge".into(),
                )
            })?;
        if pose.bounded {
            let left = self.orientation_left.get().unwrap_or(0.0);
            self.orientation_left.set(Some(left.max(pose.left_rad)));
        }
        self.largest_rotary_correction.set(
            self.largest_rotary_correction
                .get()
                .max(pose.rotary_correction_deg),
        );
        Ok(pose.command)
    }

    /// Adds what the orientation compensation of this block did to `report`: its rotary
    /// correction, and the orientation the bound left on its line.
    pub(super) fn report_orientation(&self, report: &mut Report) {
        report.largest_rotary_correction_deg = report
            .largest_rotary_correction_deg
            .max(self.largest_rotary_correction.get());
        let Some(left_rad) = self.orientation_left.get() else {
            return;
        };
        match report.orientation_left.last_mut() {
            // A line run again (a subprogram, a cycle's repeat) keeps its largest.
            Some(last) if last.line == self.line => last.left_rad = last.left_rad.max(left_rad),
            _ => report.orientation_left.push(OrientationLeft {
                line: self.line,
                left_rad,
            }),
        }
    }

    /// The largest angle between the real and the intended tool axis a piece from `a` to `b`
    /// (compensated points) may have, for the intended points `ia`, `ib` at its ends: the
    /// angular tolerance, plus, where the bound on the rotary correction left part of this
    /// block's orientation error, the smaller angle left at its ends (no piece gets closer than
    /// its ends; the smaller, so a piece from a reachable pose into an unreachable one is split
    /// until the correction is reachable along it).
    pub(super) fn angle_allowed(
        &self,
        (a, b): ([f64; 6], [f64; 6]),
        (ia, ib): ([f64; 6], [f64; 6]),
        directions: &Directions,
    ) -> f64 {
        let tolerance = self.angular_tolerance().unwrap_or(0.0);
        if self.orientation_left.get().is_none() {
            return tolerance;
        }
        let left = |p: &[f64; 6], i: &[f64; 6]| {
            self.kin.axis_miss(
                &self.command(&self.written(p)),
                &self.command(i),
                directions,
            )
        };
        tolerance + left(&a, &ia).min(left(&b, &ib))
    }

    /// The angular tolerance where the orientation is compensated.
    pub(super) fn angular_tolerance(&self) -> Option<f64> {
        self.options.orientation_tolerance_rad
    }

    /// The largest angle between the real tool axis along the straight piece from `a` to `b`
    /// (the commands as written, rounded) and the intended axis at the same fraction of
    /// `[ta, tb]` of `intended` (programmed points); 0 where the orientation is not compensated.
    pub(super) fn chord_angle(
        &self,
        intended: &dyn Fn(f64) -> [f64; 6],
        (ta, tb): (f64, f64),
        (a, b): ([f64; 6], [f64; 6]),
        directions: &Directions,
    ) -> f64 {
        let (a, b) = (self.written(&a), self.written(&b));
        self.angle_along(
            &|s| std::array::from_fn(|d| a[d] + (b[d] - a[d]) * s),
            &|s| intended(ta + (tb - ta) * s),
            (3..6).map(|d| (b[d] - a[d]).abs()).fold(0.0, f64::max),
            directions,
        )
    }

    /// The largest angle between the real tool axis along `commanded` and the intended one along
    /// `intended` at the same fraction (program points), sampled every quarter degree of `turn`
    /// (degrees, 8 to 64 samples); 0 where the orientation is not compensated.
    pub(super) fn angle_along(
        &self,
        commanded: &dyn Fn(f64) -> [f64; 6],
        intended: &dyn Fn(f64) -> [f64; 6],
        turn: f64,
        directions: &Directions,
    ) -> f64 {
        if self.angular_tolerance().is_none() {
            return 0.0;
        }
        let n = ((turn / 0.25).ceil() as usize).clamp(8, 64);
        (0..=n)
            .map(|k| {
                let s = k as f64 / n as f64;
                self.kin.axis_miss(
                    &self.command(&commanded(s)),
                    &self.command(&intended(s)),
                    directions,
                )
            })
            .fold(0.0, f64::max)
    }

    /// The largest angle between the real and the intended tool axis along a move as the program
    /// had it; 0 where the orientation is not compensated.
    pub(super) fn angle_before(
        &self,
        intended: &dyn Fn(f64) -> [f64; 6],
        directions: &dyn Fn(f64) -> Directions,
    ) -> f64 {
        if self.angular_tolerance().is_none() {
            return 0.0;
        }
        let n = 32;
        (0..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let q = self.command(&intended(t));
                self.kin.axis_miss(&q, &q, &directions(t))
            })
            .fold(0.0, f64::max)
    }
}
