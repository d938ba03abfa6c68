//! The machine and the grid packed into the chain kernel's buffers, on the host in f64 and stored
//! in f32: the error functions as polynomial pieces, every axis with its location, the factors of
//! `Pre` and `Post` folded into at most two group tables per side, X's errors as polynomials in
//! the grid index, and the shape of machine the point pass is compiled for.
//!
//! Product order: `E_rel = Pre · X(i) · Post`, `Pre` the axes before X then X's location, `Post`
//! the axes after X then `S·Trans(tool)`; without X every axis stands in `Pre`.

use nalgebra::Matrix3;

use crate::gpu::layout::{
    AxisData, DevData, Factor, Function, Group, Mat4, Params, Piece, CONSTANTS_PER_SAMPLE,
    CONSTANT_TAIL, CONSTANT_X_LOCATION, FUNCTION_ARG2_SHIFT, FUNCTION_ARG_SHIFT, FUNCTION_PERIODIC,
    FUNCTION_TABLE2D, GROUP_TABLES, INDEX_J, INDEX_K, INDEX_ONE, KIND_LINEAR, KIND_ROTARY,
    NO_FUNCTION, SOURCE_FIXED, TABLE_ABSENT, UNBOUNDED,
};
use crate::model::grid::Grid;
use crate::model::{Axis, AxisLetter, ErrorFunction, Machine};
use crate::reference::{self, Twin};

/// The machine and grid as the shader's buffers.
#[derive(Debug, Clone)]
pub struct Packed {
    pub params: Params,
    /// The constant factors X's location (`CONSTANT_X_LOCATION`; zero where there is no X) and
    /// `S·Trans(tool)` (`CONSTANT_TAIL`), in deviation form, computed in f64.
    pub constants: [DevData; CONSTANTS_PER_SAMPLE as usize],
    pub axes: Vec<AxisData>,
    pub functions: Vec<Function>,
    pub pieces: Vec<Piece>,
    /// Flat coefficients, padded to whole vec4s.
    pub coefficients: Vec<[f32; 4]>,
    /// PA, PB, QA, QB: the group tables the group pass fills.
    pub groups: [Group; GROUP_TABLES as usize],
    /// The factors of the groups, group after group.
    pub factors: Vec<Factor>,
    /// The shape of the machine the point pass is compiled for.
    pub shape: MachineShape,
}

/// The shape of a machine as the point pass sees it: how each group table is indexed and where
/// X's errors come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MachineShape {
    /// How PA, PB, QA, QB are indexed: `INDEX_ONE`, `INDEX_J`, `INDEX_K`, or `TABLE_ABSENT`.
    pub group_index: [u32; GROUP_TABLES as usize],
    /// Pre changes from line to line (Y or Z stands before X in the product order).
    pub pre_varies: bool,
    /// X's translations (EXX EYX EZX) come from the axis pass's table, not from polynomials.
    pub x_translation_table: bool,
    /// X's rotations (EAX EBX ECX) likewise.
    pub x_rotation_table: bool,
}

/// A shape of machine with the lines per invocation of a tiling: the point pass's
/// pipeline-overridable constants (see `shaders/chain.wgsl`), one compiled pipeline each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PointVariant {
    pub shape: MachineShape,
    pub lines_per_lane: u32,
}

impl PointVariant {
    pub(super) fn constants(&self) -> [(&'static str, f64); 8] {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let shape = &self.shape;
        [
            ("LINES_PER_LANE", self.lines_per_lane as f64),
            ("PRE_A", shape.group_index[0] as f64),
            ("PRE_B", shape.group_index[1] as f64),
            ("POST_A", shape.group_index[2] as f64),
            ("POST_B", shape.group_index[3] as f64),
            ("PRE_VARIES", flag(shape.pre_varies)),
            ("X_TRANSLATION_TABLE", flag(shape.x_translation_table)),
            ("X_ROTATION_TABLE", flag(shape.x_rotation_table)),
        ]
    }
}

pub(super) fn mat4_of(m: &Matrix3<f64>) -> Mat4 {
    let mut out = [[0.0f32; 4]; 4];
    for (c, column) in out.iter_mut().enumerate().take(3) {
        for (r, value) in column.iter_mut().enumerate().take(3) {
            *value = m[(r, c)] as f32;
        }
    }
    out
}

pub(super) fn vec4_of(v: [f64; 3]) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, 0.0]
}

fn finite_or_unbounded(x: f64) -> f32 {
    if x.is_finite() {
        x as f32
    } else {
        x.signum() as f32 * UNBOUNDED
    }
}

/// `Rot(a, b, c) − I` in f64, exact, then small enough to keep its precision in f32.
pub(super) fn rot_deviation(a: f64, b: f64, c: f64) -> Matrix3<f64> {
    reference::rot(a, b, c)
        .fixed_view::<3, 3>(0, 0)
        .into_owned()
        - Matrix3::identity()
}

/// The deviation form `[(I + M)·R0, t0 + d]` of the transform from `ideal` to `real`, both
/// computed in f64: `R0 = R_ideal`, `t0 = t_ideal`, `M = R_real·R_idealᵀ − I`, `d = t_real − t_ideal`.
pub(super) fn deviation_form(real: &reference::Transform, ideal: &reference::Transform) -> DevData {
    let r_real = real.fixed_view::<3, 3>(0, 0);
    let r_ideal = ideal.fixed_view::<3, 3>(0, 0);
    let m = r_real * r_ideal.transpose() - Matrix3::identity();
    let t0 = ideal.fixed_view::<3, 1>(0, 3);
    let d = real.fixed_view::<3, 1>(0, 3) - t0;
    DevData {
        r0_t0: std::array::from_fn(|c| {
            [
                r_ideal[(0, c)] as f32,
                r_ideal[(1, c)] as f32,
                r_ideal[(2, c)] as f32,
                t0[c] as f32,
            ]
        }),
        m_d: std::array::from_fn(|c| {
            [
                m[(0, c)] as f32,
                m[(1, c)] as f32,
                m[(2, c)] as f32,
                d[c] as f32,
            ]
        }),
    }
}

/// Splits one side of X (its factors in product order) into at most two runs with at most one
/// factor each that varies along the grid (Y with j, Z with k): the second run starts at the
/// second varying factor. Returns each run with how it is indexed (`INDEX_ONE`: it does not
/// vary).
fn split_side(side: &[Factor]) -> Vec<(&[Factor], u32)> {
    let varying: Vec<usize> = (0..side.len())
        .filter(|&n| side[n].index() != INDEX_ONE)
        .collect();
    debug_assert!(
        varying.len() <= 2,
        "only Y and Z vary along a line's neighbours"
    );
    match varying.as_slice() {
        [first, second, ..] => vec![
            (&side[..*second], side[*first].index()),
            (&side[*second..], side[*second].index()),
        ],
        [only] => vec![(side, side[*only].index())],
        [] => vec![(side, INDEX_ONE)],
    }
}

/// `Σ c_k s^k` with `s = a + b·t`, as coefficients in `t` (f64, then f32).
pub(super) fn polynomial_in_t(coefficients: &[f64], a: f64, b: f64) -> [f64; 4] {
    let mut out = [0.0; 4];
    for (k, &c) in coefficients.iter().enumerate() {
        // c·(a + b·t)^k = c·Σ_m C(k, m)·a^(k−m)·b^m·t^m
        let mut binomial = 1.0;
        for (m, slot) in out.iter_mut().enumerate().take(k + 1) {
            *slot += c * binomial * a.powi((k - m) as i32) * b.powi(m as i32);
            binomial = binomial * (k - m) as f64 / (m + 1) as f64;
        }
    }
    out
}

/// X's six component errors as polynomials of degree 3 at most in `t = i − centre`, where each is
/// one polynomial piece over every X of the grid (so the point pass evaluates it exactly, without
/// clamping, from coefficients every invocation shares); `None` for those that are not.
pub(super) fn x_polynomials(x: &Axis, grid: &Grid, centre: f64) -> [Option<[f64; 4]>; 6] {
    std::array::from_fn(|n| match x.components[n].as_ref() {
        None => Some([0.0; 4]),
        Some(f) => {
            let mut sum = [0.0; 4];
            for term in f.terms() {
                let c = term_in_t(term, grid, centre)?;
                for (s, c) in sum.iter_mut().zip(c) {
                    *s += c;
                }
            }
            Some(sum)
        }
    })
}

/// One term of an X error as a polynomial in `t = i − centre` where it is one polynomial piece
/// over every X of the grid.
fn term_in_t(term: &ErrorFunction, grid: &Grid, centre: f64) -> Option<[f64; 4]> {
    let (origin, spacing) = (grid.origin_mm[0], grid.spacing_mm[0]);
    let (q_low, q_high) = (origin, origin + spacing * (grid.dims[0] - 1) as f64);
    let form = term.pieces()?;
    match form.pieces.as_slice() {
        [piece]
            if !form.periodic
                && piece.coefficients.len() <= 4
                && form.lo <= q_low
                && q_high <= form.hi =>
        {
            Some(polynomial_in_t(
                &piece.coefficients,
                origin + spacing * centre - piece.start,
                spacing,
            ))
        }
        _ => None,
    }
}

/// The constant factors of a machine against its ideal twin, in the order of `CONSTANT_*`.
pub fn machine_constants(twin: &Twin) -> [DevData; CONSTANTS_PER_SAMPLE as usize] {
    let x_location = match (
        twin.real().axis(AxisLetter::X),
        twin.ideal().axis(AxisLetter::X),
    ) {
        (Some(real), Some(ideal)) => {
            deviation_form(&reference::location(real), &reference::location(ideal))
        }
        _ => bytemuck::Zeroable::zeroed(),
    };
    let tail = deviation_form(
        &reference::spindle_and_tool(twin.real()),
        &reference::spindle_and_tool(twin.ideal()),
    );
    [x_location, tail]
}

/// The error functions of every axis as polynomial pieces, in the layout of the shader's
/// `functions`, `pieces` and `coefficients` buffers.
#[derive(Default)]
struct FunctionTables {
    functions: Vec<Function>,
    pieces: Vec<Piece>,
    coefficients: Vec<f32>,
}

impl FunctionTables {
    /// Adds the six component errors of `axis`; returns each one's function index
    /// (`NO_FUNCTION` for a zero error). A sum is a chain of functions, each naming the next.
    fn add_axis(&mut self, axis: &Axis) -> [u32; 6] {
        let mut indices = [NO_FUNCTION; 6];
        for (n, component) in axis.components.iter().enumerate() {
            let Some(f) = component.as_ref().filter(|f| !f.is_zero()) else {
                continue;
            };
            let terms: Vec<&ErrorFunction> =
                f.terms().into_iter().filter(|t| !t.is_zero()).collect();
            indices[n] = self.functions.len() as u32;
            for (k, term) in terms.iter().enumerate() {
                let next = if k + 1 < terms.len() {
                    self.functions.len() as u32 + 1
                } else {
                    NO_FUNCTION
                };
                self.add_term(term, next);
            }
        }
        indices
    }

    /// Adds one term of an error value (not a sum) as a function whose successor is `next`.
    fn add_term(&mut self, term: &ErrorFunction, next: u32) {
        let (form, argument) = match term {
            ErrorFunction::Of { axis, form } => (form.as_ref(), axis.index() as u32 + 1),
            ErrorFunction::Table2d(t) => {
                let first = self.coefficients.len() as u32;
                self.coefficients.extend(t.x.iter().map(|&v| v as f32));
                self.coefficients.extend(t.y.iter().map(|&v| v as f32));
                for row in &t.values {
                    self.coefficients.extend(row.iter().map(|&v| v as f32));
                }
                let [a, b] = t.axes.map(|l| l.index() as u32 + 1);
                self.functions.push(Function {
                    pieces: [
                        first,
                        t.x.len() as u32 | (t.y.len() as u32) << 16,
                        FUNCTION_TABLE2D | a << FUNCTION_ARG_SHIFT | b << FUNCTION_ARG2_SHIFT,
                        next,
                    ],
                    domain: [0.0; 4],
                });
                return;
            }
            other => (other, 0),
        };
        let Some(form) = form.pieces() else {
            // Parsed forms put a polynomial or table inside `of`; anything else is zero here.
            self.functions.push(Function {
                pieces: [self.pieces.len() as u32, 0, 0, next],
                domain: [0.0; 4],
            });
            return;
        };
        self.functions.push(Function {
            pieces: [
                self.pieces.len() as u32,
                form.pieces.len() as u32,
                (form.periodic as u32 * FUNCTION_PERIODIC) | (argument << FUNCTION_ARG_SHIFT),
                next,
            ],
            domain: [
                finite_or_unbounded(form.lo),
                finite_or_unbounded(form.hi),
                0.0,
                0.0,
            ],
        });
        for piece in &form.pieces {
            self.pieces.push(Piece {
                start: piece.start as f32,
                degree: piece.coefficients.len() as u32 - 1,
                coefficient: self.coefficients.len() as u32,
                _pad: 0,
            });
            self.coefficients
                .extend(piece.coefficients.iter().map(|&c| c as f32));
        }
    }

    /// The coefficients padded to whole vec4s.
    fn coefficient_vec4s(&self) -> Vec<[f32; 4]> {
        self.coefficients
            .chunks(4)
            .map(|c| std::array::from_fn(|k| c.get(k).copied().unwrap_or(0.0)))
            .collect()
    }
}

/// One axis as the shader takes it, its entries in the axis-value table starting at
/// `first_entry`, with its error functions' indices.
fn axis_data(axis: &Axis, grid: &Grid, first_entry: u32, functions: [u32; 6]) -> AxisData {
    let [ex, ey, ez, ea, eb, ec] = axis.location;
    let letter = axis.letter;
    let (kind, driver, fixed) = if letter.is_linear() {
        (KIND_LINEAR, letter.direction_index() as u32, 0.0)
    } else {
        (KIND_ROTARY, SOURCE_FIXED, grid.pose[letter.index()] as f32)
    };
    AxisData {
        offset: vec4_of(axis.offset_mm),
        location_delta: vec4_of([ex, ey, ez]),
        location_m: mat4_of(&rot_deviation(ea, eb, ec)),
        unit: vec4_of(axis.unit_vector()),
        info: [kind, driver, letter.direction_index() as u32, first_entry],
        fixed_q: [fixed, 0.0, 0.0, 0.0],
        functions_a: [functions[0], functions[1], functions[2], functions[3]],
        functions_b: [functions[4], functions[5], letter.index() as u32, 0],
    }
}

/// The entries an axis takes in the axis-value table: one per grid value of its dimension, one
/// when it stands at the pose.
fn entry_count(axis: &AxisData, grid: &Grid) -> u32 {
    match axis.driver() {
        SOURCE_FIXED => 1,
        d => grid.dims[d as usize] as u32,
    }
}

/// The group tables: PA, PB from Pre, QA, QB from Post (a side with one run leaves its second
/// table absent), their factors one table after the other, how each is indexed, and the number
/// of group entries.
struct Folded {
    groups: [Group; GROUP_TABLES as usize],
    factors: Vec<Factor>,
    group_index: [u32; GROUP_TABLES as usize],
    entries: u32,
}

fn fold_groups(pre: &[Factor], post: &[Factor], grid: &Grid) -> Folded {
    let mut folded = Folded {
        groups: [Group::default(); GROUP_TABLES as usize],
        factors: Vec::new(),
        group_index: [TABLE_ABSENT; GROUP_TABLES as usize],
        entries: 0,
    };
    for (side, first_table) in [(pre, 0usize), (post, 2usize)] {
        let runs = split_side(side);
        for table in first_table..first_table + 2 {
            folded.groups[table] = Group::unused(folded.entries);
            let Some(&(run, index)) = runs.get(table - first_table) else {
                continue;
            };
            folded.groups[table] = Group::new(
                folded.factors.len() as u32,
                run.len() as u32,
                index,
                folded.entries,
            );
            folded.factors.extend_from_slice(run);
            folded.group_index[table] = index;
            folded.entries += match index {
                INDEX_J => grid.dims[1] as u32,
                INDEX_K => grid.dims[2] as u32,
                _ => 1,
            };
        }
    }
    folded
}

/// Packs the machine and the grid for the chain kernel.
pub fn pack(machine: &Machine, grid: &Grid) -> Packed {
    let twin = Twin::of(machine);
    let mut tables = FunctionTables::default();
    let mut axes = Vec::new();
    let mut entries = 0u32;
    let (mut pre, mut post) = (Vec::new(), Vec::new());
    let mut x_seen = false;
    for axis in machine.axes_in_product_order() {
        let functions = tables.add_axis(axis);
        let data = axis_data(axis, grid, entries, functions);
        entries += entry_count(&data, grid);
        axes.push(data);
        if axis.letter == AxisLetter::X {
            // X's location closes Pre; the axes after it belong to Post.
            x_seen = true;
            pre.push(Factor::constant(CONSTANT_X_LOCATION));
            continue;
        }
        let index = match data.driver() {
            1 => INDEX_J,
            2 => INDEX_K,
            _ => INDEX_ONE,
        };
        let factor = Factor::axis_entry(data.first_entry(), index);
        if x_seen {
            post.push(factor);
        } else {
            pre.push(factor);
        }
    }
    post.push(Factor::constant(CONSTANT_TAIL));
    let folded = fold_groups(&pre, &post, grid);
    let pre_varies = folded.group_index[..2]
        .iter()
        .any(|&s| s == INDEX_J || s == INDEX_K);

    // X's errors as polynomials in t = i − centre where each is one piece, else its table.
    let nx = grid.dims[0];
    let centre = (nx - 1) as f64 / 2.0;
    let (polynomials, sense) = match machine.axis(AxisLetter::X) {
        Some(x) => (x_polynomials(x, grid, centre), x.unit_vector()[0]),
        None => ([Some([0.0; 4]); 6], 0.0),
    };
    let coefficients_of = |group: &[Option<[f64; 4]>]| -> [[f32; 4]; 4] {
        std::array::from_fn(|k| {
            let c = |n: usize| group[n].map_or(0.0, |p| p[k]) as f32;
            [c(0), c(1), c(2), 0.0]
        })
    };
    let (origin_x, spacing_x) = (grid.origin_mm[0], grid.spacing_mm[0]);
    let params = Params {
        origin: vec4_of(grid.origin_mm),
        spacing: vec4_of(grid.spacing_mm),
        grid: [
            grid.dims[0] as u32,
            grid.dims[1] as u32,
            grid.dims[2] as u32,
            axes.len() as u32,
        ],
        counts: [entries, folded.entries, 0, 1],
        chunk: [0; 4],
        group_starts: folded.groups.map(|g| g.first_entry()),
        x_motion: [
            (sense * (origin_x + spacing_x * centre)) as f32,
            (sense * spacing_x) as f32,
            centre as f32,
            0.0,
        ],
        x_translation: coefficients_of(&polynomials[..3]),
        x_rotation: coefficients_of(&polynomials[3..]),
    };
    let shape = MachineShape {
        group_index: folded.group_index,
        pre_varies,
        x_translation_table: polynomials[..3].iter().any(Option::is_none),
        x_rotation_table: polynomials[3..].iter().any(Option::is_none),
    };
    Packed {
        params,
        constants: machine_constants(&twin),
        axes,
        coefficients: tables.coefficient_vec4s(),
        functions: tables.functions,
        pieces: tables.pieces,
        groups: folded.groups,
        factors: folded.factors,
        shape,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::embedded;
    use crate::model::AxisLetter;

    #[test]
    fn polynomials_in_the_grid_index_equal_the_pieces() {
        let coefficients = [0.02, -3e-5, 4e-8, -2e-11];
        let (a, b) = (-137.5, 12.5);
        let in_t = polynomial_in_t(&coefficients, a, b);
        for t in [-40.0, -3.5, 0.0, 1.0, 17.25, 40.0] {
            let s = a + b * t;
            let want: f64 = coefficients.iter().rev().fold(0.0, |acc, c| acc * s + c);
            let got: f64 = in_t.iter().rev().fold(0.0, |acc, c| acc * t + c);
            assert!((want - got).abs() < 1e-15, "t = {t}: {want} vs {got}");
        }
        assert_eq!(polynomial_in_t(&[0.5], 3.0, 2.0), [0.5, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn each_side_folds_into_at_most_two_tables_by_j_or_k() {
        let grid = |m: &Machine, pose| Grid::full_travel(m, [5, 6, 7], pose).unwrap();
        // Li (FFXYZ): Pre is X's location alone, Post runs through Y then Z.
        let li = embedded::load("vmc-li2015").unwrap();
        let packed = pack(&li, &grid(&li, [0.0; 6]));
        assert_eq!(
            packed.shape.group_index,
            [INDEX_ONE, TABLE_ABSENT, INDEX_J, INDEX_K]
        );
        assert!(!packed.shape.pre_varies);
        let entries: Vec<u32> = packed.groups.iter().map(|g| g.first_entry()).collect();
        assert_eq!(entries, [0, 1, 1, 7]);
        assert_eq!(packed.params.counts[1], 1 + 6 + 7);
        // Hwang's 4-axis FYCFXZ (product order C Y X Z): Pre = C·Y(j)·L_X, Post = Z(k)·S·tool.
        let four = embedded::load("4axis-hwang2014").unwrap();
        let packed = pack(&four, &grid(&four, [0.0, 0.0, 0.0, 0.0, 0.0, 40.0]));
        assert_eq!(
            packed.shape.group_index,
            [INDEX_J, TABLE_ABSENT, INDEX_K, TABLE_ABSENT]
        );
        assert!(packed.shape.pre_varies);
        let run = |g: &Group| [g.first_factor(), g.factors(), g.index()];
        assert_eq!(run(&packed.groups[0]), [0, 3, INDEX_J]);
        assert_eq!(run(&packed.groups[2]), [3, 2, INDEX_K]);
        // Without X every axis stands in Pre: Y(j) then Z(k).
        let travels = [(AxisLetter::Y, [0.0, 100.0]), (AxisLetter::Z, [0.0, 50.0])];
        let no_x = Machine::nominal("no X", "FYFZ", &travels).unwrap();
        let packed = pack(
            &no_x,
            &Grid::full_travel(&no_x, [1, 6, 7], [0.0; 6]).unwrap(),
        );
        assert_eq!(
            packed.shape.group_index,
            [INDEX_J, INDEX_K, INDEX_ONE, TABLE_ABSENT]
        );
        assert!(packed.shape.pre_varies);
    }

    #[test]
    fn x_errors_are_polynomials_only_where_one_piece_covers_the_grid() {
        // The 5-axis machine's EXX is a cubic spline of four pieces; its other X errors are
        // polynomials or three-node tables over the whole travel.
        let five = embedded::load("5axis-hwang2014").unwrap();
        let packed = pack(
            &five,
            &Grid::full_travel(&five, [9, 4, 3], [0.0, 0.0, 0.0, 0.0, 30.0, 60.0]).unwrap(),
        );
        assert!(packed.shape.x_translation_table);
        assert!(!packed.shape.x_rotation_table);
        let li = embedded::load("vmc-li2015").unwrap();
        let grid = Grid::full_travel(&li, [9, 4, 3], [0.0; 6]).unwrap();
        let packed = pack(&li, &grid);
        assert!(!packed.shape.x_translation_table && !packed.shape.x_rotation_table);
        // EXX of Li is 2e-5·q: in t = i − 4 with 125 mm steps, 0.01 + 2.5e-3·t.
        let [c0, c1, c2, c3] = packed.params.x_translation.map(|c| c[0] as f64);
        assert!(
            (c0 - 0.01).abs() < 1e-9 && (c1 - 2.5e-3).abs() < 1e-9,
            "{c0} {c1}"
        );
        assert_eq!([c2, c3], [0.0, 0.0]);
        assert_eq!(packed.params.x_motion[..3], [500.0, 125.0, 4.0]);
    }
}
