// Wavelet statistics of a terrain on the GPU (seed paper 001: GSA eqs. 6-7, LSA eq. 8).
// Mirrors src/wavelet/analysis.rs (`analyze_transformed`, `WindowSums`, `local_fit`) and the
// calibrated tables of src/wavelet/synthesis.rs (`SigmaTables::build`); see those for the
// equations. The forward transform itself is wavelet.wgsl's `lift` kernel.
//
// - `energy`: per workgroup, the sum of squared coefficients of each band at one level (the
//   numerator of eq. 6); the CPU adds the workgroups' sums in f64 and fits eq. 7.
// - `window_rows`, `window_logs`: each coefficient's mean square over a window of
//   `window x window` coefficients of its band (shifted inside the grid, as the CPU's
//   `mean_around`), floored, as a log2 plus the small-sample bias (separable sums).
// - `slope_stats`: per cell and band the raw local slope of eq. 7 through the analysed
//   levels' windowed log-variances; per workgroup their sum and sum of squares (the
//   shrinkage's spread).
// - `local_sigma`: per cell and band the (shrunk) fit and eq. 8's log2 variance for each new
//   level, into the sigma tables; per workgroup the sums that calibrate each level's mean
//   energy to the global line. With eq. 8 as written, the standard deviations directly.
// - `sigma_finish`: calibrated log2 variance -> standard deviation in the lifting domain.
//
// Sums run in f32 inside a workgroup and in f64 across workgroups (on the CPU).

const MAX_LEVELS: u32 = 16u;
const MAX_SUMS: u32 = 9u;

struct Params {
    width: u32,
    height: u32,
    // Stride of the level, and the band's parities (window kernels).
    stride: u32,
    px: u32,
    py: u32,
    // Coefficients along x and y: of the band (window kernels) or of the sub-grid (`energy`).
    nx: u32,
    ny: u32,
    window: u32,
    // Where `window_logs` writes its level into `logs`.
    offset: u32,
    // Analysed levels (local fit), new levels (sigma tables), eq. 8 as written (1) or not.
    levels: u32,
    new_levels: u32,
    as_written: u32,
    floor: f32,
    bias: f32,
    // Squared normalisation of the band at this level (window kernels).
    norm2: f32,
    mean_depth: f32,
    sxx: f32,
    // Where this dispatch's workgroups write their sums into `partials`.
    partial_offset: u32,
    _pad0: u32,
    _pad1: u32,
    // Per band b and analysed level k (index b * MAX_LEVELS + k): nx, ny, offset into `logs`,
    // stride.
    geometry: array<vec4<u32>, 48>,
    // Per band: centre and keep of the shrinkage, whether the band has a global fit (1 or 0),
    // the largest local slope kept.
    shrink: array<vec4<f32>, 3>,
    // Per table (new level k - 1) * 3 + band: the global line's log2 variance there, the
    // calibration shift, the lifting-domain normalisation.
    tables: array<vec4<f32>, 9>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> data: array<f32>;
@group(0) @binding(2) var<storage, read_write> rows: array<f32>;
@group(0) @binding(3) var<storage, read_write> logs: array<f32>;
@group(0) @binding(4) var<storage, read_write> partials: array<f32>;
@group(0) @binding(5) var<storage, read_write> sigma: array<f32>;

var<workgroup> scratch: array<f32, 2304>;

// Adds lanes 0..count of every invocation's scratch row into row 0, then writes them to
// `partials` at this workgroup's place. Every invocation of the workgroup must call it.
fn reduce_and_store(lid: u32, count: u32, group: u32) {
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride = stride >> 1u) {
        if (lid < stride) {
            for (var c = 0u; c < count; c++) {
                scratch[lid * MAX_SUMS + c] += scratch[(lid + stride) * MAX_SUMS + c];
            }
        }
        workgroupBarrier();
    }
    if (lid < count) {
        partials[params.partial_offset + group * count + lid] = scratch[lid];
    }
}

fn clear_scratch(lid: u32) {
    for (var c = 0u; c < MAX_SUMS; c++) {
        scratch[lid * MAX_SUMS + c] = 0.0;
    }
}

fn group_index(wg: vec3<u32>, groups: vec3<u32>) -> u32 {
    return wg.y * groups.x + wg.x;
}

// Band parities (odd x, odd y): H = (0, 1), V = (1, 0), D = (1, 1).
fn band_px(b: u32) -> u32 {
    return select(1u, 0u, b == 0u);
}

fn band_py(b: u32) -> u32 {
    return select(1u, 0u, b == 1u);
}

@compute @workgroup_size(16, 16, 1)
fn energy(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    clear_scratch(lid);
    let i = gid.x;
    let j = gid.y;
    let odd_x = (i & 1u) == 1u;
    let odd_y = (j & 1u) == 1u;
    if (i < params.nx && j < params.ny && (odd_x || odd_y)) {
        let s = params.stride;
        let v = data[j * s * params.width + i * s];
        var band = 2u;
        if (!odd_y) {
            band = 1u;
        } else if (!odd_x) {
            band = 0u;
        }
        scratch[lid * MAX_SUMS + band] = v * v;
    }
    reduce_and_store(lid, 3u, group_index(wg, groups));
}

// First of the `min(window, n)` coefficients of the window around `c`, shifted inside 0..n.
fn window_start(c: u32, n: u32) -> u32 {
    let w = min(params.window, n);
    let half = params.window / 2u;
    let lo = select(0u, c - half, c >= half);
    return min(lo, n - w);
}

@compute @workgroup_size(16, 16, 1)
fn window_rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    let ci = gid.x;
    let cj = gid.y;
    if (ci >= params.nx || cj >= params.ny) {
        return;
    }
    let s = params.stride;
    let row = (2u * cj + params.py) * s * params.width;
    let lo = window_start(ci, params.nx);
    let count = min(params.window, params.nx);
    var sum = 0.0;
    for (var k = 0u; k < count; k++) {
        let v = data[row + (2u * (lo + k) + params.px) * s];
        sum += v * v;
    }
    rows[cj * params.nx + ci] = sum;
}

@compute @workgroup_size(16, 16, 1)
fn window_logs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let ci = gid.x;
    let cj = gid.y;
    if (ci >= params.nx || cj >= params.ny) {
        return;
    }
    let lo = window_start(cj, params.ny);
    let count = min(params.window, params.ny);
    var sum = 0.0;
    for (var k = 0u; k < count; k++) {
        sum += rows[(lo + k) * params.nx + ci];
    }
    let cells = f32(count * min(params.window, params.nx));
    let mean = sum * params.norm2 / cells;
    logs[params.offset + cj * params.nx + ci] = log2(max(mean, params.floor)) + params.bias;
}

// The raw fit of eq. 7 at cell (x, y) for band b: (slope, mean log2 variance), from the
// windowed log-variance of the coefficient nearest to the cell at each analysed level.
fn raw_fit(x: u32, y: u32, b: u32) -> vec2<f32> {
    var values: array<f32, 16>;
    var mean = 0.0;
    let px = band_px(b);
    let py = band_py(b);
    for (var k = 0u; k < params.levels; k++) {
        let g = params.geometry[b * MAX_LEVELS + k];
        let s = g.w;
        // Nearest band sample: samples sit at (2 i + p) s; round half up, as the CPU's
        // `nearest_coefficient` does for these non-negative positions.
        let ci = min((x + s - px * s) / (2u * s), g.x - 1u);
        let cj = min((y + s - py * s) / (2u * s), g.y - 1u);
        let v = logs[g.z + cj * g.x + ci];
        values[k] = v;
        mean += v;
    }
    mean /= f32(params.levels);
    var sxy = 0.0;
    for (var k = 0u; k < params.levels; k++) {
        sxy += (f32(k + 1u) - params.mean_depth) * (values[k] - mean);
    }
    return vec2<f32>(sxy / params.sxx, mean);
}

@compute @workgroup_size(16, 16, 1)
fn slope_stats(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    clear_scratch(lid);
    if (gid.x < params.width && gid.y < params.height) {
        for (var b = 0u; b < 3u; b++) {
            let slope = raw_fit(gid.x, gid.y, b).x;
            scratch[lid * MAX_SUMS + 2u * b] = slope;
            scratch[lid * MAX_SUMS + 2u * b + 1u] = slope * slope;
        }
    }
    reduce_and_store(lid, 6u, group_index(wg, groups));
}

@compute @workgroup_size(16, 16, 1)
fn local_sigma(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    clear_scratch(lid);
    let cells = params.width * params.height;
    if (gid.x < params.width && gid.y < params.height) {
        let cell = gid.y * params.width + gid.x;
        for (var b = 0u; b < 3u; b++) {
            let shrink = params.shrink[b];
            let fit = raw_fit(gid.x, gid.y, b);
            var slope = fit.x;
            if (params.as_written == 0u) {
                slope = clamp(shrink.x + shrink.y * (fit.x - shrink.x), 0.0, shrink.w);
            }
            let intercept = fit.y - slope * params.mean_depth;
            for (var k = 1u; k <= params.new_levels; k++) {
                let t = (k - 1u) * 3u + b;
                let depth = 1.0 - f32(k);
                let log2_var = intercept + slope * depth;
                var value = 0.0;
                if (shrink.z == 0.0) {
                    // No global fit: no detail in this band, as on the CPU.
                } else if (params.as_written == 1u) {
                    value = exp2(0.5 * log2_var) / params.tables[t].z;
                } else {
                    value = log2_var;
                    scratch[lid * MAX_SUMS + t] = exp2(log2_var - params.tables[t].x);
                }
                sigma[t * cells + cell] = value;
            }
        }
    }
    reduce_and_store(lid, 3u * params.new_levels, group_index(wg, groups));
}

@compute @workgroup_size(16, 16, 1)
fn sigma_finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let cells = params.width * params.height;
    let cell = gid.y * params.width + gid.x;
    for (var t = 0u; t < 3u * params.new_levels; t++) {
        if (params.shrink[t % 3u].z != 0.0) {
            let table = params.tables[t];
            let i = t * cells + cell;
            sigma[i] = exp2(0.5 * (sigma[i] + table.y)) / table.z;
        }
    }
}
