//! The correction a table should hold, what a format's tables can hold of it ([`Structure`]),
//! and its additive fit.
//!
//! For every target command `t` (X, Y, Z over their travels, the rotary axes at the pose) the
//! correction is `d(t) = c(t) − t`, `c(t)` the command whose REAL tool tip lands where the IDEAL
//! machine puts the tip at `t` ([`Twin::real_command_for`], Newton steps with the inverse of the
//! ideal Jacobian): the command correction that puts the tip on target, in machine axis
//! coordinates (to first order `−J⁻¹·VE(t)`), not the error.
//!
//! Per-axis and cross-axis tables are sums of functions of one axis position each. On a full
//! regular (factorial) grid the least-squares fit of such a sum is the grand mean plus the main
//! effects, which are orthogonal there: the main effect of axis `i` on the correction of axis `k`
//! is the mean of `d_k` over the other two axes at each position of `i`, less the grand mean
//! ([`Fitting::additive`]).
//!
//! [`Structure`] lives here, not with the formats, because the fit and the structural remainder
//! read it: a format's facts (its `Spec`) import it from here.

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::error::ExportError;
use crate::model::inputs::{Approach, Inputs};
use crate::model::{AxisLetter, Command, ErrorFunction, Machine};
use crate::reference::Twin;

/// Points per axis of the factorial grid the additive fit averages over (and the constant and
/// slopes are fitted on).
pub const AVERAGING_POINTS: usize = 11;

/// The linear axes.
pub const LINEAR: [AxisLetter; 3] = [AxisLetter::X, AxisLetter::Y, AxisLetter::Z];

/// What the tables of a format can hold of a correction `d(t)`, for the report of what is left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// A 3-D grid: any smooth correction of X, Y, Z at the pose, limited only by its spacing.
    Grid,
    /// A sum of functions of one axis position each: `terms[k][i]` says what the correction of
    /// axis `k` (X, Y, Z) may be as a function of the commanded position of axis `i`.
    Additive([[Term; 3]; 3]),
    /// Per axis `k`, a function of its own position plus a function of the other two axes'
    /// positions together: `d_k = f_k(q_k) + g_k(q_i, q_j)` (an axis table and a plane table).
    AxisAndPlane,
    /// Z's correction alone, one function of X and Y together (a bed height map):
    /// `d = (0, 0, h(q_x, q_y))`.
    ZOfXY,
}

/// One term of an [`Structure::Additive`] correction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Term {
    /// Nothing of it.
    None,
    /// `s · q`: a slope through the machine zero (a skew or scale factor).
    Slope,
    /// Any function of the position (a table), offsets included.
    Curve,
}

/// The correction of one machine at one set of evaluation inputs, at the pose.
pub struct Field {
    twin: Twin,
    inverse: Matrix3<f64>,
    pose: Command,
}

impl Field {
    /// The field of `machine` (already at its inputs) with the rotary axes at `pose`.
    pub fn new(machine: Machine, pose: Command) -> Result<Field, ExportError> {
        let twin = Twin::new(machine);
        let inverse = twin
            .ideal_jacobian(&pose)
            .try_inverse()
            .ok_or(ExportError::Singular)?;
        Ok(Field {
            twin,
            inverse,
            pose,
        })
    }

    pub fn twin(&self) -> &Twin {
        &self.twin
    }

    /// The inverse of the ideal Jacobian of the tip by X, Y, Z at the pose: to first order the
    /// correction is `−J⁻¹·VE`.
    pub fn inverse_jacobian(&self) -> Matrix3<f64> {
        self.inverse
    }

    /// The command of target X, Y, Z at the pose.
    pub fn command(&self, xyz: [f64; 3]) -> Command {
        let mut c = self.pose;
        c[..3].copy_from_slice(&xyz);
        c
    }

    /// `d(t) = c(t) − t` at target `xyz`, mm, machine axis coordinates.
    pub fn correction(&self, xyz: [f64; 3]) -> Result<[f64; 3], ExportError> {
        let t = self.command(xyz);
        let tip = self.twin.ideal_tip(&t);
        let mut c = self
            .twin
            .real_command_for(tip, &t, &self.inverse)
            .ok_or(ExportError::NoSolution { at_mm: xyz })?;
        // One step more: the solve stops within 1e-10 mm, and slopes fitted over a metre of
        // corrections want them to the last digit.
        let step = self.inverse * (self.twin.real_tip(&c) - tip);
        for d in 0..3 {
            c[d] -= step[d];
        }
        Ok([c[0] - xyz[0], c[1] - xyz[1], c[2] - xyz[2]])
    }

    /// [`Field::correction`] at many targets, in parallel, in order.
    pub fn corrections(&self, targets: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, ExportError> {
        targets.par_iter().map(|&t| self.correction(t)).collect()
    }

    /// The mean correction over the factorial grid `positions` (X, Y, Z lists) at each position
    /// of axis `along`: `g[k][p]`, the mean of `d_k` over the other two axes at
    /// `positions[along][p]`.
    pub fn axis_means(
        &self,
        along: usize,
        positions: &[Vec<f64>; 3],
    ) -> Result<[Vec<f64>; 3], ExportError> {
        let (a, b) = others(along);
        let targets: Vec<[f64; 3]> = positions[along]
            .iter()
            .flat_map(|&p| {
                positions[a].iter().flat_map(move |&qa| {
                    positions[b].iter().map(move |&qb| {
                        let mut t = [0.0; 3];
                        (t[along], t[a], t[b]) = (p, qa, qb);
                        t
                    })
                })
            })
            .collect();
        let d = self.corrections(&targets)?;
        let per = positions[a].len() * positions[b].len();
        Ok(std::array::from_fn(|k| {
            d.chunks(per)
                .map(|chunk| chunk.iter().map(|v| v[k]).sum::<f64>() / per as f64)
                .collect()
        }))
    }
}

/// The two axes other than `axis`, in order.
pub fn others(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// `n` positions from `lo` to `hi`, evenly spaced (`lo` alone for one).
pub fn uniform(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![lo];
    }
    (0..n)
        .map(|i| {
            if i == n - 1 {
                hi
            } else {
                lo + (hi - lo) * i as f64 / (n - 1) as f64
            }
        })
        .collect()
}

/// The least-squares slope of `values` over `positions`.
pub fn slope(positions: &[f64], values: &[f64]) -> f64 {
    let n = positions.len() as f64;
    let mq = positions.iter().sum::<f64>() / n;
    let mv = values.iter().sum::<f64>() / n;
    let (mut sqv, mut sqq) = (0.0, 0.0);
    for (q, v) in positions.iter().zip(values) {
        sqv += (q - mq) * (v - mv);
        sqq += (q - mq) * (q - mq);
    }
    if sqq == 0.0 {
        0.0
    } else {
        sqv / sqq
    }
}

/// An additive fit `d_k(t) ≈ constant[k] + Σ_i term_ki(t_i)` of the correction, term by term as
/// a [`Structure::Additive`] allows: a `Curve` term is the main effect, a `Slope` term
/// `slopes[k][i]·q`. A row with a curve holds its constant (folded into [`Additive::table`]);
/// a row of slopes only holds no constant.
#[derive(Debug, Clone, PartialEq)]
pub struct Additive {
    pub terms: [[Term; 3]; 3],
    pub constant: [f64; 3],
    pub slopes: [[f64; 3]; 3],
    /// Positions of each axis the curves are given at.
    pub positions: [Vec<f64>; 3],
    /// `curves[k][i]`: the main effect of axis `i` on `d_k` at `positions[i]` (empty unless
    /// `Curve`).
    pub curves: [[Vec<f64>; 3]; 3],
}

impl Additive {
    /// The axis whose table carries row `k`'s constant: its own axis when that is a curve, else
    /// the first curve of the row.
    pub fn carrier(&self, k: usize) -> Option<usize> {
        if self.terms[k][k] == Term::Curve {
            return Some(k);
        }
        (0..3).find(|&i| self.terms[k][i] == Term::Curve)
    }

    /// The table of the correction of axis `k` along axis `i` at `positions[i]`: the curve, with
    /// the row's constant where this table carries it.
    pub fn table(&self, k: usize, i: usize) -> Vec<f64> {
        let offset = if self.carrier(k) == Some(i) {
            self.constant[k]
        } else {
            0.0
        };
        self.curves[k][i].iter().map(|v| v + offset).collect()
    }

    /// The fitted correction at a target whose axis positions are the `index`-th of
    /// `positions` (curves) and `xyz` (slopes).
    fn at_indices(&self, index: [usize; 3], xyz: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| {
            let mut v = self.constant[k];
            for i in 0..3 {
                v += match self.terms[k][i] {
                    Term::None => 0.0,
                    Term::Slope => self.slopes[k][i] * xyz[i],
                    Term::Curve => self.curves[k][i][index[i]],
                };
            }
            v
        })
    }
}

/// What a format fits to: the machine, the inputs asked, the pose and the travels.
pub struct Fitting<'a> {
    /// As loaded: its input-dependent errors unresolved.
    pub machine: &'a Machine,
    pub inputs: &'a Inputs,
    pub pose: Command,
    /// Travels of X, Y, Z, mm.
    pub ranges: [[f64; 2]; 3],
    /// Lines every file's header carries: who wrote it, the machine, the inputs, the pose, the
    /// sign convention; each format comments them in its own way.
    pub header: Vec<String>,
    /// The name the file of a one-file format is written as, where the request gives one.
    pub file_name: Option<String>,
    /// The version or generation of the control the files are written for, where the format
    /// has a choice.
    pub control: Option<&'static str>,
    /// The compensation point numbers the tables may take (first, last), where the request
    /// gives them.
    pub point_numbers: Option<[i64; 2]>,
    /// The probe's offset from the nozzle (X, Y, mm), where the request gives it.
    pub probe_offset_mm: Option<[f64; 2]>,
    field: Field,
}

impl<'a> Fitting<'a> {
    pub fn new(
        machine: &'a Machine,
        inputs: &'a Inputs,
        pose: Command,
        header: Vec<String>,
    ) -> Result<Fitting<'a>, ExportError> {
        let mut ranges = [[0.0; 2]; 3];
        let mut missing = Vec::new();
        for (d, letter) in LINEAR.into_iter().enumerate() {
            match machine.axis(letter) {
                Some(axis) => ranges[d] = axis.range,
                None => missing.push(letter.to_string()),
            }
        }
        if !missing.is_empty() {
            return Err(ExportError::MissingAxes {
                chain: machine.chain.hwang_notation(),
                missing: missing.join(", "),
            });
        }
        let field = Field::new(machine.at(inputs), pose)?;
        Ok(Fitting {
            machine,
            inputs,
            pose,
            ranges,
            header,
            file_name: None,
            control: None,
            point_numbers: None,
            probe_offset_mm: None,
            field,
        })
    }

    /// The correction at the inputs asked.
    pub fn field(&self) -> &Field {
        &self.field
    }

    /// The correction at the inputs asked with axis `axis` (0..6) approaching in `approach`.
    pub fn field_approaching(&self, axis: usize, approach: Approach) -> Result<Field, ExportError> {
        let mut inputs = self.inputs.clone();
        inputs.approach[axis] = approach;
        Field::new(self.machine.at(&inputs), self.pose)
    }

    /// `n` positions evenly over the travel of linear axis `axis`.
    pub fn travel(&self, axis: usize, n: usize) -> Vec<f64> {
        uniform(self.ranges[axis][0], self.ranges[axis][1], n)
    }

    /// The additive fit of `field` with the terms `terms`, its curves given at `positions` (per
    /// axis; an axis no curve reads may have none). The constant and the slopes come from the
    /// factorial grid of [`AVERAGING_POINTS`] per axis; each curve is the mean of `d_k` over
    /// that grid's other two axes at each of `positions[i]`, less the grand mean.
    pub fn additive(
        &self,
        field: &Field,
        terms: [[Term; 3]; 3],
        positions: [Vec<f64>; 3],
    ) -> Result<Additive, ExportError> {
        let coarse: [Vec<f64>; 3] = std::array::from_fn(|i| self.travel(i, AVERAGING_POINTS));
        additive_fit(field, terms, &coarse, positions)
    }
}

/// [`Fitting::additive`] on the averaging grid `coarse`.
pub fn additive_fit(
    field: &Field,
    terms: [[Term; 3]; 3],
    coarse: &[Vec<f64>; 3],
    positions: [Vec<f64>; 3],
) -> Result<Additive, ExportError> {
    // Means along each axis on the coarse grid: the grand mean and the slopes.
    let coarse_means: Vec<[Vec<f64>; 3]> = (0..3)
        .map(|i| field.axis_means(i, coarse))
        .collect::<Result<_, _>>()?;
    let grand: [f64; 3] = std::array::from_fn(|k| {
        coarse_means[0][k].iter().sum::<f64>() / coarse_means[0][k].len() as f64
    });
    let mut slopes = [[0.0; 3]; 3];
    let mut curves: [[Vec<f64>; 3]; 3] = Default::default();
    for i in 0..3 {
        let reads_curve = (0..3).any(|k| terms[k][i] == Term::Curve);
        let means = if reads_curve {
            let mut grid = coarse.clone();
            grid[i] = positions[i].clone();
            Some(field.axis_means(i, &grid)?)
        } else {
            None
        };
        for k in 0..3 {
            match terms[k][i] {
                Term::None => {}
                Term::Slope => slopes[k][i] = slope(&coarse[i], &coarse_means[i][k]),
                Term::Curve => {
                    let means = means.as_ref().expect("computed for curves");
                    curves[k][i] = means[k].iter().map(|g| g - grand[k]).collect();
                }
            }
        }
    }
    let constant: [f64; 3] = std::array::from_fn(|k| {
        if terms[k].contains(&Term::Curve) {
            // Slopes run through the machine zero: the constant takes their mean back.
            grand[k]
                - (0..3)
                    .filter(|&i| terms[k][i] == Term::Slope)
                    .map(|i| slopes[k][i] * mean(&coarse[i]))
                    .sum::<f64>()
        } else {
            0.0
        }
    });
    Ok(Additive {
        terms,
        constant,
        slopes,
        positions,
        curves,
    })
}

/// The mean of `values`.
pub(crate) fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The largest part of the correction a structure cannot hold at any table size, over the
/// factorial grid `grid` (mm, machine axis coordinates): `max |d − fit(d)|`.
pub fn structural_remainder(
    field: &Field,
    structure: Structure,
    grid: &[Vec<f64>; 3],
) -> Result<f64, ExportError> {
    let terms = match structure {
        Structure::Grid => return Ok(0.0),
        Structure::AxisAndPlane => return axis_and_plane_remainder(field, grid),
        Structure::ZOfXY => return z_of_xy_remainder(field, grid),
        Structure::Additive(terms) => terms,
    };
    let fit = additive_fit(field, terms, grid, grid.clone())?;
    let mut indices = Vec::new();
    for i in 0..grid[0].len() {
        for j in 0..grid[1].len() {
            for k in 0..grid[2].len() {
                indices.push([i, j, k]);
            }
        }
    }
    let targets: Vec<[f64; 3]> = indices
        .iter()
        .map(|&[i, j, k]| [grid[0][i], grid[1][j], grid[2][k]])
        .collect();
    let d = field.corrections(&targets)?;
    Ok(indices
        .iter()
        .zip(&targets)
        .zip(&d)
        .map(|((&index, &xyz), d)| {
            let f = fit.at_indices(index, xyz);
            ((d[0] - f[0]).powi(2) + (d[1] - f[1]).powi(2) + (d[2] - f[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max))
}

/// [`structural_remainder`] of [`Structure::ZOfXY`]: the least-squares `h(x, y)` on a factorial
/// grid is Z's correction's mean along Z at each (x, y); X's and Y's corrections are all left.
fn z_of_xy_remainder(field: &Field, grid: &[Vec<f64>; 3]) -> Result<f64, ExportError> {
    let mut largest = 0.0f64;
    for &x in &grid[0] {
        for &y in &grid[1] {
            let targets: Vec<[f64; 3]> = grid[2].iter().map(|&z| [x, y, z]).collect();
            let d = field.corrections(&targets)?;
            let h = mean(&d.iter().map(|v| v[2]).collect::<Vec<_>>());
            for v in &d {
                largest = largest.max((v[0] * v[0] + v[1] * v[1] + (v[2] - h).powi(2)).sqrt());
            }
        }
    }
    Ok(largest)
}

/// [`structural_remainder`] of [`Structure::AxisAndPlane`]: on a factorial grid the
/// least-squares `f_k(q_k) + g_k(q_i, q_j)` is the mean of `d_k` over the plane at each `q_k`
/// plus its mean along `k` at each plane point, less the grand mean; what is left is the
/// interaction of axis `k`'s position with the plane's.
fn axis_and_plane_remainder(field: &Field, grid: &[Vec<f64>; 3]) -> Result<f64, ExportError> {
    let n = [grid[0].len(), grid[1].len(), grid[2].len()];
    let index = |i: usize, j: usize, l: usize| (i * n[1] + j) * n[2] + l;
    let mut targets = Vec::with_capacity(n[0] * n[1] * n[2]);
    for &x in &grid[0] {
        for &y in &grid[1] {
            for &z in &grid[2] {
                targets.push([x, y, z]);
            }
        }
    }
    let d = field.corrections(&targets)?;
    let mut remainder = vec![[0.0f64; 3]; d.len()];
    for k in 0..3 {
        let grand = mean(&d.iter().map(|v| v[k]).collect::<Vec<_>>());
        // Mean over the plane at each position of axis k, and along k at each plane point.
        let mut along_k = vec![0.0; n[k]];
        let mut plane = std::collections::HashMap::<[usize; 2], f64>::new();
        for i in 0..n[0] {
            for j in 0..n[1] {
                for l in 0..n[2] {
                    let at = [i, j, l];
                    let v = d[index(i, j, l)][k];
                    along_k[at[k]] += v;
                    let others = [at[(k + 1) % 3], at[(k + 2) % 3]];
                    *plane.entry(others).or_insert(0.0) += v;
                }
            }
        }
        let plane_points = (n[0] * n[1] * n[2] / n[k]) as f64;
        for i in 0..n[0] {
            for j in 0..n[1] {
                for l in 0..n[2] {
                    let at = [i, j, l];
                    let others = [at[(k + 1) % 3], at[(k + 2) % 3]];
                    let fit = along_k[at[k]] / plane_points + plane[&others] / n[k] as f64 - grand;
                    remainder[index(i, j, l)][k] = d[index(i, j, l)][k] - fit;
                }
            }
        }
    }
    Ok(remainder
        .iter()
        .map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .fold(0.0, f64::max))
}

/// The positions along linear axis `axis` where an error value of `machine` that reads that
/// axis changes its form (table nodes, piece starts, `table2d` nodes): a free-node table should
/// be able to put a node there.
pub fn breakpoints(machine: &Machine, axis: AxisLetter) -> Vec<f64> {
    let mut points = Vec::new();
    for a in &machine.axes {
        for f in a.components.iter().flatten() {
            collect_breakpoints(f, a.letter, axis, &mut points);
        }
    }
    for d in &machine.dependent {
        if let crate::model::perturbation::ErrorTarget::Component { axis: own, .. } = d.target {
            let forms = std::iter::once(&d.value)
                .chain(d.reverse.iter())
                .chain(d.per_kelvin.iter().map(|(_, f)| f));
            for f in forms {
                collect_breakpoints(f, own, axis, &mut points);
            }
        }
    }
    points.sort_by(f64::total_cmp);
    points.dedup();
    points
}

fn collect_breakpoints(f: &ErrorFunction, own: AxisLetter, axis: AxisLetter, out: &mut Vec<f64>) {
    match f {
        ErrorFunction::Table(t) if own == axis => out.extend(t.nodes().map(|(q, _)| q)),
        ErrorFunction::Sum(terms) => terms
            .iter()
            .for_each(|t| collect_breakpoints(t, own, axis, out)),
        ErrorFunction::Of { axis: of, form } => collect_breakpoints(form, *of, axis, out),
        ErrorFunction::Table2d(t) => {
            for (n, a) in t.axes.iter().enumerate() {
                if *a == axis {
                    out.extend(if n == 0 { t.x.iter() } else { t.y.iter() }.copied());
                }
            }
        }
        _ => {}
    }
}
