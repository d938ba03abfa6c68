// The point pass (per chunk) of chain.wgsl: the field of one machine stored (points_main), or the
// fields of a batch of sampled machines reduced to their statistics (points_reduce_main); and the
// write-only kernel the point pass is measured against.

// The statistics of each workgroup of the reduce pass, sample after sample (Partial).
@group(0) @binding(16) var<storage, read_write> partials: array<Partial>;

// Group table `table` (0 PA, 1 PB, 2 QA, 3 QB) at line (j, k), indexed as `index` says, of
// machine `sample` of the batch.
fn group_value(table: u32, index: u32, j: u32, k: u32, sample: u32) -> Dev {
    var entry = sample * params.counts.y + params.group_starts[table];
    if index == INDEX_J {
        entry = entry + j;
    } else if index == INDEX_K {
        entry = entry + k;
    }
    return dev_of(group_values[entry]);
}

fn pre_at(j: u32, k: u32, sample: u32) -> Dev {
    var pre = group_value(0u, PRE_A, j, k, sample);
    if PRE_B != TABLE_ABSENT {
        pre = compose(pre, group_value(1u, PRE_B, j, k, sample));
    }
    return pre;
}

fn post_at(j: u32, k: u32, sample: u32) -> Dev {
    var post = group_value(2u, POST_A, j, k, sample);
    if POST_B != TABLE_ABSENT {
        post = compose(post, group_value(3u, POST_B, j, k, sample));
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
    // Where the machine's table of X's errors starts in x_errors.
    table: u32,
}

fn x_terms() -> XTerms {
    return XTerms(
        params.x_translation[0].xyz, params.x_translation[1].xyz,
        params.x_translation[2].xyz, params.x_translation[3].xyz,
        params.x_rotation[0].xyz, params.x_rotation[1].xyz,
        params.x_rotation[2].xyz, params.x_rotation[3].xyz,
        params.x_motion, params.grid.x, 0u);
}

// X's polynomials of machine `sample` of a batch.
fn x_terms_sampled(sample: u32) -> XTerms {
    let p = x_polys[sample];
    return XTerms(
        p.translation[0].xyz, p.translation[1].xyz, p.translation[2].xyz, p.translation[3].xyz,
        p.rotation[0].xyz, p.rotation[1].xyz, p.rotation[2].xyz, p.rotation[3].xyz,
        params.x_motion, params.grid.x, sample * 2u * params.grid.x);
}

fn x_values(x: XTerms, i: u32) -> XValues {
    let t = f32(i) - x.motion.z;
    var e = x.e0 + t * (x.e1 + t * (x.e2 + t * x.e3));
    if X_TRANSLATION_TABLE {
        e = x_errors[x.table + i].xyz;
    }
    var angles = x.a0 + t * (x.a1 + t * (x.a2 + t * x.a3));
    if X_ROTATION_TABLE {
        angles = x_errors[x.table + x.nx + i].xyz;
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

// The point's (OE, VE) from its line's terms and X's part.
fn point_errors(line: LineTerms, x: XValues) -> array<vec3<f32>, 2> {
    let u = x.e + x.mx * line.vb;
    let ve = line.c + line.p * u + x.tq * line.t;
    let s = line.s0 + line.j0 * x.mx[0] + line.j1 * x.mx[1] + line.j2 * x.mx[2];
    return array<vec3<f32>, 2>(rotation_vector_of_half_skew(s), ve);
}

fn store_point(base: u32, nx: u32, line: LineTerms, x: XValues) {
    let e = point_errors(line, x);
    store(base, nx, e[0], e[1]);
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
    let pre0 = pre_at(jk0.x, jk0.y, 0u);
    let line0 = line_terms(pre0, post_at(jk0.x, jk0.y, 0u));
    var line1 = line0;
    var line2 = line0;
    var line3 = line0;
    if LINES_PER_LANE > 1u {
        let jk = line_jk(first_line + min(1u, lines_here - 1u));
        var pre = pre0;
        if PRE_VARIES {
            pre = pre_at(jk.x, jk.y, 0u);
        }
        line1 = line_terms(pre, post_at(jk.x, jk.y, 0u));
    }
    if LINES_PER_LANE > 2u {
        let jk2 = line_jk(first_line + min(2u, lines_here - 1u));
        let jk3 = line_jk(first_line + min(3u, lines_here - 1u));
        var pre2 = pre0;
        var pre3 = pre0;
        if PRE_VARIES {
            pre2 = pre_at(jk2.x, jk2.y, 0u);
            pre3 = pre_at(jk3.x, jk3.y, 0u);
        }
        line2 = line_terms(pre2, post_at(jk2.x, jk2.y, 0u));
        line3 = line_terms(pre3, post_at(jk3.x, jk3.y, 0u));
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

// ---- the reduce pass: the statistics of a batch of sampled machines ----

// What an invocation has seen of its points: max |VE|, Σ |VE|², max |OE|; max |VE| along each
// axis; the line and i of the max |VE| (the first where several are equal).
struct Accumulator {
    stats: vec4<f32>,
    axes: vec4<f32>,
    at: vec2<u32>,
}

var<workgroup> wg_stats: array<vec4<f32>, WORKGROUP_SIZE>;
var<workgroup> wg_axes: array<vec4<f32>, WORKGROUP_SIZE>;
var<workgroup> wg_at: array<vec2<u32>, WORKGROUP_SIZE>;

// Whether the max |VE| `a` seen at `at_a` comes before `b` at `at_b`: larger, or as large and
// earlier in the grid.
fn comes_first(a: f32, at_a: vec2<u32>, b: f32, at_b: vec2<u32>) -> bool {
    return a > b || (a == b && (at_a.x < at_b.x || (at_a.x == at_b.x && at_a.y < at_b.y)));
}

fn accumulate(acc: ptr<function, Accumulator>, line: u32, i: u32, line_terms: LineTerms, x: XValues) {
    accumulate_errors(acc, line, i, point_errors(line_terms, x));
}

// Adds the point (line, i) with errors e = (OE, VE) to what the invocation has seen.
fn accumulate_errors(acc: ptr<function, Accumulator>, line: u32, i: u32, e: array<vec3<f32>, 2>) {
    let ve2 = dot(e[1], e[1]);
    let ve = sqrt(ve2);
    if comes_first(ve, vec2<u32>(line, i), (*acc).stats.x, (*acc).at) {
        (*acc).stats.x = ve;
        (*acc).at = vec2<u32>(line, i);
    }
    (*acc).stats.y = (*acc).stats.y + ve2;
    (*acc).stats.z = max((*acc).stats.z, length(e[0]));
    (*acc).axes = max((*acc).axes, vec4<f32>(abs(e[1]), 0.0));
}

// The point pass of a batch of sampled machines: workgroup (x, line group, sample). Each
// invocation accumulates the statistics of its points, the workgroup combines them, and its first
// invocation writes them to `partials` (every invocation reaches the barriers, so none returns
// early).
@compute @workgroup_size(WORKGROUP_SIZE)
fn points_reduce_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(num_workgroups) groups_in: vec3<u32>,
) {
    let nx = params.grid.x;
    let lines = params.chunk.y;
    let sample = wid.z;
    let tile = point_tile(wid, lid);
    let first_line = tile.x;
    let first = tile.y;
    var acc = Accumulator(vec4<f32>(-1.0, 0.0, 0.0, 0.0), vec4<f32>(0.0), vec2<u32>(0xffffffffu));
    if first_line < lines && first < nx && sample < params.counts.w {
        let stride = params.chunk.w;
        let lines_here = min(LINES_PER_LANE, lines - first_line);
        let x = x_terms_sampled(sample);
        for (var l = 0u; l < lines_here; l = l + 1u) {
            let jk = line_jk(first_line + l);
            let terms_of_line = line_terms(pre_at(jk.x, jk.y, sample), post_at(jk.x, jk.y, sample));
            let line = params.chunk.x + first_line + l;
            for (var n = 0u; n < params.chunk.z; n = n + 1u) {
                let i = first + n * stride;
                if i >= nx {
                    break;
                }
                accumulate(&acc, line, i, terms_of_line, x_values(x, i));
            }
        }
    }
    write_partial(wid, lid, groups_in, sample, acc);
}

// Combines the accumulators of a workgroup's invocations and has its first invocation write them
// to `partials`, at the workgroup's place among the `groups_in.x · groups_in.y` of `sample`.
// Every invocation of the workgroup must call it (it holds barriers).
fn write_partial(wid: vec3<u32>, lid: vec3<u32>, groups_in: vec3<u32>, sample: u32, acc: Accumulator) {
    wg_stats[lid.x] = acc.stats;
    wg_axes[lid.x] = acc.axes;
    wg_at[lid.x] = acc.at;
    workgroupBarrier();
    for (var half = WORKGROUP_SIZE / 2u; half > 0u; half = half / 2u) {
        if lid.x < half {
            let a = wg_stats[lid.x];
            let b = wg_stats[lid.x + half];
            var best = a.x;
            var at = wg_at[lid.x];
            if comes_first(b.x, wg_at[lid.x + half], a.x, at) {
                best = b.x;
                at = wg_at[lid.x + half];
            }
            wg_stats[lid.x] = vec4<f32>(best, a.y + b.y, max(a.z, b.z), 0.0);
            wg_axes[lid.x] = max(wg_axes[lid.x], wg_axes[lid.x + half]);
            wg_at[lid.x] = at;
        }
        workgroupBarrier();
    }
    if lid.x == 0u {
        let per_sample = groups_in.x * groups_in.y;
        let index = sample * per_sample + wid.y * groups_in.x + wid.x;
        if index < arrayLength(&partials) {
            partials[index] = Partial(wg_stats[0], wg_axes[0], vec4<u32>(wg_at[0], 0u, 0u));
        }
    }
}
