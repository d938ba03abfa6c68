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
// Host mirrors: src/gpu/layout.rs. Keep in sync with that file.

struct Params {
    origin: vec4<f32>,       // commanded X, Y, Z of grid point (0, 0, 0), mm
    spacing: vec4<f32>,      // grid step along X, Y, Z, mm
    grid: vec4<u32>,         // nx, ny, nz, number of axes
    chunk: vec4<u32>,        // first line of the chunk, points in the chunk, -, -
    tail_offset: vec4<f32>,  // nominal translation of S·Trans(tool)
    tail_delta: vec4<f32>,   // translation deviation of S·Trans(tool)
    tail_m: mat4x4<f32>,     // R_S − I (upper 3×3)
}

struct AxisData {
    offset: vec4<f32>,          // o_k, mm
    location_delta: vec4<f32>,  // (EX0k, EY0k, EZ0k), mm
    location_m: mat4x4<f32>,    // Rot(EA0k, EB0k, EC0k) − I
    unit: vec4<f32>,            // u_k
    info: vec4<u32>,            // kind (0 linear, 1 rotary), source (0..2 grid dim, 3 fixed), rotation axis, -
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

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> axes: array<AxisData>;
@group(0) @binding(2) var<storage, read> functions: array<Function>;
@group(0) @binding(3) var<storage, read> pieces: array<Piece>;
@group(0) @binding(4) var<storage, read> coefficients: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> out: array<f32>;

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

// The rotation vector of I + m for the small rotations of machine errors (|θ| < 0.1 rad): the
// axial vector s of the skew part has |s| = sin θ, and θ/sin θ = asin(|s|)/|s| as a series in
// |s|², so neither sqrt nor atan2 (whose WGSL accuracy is loose) enters.
fn rotation_vector(m: mat3x3<f32>) -> vec3<f32> {
    let s = 0.5 * vec3<f32>(m[1].z - m[2].y, m[2].x - m[0].z, m[0].y - m[1].x);
    let s2 = dot(s, s);
    let factor = 1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0 + s2 * (35.0 / 1152.0))));
    return s * factor;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = gid.x + gid.y * groups.x * WORKGROUP;
    if local >= params.chunk.y {
        return;
    }
    let nx = params.grid.x;
    let line_in_chunk = local / nx;
    let i = local % nx;
    let line = params.chunk.x + line_in_chunk;
    let j = line % params.grid.y;
    let k = line / params.grid.y;
    let position = params.origin.xyz + vec3<f32>(f32(i), f32(j), f32(k)) * params.spacing.xyz;

    var acc = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        var q = a.fixed_q.x;
        if a.info.y != SOURCE_FIXED {
            q = position[a.info.y];
        }
        acc = compose(acc, axis_transform(a, q));
    }
    let tail_m = mat3x3<f32>(params.tail_m[0].xyz, params.tail_m[1].xyz, params.tail_m[2].xyz);
    acc = compose(acc, Dev(IDENTITY3, params.tail_offset.xyz, tail_m, params.tail_delta.xyz));

    let oe = rotation_vector(acc.m);
    let base = line_in_chunk * 6u * nx + i;
    if base + 5u * nx >= arrayLength(&out) {
        return;
    }
    out[base] = oe.x;
    out[base + nx] = oe.y;
    out[base + 2u * nx] = oe.z;
    out[base + 3u * nx] = acc.d.x;
    out[base + 4u * nx] = acc.d.y;
    out[base + 5u * nx] = acc.d.z;
}
