//! The statistics of a field (docs/model.md, "Tolerances and sampled machines"): over every point
//! of a grid, and over every pose of a sweep, the largest |VE| (Euclidean) and where, the RMS of
//! |VE|, the largest |OE|, and the largest |VE| along each axis.

use super::channels::CHANNELS;

/// Statistics of a field, accumulated chunk by chunk and pose by pose.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FieldStats {
    pub points: u64,
    /// Σ |VE|², mm².
    pub sum_sq_ve: f64,
    /// The largest |VE|, mm, the point number (`i + nx·line`) and the pose (its index in a
    /// sweep, 0 for one pose) where it is; the first of equal ones.
    pub max_ve_mm: f64,
    pub max_ve_point: u64,
    pub max_ve_pose: usize,
    /// The largest |OE|, rad.
    pub max_oe_rad: f64,
    /// The largest |VE·x̂|, |VE·ŷ|, |VE·ẑ|, mm.
    pub max_axis_mm: [f64; 3],
}

impl FieldStats {
    /// Adds a chunk in the field layout (per line, `nx` values of each channel in turn). The
    /// lines are summed on every core, each line's statistics merged in order: the same figures
    /// whatever the chunks, and off the thread that computes the next chunk for most of the time.
    pub fn add_chunk(&mut self, first_line: u64, lines: u64, nx: usize, data: &[f32]) {
        use rayon::prelude::*;
        let per_line = CHANNELS.len() * nx;
        let data = &data[..(lines as usize * per_line).min(data.len())];
        let per_line_stats: Vec<FieldStats> = data
            .par_chunks_exact(per_line)
            .enumerate()
            .map(|(n, line)| {
                let mut stats = FieldStats::default();
                let (oe, ve) = line.split_at(3 * nx);
                for i in 0..nx {
                    let ve: [f64; 3] = std::array::from_fn(|c| ve[c * nx + i] as f64);
                    let oe: [f64; 3] = std::array::from_fn(|c| oe[c * nx + i] as f64);
                    let point = (first_line + n as u64) * nx as u64 + i as u64;
                    stats.add_point(point, oe, ve);
                }
                stats
            })
            .collect();
        for line in &per_line_stats {
            self.merge(line, self.max_ve_pose);
        }
    }

    /// Adds one point's OE (rad) and VE (mm), in the order of the points.
    pub fn add_point(&mut self, point: u64, oe: [f64; 3], ve: [f64; 3]) {
        let ve2: f64 = ve.iter().map(|v| v * v).sum();
        let oe2: f64 = oe.iter().map(|v| v * v).sum();
        self.sum_sq_ve += ve2;
        let ve_norm = ve2.sqrt();
        if ve_norm > self.max_ve_mm || self.points == 0 {
            self.max_ve_mm = ve_norm;
            self.max_ve_point = point;
            self.max_ve_pose = 0;
        }
        self.max_oe_rad = self.max_oe_rad.max(oe2.sqrt());
        for (m, v) in self.max_axis_mm.iter_mut().zip(ve) {
            *m = m.max(v.abs());
        }
        self.points += 1;
    }

    /// Adds the statistics of a field of pose `pose` (a later pose of a sweep, or a later part of
    /// the same field with its points numbered on).
    pub fn merge(&mut self, other: &FieldStats, pose: usize) {
        if other.points == 0 {
            return;
        }
        if self.points == 0 || other.max_ve_mm > self.max_ve_mm {
            self.max_ve_mm = other.max_ve_mm;
            self.max_ve_point = other.max_ve_point;
            self.max_ve_pose = pose;
        }
        self.points += other.points;
        self.sum_sq_ve += other.sum_sq_ve;
        self.max_oe_rad = self.max_oe_rad.max(other.max_oe_rad);
        for (m, o) in self.max_axis_mm.iter_mut().zip(other.max_axis_mm) {
            *m = m.max(o);
        }
    }

    /// Root mean square of |VE|, mm.
    pub fn rms_ve_mm(&self) -> f64 {
        if self.points == 0 {
            0.0
        } else {
            (self.sum_sq_ve / self.points as f64).sqrt()
        }
    }

    /// The axis (0 x, 1 y, 2 z) along which |VE| is largest, and that largest value, mm.
    pub fn largest_axis(&self) -> (usize, f64) {
        (0..3).fold((0, self.max_axis_mm[0]), |best, d| {
            if self.max_axis_mm[d] > best.1 {
                (d, self.max_axis_mm[d])
            } else {
                best
            }
        })
    }
}
