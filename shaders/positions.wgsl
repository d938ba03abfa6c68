// The positions pass of chain.wgsl: the whole chain multiplied at arbitrary commanded positions
// (the cutter positions of a part), for every machine of a batch of sampled machines. No grid
// structure to exploit, so each invocation composes every axis itself:
//
//   E_rel = A_1(q_1) ⋯ A_n(q_n) · S · Trans(tool)      (product order, work axes already inverted)
//
// with q_k the position's X, Y or Z for a linear axis and the pose for a rotary one.

// The commanded X, Y, Z of each position (w unused); the rotary axes stand at their pose.
@group(0) @binding(17) var<storage, read> positions: array<vec4<f32>>;
// For each machine of the batch and each position, the six channels OE.X OE.Y OE.Z VE.X VE.Y VE.Z.
@group(0) @binding(18) var<storage, read_write> position_values: array<f32>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn positions_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    let sample = gid.y;
    let count = arrayLength(&positions);
    if p >= count || sample >= params.counts.w {
        return;
    }
    let position = positions[p];
    let command = Command(position.xyz, pose_of_rotary_axes());
    var t = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        let q = position_q(a, position);
        let location = locations[sample * params.grid.w + n];
        let errors = sampled_errors_at(a, n, sample, q, command);
        t = compose(t, axis_transform_with(a, location, errors, q));
    }
    t = compose(t, dev_of(constants[sample * CONSTANTS_PER_SAMPLE + CONSTANT_TAIL]));
    let oe = rotation_vector_of_half_skew(0.5 * skew(t.m));
    let base = 6u * (sample * count + p);
    if base + 5u < arrayLength(&position_values) {
        position_values[base] = oe.x;
        position_values[base + 1u] = oe.y;
        position_values[base + 2u] = oe.z;
        position_values[base + 3u] = t.d.x;
        position_values[base + 4u] = t.d.y;
        position_values[base + 5u] = t.d.z;
    }
}

// The positions A B C of the rotary axes (0 for those the machine lacks).
fn pose_of_rotary_axes() -> vec3<f32> {
    var pose = vec3<f32>(0.0);
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        if a.info.y == SOURCE_FIXED && a.functions_b.z >= 3u {
            pose[min(a.functions_b.z, 5u) - 3u] = a.fixed_q.x;
        }
    }
    return pose;
}

// The commanded position of axis `a` at `position`: its X, Y or Z, or its pose.
fn position_q(a: AxisData, position: vec4<f32>) -> f32 {
    if a.info.y == SOURCE_FIXED {
        return a.fixed_q.x;
    }
    return position[a.info.y];
}

// The map of a machine whose error values read other axes' positions (`of`, `table2d`), which
// cannot be tabulated per grid value of the axis's own dimension: every point of the chunk
// composes every axis itself, each axis's errors evaluated at the point's commanded positions,
// and stores its six channels in the chunk layout of the point pass. Invocation (x, y) is point
// x + y · chunk.z of the chunk (chunk.z: invocations per row). For machines whose every axis
// varies along X; `grid_runs_main` shares the others.
@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_points_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let nx = params.grid.x;
    let local = gid.x + gid.y * params.chunk.z;
    if local >= params.chunk.y * nx {
        return;
    }
    let line = params.chunk.x + local / nx;
    let ijk = vec3<u32>(local % nx, line % params.grid.y, line / params.grid.y);
    let command = Command(
        params.origin.xyz + vec3<f32>(ijk) * params.spacing.xyz,
        pose_of_rotary_axes(),
    );
    var t = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        t = compose(t, grid_axis_transform(axes[n], ijk, command));
    }
    t = compose(t, dev_of(constants[CONSTANT_TAIL]));
    let oe = rotation_vector_of_half_skew(0.5 * skew(t.m));
    store((local / nx) * 6u * nx + ijk.x, nx, oe, t.d);
}

// `grid_points_main` for a machine with axes or error terms that do not vary along X: each
// invocation takes a run of up to GRID_RUN points along one line. The axes before the first and
// after the last axis that depends on X (X itself, or an axis with an error of X's position;
// chunk.w holds the range as first | last << 8) are composed once for the run with their errors
// at the line's commanded positions; the axes of that range at every point, with the terms of
// their errors that do not read X (an error of Z on the X axis) evaluated once for the run.
// Invocation (x, y) is run x + y · chunk.z.
const GRID_RUN: u32 = 64u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_runs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let nx = params.grid.x;
    let runs = (nx + GRID_RUN - 1u) / GRID_RUN;
    let local = gid.x + gid.y * params.chunk.z;
    if local >= params.chunk.y * runs {
        return;
    }
    let line = params.chunk.x + local / runs;
    let first_i = (local % runs) * GRID_RUN;
    let first_x = params.chunk.w & 255u;
    let last_x = min(params.chunk.w >> 8u, first_x + 5u);
    var ijk = vec3<u32>(first_i, line % params.grid.y, line / params.grid.y);
    var command = Command(
        params.origin.xyz + vec3<f32>(ijk) * params.spacing.xyz,
        pose_of_rotary_axes(),
    );
    var pre = Dev(IDENTITY3, vec3<f32>(0.0), ZERO3, vec3<f32>(0.0));
    var post = pre;
    // The terms constant along the line of the axes composed at every point.
    var across: array<array<vec3<f32>, 2>, 6>;
    for (var n = 0u; n < params.grid.w; n = n + 1u) {
        let a = axes[n];
        if n < first_x {
            pre = compose(pre, grid_axis_transform(a, ijk, command));
        } else if n > last_x {
            post = compose(post, grid_axis_transform(a, ijk, command));
        } else {
            across[n - first_x] = component_terms_at(a, grid_q(a, ijk), command, TERMS_ACROSS_X);
        }
    }
    post = compose(post, dev_of(constants[CONSTANT_TAIL]));
    let last_i = min(first_i + GRID_RUN, nx);
    for (var i = first_i; i < last_i; i = i + 1u) {
        ijk.x = i;
        command.linear.x = params.origin.x + f32(i) * params.spacing.x;
        var t = pre;
        for (var n = first_x; n <= last_x && n < params.grid.w; n = n + 1u) {
            let a = axes[n];
            let q = grid_q(a, ijk);
            let along = component_terms_at(a, q, command, TERMS_ALONG_X);
            let line_terms = across[n - first_x];
            let errors = array<vec3<f32>, 2>(line_terms[0] + along[0], line_terms[1] + along[1]);
            let location = Location(a.location_delta, a.location_m);
            t = compose(t, axis_transform_with(a, location, errors, q));
        }
        t = compose(t, post);
        let oe = rotation_vector_of_half_skew(0.5 * skew(t.m));
        store((line - params.chunk.x) * 6u * nx + i, nx, oe, t.d);
    }
}

// A_k of axis `a` at grid point `ijk` with every axis at `command`.
fn grid_axis_transform(a: AxisData, ijk: vec3<u32>, command: Command) -> Dev {
    let q = grid_q(a, ijk);
    let location = Location(a.location_delta, a.location_m);
    return axis_transform_with(a, location, component_errors_at(a, q, command), q);
}

// The commanded position of axis `a` at grid point `ijk`: its grid value, or its pose.
fn grid_q(a: AxisData, ijk: vec3<u32>) -> f32 {
    if a.info.y == SOURCE_FIXED {
        return a.fixed_q.x;
    }
    return params.origin[a.info.y] + f32(ijk[a.info.y]) * params.spacing[a.info.y];
}
