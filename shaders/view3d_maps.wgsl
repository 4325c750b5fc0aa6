// The 3D view's rasters on the GPU, the twin of `src/view3d/maps.rs` (see
// `src/view3d/gpu_maps.rs`): the B-spline's interpolating control points (seed 004, a
// tridiagonal solve per row, then per column), the surface gradients as half floats and eq. 5's
// roughness from the finest wavelet level's squared detail. Each raster is written with rows
// padded for a buffer-to-texture copy (256-byte rows).
//
// Entry points:
//   spline_rows     one invocation per row: heights -> the row's control points (Thomas)
//   spline_columns  one invocation per column, in place on the control points
//   gradients       one invocation per cell: (dz/dx, dz/dy) packed as two half floats
//   roughness       one invocation per 4 cells of a row: the window's standard deviation of
//                   the finest detail (squared from the heights' forward transform, made by
//                   the wavelet analysis's kernels), times p.scale, as 4 bytes

struct Params {
    w: u32,
    h: u32,
    // Row strides, in elements, of the control points, the gradients and the roughness words.
    control_stride: u32,
    gradient_stride: u32,
    roughness_stride: u32,
    // Half-width of the roughness window.
    radius: u32,
    // Metres per cell.
    cell: f32,
    // 1 / (2 x the root mean square of the finest detail).
    scale: f32,
    // The finest level's normalisation by cell parity, index x odd + 2 y odd (0 on the
    // coarse cells, which hold no detail).
    norms: vec4<f32>,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> heights: array<f32>;
@group(0) @binding(2) var<storage, read_write> control: array<f32>;
// Thomas factors of a row (w of each) and of a column (h of each): pivots, then uppers.
@group(0) @binding(3) var<storage, read> row_factors: array<f32>;
@group(0) @binding(4) var<storage, read> column_factors: array<f32>;
@group(0) @binding(5) var<storage, read_write> packed: array<u32>;
// The heights' forward wavelet transform (the CPU's lifting layout): the finest detail on
// the cells with an odd coordinate.
@group(0) @binding(6) var<storage, read> transform: array<f32>;

// The tridiagonal solve of `subdivision.rs`'s `solve_line` (rows 1/6, 4/6, 1/6; the first and
// last rows identities) on `len` values read at `src(i)`, written to control[dst(i)]: the
// forward sweep leaves its right-hand sides in control, the back substitution replaces them.
@compute @workgroup_size(64, 1, 1)
fn spline_rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    let y = gid.x;
    if (y >= p.h) {
        return;
    }
    let n = p.w;
    let src = y * p.w;
    let dst = y * p.control_stride;
    if (n < 3u) {
        for (var i = 0u; i < n; i += 1u) {
            control[dst + i] = heights[src + i];
        }
        return;
    }
    var previous = heights[src];
    control[dst] = previous;
    for (var i = 1u; i < n - 1u; i += 1u) {
        previous = (heights[src + i] - previous / 6.0) / row_factors[i];
        control[dst + i] = previous;
    }
    var next = heights[src + n - 1u];
    control[dst + n - 1u] = next;
    for (var i = n - 1u; i > 0u; i -= 1u) {
        next = control[dst + i - 1u] - row_factors[n + i - 1u] * next;
        control[dst + i - 1u] = next;
    }
}

@compute @workgroup_size(64, 1, 1)
fn spline_columns(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let n = p.h;
    if (x >= p.w || n < 3u) {
        return;
    }
    let s = p.control_stride;
    var previous = control[x];
    for (var i = 1u; i < n - 1u; i += 1u) {
        previous = (control[i * s + x] - previous / 6.0) / column_factors[i];
        control[i * s + x] = previous;
    }
    var next = control[(n - 1u) * s + x];
    for (var i = n - 1u; i > 0u; i -= 1u) {
        next = control[(i - 1u) * s + x] - column_factors[n + i - 1u] * next;
        control[(i - 1u) * s + x] = next;
    }
}

// The largest finite half float.
const MAX_HALF: f32 = 65504.0;

fn height(x: u32, y: u32) -> f32 {
    return heights[y * p.w + x];
}

// Central differences, one-sided at the border, in metres per metre (`gradient_rows`).
@compute @workgroup_size(16, 16, 1)
fn gradients(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if (x >= p.w || y >= p.h) {
        return;
    }
    let xa = select(x - 1u, 0u, x == 0u);
    let xb = min(x + 1u, p.w - 1u);
    let ya = select(y - 1u, 0u, y == 0u);
    let yb = min(y + 1u, p.h - 1u);
    let dx = (height(xb, y) - height(xa, y)) / (f32(max(xb - xa, 1u)) * p.cell);
    let dy = (height(x, yb) - height(x, ya)) / (f32(max(yb - ya, 1u)) * p.cell);
    // Within the half floats' range, as `maps.rs` clamps them (pack2x16float is undefined
    // beyond it).
    let d = clamp(vec2<f32>(dx, dy), vec2<f32>(-MAX_HALF), vec2<f32>(MAX_HALF));
    packed[y * p.gradient_stride + x] = pack2x16float(d);
}

// Cells in [a, b] with an even coordinate.
fn evens(a: u32, b: u32) -> u32 {
    return b / 2u - (a + 1u) / 2u + 1u;
}

// `roughness` in `maps.rs`: the standard deviation of the detail over the window's detail
// cells (its cells less its (even, even) ones), times p.scale, clamped to 1, in bytes.
fn roughness_at(x: u32, y: u32) -> u32 {
    let r = p.radius;
    let x0 = select(x - r, 0u, x < r);
    let x1 = min(x + r, p.w - 1u);
    let y0 = select(y - r, 0u, y < r);
    let y1 = min(y + r, p.h - 1u);
    var sum = 0.0;
    for (var yy = y0; yy <= y1; yy += 1u) {
        for (var xx = x0; xx <= x1; xx += 1u) {
            let d = transform[yy * p.w + xx] * p.norms[(xx & 1u) + 2u * (yy & 1u)];
            sum += d * d;
        }
    }
    let n = (x1 - x0 + 1u) * (y1 - y0 + 1u) - evens(x0, x1) * evens(y0, y1);
    let sigma = sqrt(max(sum, 0.0) / f32(max(n, 1u)));
    // Halves round up, as Rust's round does for these non-negative values.
    return u32(floor(min(sigma * p.scale, 1.0) * 255.0 + 0.5));
}

@compute @workgroup_size(16, 16, 1)
fn roughness(@builtin(global_invocation_id) gid: vec3<u32>) {
    let y = gid.y;
    let x = 4u * gid.x;
    if (x >= p.w || y >= p.h) {
        return;
    }
    var word = 0u;
    for (var k = 0u; k < 4u; k += 1u) {
        if (x + k < p.w) {
            word |= roughness_at(x + k, y) << (8u * k);
        }
    }
    packed[y * p.roughness_stride + gid.x] = word;
}
