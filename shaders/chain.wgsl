// The full kinematic chain of MODEL.md at every grid point of a chunk.
//
//   E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)
//   linear axis: A_k(q) = L_k · Trans(q·u_k) · E_k(q)
//   rotary axis: A_k(q) = L_k · E_k(q) · Rot_u(q)
//
// In f32 the real and the ideal tool tip (up to 2 m from the origin) cannot be subtracted without
// losing 0.2–0.4 µm, so every transform is carried as a nominal part and its deviation:
//
//   T = [(I + M)·R0,  t0 + d]
//
// R0, t0 are the ideal (error-free) transform; M and d are small and are composed exactly, so the
// volumetric error VE = d and the orientation error is the rotation vector of I + M, both in the
// workpiece frame, never formed as a difference of large numbers.
//
// The product is split at X, the axis the grid's lines run along: E_rel = Pre · X(i) · Post, where
// Pre (the axes before X, then X's location L_X) and Post (the axes after X, then S·Trans(tool))
// are constant along a line (j, k). Three passes share the work:
//   axis_values  once per map: every axis at every grid value of its coordinate, the transform
//                A_k(q) of Y at each j, Z at each k, a rotary axis at its pose, and X's six
//                component errors at each i; the machine's error tables are evaluated here;
//   groups       once per map: each side folded into at most two tables, Pre = PA · PB and
//                Post = QA · QB, each one entry (constant factors) or one entry per j or per k
//                (the Y or Z axis with the constant factors around it);
//   points       per chunk: each invocation takes up to LINES_PER_LANE lines and a run of points
//                along them. Per line it composes Pre and Post from the group tables and derives
//                the line terms below; per point it forms X's errors (e, Mx) once, from their
//                polynomials or the axis pass's table, and evaluates each of its lines:
//
//   VE = c + P·(e + Mx·vb) + tq·t                 OE = rotvec(s),  s = s0 + J0·Mx[0] + J1·Mx[1] + J2·Mx[2]
//
// with Pre = [(I + Mp)·Ra, tp + dp], Post = [(I + Mb)·Rb, tb + db], Ma = Raᵀ·Mp·Ra, vb = tb + db,
// P = Ra·(I + Ma), c = dp + Ra·(db + Ma·vb), t = Ra·Ma·x̂ and tq = q·(X's sense) for X's nominal
// motion, and the half skew part of Ra·(I + Ma)(I + Mx)(I + Mb)·Raᵀ split into its constant part
// s0 = ½Ra·skew(Ma + Mb + Ma·Mb) and its part linear in Mx: column a of J_b is ½Ra·(q_b × p_a),
// p_a the columns of I + Ma and q_b the rows of I + Mb. Nothing here drops a term: it is the exact
// product, rearranged so that a point costs a few small products and its six stores.
//
// Host mirrors: src/gpu/layout.rs. Keep in sync with that file.

struct Params {
    origin: vec4<f32>,       // commanded X, Y, Z of grid point (0, 0, 0), mm
    spacing: vec4<f32>,      // grid step along X, Y, Z, mm
    grid: vec4<u32>,         // nx, ny, nz, number of axes
    counts: vec4<u32>,       // axis-value entries, group entries, -, -
    chunk: vec4<u32>,        // first line of the chunk, lines in the chunk, points per lane, lanes per line group
    slots: vec4<u32>,        // first group entry of PA, PB, QA, QB
    x_motion: vec4<f32>,     // tq at the centre index, tq per index step, centre index (t = i − centre), -
    x_translation: array<vec4<f32>, 4>,  // EXX EYX EZX as polynomials in t: c0..c3 (xyz)
    x_rotation: array<vec4<f32>, 4>,     // EAX EBX ECX likewise
}

struct AxisData {
    offset: vec4<f32>,          // o_k, mm
    location_delta: vec4<f32>,  // (EX0k, EY0k, EZ0k), mm
    location_m: mat4x4<f32>,    // Rot(EA0k, EB0k, EC0k) − I
    unit: vec4<f32>,            // u_k
    info: vec4<u32>,            // kind (0 linear, 1 rotary), source (0..2 grid dim, 3 fixed), rotation axis, first axis-value entry
    fixed_q: vec4<f32>,         // x: position when the source is fixed
    functions_a: vec4<u32>,     // EXk EYk EZk EAk (NO_FUNCTION: zero)
    functions_b: vec4<u32>,     // EBk ECk, -, -
}

struct Function {
    pieces: vec4<u32>,  // first piece, piece count, periodic, -
    domain: vec4<f32>,  // lo, hi, -, -
}

struct Piece {
    start: f32,
    degree: u32,
    coefficient: u32,
    pad: u32,
}

// A transform in deviation form: columns of R0 with t0 in w, columns of M with d in w.
struct DevData {
    r0_t0: array<vec4<f32>, 3>,
    m_d: array<vec4<f32>, 3>,
}

// One factor of a group: an axis-value entry (source 0: the axis's first entry, plus j or k
// when the axis runs along the group's dimension) or the constant transform it carries (source
// 1: X's location, S·Trans(tool)).
struct Factor {
    info: vec4<u32>,  // source, first axis-value entry, dimension (0 fixed, 1 j, 2 k), -
    value: DevData,
}

// One of PA, PB, QA, QB: the product of factors [first, first + count), tabulated over its
// dimension (0: one entry, 1: each j, 2: each k) from group entry `info.w` on.
struct Group {
    info: vec4<u32>,  // first factor, factor count, dimension, first group entry
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> axes: array<AxisData>;
@group(0) @binding(2) var<storage, read> functions: array<Function>;
@group(0) @binding(3) var<storage, read> pieces: array<Piece>;
@group(0) @binding(4) var<storage, read> coefficients: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> axis_values: array<DevData>;
@group(0) @binding(6) var<storage, read_write> group_values: array<DevData>;
@group(0) @binding(7) var<storage, read_write> out: array<f32>;
// X's component errors at each i: (EXX, EYX, EZX, -) at [i] and (EAX, EBX, ECX, -) at [nx + i],
// for the point pass where they are not single polynomial pieces.
@group(0) @binding(8) var<storage, read_write> x_errors: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> groups: array<Group>;
@group(0) @binding(10) var<storage, read> factors: array<Factor>;

// The point pass is compiled per tiling and per shape of machine, so that its loop has no
// branches on either (a CPU adapter runs both sides of a branch it cannot prove uniform):
// lines per invocation (1, 2 or 4), where each of PA, PB, QA, QB comes from (SLOT_*), whether Pre
// changes from line to line, and whether X's translations and rotations come from the axis
// pass's table instead of their polynomials in Params.
override LINES_PER_LANE: u32 = 1u;
override PRE_A: u32 = 0u;
override PRE_B: u32 = 3u;
override POST_A: u32 = 0u;
override POST_B: u32 = 3u;
override PRE_VARIES: bool = false;
override X_TRANSLATION_TABLE: bool = false;
override X_ROTATION_TABLE: bool = false;

const NO_FUNCTION: u32 = 0xffffffffu;
const KIND_LINEAR: u32 = 0u;
const SOURCE_FIXED: u32 = 3u;
const SOURCE_CONSTANT: u32 = 1u;
const DIM_J: u32 = 1u;
const DIM_K: u32 = 2u;
// Where a group slot's entry comes from (PRE_A ...): its one entry, the entry of the line's j or
// k, or nowhere (the slot is the identity).
const SLOT_ONE: u32 = 0u;
const SLOT_J: u32 = 1u;
const SLOT_K: u32 = 2u;
const SLOT_ABSENT: u32 = 3u;
const WORKGROUP: u32 = 64u;
const PERIOD_DEG: f32 = 360.0;
const HALF_PI_HI: f32 = 1.5707963705062866;     // f32(π/2)
const HALF_PI_LO: f32 = -4.371139000186243e-8;  // π/2 − HALF_PI_HI
const RAD_PER_DEG: f32 = 0.017453292519943295;

// A transform as nominal part and deviation: [(I + m)·r0, t0 + d].
struct Dev {
    r0: mat3x3<f32>,
    t0: vec3<f32>,
    m: mat3x3<f32>,
    d: vec3<f32>,
}

const ZERO3: mat3x3<f32> = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
const IDENTITY3: mat3x3<f32> = mat3x3<f32>(
    vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));

// a·b, with (I + a.m) a.r0 (I + b.m) b.r0 = (I + m) a.r0 b.r0 where m = a.m + b.m' + a.m b.m',
// b.m' = a.r0 b.m a.r0ᵀ; and the translation deviation δ1 + R01 δ2 + M1 R01 (t02 + δ2).
fn compose(a: Dev, b: Dev) -> Dev {
    let rt = a.r0 * b.t0;
    let rd = a.r0 * b.d;
    let bm = a.r0 * b.m * transpose(a.r0);
    return Dev(a.r0 * b.r0, a.t0 + rt, a.m + bm + a.m * bm, a.d + rd + a.m * (rt + rd));
}

// sin and cos of |x| ≤ π/4 by Taylor series: WGSL's built-ins may be off by 2^-11, far too much.
fn sincos_reduced(x: f32) -> vec2<f32> {
    let x2 = x * x;
    let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0)))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (-1.0 / 3628800.0)))));
    return vec2<f32>(s, c);
}

// (sin, cos) of r + n·π/2 by quadrant.
fn sincos_quadrant(sc: vec2<f32>, n: f32) -> vec2<f32> {
    let quadrant = ((i32(n) % 4) + 4) % 4;
    switch quadrant {
        case 1: { return vec2<f32>(sc.y, -sc.x); }
        case 2: { return vec2<f32>(-sc.x, -sc.y); }
        case 3: { return vec2<f32>(-sc.y, sc.x); }
        default: { return sc; }
    }
}

fn sincos_deg(q: f32) -> vec2<f32> {
    let n = round(q / 90.0);
    return sincos_quadrant(sincos_reduced((q - n * 90.0) * RAD_PER_DEG), n);
}

fn sincos_rad(x: f32) -> vec2<f32> {
    let n = round(x / HALF_PI_HI);
    let r = (x - n * HALF_PI_HI) - n * HALF_PI_LO;
    return sincos_quadrant(sincos_reduced(r), n);
}

// The elementary rotation about coordinate axis `axis` (0 x, 1 y, 2 z) minus I, from (sin, cos − 1).
fn rot_minus_identity_about(axis: u32, s: f32, cm1: f32) -> mat3x3<f32> {
    switch axis {
        case 0u: { return mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0, cm1, s), vec3<f32>(0.0, -s, cm1)); }
        case 1u: { return mat3x3<f32>(vec3<f32>(cm1, 0.0, -s), vec3<f32>(0.0), vec3<f32>(s, 0.0, cm1)); }
        default: { return mat3x3<f32>(vec3<f32>(cm1, s, 0.0), vec3<f32>(-s, cm1, 0.0), vec3<f32>(0.0)); }
    }
}

// Rx(angle) − I etc. with cos − 1 = −2 sin²(angle/2), exact for tiny angles.
fn small_rotation(axis: u32, angle: f32) -> mat3x3<f32> {
    let half = sincos_rad(0.5 * angle).x;
    return rot_minus_identity_about(axis, sincos_rad(angle).x, -2.0 * half * half);
}

// Rot(a, b, c) − I = (I + Mx)(I + My)(I + Mz) − I, kept small.
fn rot_deviation(e: vec3<f32>) -> mat3x3<f32> {
    let mx = small_rotation(0u, e.x);
    let my = small_rotation(1u, e.y);
    let mz = small_rotation(2u, e.z);
    let mxy = mx + my + mx * my;
    return mxy + mz + mxy * mz;
}

// (sin x, cos x − 1) for error angles below 0.1 rad (checked on the host), by Taylor series that
// are exact in f32 there: sin x = x(1 − x²/6(1 − x²/20(1 − x²/42))),
// cos x − 1 = −x²/2 (1 − x²/12 (1 − x²/30)).
fn tiny_sincos(x: vec3<f32>) -> array<vec3<f32>, 2> {
    let x2 = x * x;
    let s = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0)));
    let cm1 = -0.5 * x2 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0));
    return array<vec3<f32>, 2>(s, cm1);
}

// Rot(a, b, c) − I = Rx(a)·Ry(b)·Rz(c) − I in closed form, the diagonal from cos − 1 so that
// nothing cancels.
fn tiny_rot_deviation(e: vec3<f32>) -> mat3x3<f32> {
    let sc = tiny_sincos(e);
    let s = sc[0];
    let c1 = sc[1];
    let c = 1.0 + c1;
    return mat3x3<f32>(
        vec3<f32>(c1.y + c1.z + c1.y * c1.z, s.x * s.y * c.z + c.x * s.z, s.x * s.z - c.x * s.y * c.z),
        vec3<f32>(-c.y * s.z, c1.x + c1.z + c1.x * c1.z - s.x * s.y * s.z, c.x * s.y * s.z + s.x * c.z),
        vec3<f32>(s.y, -s.x * c.y, c1.x + c1.y + c1.x * c1.y));
}

// Evaluates error function `index` at position q: wrap (periodic) and clamp into the domain, find
// the last piece starting at or before q, Horner in q − start.
fn eval_function(index: u32, q_in: f32) -> f32 {
    if index == NO_FUNCTION {
        return 0.0;
    }
    let f = functions[index];
    var q = q_in;
    if f.pieces.z != 0u {
        let u = q - f.domain.x;
        q = f.domain.x + (u - PERIOD_DEG * floor(u / PERIOD_DEG));
    }
    q = clamp(q, f.domain.x, f.domain.y);
    var first = f.pieces.x;
    var n = f.pieces.y;
    while n > 1u {
        let half = n / 2u;
        if pieces[first + half].start <= q {
            first = first + half;
            n = n - half;
        } else {
            n = half;
        }
    }
    let p = pieces[first];
    let s = q - p.start;
    var acc = 0.0;
    for (var k = i32(p.degree); k >= 0; k = k - 1) {
        let c = p.coefficient + u32(k);
        acc = acc * s + coefficients[c / 4u][c % 4u];
    }
    return acc;
}

fn nominal_rotation(axis: u32, degrees: f32) -> mat3x3<f32> {
    let sc = sincos_deg(degrees);
    return IDENTITY3 + rot_minus_identity_about(axis, sc.x, sc.y - 1.0);
}

// A_k(q) as nominal part and deviation.
fn axis_transform(a: AxisData, q: f32) -> Dev {
    let errors_t = vec3<f32>(
        eval_function(a.functions_a.x, q),
        eval_function(a.functions_a.y, q),
        eval_function(a.functions_a.z, q));
    let errors_m = rot_deviation(vec3<f32>(
        eval_function(a.functions_a.w, q),
        eval_function(a.functions_b.x, q),
        eval_function(a.functions_b.y, q)));
    let location_m = mat3x3<f32>(a.location_m[0].xyz, a.location_m[1].xyz, a.location_m[2].xyz);
    let location = Dev(IDENTITY3, a.offset.xyz, location_m, a.location_delta.xyz);
    let errors = Dev(IDENTITY3, vec3<f32>(0.0), errors_m, errors_t);
    if a.info.x == KIND_LINEAR {
        let motion = Dev(IDENTITY3, q * a.unit.xyz, ZERO3, vec3<f32>(0.0));
        return compose(compose(location, motion), errors);
    }
    let direction = a.unit[a.info.z];
    let motion = Dev(nominal_rotation(a.info.z, direction * q), vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    return compose(compose(location, errors), motion);
}

// twice the axial vector of the skew part of m: (m21 − m12, m02 − m20, m10 − m01).
fn skew(m: mat3x3<f32>) -> vec3<f32> {
    return vec3<f32>(m[1].z - m[2].y, m[2].x - m[0].z, m[0].y - m[1].x);
}

// The rotation vector of a small rotation from s, the axial vector of the half skew part of its
// matrix (|s| = sin θ, θ < 0.1 rad): θ/sin θ = asin(|s|)/|s| as a series in |s|², so neither sqrt
// nor atan2 (whose WGSL accuracy is loose) enters.
fn rotation_vector_of_half_skew(s: vec3<f32>) -> vec3<f32> {
    let s2 = dot(s, s);
    let factor = 1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0 + s2 * (35.0 / 1152.0))));
    return s * factor;
}

fn dev_of(v: DevData) -> Dev {
    return Dev(
        mat3x3<f32>(v.r0_t0[0].xyz, v.r0_t0[1].xyz, v.r0_t0[2].xyz),
        vec3<f32>(v.r0_t0[0].w, v.r0_t0[1].w, v.r0_t0[2].w),
        mat3x3<f32>(v.m_d[0].xyz, v.m_d[1].xyz, v.m_d[2].xyz),
        vec3<f32>(v.m_d[0].w, v.m_d[1].w, v.m_d[2].w));
}

fn data_of(t: Dev) -> DevData {
    return DevData(
        array<vec4<f32>, 3>(vec4<f32>(t.r0[0], t.t0.x), vec4<f32>(t.r0[1], t.t0.y), vec4<f32>(t.r0[2], t.t0.z)),
        array<vec4<f32>, 3>(vec4<f32>(t.m[0], t.d.x), vec4<f32>(t.m[1], t.d.y), vec4<f32>(t.m[2], t.d.z)));
}

// ---- axis pass (once per map) ----

// Axis-value entries are laid out axis after axis in product order: an axis driven by grid
// dimension d has one entry per grid value along d, a fixed axis one entry.
fn entry_count(a: AxisData) -> u32 {
    if a.info.y == SOURCE_FIXED {
        return 1u;
    }
    return params.grid[a.info.y];
}

@compute @workgroup_size(64)
fn axis_values_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let entry = gid.x;
    if entry >= params.counts.x {
        return;
    }
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        let first = a.info.w;
        if entry >= first && entry < first + entry_count(a) {
            var q = a.fixed_q.x;
            if a.info.y != SOURCE_FIXED {
                q = params.origin[a.info.y] + f32(entry - first) * params.spacing[a.info.y];
            }
            if a.info.y == 0u {
                // X enters the point pass as its errors (its location is a factor of Pre); its
                // entries of axis_values stay unused.
                let i = entry - first;
                x_errors[i] = vec4<f32>(
                    eval_function(a.functions_a.x, q), eval_function(a.functions_a.y, q),
                    eval_function(a.functions_a.z, q), 0.0);
                x_errors[params.grid.x + i] = vec4<f32>(
                    eval_function(a.functions_a.w, q), eval_function(a.functions_b.x, q),
                    eval_function(a.functions_b.y, q), 0.0);
            } else {
                axis_values[entry] = data_of(axis_transform(a, q));
            }
            return;
        }
    }
}

// ---- group pass (once per map) ----

fn group_entries(g: Group) -> u32 {
    if g.info.y == 0u {
        return 0u;
    }
    if g.info.z == 0u {
        return 1u;
    }
    return params.grid[g.info.z];
}

fn factor_at(f: Factor, index: u32) -> Dev {
    if f.info.x == SOURCE_CONSTANT {
        return dev_of(f.value);
    }
    var entry = f.info.y;
    if f.info.z != 0u {
        entry = entry + index;
    }
    return dev_of(axis_values[entry]);
}

@compute @workgroup_size(64)
fn groups_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let entry = gid.x;
    if entry >= params.counts.y {
        return;
    }
    for (var s = 0u; s < 4u; s = s + 1u) {
        let g = groups[s];
        let first = g.info.w;
        if entry >= first && entry < first + group_entries(g) {
            var product = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
            for (var f = g.info.x; f < g.info.x + g.info.y; f = f + 1u) {
                product = compose(product, factor_at(factors[f], entry - first));
            }
            group_values[entry] = data_of(product);
            return;
        }
    }
}

// ---- point pass (per chunk) ----

// Group slot `slot` (0 PA, 1 PB, 2 QA, 3 QB) at line (j, k), from where `source` says.
fn slot_value(slot: u32, source: u32, j: u32, k: u32) -> Dev {
    var entry = params.slots[slot];
    if source == SLOT_J {
        entry = entry + j;
    } else if source == SLOT_K {
        entry = entry + k;
    }
    return dev_of(group_values[entry]);
}

fn pre_at(j: u32, k: u32) -> Dev {
    var pre = slot_value(0u, PRE_A, j, k);
    if PRE_B != SLOT_ABSENT {
        pre = compose(pre, slot_value(1u, PRE_B, j, k));
    }
    return pre;
}

fn post_at(j: u32, k: u32) -> Dev {
    var post = slot_value(2u, POST_A, j, k);
    if POST_B != SLOT_ABSENT {
        post = compose(post, slot_value(3u, POST_B, j, k));
    }
    return post;
}

// What a line contributes to each of its points (see the top of this file).
struct LineTerms {
    p: mat3x3<f32>,
    c: vec3<f32>,
    t: vec3<f32>,
    vb: vec3<f32>,
    j0: mat3x3<f32>,
    j1: mat3x3<f32>,
    j2: mat3x3<f32>,
    s0: vec3<f32>,
}

fn line_terms(pre: Dev, post: Dev) -> LineTerms {
    let ra = pre.r0;
    let ma = transpose(ra) * pre.m * ra;
    let mb = post.m;
    let vb = post.t0 + post.d;
    let p = IDENTITY3 + ma;
    let q = transpose(IDENTITY3 + mb);
    let half_ra = 0.5 * ra;
    return LineTerms(
        ra * p,
        pre.d + ra * (post.d + ma * vb),
        ra * ma[0],
        vb,
        half_ra * mat3x3<f32>(cross(q[0], p[0]), cross(q[0], p[1]), cross(q[0], p[2])),
        half_ra * mat3x3<f32>(cross(q[1], p[0]), cross(q[1], p[1]), cross(q[1], p[2])),
        half_ra * mat3x3<f32>(cross(q[2], p[0]), cross(q[2], p[1]), cross(q[2], p[2])),
        half_ra * skew(ma + mb + ma * mb));
}

// Line `local` of the chunk as (j, k).
fn line_jk(local: u32) -> vec2<u32> {
    let line = params.chunk.x + local;
    return vec2<u32>(line % params.grid.y, line / params.grid.y);
}

// X's part of a point: its component errors e (translations) and Mx = Rot(EAX, EBX, ECX) − I, and
// tq, X's nominal motion along x̂.
struct XValues {
    e: vec3<f32>,
    mx: mat3x3<f32>,
    tq: f32,
}

// X's polynomials and motion, read from the uniforms once per invocation: a CPU adapter reloads
// uniforms at every use otherwise.
struct XTerms {
    e0: vec3<f32>,
    e1: vec3<f32>,
    e2: vec3<f32>,
    e3: vec3<f32>,
    a0: vec3<f32>,
    a1: vec3<f32>,
    a2: vec3<f32>,
    a3: vec3<f32>,
    motion: vec4<f32>,
    nx: u32,
}

fn x_terms() -> XTerms {
    return XTerms(
        params.x_translation[0].xyz, params.x_translation[1].xyz,
        params.x_translation[2].xyz, params.x_translation[3].xyz,
        params.x_rotation[0].xyz, params.x_rotation[1].xyz,
        params.x_rotation[2].xyz, params.x_rotation[3].xyz,
        params.x_motion, params.grid.x);
}

fn x_values(x: XTerms, i: u32) -> XValues {
    let t = f32(i) - x.motion.z;
    var e = x.e0 + t * (x.e1 + t * (x.e2 + t * x.e3));
    if X_TRANSLATION_TABLE {
        e = x_errors[i].xyz;
    }
    var angles = x.a0 + t * (x.a1 + t * (x.a2 + t * x.a3));
    if X_ROTATION_TABLE {
        angles = x_errors[x.nx + i].xyz;
    }
    return XValues(e, tiny_rot_deviation(angles), x.motion.x + t * x.motion.y);
}

// The six channels of the point at `base` (its OE.X; the channels of a line are nx apart).
fn store(base: u32, nx: u32, oe: vec3<f32>, ve: vec3<f32>) {
    if base + 5u * nx < arrayLength(&out) {
        out[base] = oe.x;
        out[base + nx] = oe.y;
        out[base + 2u * nx] = oe.z;
        out[base + 3u * nx] = ve.x;
        out[base + 4u * nx] = ve.y;
        out[base + 5u * nx] = ve.z;
    }
}

fn store_point(base: u32, nx: u32, line: LineTerms, x: XValues) {
    let u = x.e + x.mx * line.vb;
    let ve = line.c + line.p * u + x.tq * line.t;
    let s = line.s0 + line.j0 * x.mx[0] + line.j1 * x.mx[1] + line.j2 * x.mx[2];
    store(base, nx, rotation_vector_of_half_skew(s), ve);
}

// The lines and points an invocation of the point pass (and of the write-only kernel) covers:
// params.chunk.w lanes share a group of LINES_PER_LANE lines (a power of two up to 64, so that
// short lines share a workgroup), each lane taking params.chunk.z points along them,
// params.chunk.w apart. Returns (first line of the group in the chunk, first i).
fn point_tile(wid: vec3<u32>, lid: vec3<u32>) -> vec2<u32> {
    let lanes = params.chunk.w;
    let group = wid.y * (WORKGROUP / lanes) + lid.x / lanes;
    return vec2<u32>(group * LINES_PER_LANE, wid.x * lanes * params.chunk.z + lid.x % lanes);
}

@compute @workgroup_size(64)
fn points_main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let nx = params.grid.x;
    let lines = params.chunk.y;
    let tile = point_tile(wid, lid);
    let first_line = tile.x;
    let first = tile.y;
    if first_line >= lines || first >= nx {
        return;
    }
    let stride = params.chunk.w;
    let points_per_lane = params.chunk.z;
    // The terms of each line this invocation covers; past the chunk's last line an invocation
    // repeats that line and writes nothing for it.
    let lines_here = min(LINES_PER_LANE, lines - first_line);
    let jk0 = line_jk(first_line);
    let pre0 = pre_at(jk0.x, jk0.y);
    let line0 = line_terms(pre0, post_at(jk0.x, jk0.y));
    var line1 = line0;
    var line2 = line0;
    var line3 = line0;
    if LINES_PER_LANE > 1u {
        let jk = line_jk(first_line + min(1u, lines_here - 1u));
        var pre = pre0;
        if PRE_VARIES {
            pre = pre_at(jk.x, jk.y);
        }
        line1 = line_terms(pre, post_at(jk.x, jk.y));
    }
    if LINES_PER_LANE > 2u {
        let jk2 = line_jk(first_line + min(2u, lines_here - 1u));
        let jk3 = line_jk(first_line + min(3u, lines_here - 1u));
        var pre2 = pre0;
        var pre3 = pre0;
        if PRE_VARIES {
            pre2 = pre_at(jk2.x, jk2.y);
            pre3 = pre_at(jk3.x, jk3.y);
        }
        line2 = line_terms(pre2, post_at(jk2.x, jk2.y));
        line3 = line_terms(pre3, post_at(jk3.x, jk3.y));
    }
    let x = x_terms();
    let line_stride = 6u * nx;
    let base0 = first_line * line_stride;
    for (var n = 0u; n < points_per_lane; n = n + 1u) {
        let i = first + n * stride;
        if i >= nx {
            break;
        }
        let xv = x_values(x, i);
        let base = base0 + i;
        store_point(base, nx, line0, xv);
        if LINES_PER_LANE > 1u && lines_here > 1u {
            store_point(base + line_stride, nx, line1, xv);
        }
        if LINES_PER_LANE > 2u && lines_here > 2u {
            store_point(base + 2u * line_stride, nx, line2, xv);
        }
        if LINES_PER_LANE > 3u && lines_here > 3u {
            store_point(base + 3u * line_stride, nx, line3, xv);
        }
    }
}

// The ceiling `volmap bench` measures the chain kernel against: the same dispatch, the same
// invocations writing the same values of the output with the same stores, computing nothing.
@compute @workgroup_size(64)
fn write_only_main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let nx = params.grid.x;
    let lines = params.chunk.y;
    let tile = point_tile(wid, lid);
    let first_line = tile.x;
    let first = tile.y;
    if first_line >= lines || first >= nx {
        return;
    }
    let stride = params.chunk.w;
    let points_per_lane = params.chunk.z;
    let lines_here = min(LINES_PER_LANE, lines - first_line);
    let line_stride = 6u * nx;
    let base0 = first_line * line_stride;
    for (var n = 0u; n < points_per_lane; n = n + 1u) {
        let i = first + n * stride;
        if i >= nx {
            break;
        }
        let base = base0 + i;
        let v = vec3<f32>(f32(i));
        store(base, nx, v, v);
        if LINES_PER_LANE > 1u && lines_here > 1u {
            store(base + line_stride, nx, v, v);
        }
        if LINES_PER_LANE > 2u && lines_here > 2u {
            store(base + 2u * line_stride, nx, v, v);
        }
        if LINES_PER_LANE > 3u && lines_here > 3u {
            store(base + 3u * line_stride, nx, v, v);
        }
    }
}
