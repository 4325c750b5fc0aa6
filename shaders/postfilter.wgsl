// Post-filters of the filled terrain (seed paper 000, Sec. V-C): Gaussian smoothing and added
// fractal Perlin noise, weighted by the river protection mask. Mirrors
// src/diffusion/post.rs (`apply_cpu`) and src/skeleton/noise.rs (`Perlin`); see those for the
// equations.
//
// `blur_x`: tmp = horizontal Gaussian of u; `blur_y`: out = vertical Gaussian of tmp;
// `combine`: out = u + weight * (blurred - u + amplitude * fbm), blurred = out or u.

struct Params {
    w: u32,
    h: u32,
    radius: u32,
    do_smooth: u32,
    amplitude: f32,
    frequency: f32,
    octaves: u32,
    roughness: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> u: array<f32>;
@group(0) @binding(2) var<storage, read> taps: array<f32>;
@group(0) @binding(3) var<storage, read> perm: array<u32>;
@group(0) @binding(4) var<storage, read> weights: array<f32>;
@group(0) @binding(5) var<storage, read_write> tmp: array<f32>;
@group(0) @binding(6) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(16, 16)
fn blur_x(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.w || id.y >= params.h) { return; }
    let r = i32(params.radius);
    var sum = 0.0;
    for (var k = -r; k <= r; k++) {
        let x = clamp(i32(id.x) + k, 0, i32(params.w) - 1);
        sum += taps[u32(k + r)] * u[id.y * params.w + u32(x)];
    }
    tmp[id.y * params.w + id.x] = sum;
}

@compute @workgroup_size(16, 16)
fn blur_y(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.w || id.y >= params.h) { return; }
    let r = i32(params.radius);
    var sum = 0.0;
    for (var k = -r; k <= r; k++) {
        let y = clamp(i32(id.y) + k, 0, i32(params.h) - 1);
        sum += taps[u32(k + r)] * tmp[u32(y) * params.w + id.x];
    }
    out[id.y * params.w + id.x] = sum;
}

fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

fn grad(h: u32, x: f32, y: f32) -> f32 {
    var g: f32;
    switch (h & 7u) {
        case 0u: { g = x + y; }
        case 1u: { g = -x + y; }
        case 2u: { g = x - y; }
        case 3u: { g = -x - y; }
        case 4u: { g = x; }
        case 5u: { g = -x; }
        case 6u: { g = y; }
        default: { g = -y; }
    }
    return g;
}

fn hash(i: u32, j: u32) -> u32 {
    return perm[perm[i] + j];
}

fn perlin(px: f32, py: f32) -> f32 {
    let xf = floor(px);
    let yf = floor(py);
    let xi = u32(i32(xf) & 255);
    let yi = u32(i32(yf) & 255);
    let x = px - xf;
    let y = py - yf;
    let fu = fade(x);
    let fv = fade(y);
    let n00 = grad(hash(xi, yi), x, y);
    let n10 = grad(hash(xi + 1u, yi), x - 1.0, y);
    let n01 = grad(hash(xi, yi + 1u), x, y - 1.0);
    let n11 = grad(hash(xi + 1u, yi + 1u), x - 1.0, y - 1.0);
    return mix(mix(n00, n10, fu), mix(n01, n11, fu), fv);
}

fn fbm(x: f32, y: f32) -> f32 {
    var sum = 0.0;
    var norm = 0.0;
    var amp = 1.0;
    var freq = params.frequency;
    for (var o = 0u; o < params.octaves; o++) {
        sum += amp * perlin(x * freq, y * freq);
        norm += amp;
        amp *= params.roughness;
        freq *= 2.0;
    }
    return select(0.0, sum / norm, norm > 0.0);
}

@compute @workgroup_size(16, 16)
fn combine(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.w || id.y >= params.h) { return; }
    let i = id.y * params.w + id.x;
    let here = u[i];
    let blurred = select(here, out[i], params.do_smooth == 1u);
    var noise = 0.0;
    if (params.amplitude != 0.0) {
        let fx = f32(id.x) / f32(max(params.w, 2u) - 1u);
        let fy = f32(id.y) / f32(max(params.h, 2u) - 1u);
        noise = params.amplitude * fbm(fx, fy);
    }
    out[i] = here + weights[i] * (blurred - here + noise);
}
