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
//                  only the parts that read i are added. Where X alone varies along a line, its
//                  parts are summed once per map over the dimensions they read (folded_x_main),
//                  and a point costs what it costs in the point pass (points.wgsl): the line's
//                  terms and X's errors; otherwise the span's axes are composed at every point.
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
// do; and for X where it alone varies along a line, its whole errors tabulated over the one or
// two dimensions its parts read (folded_x_main), as part `w − 1` (0: none).
@group(0) @binding(20) var<storage, read> folded_axes: array<vec4<u32>>;

// X alone varies along a line: the point pass's formula with X's errors from its parts.
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
    // counts.y: the entries of the parts (X's whole errors, after them, are folded_x_main's).
    if entry >= params.counts.y || sample >= params.counts.w {
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

// Invocation (entry, row, sample) of X's whole errors (folded_axes[n].w − 1 of the X axis n =
// params.group_starts.x): the sum of its parts at the entry's grid point. After folded_values_main.
@compute @workgroup_size(WORKGROUP_SIZE)
fn folded_x_main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups_in: vec3<u32>,
) {
    let sample = gid.z;
    let x = params.group_starts.x;
    if x >= params.grid.w || sample >= params.counts.w {
        return;
    }
    let ax = folded_axes[x];
    if ax.w == 0u {
        return;
    }
    let whole = folded_parts[ax.w - 1u];
    let e = gid.x + gid.y * groups_in.x * WORKGROUP_SIZE;
    if e >= whole.table.y {
        return;
    }
    var ijk = vec3<u32>(0u);
    for (var d = 0u; d < 3u; d = d + 1u) {
        if whole.stride[d] != 0u {
            ijk[d] = (e / whole.stride[d]) % params.grid[d];
        }
    }
    let errors = parts_sum(ax.x, ax.y + ax.z, ijk, sample);
    let slot = 2u * (sample * params.counts.x + whole.table.x + e);
    if slot + 1u < arrayLength(&x_errors) {
        x_errors[slot] = vec4<f32>(errors[0], 0.0);
        x_errors[slot + 1u] = vec4<f32>(errors[1], 0.0);
    }
}

// The sum of parts [first, first + count) of machine `sample` at grid point ijk.
fn parts_sum(first: u32, count: u32, ijk: vec3<u32>, sample: u32) -> array<vec3<f32>, 2> {
    var e = array<vec3<f32>, 2>(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var p = first; p < first + count; p = p + 1u) {
        let part = folded_parts[p];
        let slot = 2u * (sample * params.counts.x + part.table.x + dot(ijk, part.stride.xyz));
        if slot + 1u < arrayLength(&x_errors) {
            e[0] = e[0] + x_errors[slot].xyz;
            e[1] = e[1] + x_errors[slot + 1u].xyz;
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

// Workgroup (x, line group, sample), its invocations divided among the chunk's lines as the
// point pass's are (point_tile, one line per invocation): each takes params.chunk.z points
// params.chunk.w apart.
@compute @workgroup_size(WORKGROUP_SIZE)
fn folded_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(num_workgroups) groups_in: vec3<u32>,
) {
    let nx = params.grid.x;
    let sample = wid.z;
    let tile = point_tile(wid, lid);
    let local = tile.x;
    var acc = Accumulator(vec4<f32>(-1.0, 0.0, 0.0, 0.0), vec4<f32>(0.0), vec2<u32>(0xffffffffu));
    if local < params.chunk.y && tile.y < nx && sample < params.counts.w {
        let line = params.chunk.x + local;
        let first = params.group_starts.x;
        let end = min(min(params.group_starts.y, params.grid.w), first + SPAN_AXES);
        var ijk = vec3<u32>(tile.y, line % params.grid.y, line / params.grid.y);
        var pre = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
        var post = pre;
        // The span's errors that do not change along the line.
        var line_errors: array<array<vec3<f32>, 2>, SPAN_AXES>;
        for (var n = 0u; n < params.grid.w; n = n + 1u) {
            if n < first {
                pre = compose(pre, folded_axis(n, ijk, sample));
            } else if n >= end {
                post = compose(post, folded_axis(n, ijk, sample));
            } else {
                let ax = folded_axes[n];
                line_errors[n - first] = parts_sum(ax.x, ax.y, ijk, sample);
            }
        }
        post = compose(post, dev_of(constants[sample * CONSTANTS_PER_SAMPLE + CONSTANT_TAIL]));
        if FOLD_X_ALONE {
            pre = compose(pre, dev_of(constants[sample * CONSTANTS_PER_SAMPLE + CONSTANT_X_LOCATION]));
        }
        let terms = line_terms(pre, post);
        // X's whole errors where X alone varies.
        let whole = folded_parts[max(folded_axes[min(first, params.grid.w - 1u)].w, 1u) - 1u];
        for (var n = 0u; n < params.chunk.z; n = n + 1u) {
            let i = tile.y + n * params.chunk.w;
            if i >= nx {
                break;
            }
            ijk.x = i;
            if FOLD_X_ALONE {
                let slot = 2u * (sample * params.counts.x + whole.table.x + dot(ijk, whole.stride.xyz));
                var e = vec3<f32>(0.0);
                var angles = vec3<f32>(0.0);
                if slot + 1u < arrayLength(&x_errors) {
                    e = x_errors[slot].xyz;
                    angles = x_errors[slot + 1u].xyz;
                }
                let tq = params.x_motion.x + (f32(i) - params.x_motion.z) * params.x_motion.y;
                let x = XValues(e, tiny_rot_deviation(angles), tq);
                folded_out(&acc, line, local, i, point_errors(terms, x));
            } else {
                var t = pre;
                for (var a = first; a < end; a = a + 1u) {
                    let ax = folded_axes[a];
                    let along = parts_sum(ax.x + ax.y, ax.z, ijk, sample);
                    let line_part = line_errors[a - first];
                    let errors = array<vec3<f32>, 2>(line_part[0] + along[0], line_part[1] + along[1]);
                    t = compose(t, folded_transform(a, ijk, sample, errors));
                }
                t = compose(t, post);
                let oe = rotation_vector_of_half_skew(0.5 * skew(t.m));
                folded_out(&acc, line, local, i, array<vec3<f32>, 2>(oe, t.d));
            }
        }
    }
    if FOLD_REDUCE {
        write_partial(wid, lid, groups_in, sample, acc);
    }
}
