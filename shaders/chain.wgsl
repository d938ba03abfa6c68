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
// Three passes share the work so that each point costs two small products:
//   axis_values  every axis transform A_k(q) once per grid value of its coordinate (X at each i, Y
//                at each j, Z at each k, a rotary axis at its pose), error tables evaluated here;
//   line_values  per grid line (j, k) of the chunk, the products before X (Pre) and after X
//                (Post, with S·Trans(tool)), which are constant along the line;
//   points       per point, Pre · A_X(i) · Post, with Pre and Post loaded once per lane for up
//                to 32 points and X's errors at q evaluated in the pass where they are single
//                polynomial pieces (params.x_poly), else loaded from x_errors. The pass is
//                compiled per shape of machine (the override constants below).
//
// Host mirrors: src/gpu/layout.rs. Keep in sync with that file.

struct Params {
    origin: vec4<f32>,       // commanded X, Y, Z of grid point (0, 0, 0), mm
    spacing: vec4<f32>,      // grid step along X, Y, Z, mm
    grid: vec4<u32>,         // nx, ny, nz, number of axes
    chunk: vec4<u32>,        // first line of the chunk, lines in the chunk, position of X in the product order (axes count: none), axis-value entries
    tail_offset: vec4<f32>,  // nominal translation of S·Trans(tool)
    tail_delta: vec4<f32>,   // translation deviation of S·Trans(tool)
    tail_m: mat4x4<f32>,     // R_S − I (upper 3×3)
    options: vec4<u32>,      // x: -; y: points per lane; z: lanes per line; w: - (the machine's shape is in the override constants)
    x_poly: array<vec4<f32>, 6>,       // X's errors EXX..ECX as c0..c3 in s = q − start, where one piece each
    x_poly_span: array<vec4<f32>, 6>,  // start, lowest, highest position
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

// What a grid line contributes to each of its points (see `points`): the nominal rotation Ra of
// Pre, Ma~ = Raᵀ·M_Pre·Ra, M_Post, c0 = d_Pre + Ra·d_Post, vb = t0_Post + d_Post.
struct LineData {
    ra: array<vec4<f32>, 3>,
    ma: array<vec4<f32>, 3>,
    mb: array<vec4<f32>, 3>,
    c0: vec4<f32>,
    vb: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> axes: array<AxisData>;
@group(0) @binding(2) var<storage, read> functions: array<Function>;
@group(0) @binding(3) var<storage, read> pieces: array<Piece>;
@group(0) @binding(4) var<storage, read> coefficients: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> axis_values: array<DevData>;
@group(0) @binding(6) var<storage, read_write> line_values: array<LineData>;
@group(0) @binding(7) var<storage, read_write> out: array<f32>;
// The component errors of X at each i: (EXX, EYX, EZX, -) at [i] and (EAX, EBX, ECX, -) at
// [nx + i]. What the point pass needs of A_X besides X's constant location, which the line pass
// folds into Pre.
@group(0) @binding(8) var<storage, read_write> x_errors: array<vec4<f32>>;

// The shape of the machine, fixed per pipeline so the point pass has no branches on it (a CPU
// adapter runs both sides of a branch it cannot prove uniform): whether a rotary axis stands
// before X in the product order, whether the chain has an X axis, and whether X's translations
// and rotations are single polynomial pieces the pass evaluates itself (params.x_poly).
override ROTARY_BEFORE_X: bool = false;
override HAS_X: bool = true;
override X_TRANSLATIONS_INLINE: bool = false;
override X_ROTATIONS_INLINE: bool = false;

const NO_FUNCTION: u32 = 0xffffffffu;
const KIND_LINEAR: u32 = 0u;
const SOURCE_FIXED: u32 = 3u;
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

// skew(a·b) from the six entries of a·b it needs.
fn skew_of_product(a: mat3x3<f32>, b: mat3x3<f32>) -> vec3<f32> {
    let a0 = vec3<f32>(a[0].x, a[1].x, a[2].x);
    let a1 = vec3<f32>(a[0].y, a[1].y, a[2].y);
    let a2 = vec3<f32>(a[0].z, a[1].z, a[2].z);
    return vec3<f32>(
        dot(a2, b[1]) - dot(a1, b[2]),
        dot(a0, b[2]) - dot(a2, b[0]),
        dot(a1, b[0]) - dot(a0, b[1]));
}

// The rotation vector of a small rotation R = I + m (|θ| < 0.1 rad) from s, the axial vector of
// its skew part: |s| = sin θ, and θ/sin θ = asin(|s|)/|s| as a series in |s|², so neither sqrt nor
// atan2 (whose WGSL accuracy is loose) enters.
fn rotation_vector_of_skew(s: vec3<f32>) -> vec3<f32> {
    let s2 = dot(s, s);
    let factor = 1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0 + s2 * (35.0 / 1152.0))));
    return s * factor;
}

fn store_dev(index: u32, t: Dev) {
    axis_values[index].r0_t0 = array<vec4<f32>, 3>(
        vec4<f32>(t.r0[0], t.t0.x), vec4<f32>(t.r0[1], t.t0.y), vec4<f32>(t.r0[2], t.t0.z));
    axis_values[index].m_d = array<vec4<f32>, 3>(
        vec4<f32>(t.m[0], t.d.x), vec4<f32>(t.m[1], t.d.y), vec4<f32>(t.m[2], t.d.z));
}

fn load_dev(index: u32) -> Dev {
    let v = axis_values[index];
    return Dev(
        mat3x3<f32>(v.r0_t0[0].xyz, v.r0_t0[1].xyz, v.r0_t0[2].xyz),
        vec3<f32>(v.r0_t0[0].w, v.r0_t0[1].w, v.r0_t0[2].w),
        mat3x3<f32>(v.m_d[0].xyz, v.m_d[1].xyz, v.m_d[2].xyz),
        vec3<f32>(v.m_d[0].w, v.m_d[1].w, v.m_d[2].w));
}

fn columns(c: array<vec4<f32>, 3>) -> mat3x3<f32> {
    return mat3x3<f32>(c[0].xyz, c[1].xyz, c[2].xyz);
}

fn as_columns(m: mat3x3<f32>) -> array<vec4<f32>, 3> {
    return array<vec4<f32>, 3>(vec4<f32>(m[0], 0.0), vec4<f32>(m[1], 0.0), vec4<f32>(m[2], 0.0));
}

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
    if entry >= params.chunk.w {
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
            store_dev(entry, axis_transform(a, q));
            if a.info.y == 0u {
                let i = entry - first;
                x_errors[i] = vec4<f32>(
                    eval_function(a.functions_a.x, q), eval_function(a.functions_a.y, q),
                    eval_function(a.functions_a.z, q), 0.0);
                x_errors[params.grid.x + i] = vec4<f32>(
                    eval_function(a.functions_a.w, q), eval_function(a.functions_b.x, q),
                    eval_function(a.functions_b.y, q), 0.0);
            }
            return;
        }
    }
}

// The entry of axis n at grid line (j, k).
fn line_entry(n: u32, j: u32, k: u32) -> Dev {
    let a = axes[n];
    var index = a.info.w;
    if a.info.y == 1u {
        index = index + j;
    } else if a.info.y == 2u {
        index = index + k;
    }
    return load_dev(index);
}

@compute @workgroup_size(64)
fn line_values_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let local_line = gid.x;
    if local_line >= params.chunk.y || local_line >= arrayLength(&line_values) {
        return;
    }
    let line = params.chunk.x + local_line;
    let j = line % params.grid.y;
    let k = line / params.grid.y;
    let x_position = params.chunk.z;
    var pre = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    var post = pre;
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        if n < x_position {
            pre = compose(pre, line_entry(n, j, k));
        } else if n > x_position {
            post = compose(post, line_entry(n, j, k));
        }
    }
    if x_position < params.grid.w {
        // A_X = L_X · [Trans(q·u) · E_X(q)]: the constant L_X joins Pre.
        let x = axes[x_position];
        let location_m = mat3x3<f32>(x.location_m[0].xyz, x.location_m[1].xyz, x.location_m[2].xyz);
        pre = compose(pre, Dev(IDENTITY3, x.offset.xyz, location_m, x.location_delta.xyz));
    }
    let tail_m = mat3x3<f32>(params.tail_m[0].xyz, params.tail_m[1].xyz, params.tail_m[2].xyz);
    post = compose(post, Dev(IDENTITY3, params.tail_offset.xyz, tail_m, params.tail_delta.xyz));
    let ra = pre.r0;
    line_values[local_line] = LineData(
        as_columns(ra),
        as_columns(transpose(ra) * pre.m * ra),
        as_columns(post.m),
        vec4<f32>(pre.d + ra * post.d, 0.0),
        vec4<f32>(post.t0 + post.d, 0.0));
}

// Which points an invocation of the point pass computes: params.options.z lanes share a line
// (a power of two up to 64, so short lines share a workgroup), each taking params.options.y
// points, params.options.z apart. Returns (line in the chunk, first i).
fn point_tile(wid: vec3<u32>, lid: vec3<u32>) -> vec2<u32> {
    let lanes_per_line = params.options.z;
    let lines_per_group = WORKGROUP / lanes_per_line;
    let local_line = wid.y * lines_per_group + lid.x / lanes_per_line;
    let first = wid.x * lanes_per_line * params.options.y + lid.x % lanes_per_line;
    return vec2<u32>(local_line, first);
}

// Three of X's errors (n = 0: EXX EYX EZX, n = 3: EAX EBX ECX) where each is one polynomial
// piece of degree 3 at most (params.x_poly): coefficients, start and clamp range as columns.
struct XPoly {
    c0: vec3<f32>,
    c1: vec3<f32>,
    c2: vec3<f32>,
    c3: vec3<f32>,
    start: vec3<f32>,
    lo: vec3<f32>,
    hi: vec3<f32>,
}

fn x_poly_group(n: u32) -> XPoly {
    let a = params.x_poly[n];
    let b = params.x_poly[n + 1u];
    let c = params.x_poly[n + 2u];
    let sa = params.x_poly_span[n];
    let sb = params.x_poly_span[n + 1u];
    let sc = params.x_poly_span[n + 2u];
    return XPoly(
        vec3<f32>(a.x, b.x, c.x), vec3<f32>(a.y, b.y, c.y), vec3<f32>(a.z, b.z, c.z),
        vec3<f32>(a.w, b.w, c.w), vec3<f32>(sa.x, sb.x, sc.x), vec3<f32>(sa.y, sb.y, sc.y),
        vec3<f32>(sa.z, sb.z, sc.z));
}

// The three errors at position q: the values the axis pass tabulates, from coefficients every
// lane shares instead of a per-lane gather.
fn eval_x_poly(p: XPoly, q: f32) -> vec3<f32> {
    let s = clamp(vec3<f32>(q), p.lo, p.hi) - p.start;
    return p.c0 + s * (p.c1 + s * (p.c2 + s * p.c3));
}

// Pre · X(i) · Post, with Pre including X's location and X(i) = Trans(q·u) · E_X(q) =
// [(I + Mx), q·u + e] (a linear axis has no nominal rotation):
//   M = Ra·M~·Raᵀ,  M~ = M1~ + Mb + M1~·Mb,  M1~ = Ma~ + Mx + Ma~·Mx
//   d = c0 + Ra·(e + Ma~·(q·u + e) + M1~·vb)
// so VE = d and OE = Ra · rotation_vector(M~), which needs only the skew part of M~. Each
// invocation computes several points of one line (see `point_tile`): the line's values are loaded
// once and used for all of them, and each point needs only X's six component errors at its q,
// evaluated here where they are single polynomial pieces (X_TRANSLATIONS_INLINE,
// X_ROTATIONS_INLINE) and loaded from x_errors otherwise. Ra is the identity unless a rotary axis
// stands before X in the product order (ROTARY_BEFORE_X).
@compute @workgroup_size(64)
fn points_main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let nx = params.grid.x;
    let tile = point_tile(wid, lid);
    let local_line = tile.x;
    let first = tile.y;
    let stride = params.options.z;
    let points_per_lane = params.options.y;
    if first >= nx || local_line >= params.chunk.y {
        return;
    }
    let line = line_values[local_line];
    let ra = columns(line.ra);
    let ma = columns(line.ma);
    let mb = columns(line.mb);
    let vb = line.vb.xyz;
    // X moves along ±x: q·u = (q·direction, 0, 0).
    let direction = axes[min(params.chunk.z, params.grid.w - 1u)].unit.x;
    let base_line = local_line * 6u * nx;
    // Everything the loop reads of the uniforms, read once: a CPU adapter reloads them per
    // iteration otherwise.
    let poly_t = x_poly_group(0u);
    let poly_a = x_poly_group(3u);
    let origin_x = params.origin.x;
    let spacing_x = params.spacing.x;
    let out_length = arrayLength(&out);
    for (var p = 0u; p < points_per_lane; p = p + 1u) {
        let i = first + p * stride;
        if i >= nx {
            break;
        }
        var mx = ZERO3;
        var tq = 0.0;
        var e = vec3<f32>(0.0);
        if HAS_X {
            let q = origin_x + f32(i) * spacing_x;
            if X_TRANSLATIONS_INLINE {
                e = eval_x_poly(poly_t, q);
            } else {
                e = x_errors[i].xyz;
            }
            if X_ROTATIONS_INLINE {
                mx = tiny_rot_deviation(eval_x_poly(poly_a, q));
            } else {
                mx = tiny_rot_deviation(x_errors[nx + i].xyz);
            }
            tq = q * direction;
        }
        let m1 = ma + mx + ma * mx;
        var w = e + ma * e + tq * ma[0] + m1 * vb;
        var rv = rotation_vector_of_skew(0.5 * (skew(m1) + skew(mb) + skew_of_product(m1, mb)));
        if ROTARY_BEFORE_X {
            w = ra * w;
            rv = ra * rv;
        }
        let ve = line.c0.xyz + w;

        let base = base_line + i;
        if base + 5u * nx >= out_length {
            return;
        }
        out[base] = rv.x;
        out[base + nx] = rv.y;
        out[base + 2u * nx] = rv.z;
        out[base + 3u * nx] = ve.x;
        out[base + 4u * nx] = ve.y;
        out[base + 5u * nx] = ve.z;
    }
}

// The ceiling `volmap bench` measures the chain kernel against: the same dispatch and the same
// output as `points_main`, computing nothing.
@compute @workgroup_size(64)
fn write_only_main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let nx = params.grid.x;
    let tile = point_tile(wid, lid);
    let local_line = tile.x;
    let first = tile.y;
    let stride = params.options.z;
    let points_per_lane = params.options.y;
    if first >= nx || local_line >= params.chunk.y {
        return;
    }
    let base_line = local_line * 6u * nx;
    let out_length = arrayLength(&out);
    for (var p = 0u; p < points_per_lane; p = p + 1u) {
        let i = first + p * stride;
        if i >= nx {
            break;
        }
        let base = base_line + i;
        if base + 5u * nx >= out_length {
            return;
        }
        let v = f32(i);
        out[base] = v;
        out[base + nx] = v;
        out[base + 2u * nx] = v;
        out[base + 3u * nx] = v;
        out[base + 4u * nx] = v;
        out[base + 5u * nx] = v;
    }
}
