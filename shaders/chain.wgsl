// The full kinematic chain of docs/model.md at every grid point of a chunk.
//
//   E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)
//   linear axis: A_k(q) = L_k · Trans(q·u_k) · E_k(q)
//   rotary axis: A_k(q) = L_k · E_k(q) · Rot_u(q)
//
// Every transform is carried in deviation form, T = [(I + M)·R0, t0 + d] (deviation.wgsl, joined in
// front of this file): VE = d and OE the rotation vector of I + M, never differences of large
// numbers.
//
// A batch of sampled machines (machine design: the base machine with tolerance deviations added)
// runs the same passes with a sample index: the axis and group passes have one set of entries per
// sample, the point pass reduces each sample's field to its statistics on the device (points.wgsl),
// and the positions pass (positions.wgsl) multiplies the whole chain at arbitrary positions.
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
    counts: vec4<u32>,       // axis-value entries, group entries (each per sample), perturbation terms, samples in the batch
    chunk: vec4<u32>,        // first line of the chunk, lines in the chunk, points per lane, lanes per line group
    group_starts: vec4<u32>, // first entry of PA, PB, QA, QB in the group values (folded.wgsl: the span first, end)
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
    functions_b: vec4<u32>,     // EBk ECk, the axis's letter index (X Y Z A B C: 0..5), -
}

// One term of an error value: polynomial pieces in its argument, or a two-axis table.
// pieces.z holds flags: FUNCTION_PERIODIC, FUNCTION_TABLE2D, and the argument axes (index + 1
// of a commanded axis; 0: the error's own axis) at FUNCTION_ARG_SHIFT and FUNCTION_ARG2_SHIFT.
// A two-axis table has pieces.x its first coefficient (x nodes, y nodes, then values row by
// row) and pieces.y nx | ny << 16.
struct Function {
    pieces: vec4<u32>,  // first piece, piece count, flags, next function of a sum (NO_FUNCTION: none)
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
// or k when it is indexed by them) or a constant transform (FACTOR_CONSTANT: X's location,
// CONSTANT_X_LOCATION, or S·Trans(tool), CONSTANT_TAIL, of the machine's row of `constants`).
struct Factor {
    info: vec4<u32>,  // source, first axis-value entry or constant, index (INDEX_ONE, INDEX_J, INDEX_K), -
}

// A tolerance's deviation of a component error of a sampled machine: shape · amplitude, the
// amplitude from the sample's row of `amplitudes`.
struct Term {
    info: vec4<u32>,   // axis (product order), component (0..5), shape (SHAPE_*), amplitude index
    range: vec4<f32>,  // the axis's travel a, b; -, -
}

// An axis location of one sampled machine: (EX0k, EY0k, EZ0k) and Rot(EA0k, EB0k, EC0k) − I.
struct Location {
    delta: vec4<f32>,
    m: mat4x4<f32>,
}

// X's errors of one sampled machine as polynomials in t = i − centre (see Params).
struct XPoly {
    translation: array<vec4<f32>, 4>,
    rotation: array<vec4<f32>, 4>,
}

// The statistics of one workgroup's points of one sampled machine.
struct Partial {
    stats: vec4<f32>,  // max |VE|, Σ |VE|², max |OE|, -
    axes: vec4<f32>,   // max |VE·x̂|, |VE·ŷ|, |VE·ẑ|, -
    at: vec4<u32>,     // line and i of the max |VE|, -, -
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
// The constant factors of each machine: X's location and S·Trans(tool), computed on the host in
// f64 (CONSTANTS_PER_SAMPLE per machine; one machine for a map).
@group(0) @binding(11) var<storage, read> constants: array<DevData>;
// Sampled machines: the perturbation terms, each sample's amplitudes (counts.z per sample), axis
// locations (grid.w per sample), X's polynomials.
@group(0) @binding(12) var<storage, read> terms: array<Term>;
@group(0) @binding(13) var<storage, read> amplitudes: array<f32>;
@group(0) @binding(14) var<storage, read> locations: array<Location>;
@group(0) @binding(15) var<storage, read> x_polys: array<XPoly>;

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
// The shapes of a tolerance's deviation over the travel [a, b]: s, s·(q − a)/(b − a),
// 4s·(q − a)(b − q)/(b − a)².
const SHAPE_CONSTANT: u32 = 0u;
const SHAPE_LINE: u32 = 1u;
const SHAPE_BOW: u32 = 2u;
// A term that deviates no component error (a location or the spindle deviation).
const TERM_NO_AXIS: u32 = 4294967295u;
// The constant factors of a sampled machine, per sample in `constants`.
const CONSTANT_X_LOCATION: u32 = 0u;
const CONSTANT_TAIL: u32 = 1u;
const CONSTANTS_PER_SAMPLE: u32 = 2u;
const PERIOD_DEG: f32 = 360.0;
const FUNCTION_PERIODIC: u32 = 1u;
const FUNCTION_TABLE2D: u32 = 2u;
const FUNCTION_ARG_SHIFT: u32 = 4u;
const FUNCTION_ARG2_SHIFT: u32 = 8u;
// A_k(q) as nominal part and deviation, with the axis located by `location` and its component
// errors `errors` (translations, angles).
fn axis_transform_with(a: AxisData, location: Location, errors: array<vec3<f32>, 2>, q: f32) -> Dev {
    let location_m = mat3x3<f32>(location.m[0].xyz, location.m[1].xyz, location.m[2].xyz);
    let located = Dev(IDENTITY3, a.offset.xyz, location_m, location.delta.xyz);
    let error = Dev(IDENTITY3, vec3<f32>(0.0), tiny_rot_deviation(errors[1]), errors[0]);
    if a.info.x == KIND_LINEAR {
        let motion = Dev(IDENTITY3, q * a.unit.xyz, ZERO3, vec3<f32>(0.0));
        return compose(compose(located, motion), error);
    }
    let direction = a.unit[a.info.z];
    let motion = Dev(nominal_rotation(a.info.z, direction * q), vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    return compose(compose(located, error), motion);
}

// A_k(q) of the base machine.
fn axis_transform(a: AxisData, q: f32) -> Dev {
    return axis_transform_with(a, Location(a.location_delta, a.location_m), component_errors(a, q), q);
}

// A_k(q) of axis n (product order) of sample `sample`.
fn sampled_axis_transform(a: AxisData, n: u32, sample: u32, q: f32) -> Dev {
    let location = locations[sample * params.grid.w + n];
    return axis_transform_with(a, location, sampled_errors(a, n, sample, q), q);
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

// The axis and the commanded position of axis-value entry `entry`, or (grid.w, -) past the last.
fn entry_axis(entry: u32) -> vec2<f32> {
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        let first = a.info.w;
        if entry >= first && entry < first + entry_count(a) {
            var q = a.fixed_q.x;
            if a.info.y != SOURCE_FIXED {
                q = params.origin[a.info.y] + f32(entry - first) * params.spacing[a.info.y];
            }
            return vec2<f32>(f32(n), q);
        }
    }
    return vec2<f32>(f32(params.grid.w), 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn axis_values_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let entry = gid.x;
    if entry >= params.counts.x {
        return;
    }
    let found = entry_axis(entry);
    let n = u32(found.x);
    if n >= params.grid.w {
        return;
    }
    let a = axes[n];
    let q = found.y;
    if a.info.y == 0u {
        // X enters the point pass as its errors (its location is a factor of Pre); its entries of
        // axis_values stay unused.
        let i = entry - a.info.w;
        let e = component_errors(a, q);
        x_errors[i] = vec4<f32>(e[0], 0.0);
        x_errors[params.grid.x + i] = vec4<f32>(e[1], 0.0);
    } else {
        axis_values[entry] = data_of(axis_transform(a, q));
    }
}

// The axis pass of a batch of sampled machines: invocation (entry, sample).
@compute @workgroup_size(WORKGROUP_SIZE)
fn axis_values_sampled_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let entry = gid.x;
    let sample = gid.y;
    if entry >= params.counts.x || sample >= params.counts.w {
        return;
    }
    let found = entry_axis(entry);
    let n = u32(found.x);
    if n >= params.grid.w {
        return;
    }
    let a = axes[n];
    let q = found.y;
    if a.info.y == 0u {
        let i = entry - a.info.w;
        let e = sampled_errors(a, n, sample, q);
        let base = sample * 2u * params.grid.x;
        x_errors[base + i] = vec4<f32>(e[0], 0.0);
        x_errors[base + params.grid.x + i] = vec4<f32>(e[1], 0.0);
    } else {
        axis_values[sample * params.counts.x + entry] = data_of(sampled_axis_transform(a, n, sample, q));
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

// Factor f at `index` along its table, for machine `sample` of the batch.
fn factor_at(f: Factor, index: u32, sample: u32) -> Dev {
    if f.info.x == FACTOR_CONSTANT {
        return dev_of(constants[sample * CONSTANTS_PER_SAMPLE + f.info.y]);
    }
    var entry = sample * params.counts.x + f.info.y;
    if f.info.z != INDEX_ONE {
        entry = entry + index;
    }
    return dev_of(axis_values[entry]);
}

// Group entry `entry` of machine `sample` of the batch.
fn group_entry(entry: u32, sample: u32) {
    for (var s = 0u; s < GROUP_TABLES; s = s + 1u) {
        let g = groups[s];
        let first = g.info.w;
        if entry >= first && entry < first + group_entries(g) {
            var product = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
            for (var f = g.info.x; f < g.info.x + g.info.y; f = f + 1u) {
                product = compose(product, factor_at(factors[f], entry - first, sample));
            }
            group_values[sample * params.counts.y + entry] = data_of(product);
            return;
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn groups_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x < params.counts.y {
        group_entry(gid.x, 0u);
    }
}

// The group pass of a batch of sampled machines: invocation (entry, sample).
@compute @workgroup_size(WORKGROUP_SIZE)
fn groups_sampled_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x < params.counts.y && gid.y < params.counts.w {
        group_entry(gid.x, gid.y);
    }
}
