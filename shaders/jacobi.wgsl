// One Jacobi sweep of the Laplace equation with fixed cells (seed paper 000, eqs. 6-7).
//
// Every free cell becomes the mean of its in-grid 4-neighbours (left, right, up, down, summed
// in that order, then divided by their count: zero flux at the map border). Fixed cells,
// one bit each in `fixed_bits` (cell i = bit i % 32 of word i / 32), are copied unchanged.
// The host ping-pongs `src` and `dst` between dispatches. Mirrors `src/diffusion/cpu.rs`.

// The buffers may hold only a band of rows (`src/diffusion/gpu/bands.rs`): rows row0.. of the
// field, of which this dispatch computes own_start..own_end; coordinates stay global.
struct Params {
    width: u32,
    height: u32,
    row0: u32,
    own_start: u32,
    own_end: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> fixed_bits: array<u32>;
@group(0) @binding(2) var<storage, read> src: array<f32>;
@group(0) @binding(3) var<storage, read_write> dst: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn jacobi_sweep(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = params.own_start + gid.y;
    let w = params.width;
    let h = params.height;
    if (x >= w || y >= params.own_end) {
        return;
    }
    let i = (y - params.row0) * w + x;
    if (((fixed_bits[i >> 5u] >> (i & 31u)) & 1u) == 1u) {
        dst[i] = src[i];
        return;
    }
    var sum = 0.0;
    var count = 0.0;
    if (x > 0u) {
        sum += src[i - 1u];
        count += 1.0;
    }
    if (x + 1u < w) {
        sum += src[i + 1u];
        count += 1.0;
    }
    if (y > 0u) {
        sum += src[i - w];
        count += 1.0;
    }
    if (y + 1u < h) {
        sum += src[i + w];
        count += 1.0;
    }
    if (count == 0.0) {
        dst[i] = src[i];
    } else {
        dst[i] = sum / count;
    }
}
