// The 3D view's terrain and water (src/view3d/renderer.rs).
//
// Terrain: one shared grid of (n x n) vertices plus a skirt ring, drawn once per chunk
// instance (src/view3d/lod.rs). The vertex stage reads heights from a texture (no storage
// buffers, so this runs on WebGL2 too): every vertex lies on the bicubic B-spline through
// the field's samples, seed 004's subdivision limit (eqs. 2-3, shaders/bspline.wgsl, which
// the renderer prepends), so chunks of any level share one surface, smooth below the
// field's resolution; in chunks finer than the field it adds seed 004's multifractal
// detail (eqs. 4-6) with the terrain's own Hurst exponent and wavelet roughness. The fragment stage mixes seed 003's four elevation
// textures (land, grassland 1, grassland 2, moss; Sec. 3.3.3) by an elevation-and-slope
// mask, adds snow (its Fig. 22), rivers as water, sun lighting and aerial fog, and writes
// gamma-encoded colour (egui shows the target as an Rgba8Unorm image).

struct Globals {
    view_proj: mat4x4<f32>,
    // xyz: eye (world metres); w: fog distance (metres).
    eye: vec4<f32>,
    // xyz: unit vector toward the sun; w: ambient light.
    sun: vec4<f32>,
    // x, y: field size in cells; z: metres per cell; w: vertical exaggeration.
    map: vec4<f32>,
    // x: lowest height; y: highest; z: water level (metres); w: snow line (fraction, < 0 off).
    heights: vec4<f32>,
    // x: rivers as water (1/0); y: water plane (1/0); z: detail amplitude (metres); w: skirts.
    flags: vec4<f32>,
    // x: eq. 4's octave gain 2^-H; y: H (from the terrain's spectral slope, maps.rs).
    detail: vec4<f32>,
};

@group(0) @binding(0) var<uniform> g: Globals;
// The B-spline's control points (src/view3d/subdivision.rs), not the samples.
@group(0) @binding(1) var height_tex: texture_2d<f32>;
@group(0) @binding(2) var gradient_tex: texture_2d<f32>;
@group(0) @binding(3) var water_tex: texture_2d<f32>;
@group(0) @binding(4) var linear_sampler: sampler;
// Eq. 5's roughness e: local standard deviation of the finest wavelet detail (seed 001's
// LSA), 0.5 = the map's average (maps.rs).
@group(0) @binding(5) var roughness_tex: texture_2d<f32>;

struct VertexIn {
    // Grid column, row (0..=n-1) and 1 on the skirt ring.
    @location(0) grid: vec3<f32>,
    // Chunk origin (cells), sample stride (cells), skirt depth (metres).
    @location(1) chunk: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    // Position on the field (cells).
    @location(1) cell: vec2<f32>,
    // Height (metres, without exaggeration).
    @location(2) height: f32,
    // Gradient of the synthetic detail (metres per metre).
    @location(3) detail_gradient: vec2<f32>,
};

// The surface (metres) at p (cells): the subdivision limit, the same at every level.
fn height_at(p: vec2<f32>) -> f32 {
    return bspline_height(p);
}

fn uv_of(cell: vec2<f32>) -> vec2<f32> {
    return (cell + vec2<f32>(0.5)) / g.map.xy;
}

// Integer hash (PCG) of a lattice point.
fn hash2(p: vec2<i32>) -> u32 {
    var v = u32(p.x) * 747796405u + u32(p.y) * 2891336453u + 12345u;
    v = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    return (v >> 22u) ^ v;
}

fn lattice_gradient(p: vec2<i32>) -> vec2<f32> {
    let angle = f32(hash2(p) & 1023u) * (6.2831853 / 1024.0);
    return vec2<f32>(cos(angle), sin(angle));
}

// Gradient (Perlin) noise: zero on the integer lattice, so with the lattice on the field's
// samples the detail never moves a real sample (seed 004, Sec. 3.2, k0 = 0).
fn perlin(p: vec2<f32>) -> f32 {
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let n00 = dot(lattice_gradient(i), f);
    let n10 = dot(lattice_gradient(i + vec2<i32>(1, 0)), f - vec2<f32>(1.0, 0.0));
    let n01 = dot(lattice_gradient(i + vec2<i32>(0, 1)), f - vec2<f32>(0.0, 1.0));
    let n11 = dot(lattice_gradient(i + vec2<i32>(1, 1)), f - vec2<f32>(1.0, 1.0));
    return mix(mix(n00, n10, u.x), mix(n01, n11, u.x), u.y);
}

// Eq. 4 with lacunarity 2, k0 = 0 and `octaves` = subdivisions beyond the field; H from the
// terrain's spectral slope (gamma = 2H + 2, seed 001), so each octave weighs 2^-H.
fn fractal(p: vec2<f32>, octaves: i32) -> f32 {
    var sum = 0.0;
    var frequency = 1.0;
    var weight = 1.0;
    for (var l = 0; l < octaves; l = l + 1) {
        sum = sum + perlin(p * frequency) * weight;
        frequency = frequency * 2.0;
        weight = weight * g.detail.x;
    }
    return sum;
}

// Eq. 5's multifractal weight M(h, s, e), linear as the paper suggests: low ground is
// smooth, steep ground (slope s) and rough ground (e: seed 001's local detail deviation,
// the paper's surface roughness) get more detail. `height` is the surface at p (metres).
fn detail_weight(p: vec2<f32>, height: f32) -> f32 {
    let uv = uv_of(p);
    let grad = textureSampleLevel(gradient_tex, linear_sampler, uv, 0.0).xy;
    let e = textureSampleLevel(roughness_tex, linear_sampler, uv, 0.0).r;
    let h = clamp((height - g.heights.x) / max(g.heights.y - g.heights.x, 1e-3), 0.0, 1.0);
    let s = min(length(grad), 1.0);
    return 0.2 + 0.3 * h + 0.3 * s + 0.2 * e;
}

@vertex
fn vs_terrain(in: VertexIn) -> VertexOut {
    let stride = in.chunk.z;
    let p = in.chunk.xy + in.grid.xy * stride;
    let cell = clamp(p, vec2<f32>(0.0), g.map.xy - vec2<f32>(1.0));
    var h = height_at(cell);
    var detail_gradient = vec2<f32>(0.0);
    if (stride < 0.99 && g.flags.z > 0.0) {
        // Eq. 6: V_d = sum_l Noise(2^l V) 2^(-H l) M(h, s, e), one octave per level below 0.
        let octaves = i32(round(-log2(stride)));
        let amplitude = g.flags.z * detail_weight(cell, h);
        h = h + amplitude * fractal(cell, octaves);
        let e = 0.25;
        let dx = fractal(cell + vec2<f32>(e, 0.0), octaves) - fractal(cell - vec2<f32>(e, 0.0), octaves);
        let dy = fractal(cell + vec2<f32>(0.0, e), octaves) - fractal(cell - vec2<f32>(0.0, e), octaves);
        detail_gradient = amplitude * vec2<f32>(dx, dy) / (2.0 * e * g.map.z);
    }
    var z = h * g.map.w;
    if (in.grid.z > 0.5 && g.flags.w > 0.5) {
        z = z - in.chunk.w * g.map.w;
    }
    let world = vec3<f32>(cell * g.map.z, z);
    var out: VertexOut;
    out.clip = g.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.cell = cell;
    out.height = h;
    out.detail_gradient = detail_gradient;
    return out;
}

fn value_hash(p: vec2<i32>) -> f32 {
    return f32(hash2(p) & 65535u) / 65535.0;
}

// Smooth value noise in [0, 1] for the textures' grain.
fn grain(p: vec2<f32>) -> f32 {
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = value_hash(i);
    let b = value_hash(i + vec2<i32>(1, 0));
    let c = value_hash(i + vec2<i32>(0, 1));
    let d = value_hash(i + vec2<i32>(1, 1));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

fn texture_grain(p: vec2<f32>, scale: f32) -> f32 {
    return 0.55 * grain(p / scale) + 0.3 * grain(p / (scale * 0.37)) + 0.15 * grain(p / (scale * 0.11));
}

fn band(t: f32, lo: f32, hi: f32) -> f32 {
    return smoothstep(lo - 0.05, lo + 0.05, t) * (1.0 - smoothstep(hi - 0.05, hi + 0.05, t));
}

fn gamma_from_linear(rgb: vec3<f32>) -> vec3<f32> {
    let cutoff = rgb < vec3<f32>(0.0031308);
    let lower = rgb * 12.92;
    let higher = 1.055 * pow(max(rgb, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(higher, lower, cutoff);
}

const SKY: vec3<f32> = vec3<f32>(0.55, 0.68, 0.85);

fn fogged(color: vec3<f32>, world: vec3<f32>) -> vec3<f32> {
    let distance = length(world - g.eye.xyz);
    let fog = 1.0 - exp(-distance / max(g.eye.w, 1.0));
    return mix(color, SKY, 0.6 * fog);
}

@fragment
fn fs_terrain(in: VertexOut) -> @location(0) vec4<f32> {
    let uv = uv_of(in.cell);
    let gradient = textureSampleLevel(gradient_tex, linear_sampler, uv, 0.0).xy + in.detail_gradient;
    let exaggeration = g.map.w;
    let normal = normalize(vec3<f32>(-gradient * exaggeration, 1.0));
    let slope = length(gradient);
    let t = clamp((in.height - g.heights.x) / max(g.heights.y - g.heights.x, 1e-3), 0.0, 1.0);

    // Seed 003, Sec. 3.3.3: a four-channel mask by elevation interval, each channel weighting
    // one texture; steep ground shows bare land whatever its height.
    var mask = vec4<f32>(
        1.0 - smoothstep(0.17, 0.27, t),
        band(t, 0.22, 0.5),
        band(t, 0.5, 0.75),
        smoothstep(0.7, 0.8, t),
    );
    mask = mask / max(mask.x + mask.y + mask.z + mask.w, 1e-3);
    let rock = smoothstep(0.55, 1.1, slope);
    mask = mix(mask, vec4<f32>(1.0, 0.0, 0.0, 0.0), rock);
    let p = in.world.xy;
    // Two grains shared by the four textures (cheap where the GPU is a CPU rasteriser).
    let coarse = texture_grain(p, 12.0);
    let fine = grain(p / 2.3);
    let land = vec3<f32>(0.36, 0.29, 0.21) * (0.7 + 0.4 * coarse + 0.2 * fine);
    let grass_1 = vec3<f32>(0.20, 0.36, 0.12) * (0.75 + 0.5 * coarse);
    let grass_2 = vec3<f32>(0.38, 0.42, 0.18) * (0.75 + 0.3 * coarse + 0.2 * fine);
    let moss = vec3<f32>(0.27, 0.31, 0.22) * (0.7 + 0.3 * coarse + 0.3 * fine);
    var albedo = mask.x * land + mask.y * grass_1 + mask.z * grass_2 + mask.w * moss;

    if (g.heights.w >= 0.0) {
        let line = g.heights.w + 0.06 * (grain(p / 40.0) - 0.5);
        let snow = smoothstep(line - 0.03, line + 0.03, t) * (1.0 - smoothstep(0.8, 1.3, slope));
        albedo = mix(albedo, vec3<f32>(0.92, 0.94, 0.97), snow);
    }
    var water = 0.0;
    if (g.flags.x > 0.5) {
        water = smoothstep(0.25, 0.6, textureSampleLevel(water_tex, linear_sampler, uv, 0.0).r);
        albedo = mix(albedo, vec3<f32>(0.09, 0.22, 0.36), water);
    }
    let light = max(dot(normal, g.sun.xyz), 0.0);
    var color = albedo * (g.sun.w + (1.0 - g.sun.w) * light);
    // A glint on the rivers.
    let view = normalize(g.eye.xyz - in.world);
    let glint = pow(max(dot(reflect(-g.sun.xyz, vec3<f32>(0.0, 0.0, 1.0)), view), 0.0), 40.0);
    color = color + water * 0.3 * glint;
    return vec4<f32>(gamma_from_linear(fogged(color, in.world)), 1.0);
}

struct WaterOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
};

// The water plane: two triangles over the map at the water level.
@vertex
fn vs_water(@builtin(vertex_index) index: u32) -> WaterOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 1.0), vec2<f32>(0.0, 1.0),
    );
    let extent = (g.map.xy - vec2<f32>(1.0)) * g.map.z;
    let world = vec3<f32>(corners[index] * extent, g.heights.z * g.map.w);
    var out: WaterOut;
    out.clip = g.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    return out;
}

@fragment
fn fs_water(in: WaterOut) -> @location(0) vec4<f32> {
    let view = normalize(g.eye.xyz - in.world);
    let glint = pow(max(dot(reflect(-g.sun.xyz, vec3<f32>(0.0, 0.0, 1.0)), view), 0.0), 60.0);
    let fresnel = 0.35 + 0.5 * pow(1.0 - max(view.z, 0.0), 3.0);
    let color = mix(vec3<f32>(0.03, 0.12, 0.24), SKY, 0.6 * fresnel) + vec3<f32>(0.6 * glint);
    return vec4<f32>(gamma_from_linear(fogged(color, in.world)), 0.8);
}
