// Transforms in deviation form, the arithmetic every kernel of the chain shares.
//
// In f32 the real and the ideal tool tip (up to 2 m from the origin) cannot be subtracted without
// losing 0.2–0.4 µm, so every transform is carried as a nominal part and its deviation:
//
//   T = [(I + M)·R0,  t0 + d]
//
// R0, t0 are the ideal (error-free) transform; M and d are small and are composed exactly, so the
// volumetric error VE = d and the orientation error is the rotation vector of I + M, both in the
// workpiece frame, never formed as a difference of large numbers. Sines and cosines come from
// range reduction and Taylor series, not WGSL's built-ins (which may be off by 2^-11).
//
// This file is joined in front of chain.wgsl (src/gpu/chain/mod.rs, CHAIN_WGSL).

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

// The elementary rotation about coordinate axis `axis` (0 x, 1 y, 2 z) minus I, from (sin, cos − 1).
fn rot_minus_identity_about(axis: u32, s: f32, cm1: f32) -> mat3x3<f32> {
    switch axis {
        case 0u: { return mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0, cm1, s), vec3<f32>(0.0, -s, cm1)); }
        case 1u: { return mat3x3<f32>(vec3<f32>(cm1, 0.0, -s), vec3<f32>(0.0), vec3<f32>(s, 0.0, cm1)); }
        default: { return mat3x3<f32>(vec3<f32>(cm1, s, 0.0), vec3<f32>(-s, cm1, 0.0), vec3<f32>(0.0)); }
    }
}

// (sin x, cos x − 1) for error angles below 0.1 rad (checked on the host), by Taylor series that
// are exact in f32 there: sin x = x(1 − x²/6(1 − x²/20(1 − x²/42))),
// cos x − 1 = −x²/2 (1 − x²/12 (1 − x²/30)).
fn tiny_sincos(x: vec3<f32>) -> array<vec3<f32>, 2> {
    let x2 = x * x;
    // Constant reciprocals, not divisions: a CPU adapter divides at every call otherwise.
    let s = x * (1.0 - x2 * (1.0 / 6.0) * (1.0 - x2 * (1.0 / 20.0) * (1.0 - x2 * (1.0 / 42.0))));
    let cm1 = -0.5 * x2 * (1.0 - x2 * (1.0 / 12.0) * (1.0 - x2 * (1.0 / 30.0)));
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

fn nominal_rotation(axis: u32, degrees: f32) -> mat3x3<f32> {
    let sc = sincos_deg(degrees);
    return IDENTITY3 + rot_minus_identity_about(axis, sc.x, sc.y - 1.0);
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
