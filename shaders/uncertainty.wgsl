// Sums over machines for the uncertainty of a map: the GPU twin of the first-order and Monte Carlo
// propagations of src/engine/uncertainty.rs.
//
// Two fields `a` and `b` of one chunk (the point pass's output of two machines, same layout) give
// per value  d = scale · (a − b), added to the running sums of the chunk:
//
//   sums[i]         += d        (Monte Carlo: the draws' deviations from the nominal machine)
//   sums[n + i]     += d²       (first order: the squared sensitivity along one direction;
//                                Monte Carlo: the squared deviations)
//
// with n = params.counts.x values in the chunk. The first term of a run writes instead of adding
// (params.counts.y = 1), so nothing clears the sums between chunks.
//
// Host mirror: UncertaintyParams in src/gpu/layout.rs; a test holds the struct size to it.

struct UncertaintyParams {
    counts: vec4<u32>,  // values in the chunk, 1 for the first term of the sums, -, -
    scale: vec4<f32>,   // the factor of a − b; yzw unused
}

@group(0) @binding(0) var<uniform> params: UncertaintyParams;
@group(0) @binding(1) var<storage, read> a: array<f32>;
@group(0) @binding(2) var<storage, read> b: array<f32>;
@group(0) @binding(3) var<storage, read_write> sums: array<f32>;

const WORKGROUP_SIZE: u32 = 64u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn accumulate_main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Chunks hold more values than one dispatch dimension has invocations: rows of workgroups.
    let i = gid.y * groups.x * WORKGROUP_SIZE + gid.x;
    let n = params.counts.x;
    if i >= n || i >= arrayLength(&a) || i >= arrayLength(&b) || n + i >= arrayLength(&sums) {
        return;
    }
    let d = params.scale.x * (a[i] - b[i]);
    if params.counts.y == 1u {
        sums[i] = d;
        sums[n + i] = d * d;
    } else {
        sums[i] = sums[i] + d;
        sums[n + i] = sums[n + i] + d * d;
    }
}
