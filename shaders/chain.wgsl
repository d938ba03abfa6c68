// The full kinematic chain of MODEL.md at every grid point of a chunk.
//
//   E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)
//   linear axis: A_k(q) = L_k · Trans(q·u_k) · E_k(q)
//   rotary axis: A_k(q) = L_k · E_k(q) · Rot_u(q)
//
// Every transform is carried in deviation form, T = [(I + M)·R0, t0 + d] (deviation.wgsl, joined in
// front of this file): VE = d and OE the rotation vector of I + M, never differences of large
// numbers.
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
// Host mirrors: src/gpu/layout.rs; a test holds the constants and struct sizes both declare to it.

struct Params {
    origin: vec4<f32>,       // commanded X, Y, Z of grid point (0, 0, 0), mm
    spacing: vec4<f32>,      // grid step along X, Y, Z, mm
    grid: vec4<u32>,         // nx, ny, nz, number of axes
    counts: vec4<u32>,       // axis-value entries, group entries, -, -
    chunk: vec4<u32>,        // first line of the chunk, lines in the chunk, points per lane, lanes per line group
    group_starts: vec4<u32>, // first entry of PA, PB, QA, QB in the group values
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

// One factor of a group: an axis-value entry (FACTOR_AXIS_ENTRY: the axis's first entry, plus j
// or k when it is indexed by them) or the constant transform it carries (FACTOR_CONSTANT: X's
// location, S·Trans(tool)).
struct Factor {
    info: vec4<u32>,  // source, first axis-value entry, index (INDEX_ONE, INDEX_J, INDEX_K), -
    value: DevData,
}

// One of the GROUP_TABLES tables PA, PB, QA, QB: the product of factors [first, first + count),
// tabulated over its index (INDEX_ONE: one entry, INDEX_J: each j, INDEX_K: each k) from group
// entry `info.w` on.
struct Group {
    info: vec4<u32>,  // first factor, factor count, index, first group entry
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
// lines per invocation (1, 2 or 4), how each of PA, PB, QA, QB is indexed (INDEX_* or
// TABLE_ABSENT), whether Pre
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

const WORKGROUP_SIZE: u32 = 64u;
const NO_FUNCTION: u32 = 0xffffffffu;
const KIND_LINEAR: u32 = 0u;
const KIND_ROTARY: u32 = 1u;
// An axis's driver: the grid dimension 0, 1, 2, or held at its fixed position.
const SOURCE_FIXED: u32 = 3u;
const FACTOR_AXIS_ENTRY: u32 = 0u;
const FACTOR_CONSTANT: u32 = 1u;
// How a table's entry is found for a line (j, k): its one entry, the entry of the line's j or k;
// a group table may be absent (the identity).
const INDEX_ONE: u32 = 0u;
const INDEX_J: u32 = 1u;
const INDEX_K: u32 = 2u;
const TABLE_ABSENT: u32 = 3u;
const GROUP_TABLES: u32 = 4u;
const PERIOD_DEG: f32 = 360.0;
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

@compute @workgroup_size(WORKGROUP_SIZE)
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
    if g.info.z == INDEX_ONE {
        return 1u;
    }
    return params.grid[g.info.z];
}

fn factor_at(f: Factor, index: u32) -> Dev {
    if f.info.x == FACTOR_CONSTANT {
        return dev_of(f.value);
    }
    var entry = f.info.y;
    if f.info.z != INDEX_ONE {
        entry = entry + index;
    }
    return dev_of(axis_values[entry]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn groups_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let entry = gid.x;
    if entry >= params.counts.y {
        return;
    }
    for (var s = 0u; s < GROUP_TABLES; s = s + 1u) {
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

// Group table `table` (0 PA, 1 PB, 2 QA, 3 QB) at line (j, k), indexed as `index` says.
fn group_value(table: u32, index: u32, j: u32, k: u32) -> Dev {
    var entry = params.group_starts[table];
    if index == INDEX_J {
        entry = entry + j;
    } else if index == INDEX_K {
        entry = entry + k;
    }
    return dev_of(group_values[entry]);
}

fn pre_at(j: u32, k: u32) -> Dev {
    var pre = group_value(0u, PRE_A, j, k);
    if PRE_B != TABLE_ABSENT {
        pre = compose(pre, group_value(1u, PRE_B, j, k));
    }
    return pre;
}

fn post_at(j: u32, k: u32) -> Dev {
    var post = group_value(2u, POST_A, j, k);
    if POST_B != TABLE_ABSENT {
        post = compose(post, group_value(3u, POST_B, j, k));
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
    let group = wid.y * (WORKGROUP_SIZE / lanes) + lid.x / lanes;
    return vec2<u32>(group * LINES_PER_LANE, wid.x * lanes * params.chunk.z + lid.x % lanes);
}

@compute @workgroup_size(WORKGROUP_SIZE)
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
@compute @workgroup_size(WORKGROUP_SIZE)
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
