// Wavelet levels of detail (seed paper 001): synthetic detail coefficients and the inverse
// spline-linear (CDF 5/3) lifting, in the vertex-preserving interleaved layout.
// Mirrors src/wavelet/synthesis.rs (`fill_row`, `mask_factor`), src/wavelet/rng.rs and
// src/wavelet/lifting.rs; see those for the equations.
//
// `fill`: every output cell gets its source sample (cells on the stride-2^K grid) or one
// Gaussian coefficient: sigma(level, band, nearest source cell) * N(0, 1) * sqrt(1 - absorbed)
// where `absorbed` sums the mask under the squared synthesis taps (MGR, eq. 9).
// `lift`: one lifting step (update or predict, along x or y) at one stride.

struct Params {
    out_w: u32,
    out_h: u32,
    src_w: u32,
    src_h: u32,
    levels: u32,
    key: u32,
    has_mask: u32,
    mask_w: u32,
    mask_h: u32,
    stride: u32,
    axis: u32,
    parity: u32,
    coef: f32,
    sigma_per_cell: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> source: array<f32>;
@group(0) @binding(2) var<storage, read> sigma: array<f32>;
@group(0) @binding(3) var<storage, read> mask: array<f32>;
@group(0) @binding(4) var<storage, read_write> out: array<f32>;

fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn gaussian(x: u32, y: u32) -> f32 {
    let h1 = pcg(x ^ pcg(y ^ params.key));
    let h2 = pcg(h1 ^ 0x9e3779b9u);
    let u1 = f32((h1 >> 8u) + 1u) / 16777216.0;
    let u2 = f32(h2 >> 8u) / 16777216.0;
    return sqrt(-2.0 * log(u1)) * cos(6.2831853071795864 * u2);
}

// The mask resampled bilinearly (vertex-registered) at output cell (x, y).
fn mask_at(x: i32, y: i32) -> f32 {
    let cx = clamp(x, 0, i32(params.out_w) - 1);
    let cy = clamp(y, 0, i32(params.out_h) - 1);
    let u = select(0.0, f32(cx) / f32(params.out_w - 1u), params.out_w > 1u);
    let v = select(0.0, f32(cy) / f32(params.out_h - 1u), params.out_h > 1u);
    let fx = u * f32(params.mask_w - 1u);
    let fy = v * f32(params.mask_h - 1u);
    let x0 = u32(floor(fx));
    let y0 = u32(floor(fy));
    let x1 = min(x0 + 1u, params.mask_w - 1u);
    let y1 = min(y0 + 1u, params.mask_h - 1u);
    let tx = fx - f32(x0);
    let ty = fy - f32(y0);
    let w = params.mask_w;
    let top = mask[y0 * w + x0] + (mask[y0 * w + x1] - mask[y0 * w + x0]) * tx;
    let bottom = mask[y1 * w + x0] + (mask[y1 * w + x1] - mask[y1 * w + x0]) * tx;
    return top + (bottom - top) * ty;
}

// Squared synthesis taps, unit energy: across a high-pass axis (-2..2), a low-pass one (-1..1).
fn high_tap(d: i32) -> f32 {
    let k = abs(d);
    return select(select(1.0 / 46.0, 4.0 / 46.0, k == 1), 36.0 / 46.0, k == 0);
}

fn low_tap(d: i32) -> f32 {
    return select(1.0 / 6.0, 4.0 / 6.0, d == 0);
}

// Eq. 9 factor for a coefficient at (x, y) of the level with stride s; band 0 = H (high in
// y), 1 = V (high in x), 2 = D.
fn mask_factor(x: u32, y: u32, s: u32, band: u32) -> f32 {
    let high_x = band != 0u;
    let high_y = band != 1u;
    let rx = select(1, 2, high_x);
    let ry = select(1, 2, high_y);
    var absorbed = 0.0;
    for (var dy = -ry; dy <= ry; dy++) {
        let wy = select(low_tap(dy), high_tap(dy), high_y);
        var sum = 0.0;
        for (var dx = -rx; dx <= rx; dx++) {
            let wx = select(low_tap(dx), high_tap(dx), high_x);
            sum += wx * mask_at(i32(x) + dx * i32(s), i32(y) + dy * i32(s));
        }
        absorbed += wy * sum;
    }
    return sqrt(max(1.0 - absorbed, 0.0));
}

@compute @workgroup_size(16, 16, 1)
fn fill(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if (x >= params.out_w || y >= params.out_h) {
        return;
    }
    let k_levels = params.levels;
    let top = 1u << k_levels;
    let t = countTrailingZeros((x | y) | top);
    let i = y * params.out_w + x;
    if (t >= k_levels) {
        out[i] = source[(y >> k_levels) * params.src_w + (x >> k_levels)];
        return;
    }
    let s = 1u << t;
    let k = k_levels - t;
    let odd_x = ((x >> t) & 1u) == 1u;
    let odd_y = ((y >> t) & 1u) == 1u;
    var band = 2u;
    if (odd_x && !odd_y) {
        band = 1u;
    } else if (!odd_x && odd_y) {
        band = 0u;
    }
    let sx = min((x + top / 2u) >> k_levels, params.src_w - 1u);
    let sy = min((y + top / 2u) >> k_levels, params.src_h - 1u);
    let table = (k - 1u) * 3u + band;
    var sd = 0.0;
    if (params.sigma_per_cell == 1u) {
        sd = sigma[table * params.src_w * params.src_h + sy * params.src_w + sx];
    } else {
        sd = sigma[table];
    }
    var value = sd * gaussian(x, y);
    if (params.has_mask == 1u) {
        value *= mask_factor(x, y, s, band);
    }
    out[i] = value;
}

@compute @workgroup_size(16, 16, 1)
fn lift(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = params.stride;
    let nx = (params.out_w - 1u) / s + 1u;
    let ny = (params.out_h - 1u) / s + 1u;
    let i = gid.x;
    let j = gid.y;
    if (i >= nx || j >= ny) {
        return;
    }
    let along_x = params.axis == 0u;
    let k = select(j, i, along_x);
    let n = select(ny, nx, along_x);
    if ((k & 1u) != params.parity) {
        return;
    }
    let left = select(k - 1u, 1u, k == 0u);
    let right = select(k + 1u, k - 1u, k + 1u >= n);
    let w = params.out_w;
    let here = j * s * w + i * s;
    var a = 0.0;
    var b = 0.0;
    if (along_x) {
        a = out[j * s * w + left * s];
        b = out[j * s * w + right * s];
    } else {
        a = out[left * s * w + i * s];
        b = out[right * s * w + i * s];
    }
    out[here] = out[here] + params.coef * (a + b);
}

// The detail's RMS (src/wavelet/synthesis.rs `detail_rms`): the output minus the source's
// bilinear interpolation, squared and summed apart where the mask leaves the detail free
// (below 0.01) and where it covers it fully (0.99 and above). Each workgroup sums a tile of
// 16 columns by 16 * RMS_ROWS rows into one `partials` entry: (free sum, free cells, covered
// sum, covered cells); the CPU adds the entries in f64.
const RMS_ROWS: u32 = 8u;

@group(0) @binding(5) var<storage, read_write> partials: array<vec4<f32>>;

var<workgroup> rms_sums: array<vec4<f32>, 256>;

fn source_at(i: u32, j: u32) -> f32 {
    return source[min(j, params.src_h - 1u) * params.src_w + min(i, params.src_w - 1u)];
}

@compute @workgroup_size(16, 16, 1)
fn detail_rms(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let f = 1u << params.levels;
    let x = wid.x * 16u + lid.x;
    var acc = vec4<f32>(0.0);
    if (x < params.out_w) {
        let x0 = min(x / f, params.src_w - 2u);
        let tx = f32(x - x0 * f) / f32(f);
        for (var r = 0u; r < RMS_ROWS; r++) {
            let y = (wid.y * RMS_ROWS + r) * 16u + lid.y;
            if (y >= params.out_h) {
                break;
            }
            let y0 = min(y / f, params.src_h - 2u);
            let ty = f32(y - y0 * f) / f32(f);
            let top = source_at(x0, y0) * (1.0 - tx) + source_at(x0 + 1u, y0) * tx;
            let bottom = source_at(x0, y0 + 1u) * (1.0 - tx) + source_at(x0 + 1u, y0 + 1u) * tx;
            let d = out[y * params.out_w + x] - (top * (1.0 - ty) + bottom * ty);
            var m = 0.0;
            if (params.has_mask == 1u) {
                m = mask_at(i32(x), i32(y));
            }
            if (m < 0.01) {
                acc += vec4<f32>(d * d, 1.0, 0.0, 0.0);
            } else if (m >= 0.99) {
                acc += vec4<f32>(0.0, 0.0, d * d, 1.0);
            }
        }
    }
    rms_sums[li] = acc;
    workgroupBarrier();
    for (var s = 128u; s > 0u; s >>= 1u) {
        if (li < s) {
            rms_sums[li] += rms_sums[li + s];
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        partials[wid.y * groups.x + wid.x] = rms_sums[0];
    }
}
