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

// The commanded position of axis `a` at grid point `ijk`: its grid value, or its pose.
fn grid_q(a: AxisData, ijk: vec3<u32>) -> f32 {
    if a.info.y == SOURCE_FIXED {
        return a.fixed_q.x;
    }
    return params.origin[a.info.y] + f32(ijk[a.info.y]) * params.spacing[a.info.y];
}
