// The error values of the chain kernel (joined after chain.wgsl, whose buffers and constants
// they read): error functions (piecewise polynomials, tables, two-axis tables) evaluated at a
// position, the terms of an error by the grid dimensions they read, an axis's six component
// errors, and the deviations of sampled machines.

// Evaluates error function `index` at position q: for each function of a sum, wrap (periodic)
// and clamp into its domain, find the last piece starting at or before q, Horner in q − start.
fn eval_function(index: u32, q: f32) -> f32 {
    var total = 0.0;
    var next = index;
    while next != NO_FUNCTION {
        let f = functions[next];
        next = f.pieces.w;
        total = total + eval_pieces(f, q);
    }
    return total;
}

fn coefficient(c: u32) -> f32 {
    return coefficients[c / 4u][c % 4u];
}

// One function's polynomial pieces at q: wrapped (periodic) or clamped into its domain, the
// piece found by bisection.
fn eval_pieces(f: Function, q_in: f32) -> f32 {
    var q = q_in;
    if (f.pieces.z & FUNCTION_PERIODIC) != 0u {
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
        acc = acc * s + coefficient(p.coefficient + u32(k));
    }
    return acc;
}

// The cell of the n nodes from coefficient `first` that holds q (clamped to the ends): its
// first node's index and the fraction along it.
fn table_cell(first: u32, n: u32, q_in: f32) -> vec2<f32> {
    let q = clamp(q_in, coefficient(first), coefficient(first + n - 1u));
    var lo = 0u;
    var count = n - 1u;
    while count > 1u {
        let half = count / 2u;
        if coefficient(first + lo + half) <= q {
            lo = lo + half;
            count = count - half;
        } else {
            count = half;
        }
    }
    let a = coefficient(first + lo);
    let b = coefficient(first + lo + 1u);
    return vec2<f32>(f32(lo), (q - a) / (b - a));
}

// A two-axis table at (u, v): bilinear in its cell, the edge's value outside.
fn eval_table2d(f: Function, u: f32, v: f32) -> f32 {
    let nx = f.pieces.y & 65535u;
    let ny = f.pieces.y >> 16u;
    let xs = f.pieces.x;
    let ys = xs + nx;
    let values = ys + ny;
    let cu = table_cell(xs, nx, u);
    let cv = table_cell(ys, ny, v);
    let i = u32(cu.x);
    let j = u32(cv.x);
    let v00 = coefficient(values + i * ny + j);
    let v01 = coefficient(values + i * ny + j + 1u);
    let v10 = coefficient(values + (i + 1u) * ny + j);
    let v11 = coefficient(values + (i + 1u) * ny + j + 1u);
    return mix(mix(v00, v01, cv.y), mix(v10, v11, cv.y), cu.y);
}

// The commanded positions of every axis at one point: X Y Z in `linear`, A B C in `rotary`
// (two vectors rather than an array, which a CPU adapter would index through memory).
struct Command {
    linear: vec3<f32>,
    rotary: vec3<f32>,
}

// The position of axis `index` (X Y Z A B C: 0..5) in `c`.
fn command_q(c: Command, index: u32) -> f32 {
    if index < 3u {
        return c.linear[index];
    }
    return c.rotary[min(index, 5u) - 3u];
}

// Which terms of an error value to evaluate: all of them, or those that read exactly the grid
// dimensions of a mask (bit d: grid dimension d; see term_dims).
const TERMS_ALL: u32 = 0xffffffffu;

// The bit of the grid dimension that drives the axis with letter index `letter` (X Y Z: 0..2);
// none for a rotary axis, which stands at its pose.
fn dim_bit(letter: u32) -> u32 {
    if letter < 3u {
        return 1u << letter;
    }
    return 0u;
}

// The grid dimensions term `f` of an error of the axis with letter index `own` reads: its
// argument's (the axis's own position, or another's), and a two-axis table's second.
fn term_dims(f: Function, own: u32) -> u32 {
    let arg = (f.pieces.z >> FUNCTION_ARG_SHIFT) & 15u;
    var first = own;
    if arg != 0u {
        first = arg - 1u;
    }
    var dims = dim_bit(first);
    if (f.pieces.z & FUNCTION_TABLE2D) != 0u {
        let arg2 = (f.pieces.z >> FUNCTION_ARG2_SHIFT) & 15u;
        dims = dims | dim_bit(max(arg2, 1u) - 1u);
    }
    return dims;
}

// Error function `index` of an error of axis `own` at its own position q with every axis at
// `c`, over the terms `which` selects (TERMS_ALL, or a mask of grid dimensions): each term of a
// sum reads its own argument.
fn eval_terms_at(index: u32, q: f32, c: Command, own: u32, which: u32) -> f32 {
    var total = 0.0;
    var next = index;
    while next != NO_FUNCTION {
        let f = functions[next];
        next = f.pieces.w;
        if which != TERMS_ALL && term_dims(f, own) != which {
            continue;
        }
        total = total + eval_term(f, q, c);
    }
    return total;
}

// One term `f` of an error value at its axis's own position q with every axis at `c`: it reads
// its own argument.
fn eval_term(f: Function, q: f32, c: Command) -> f32 {
    let arg = (f.pieces.z >> FUNCTION_ARG_SHIFT) & 15u;
    var x = q;
    if arg != 0u {
        x = command_q(c, arg - 1u);
    }
    if (f.pieces.z & FUNCTION_TABLE2D) != 0u {
        let arg2 = (f.pieces.z >> FUNCTION_ARG2_SHIFT) & 15u;
        return eval_table2d(f, x, command_q(c, max(arg2, 1u) - 1u));
    }
    return eval_pieces(f, x);
}

// An axis's six component errors at q: translations and angles.
fn component_errors(a: AxisData, q: f32) -> array<vec3<f32>, 2> {
    return array<vec3<f32>, 2>(
        vec3<f32>(
            eval_function(a.functions_a.x, q),
            eval_function(a.functions_a.y, q),
            eval_function(a.functions_a.z, q)),
        vec3<f32>(
            eval_function(a.functions_a.w, q),
            eval_function(a.functions_b.x, q),
            eval_function(a.functions_b.y, q)));
}

// The six component errors of axis `a` at q with every axis at `command`, over the terms
// `which` selects (TERMS_ALL, or those that read exactly a mask of grid dimensions).
fn component_terms_at(a: AxisData, q: f32, command: Command, which: u32) -> array<vec3<f32>, 2> {
    let own = a.functions_b.z;
    return array<vec3<f32>, 2>(
        vec3<f32>(
            eval_terms_at(a.functions_a.x, q, command, own, which),
            eval_terms_at(a.functions_a.y, q, command, own, which),
            eval_terms_at(a.functions_a.z, q, command, own, which)),
        vec3<f32>(
            eval_terms_at(a.functions_a.w, q, command, own, which),
            eval_terms_at(a.functions_b.x, q, command, own, which),
            eval_terms_at(a.functions_b.y, q, command, own, which)));
}

// An axis's six component errors at q with every axis at `command`.
fn component_errors_at(a: AxisData, q: f32, command: Command) -> array<vec3<f32>, 2> {
    return component_terms_at(a, q, command, TERMS_ALL);
}

// A tolerance's deviation of shape `shape` and amplitude s at q over the travel [a, b].
fn deviation_shape(shape: u32, s: f32, range: vec4<f32>, q: f32) -> f32 {
    let u = (q - range.x) / (range.y - range.x);
    if shape == SHAPE_LINE {
        return s * u;
    }
    if shape == SHAPE_BOW {
        return 4.0 * s * u * (1.0 - u);
    }
    return s;
}

// The component errors of axis n of sample `sample` at q: the base machine's plus the sample's
// deviations.
fn sampled_errors(a: AxisData, n: u32, sample: u32, q: f32) -> array<vec3<f32>, 2> {
    return add_deviations(component_errors(a, q), n, sample, q);
}

// sampled_errors with every axis at `command` (errors of other axes' positions).
fn sampled_errors_at(a: AxisData, n: u32, sample: u32, q: f32, command: Command) -> array<vec3<f32>, 2> {
    return add_deviations(component_errors_at(a, q, command), n, sample, q);
}

// The component errors `base` of axis n with sample `sample`'s deviations added.
fn add_deviations(base: array<vec3<f32>, 2>, n: u32, sample: u32, q: f32) -> array<vec3<f32>, 2> {
    var e = base;
    for (var t = 0u; t < params.counts.z; t = t + 1u) {
        let term = terms[t];
        if term.info.x == n {
            let s = amplitudes[sample * params.counts.z + term.info.w];
            let d = deviation_shape(term.info.z, s, term.range, q);
            let c = term.info.y;
            if c < 3u {
                e[0][c] = e[0][c] + d;
            } else {
                e[1][c - 3u] = e[1][c - 3u] + d;
            }
        }
    }
    return e;
}
