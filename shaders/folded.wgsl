// The map of a machine whose error values read other axes' positions (`of`, `table2d`, `sum`),
// for one machine or a batch of sampled machines. On a grid every term of an error value is a
// function of the one or two grid indices it reads (its own axis's, or the axes it names), so
// each axis's six component errors are a sum of parts, one per set of grid dimensions its terms
// read: a part of i, of j, of (j, k)... Two passes:
//
//   folded_values  once per map (per batch): every part tabulated over exactly its dimensions,
//                  the six errors of the terms that read them (the sample's tolerance deviations
//                  in the part of the axis's own dimension): one entry per value of one index,
//                  or per pair, a face of the grid at most.
//   folded         per chunk: each invocation takes points along one line, tiled as the point
//                  pass's (neighbouring invocations, neighbouring points). The axes before the
//                  first and after the last that vary along the line (the span [first, end),
//                  params.group_starts.xy) are composed once per invocation into Pre and Post,
//                  and the parts of the span's axes that do not read i summed once; per point,
//                  only the parts that read i are added, and the span's axes composed. Where X
//                  alone varies along a line, a point costs what it costs in the point pass
//                  (points.wgsl): an invocation takes LINES_PER_LANE lines, as the point pass
//                  does, reads X's part of i once per point for all of them, and adds each line's
//                  own sum of X's other parts (and the parts of i and j, or i and k, if any).
//
// The field is stored in the chunk layout of the point pass, or with FOLD_REDUCE each sample's
// points are reduced to their statistics in `partials` (workgroup (x, line group, sample)), so
// that a Monte Carlo of such machines reads nothing per point back.
//
// Host side: src/gpu/chain/folded.rs; the CPU engine's twin: src/engine/cpu/folded.rs.

// One part of an axis's errors: its table of the six errors (translations, angles) in
// `x_errors`, two vec4 per entry, at 2 (sample · counts.x + first entry + ijk · stride).
struct FoldedPart {
    table: vec4<u32>,   // first entry, entries, axis (product order), grid dimensions read (bit d)
    stride: vec4<u32>,  // entry step per i, j, k (0 for a dimension the part does not read), -
}

@group(0) @binding(19) var<storage, read> folded_parts: array<FoldedPart>;
// Per axis (product order): its first part, then its parts that do not read i, then those that
// do (the part of i alone first: every axis has the part of its own dimension).
@group(0) @binding(20) var<storage, read> folded_axes: array<vec4<u32>>;
// The same tables as `x_errors` (which folded_values_main writes), read-only where only read.
@group(0) @binding(21) var<storage, read> folded_values: array<vec4<f32>>;

// X alone varies along a line: the point pass's formula with X's errors from its parts, for
// LINES_PER_LANE lines an invocation.
override FOLD_X_ALONE: bool = false;
// Reduce each sample's field to its statistics instead of storing it.
override FOLD_REDUCE: bool = false;

// The commanded positions at grid point ijk: its X, Y, Z; the rotary axes at their pose.
fn grid_command(ijk: vec3<u32>) -> Command {
    return Command(params.origin.xyz + vec3<f32>(ijk) * params.spacing.xyz, pose_of_rotary_axes());
}

// Invocation (entry, row, sample): entry `entry + row · (workgroups along x) · WORKGROUP_SIZE` of
// the parts of machine `sample`.
@compute @workgroup_size(WORKGROUP_SIZE)
fn folded_values_main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups_in: vec3<u32>,
) {
    let entry = gid.x + gid.y * groups_in.x * WORKGROUP_SIZE;
    let sample = gid.z;
    if entry >= params.counts.x || sample >= params.counts.w {
        return;
    }
    for (var p = 0u; p < arrayLength(&folded_parts); p = p + 1u) {
        let part = folded_parts[p];
        if entry < part.table.x || entry >= part.table.x + part.table.y {
            continue;
        }
        let e = entry - part.table.x;
        var ijk = vec3<u32>(0u);
        for (var d = 0u; d < 3u; d = d + 1u) {
            if part.stride[d] != 0u {
                ijk[d] = (e / part.stride[d]) % params.grid[d];
            }
        }
        let n = part.table.z;
        let a = axes[n];
        let q = grid_q(a, ijk);
        var errors = component_terms_at(a, q, grid_command(ijk), part.table.w);
        if part.table.w == dim_bit(a.functions_b.z) {
            errors = add_deviations(errors, n, sample, q);
        }
        let slot = 2u * (sample * params.counts.x + entry);
        if slot + 1u < arrayLength(&x_errors) {
            x_errors[slot] = vec4<f32>(errors[0], 0.0);
            x_errors[slot + 1u] = vec4<f32>(errors[1], 0.0);
        }
        return;
    }
}

// The sum of parts [first, first + count) of machine `sample` at grid point ijk.
fn parts_sum(first: u32, count: u32, ijk: vec3<u32>, sample: u32) -> array<vec3<f32>, 2> {
    var e = array<vec3<f32>, 2>(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var p = first; p < first + count; p = p + 1u) {
        let part = folded_parts[p];
        let slot = 2u * (sample * params.counts.x + part.table.x + dot(ijk, part.stride.xyz));
        if slot + 1u < arrayLength(&folded_values) {
            e[0] = e[0] + folded_values[slot].xyz;
            e[1] = e[1] + folded_values[slot + 1u].xyz;
        }
    }
    return e;
}

// A_k of axis n of machine `sample` at grid point ijk with component errors `errors`.
fn folded_transform(n: u32, ijk: vec3<u32>, sample: u32, errors: array<vec3<f32>, 2>) -> Dev {
    let a = axes[n];
    let location = locations[sample * params.grid.w + n];
    return axis_transform_with(a, location, errors, grid_q(a, ijk));
}

// A_k of axis n at ijk, every part summed.
fn folded_axis(n: u32, ijk: vec3<u32>, sample: u32) -> Dev {
    let ax = folded_axes[n];
    return folded_transform(n, ijk, sample, parts_sum(ax.x, ax.y + ax.z, ijk, sample));
}

// Point (line, i), local line `local` of the chunk: stored, or added to the statistics.
fn folded_out(acc: ptr<function, Accumulator>, line: u32, local: u32, i: u32, e: array<vec3<f32>, 2>) {
    if FOLD_REDUCE {
        accumulate_errors(acc, line, i, e);
    } else {
        let nx = params.grid.x;
        store(local * 6u * nx + i, nx, e[0], e[1]);
    }
}

// The most axes a span holds (a machine's axes).
const SPAN_AXES: u32 = 6u;

// Pre and Post of the line at ijk (the axes before and after the span [first, end)), and the
// sum of the parts of the span's axes that do not read i; Post with the tail, and with X alone,
// Pre with X's location.
struct LineSetup {
    pre: Dev,
    post: Dev,
    errors: array<array<vec3<f32>, 2>, SPAN_AXES>,
}

fn line_setup(ijk: vec3<u32>, sample: u32, first: u32, end: u32) -> LineSetup {
    var pre = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    var post = pre;
    var errors: array<array<vec3<f32>, 2>, SPAN_AXES>;
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        if n < first {
            pre = compose(pre, folded_axis(n, ijk, sample));
        } else if n >= end {
            post = compose(post, folded_axis(n, ijk, sample));
        } else {
            let ax = folded_axes[n];
            errors[n - first] = parts_sum(ax.x, ax.y, ijk, sample);
        }
    }
    post = compose(post, dev_of(constants[sample * CONSTANTS_PER_SAMPLE + CONSTANT_TAIL]));
    if FOLD_X_ALONE {
        pre = compose(pre, dev_of(constants[sample * CONSTANTS_PER_SAMPLE + CONSTANT_X_LOCATION]));
    }
    return LineSetup(pre, post, errors);
}

// The grid point of line `line` (of the grid) at i.
fn line_point(line: u32, i: u32) -> vec3<u32> {
    return vec3<u32>(i, line % params.grid.y, line / params.grid.y);
}

// Workgroup (x, line group, sample), its invocations divided among the chunk's lines as the
// point pass's are (point_tile): each takes params.chunk.z points params.chunk.w apart, of one
// line, or where X alone varies, of LINES_PER_LANE lines.
@compute @workgroup_size(WORKGROUP_SIZE)
fn folded_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(num_workgroups) groups_in: vec3<u32>,
) {
    let nx = params.grid.x;
    let sample = wid.z;
    let tile = point_tile(wid, lid);
    var acc = Accumulator(vec4<f32>(-1.0, 0.0, 0.0, 0.0), vec4<f32>(0.0), vec2<u32>(0xffffffffu));
    if tile.x < params.chunk.y && tile.y < nx && sample < params.counts.w {
        if FOLD_X_ALONE {
            x_alone_points(&acc, tile, sample);
        } else {
            span_points(&acc, tile, sample);
        }
    }
    if FOLD_REDUCE {
        write_partial(wid, lid, groups_in, sample, acc);
    }
}

// The points of one line (local line tile.x of the chunk, from i = tile.y), the span's axes
// composed at each.
fn span_points(acc: ptr<function, Accumulator>, tile: vec2<u32>, sample: u32) {
    let nx = params.grid.x;
    let local = tile.x;
    let line = params.chunk.x + local;
    let first = params.group_starts.x;
    let end = min(min(params.group_starts.y, params.grid.w), first + SPAN_AXES);
    var ijk = line_point(line, 0u);
    let setup = line_setup(ijk, sample, first, end);
    for (var n = 0u; n < params.chunk.z; n = n + 1u) {
        let i = tile.y + n * params.chunk.w;
        if i >= nx {
            break;
        }
        ijk.x = i;
        var t = setup.pre;
        for (var a = first; a < end; a = a + 1u) {
            let ax = folded_axes[a];
            let along = parts_sum(ax.x + ax.y, ax.z, ijk, sample);
            let line_part = setup.errors[a - first];
            let errors = array<vec3<f32>, 2>(line_part[0] + along[0], line_part[1] + along[1]);
            t = compose(t, folded_transform(a, ijk, sample, errors));
        }
        t = compose(t, setup.post);
        let oe = rotation_vector_of_half_skew(0.5 * skew(t.m));
        folded_out(acc, line, local, i, array<vec3<f32>, 2>(oe, t.d));
    }
}

// What a line of x_alone_points holds: its terms, the sum of X's parts that do not read i.
struct XLine {
    terms: LineTerms,
    errors: array<vec3<f32>, 2>,
}

fn x_line(line: u32, sample: u32) -> XLine {
    let x = params.group_starts.x;
    let setup = line_setup(line_point(line, 0u), sample, x, x + 1u);
    return XLine(line_terms(setup.pre, setup.post), setup.errors[0]);
}

// The point (line, i) of local line `local`, X's part of i `own` (translations, angles) added
// to the line's, and its parts of i and j or k, if any (`ax`: X's entry of folded_axes).
fn x_alone_point(
    acc: ptr<function, Accumulator>, xl: XLine, line: u32, local: u32, i: u32,
    own: array<vec3<f32>, 2>, tq: f32, ax: vec4<u32>, sample: u32,
) {
    var e = array<vec3<f32>, 2>(xl.errors[0] + own[0], xl.errors[1] + own[1]);
    if ax.z > 1u {
        let mixed = parts_sum(ax.x + ax.y + 1u, ax.z - 1u, line_point(line, i), sample);
        e = array<vec3<f32>, 2>(e[0] + mixed[0], e[1] + mixed[1]);
    }
    let xv = XValues(e[0], tiny_rot_deviation(e[1]), tq);
    folded_out(acc, line, local, i, point_errors(xl.terms, xv));
}

// The points of up to LINES_PER_LANE lines (from local line tile.x of the chunk, from
// i = tile.y) where X alone varies: the point pass's formula, X's part of i read once per point
// for all the lines (each line in its own variables, as in points_main, so that they stay in
// registers).
fn x_alone_points(acc: ptr<function, Accumulator>, tile: vec2<u32>, sample: u32) {
    let nx = params.grid.x;
    let ax = folded_axes[min(params.group_starts.x, params.grid.w - 1u)];
    let lines = min(LINES_PER_LANE, params.chunk.y - tile.x);
    let line0 = params.chunk.x + tile.x;
    let x0 = x_line(line0, sample);
    var x1 = x0;
    var x2 = x0;
    var x3 = x0;
    if LINES_PER_LANE > 1u && lines > 1u {
        x1 = x_line(line0 + 1u, sample);
    }
    if LINES_PER_LANE > 2u && lines > 2u {
        x2 = x_line(line0 + 2u, sample);
    }
    if LINES_PER_LANE > 3u && lines > 3u {
        x3 = x_line(line0 + 3u, sample);
    }
    // Read once: a CPU adapter reloads uniforms at every use otherwise.
    let points = params.chunk.z;
    let step = params.chunk.w;
    let motion = params.x_motion;
    // X's part of i alone (its first that reads i).
    let own_part = folded_parts[ax.x + ax.y];
    let own_first = 2u * (sample * params.counts.x + own_part.table.x);
    let last = arrayLength(&folded_values) - 2u;
    for (var n = 0u; n < points; n = n + 1u) {
        let i = tile.y + n * step;
        if i >= nx {
            break;
        }
        // Clamped, not branched on: a CPU adapter runs a branch's loads lane by lane.
        let at = min(own_first + 2u * i * own_part.stride.x, last);
        let own = array<vec3<f32>, 2>(folded_values[at].xyz, folded_values[at + 1u].xyz);
        let tq = motion.x + (f32(i) - motion.z) * motion.y;
        x_alone_point(acc, x0, line0, tile.x, i, own, tq, ax, sample);
        if LINES_PER_LANE > 1u && lines > 1u {
            x_alone_point(acc, x1, line0 + 1u, tile.x + 1u, i, own, tq, ax, sample);
        }
        if LINES_PER_LANE > 2u && lines > 2u {
            x_alone_point(acc, x2, line0 + 2u, tile.x + 2u, i, own, tq, ax, sample);
        }
        if LINES_PER_LANE > 3u && lines > 3u {
            x_alone_point(acc, x3, line0 + 3u, tile.x + 3u, i, own, tq, ax, sample);
        }
    }
}
