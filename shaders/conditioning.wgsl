// Depression filling on the GPU (`src/terrain/drainage/gpu.rs` drives these kernels; the
// CPU's Priority-Flood + epsilon in `src/terrain/drainage/mod.rs` is the reference, and the
// result is the same bits).
//
// Heights are compared as ordered keys: the f32 bit pattern mapped to a u32 that sorts as the
// floats do (both zeros to one key), so the next float above a height is its key + 1 and no
// float arithmetic (nor a GPU's flushing of subnormals) enters a comparison.
//
// The result L is the least surface above the terrain z in which every interior cell has a
// strictly lower neighbour: L = z on the map border, L_i = max(z_i, min_j L_j + 1) inside
// (Priority-Flood + epsilon, Barnes, Lehman & Mulla 2014, gives exactly this surface). Planchon
// & Darboux (2001) reach it from above: start from a surface W >= L that is z wherever the
// descent already reaches the border, and lower W_i to max(z_i, min_j W_j + 1) until nothing
// changes. Every W stays >= L and the only resting point is L, so the order of the updates
// does not matter: the result is L to the bit, however the GPU schedules the work.
// 1. `receivers` + `jump` (pointer jumping): each cell's lowest strictly lower neighbour and
//    the end of its descent. Cells whose descent ends on the border start at their own key
//    (L = z there); the cells of pits' basins at TOP.
// 2. `flood`: each 16 x 16 tile and a one-cell halo in workgroup memory iterate the rule until
//    the tile settles (at most LOCAL_ITERS), then lower the global levels (atomicMin) and count
//    the cells they lowered; the driver repeats the pass until one lowers nothing.
// 3. `apply`: raised cells take their level's float; the raised cells are counted and the
//    largest raise kept.

struct Params {
    width: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
}

// Above every height's key: "no outlet found yet".
const TOP: u32 = 0xffffffffu;
const NONE: u32 = 0xffffffffu;
// `stats`: NaN cells seen, cells lowered by the last flood pass, cells raised, largest raise
// (f32 bits; a raise is positive, so its bits order as the floats do).
const NAN_CELLS: u32 = 0u;
const LOWERED: u32 = 1u;
const RAISED: u32 = 2u;
const MAX_RAISE: u32 = 3u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> heights: array<f32>;
@group(0) @binding(2) var<storage, read_write> level: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read> ptr_in: array<u32>;
@group(0) @binding(4) var<storage, read_write> ptr_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> stats: array<atomic<u32>>;

// The ordered key of a height: negative floats reversed below 2^31, positive ones above it,
// -0 and +0 both at 2^31.
fn key(v: f32) -> u32 {
    let bits = bitcast<u32>(v);
    if ((bits & 0x7fffffffu) == 0u) {
        return 0x80000000u;
    }
    if ((bits & 0x80000000u) != 0u) {
        return ~bits;
    }
    return bits | 0x80000000u;
}

// The float of a key (the inverse of `key`; 2^31 is +0).
fn height_of(k: u32) -> f32 {
    if ((k & 0x80000000u) != 0u) {
        return bitcast<f32>(k & 0x7fffffffu);
    }
    return bitcast<f32>(~k);
}

// NaN by its bits (a compiler may fold `z != z` to false).
fn is_nan(v: f32) -> bool {
    let bits = bitcast<u32>(v);
    return (bits & 0x7f800000u) == 0x7f800000u && (bits & 0x007fffffu) != 0u;
}

fn cell_of(gid: vec3<u32>) -> u32 {
    if (gid.x >= params.width || gid.y >= params.height) {
        return NONE;
    }
    return gid.y * params.width + gid.x;
}

fn on_border(x: u32, y: u32) -> bool {
    return x == 0u || y == 0u || x + 1u == params.width || y + 1u == params.height;
}

// D8 offsets: the eight neighbours of the 3 x 3 block around a cell, its centre skipped.
fn block_offset(d: u32) -> u32 {
    return select(d, d + 1u, d >= 4u);
}

// ---- 1. where each descent ends --------------------------------------------------------

// The lowest strictly lower neighbour (the cell itself on the border, at a pit or at NaN).
@compute @workgroup_size(16, 16, 1)
fn receivers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let z = heights[i];
    if (is_nan(z)) {
        atomicAdd(&stats[NAN_CELLS], 1u);
        ptr_out[i] = i;
        return;
    }
    if (on_border(gid.x, gid.y)) {
        ptr_out[i] = i;
        return;
    }
    var best = key(z);
    var r = i;
    for (var d = 0u; d < 8u; d++) {
        let c = block_offset(d);
        let j = (gid.y + c / 3u - 1u) * params.width + gid.x + c % 3u - 1u;
        let kj = key(heights[j]);
        if (kj < best) {
            best = kj;
            r = j;
        }
    }
    ptr_out[i] = r;
}

@compute @workgroup_size(16, 16, 1)
fn jump(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    ptr_out[i] = ptr_in[ptr_in[i]];
}

// The starting surface: a cell's own key where its descent ends on the border, else TOP.
@compute @workgroup_size(16, 16, 1)
fn init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let root = ptr_in[i];
    let drains = on_border(root % params.width, root / params.width);
    atomicStore(&level[i], select(TOP, key(heights[i]), drains));
}

// ---- 2. the flood ----------------------------------------------------------------------

const TILE_SIDE: u32 = 18u;
const TILE_CELLS: u32 = 324u;
const LOCAL_ITERS: u32 = 32u;
var<workgroup> tile_z: array<u32, 324>;
var<workgroup> tile_w: array<array<u32, 324>, 2>;
var<workgroup> open_count: atomic<u32>;
var<workgroup> open_flag: u32;
var<workgroup> changed_count: atomic<u32>;
var<workgroup> changed_flag: u32;

@compute @workgroup_size(16, 16, 1)
fn flood(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let ox = i32(wid.x * 16u) - 1;
    let oy = i32(wid.y * 16u) - 1;
    for (var t = lid.y * 16u + lid.x; t < TILE_CELLS; t += 256u) {
        let gx = ox + i32(t % TILE_SIDE);
        let gy = oy + i32(t / TILE_SIDE);
        var zk = TOP;
        var wk = TOP;
        if (gx >= 0 && gy >= 0 && gx < i32(params.width) && gy < i32(params.height)) {
            let g = u32(gy) * params.width + u32(gx);
            zk = key(heights[g]);
            wk = atomicLoad(&level[g]);
        }
        tile_z[t] = zk;
        tile_w[0][t] = wk;
        tile_w[1][t] = wk;
    }
    workgroupBarrier();
    let gx = wid.x * 16u + lid.x;
    let gy = wid.y * 16u + lid.y;
    // Border cells are outlets: they keep their heights.
    let free = gx < params.width && gy < params.height && !on_border(gx, gy);
    let k = (lid.y + 1u) * TILE_SIDE + lid.x + 1u;
    let zi = tile_z[k];
    let loaded = tile_w[0][k];
    // A tile whose levels all equal their heights is settled (nothing there is above L).
    if (free && loaded > zi) {
        atomicAdd(&open_count, 1u);
    }
    workgroupBarrier();
    if (lid.x == 0u && lid.y == 0u) {
        open_flag = atomicLoad(&open_count);
    }
    if (workgroupUniformLoad(&open_flag) == 0u) {
        return;
    }
    // Jacobi within the tile, the halo held at the levels loaded: once an iteration changes
    // no cell the tile rests, and both buffers hold its levels.
    var last = 0u;
    for (var it = 0u; it < LOCAL_ITERS; it++) {
        let src = it % 2u;
        let before = tile_w[src][k];
        var w = before;
        if (free && w > zi) {
            var lowest = TOP;
            for (var d = 0u; d < 8u; d++) {
                let c = block_offset(d);
                lowest = min(lowest, tile_w[src][(lid.y + c / 3u) * TILE_SIDE + lid.x + c % 3u]);
            }
            if (lowest < TOP) {
                w = min(w, max(zi, lowest + 1u));
            }
        }
        tile_w[1u - src][k] = w;
        last = 1u - src;
        if (w != before) {
            atomicAdd(&changed_count, 1u);
        }
        workgroupBarrier();
        if (lid.x == 0u && lid.y == 0u) {
            changed_flag = atomicExchange(&changed_count, 0u);
        }
        if (workgroupUniformLoad(&changed_flag) == 0u) {
            break;
        }
    }
    let w = tile_w[last][k];
    if (free && w < loaded) {
        atomicMin(&level[gy * params.width + gx], w);
        atomicAdd(&stats[LOWERED], 1u);
    }
}

// ---- 3. the raised cells ---------------------------------------------------------------

@compute @workgroup_size(16, 16, 1)
fn apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let w = atomicLoad(&level[i]);
    let z = heights[i];
    if (w == TOP || w == key(z)) {
        return;
    }
    let raised = height_of(w);
    heights[i] = raised;
    atomicAdd(&stats[RAISED], 1u);
    atomicMax(&stats[MAX_RAISE], bitcast<u32>(raised - z));
}
