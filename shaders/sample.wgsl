// Trilinear samples of a field at arbitrary commanded positions: the GPU twin of
// `LoadedField::sample` in src/io/field/loaded.rs.
//
// The host finds each position's grid cell and its fractions in f64 (rejecting positions outside
// the grid, with the CSV line), so this kernel only blends the cell's eight corners:
//
//   v(p) = Σ_corners  Π_d (t_d if the corner is upper along d, else 1 − t_d) · v(corner)
//
// `field` holds whole z planes of the grid (a slab, from plane params.range.x on), point after
// point with the six values of a grid point side by side in the column order of `volmap sample`
// (VE.X VE.Y VE.Z OE.X OE.Y OE.Z).
//
// Host mirrors: SampleParams and SamplePoint in src/gpu/layout.rs; a test holds the constants and
// struct sizes both declare to it.

struct SampleParams {
    dims: vec4<u32>,   // nx, ny, nz of the whole grid, -
    range: vec4<u32>,  // first z plane in `field`, -, points in this dispatch, -
}

struct SamplePoint {
    cell: vec4<u32>,  // i, j, k (whole grid) of the cell's lower corner, -
    t: vec4<f32>,     // fractions along x, y, z in [0, 1]; w unused
}

@group(0) @binding(0) var<uniform> params: SampleParams;
@group(0) @binding(1) var<storage, read> field: array<f32>;
@group(0) @binding(2) var<storage, read> points: array<SamplePoint>;
@group(0) @binding(3) var<storage, read_write> samples: array<f32>;

const WORKGROUP_SIZE: u32 = 64u;
// Values per grid point and per sample.
const SAMPLE_VALUES: u32 = 6u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn sample_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = gid.x;
    if n >= params.range.z || n >= arrayLength(&points) || SAMPLE_VALUES * n + 5u >= arrayLength(&samples) {
        return;
    }
    let p = points[n];
    let dims = params.dims.xyz;
    // A grid one point deep along d has t_d = 0: the clamped upper corner gets weight 0.
    let upper = min(p.cell.xyz + vec3<u32>(1u), dims - vec3<u32>(1u));
    var acc = array<f32, 6>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var corner = 0u; corner < 8u; corner = corner + 1u) {
        let is_upper = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u) == vec3<u32>(1u);
        let ijk = select(p.cell.xyz, upper, is_upper);
        let w = select(vec3<f32>(1.0) - p.t.xyz, p.t.xyz, is_upper);
        let weight = w.x * w.y * w.z;
        // The host puts every point's cell inside the slab; the check keeps a wrong one in bounds.
        let base = SAMPLE_VALUES * (ijk.x + dims.x * (ijk.y + dims.y * (ijk.z - params.range.x)));
        if ijk.z < params.range.x || base + 5u >= arrayLength(&field) {
            continue;
        }
        for (var c = 0u; c < SAMPLE_VALUES; c = c + 1u) {
            acc[c] = acc[c] + weight * field[base + c];
        }
    }
    for (var c = 0u; c < SAMPLE_VALUES; c = c + 1u) {
        samples[SAMPLE_VALUES * n + c] = acc[c];
    }
}
