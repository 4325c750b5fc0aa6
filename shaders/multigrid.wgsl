// Multigrid for the diffusion problem (seed paper 000, eqs. 6-7), the GPU twin of
// `src/diffusion/multigrid/ops.rs`. Solves (A u)_i = b_i on free cells, u given on fixed cells,
// with (A u)_i = n_i u_i - sum of the n_i in-grid 4-neighbours (zero flux at the border).
// Neighbours are visited left, right, up, down and sums formed in the same order as on the CPU.
//
// A level may be tiled into bands of rows (`src/diffusion/gpu/bands.rs`): the buffers then hold
// rows fine_row0.. (coarse_row0..) of the level, coordinates stay global (borders at row 0 and
// fine_h - 1), and a dispatch covers the band's owned rows own_start..own_end. Untiled, both
// row offsets are 0 and the band is the whole level.
//
// Entry points (16 x 16 workgroups but solve_coarsest):
//   relax             one colour of a red-black Gauss-Seidel sweep on the fine level
//   relax_small       p.sweeps whole red-black sweeps on a level of at most 16 x 16 cells, in
//                     one workgroup: the same arithmetic, in the same order, as relax
//   solve_coarsest    the same on the coarsest level (at most 4 x 4 cells), 4 x 4 workgroup
//   smooth_tile       p.sweeps (at most TILE_SWEEPS) red-black sweeps of an untiled level in
//                     one dispatch: each workgroup smooths a tile with a halo in workgroup
//                     memory and writes its tile, read from u, into smoothed
//   restrict_residual coarse b = sum of the fine residual over the 2 x 2 children
//   prolong_add       fine u += bilinear interpolation of the coarse correction (free cells)
//   prolong_replace   fine u  = bilinear interpolation of the coarse solution (free cells)
//   residual_max      result[0] = max over free cells of |r_i| / n_i (f32 bits, atomicMax)
//   correction_max    result[1] = max |u| on this level (the coarse correction)
//   restrict_problem  builds the coarse level's problem (fixed bits, starting u) from this one

struct Params {
    fine_w: u32,
    fine_h: u32,
    coarse_w: u32,
    coarse_h: u32,
    colour: u32,
    has_rhs: u32,
    // Global row of the first row held by the fine (coarse) buffers.
    fine_row0: u32,
    coarse_row0: u32,
    // Fine rows this dispatch computes (restriction: their parents).
    own_start: u32,
    own_end: u32,
    // Red-black sweeps of solve_coarsest, relax_small and smooth_tile.
    sweeps: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> fixed_bits: array<u32>;
@group(0) @binding(2) var<storage, read_write> u: array<f32>;
@group(0) @binding(3) var<storage, read> b: array<f32>;
@group(0) @binding(4) var<storage, read_write> coarse: array<f32>;
// [0]: max |r_i| / n_i on the finest level; [1]: max |u| of the level below (the last
// coarse-grid correction), both as f32 bits.
@group(0) @binding(5) var<storage, read_write> result: array<atomic<u32>, 2>;
// The coarse level's fixed bits while restrict_problem builds them (created zeroed).
@group(0) @binding(6) var<storage, read_write> coarse_fixed: array<atomic<u32>>;
// Where smooth_tile writes the smoothed level (never the buffer it reads, u).
@group(0) @binding(7) var<storage, read_write> smoothed: array<f32>;

// Buffer index of global cell (x, y) on the fine and on the coarse level.
fn fine_index(x: u32, y: u32) -> u32 {
    return (y - p.fine_row0) * p.fine_w + x;
}

fn coarse_index(x: u32, y: u32) -> u32 {
    return (y - p.coarse_row0) * p.coarse_w + x;
}

fn is_fixed(i: u32) -> bool {
    return ((fixed_bits[i >> 5u] >> (i & 31u)) & 1u) == 1u;
}

fn rhs(i: u32) -> f32 {
    if (p.has_rhs == 1u) {
        return b[i];
    }
    return 0.0;
}

// Sum and count of the in-grid neighbours of (x, y) on the fine level.
fn neighbours(x: u32, y: u32) -> vec2<f32> {
    let w = p.fine_w;
    let i = fine_index(x, y);
    var sum = 0.0;
    var count = 0.0;
    if (x > 0u) {
        sum += u[i - 1u];
        count += 1.0;
    }
    if (x + 1u < w) {
        sum += u[i + 1u];
        count += 1.0;
    }
    if (y > 0u) {
        sum += u[i - w];
        count += 1.0;
    }
    if (y + 1u < p.fine_h) {
        sum += u[i + w];
        count += 1.0;
    }
    return vec2<f32>(sum, count);
}

// sum of (u_j - u_i) over the in-grid neighbours: -(A u)_i. Differences of close heights are
// exact in floating point, so the residual keeps full precision near convergence.
fn differences(x: u32, y: u32) -> f32 {
    let w = p.fine_w;
    let i = fine_index(x, y);
    let c = u[i];
    var sum = 0.0;
    if (x > 0u) {
        sum += u[i - 1u] - c;
    }
    if (x + 1u < w) {
        sum += u[i + 1u] - c;
    }
    if (y > 0u) {
        sum += u[i - w] - c;
    }
    if (y + 1u < p.fine_h) {
        sum += u[i + w] - c;
    }
    return sum;
}

fn residual_at(x: u32, y: u32) -> f32 {
    let i = fine_index(x, y);
    if (is_fixed(i)) {
        return 0.0;
    }
    return rhs(i) + differences(x, y);
}

@compute @workgroup_size(16, 16, 1)
fn relax(@builtin(global_invocation_id) gid: vec3<u32>) {
    let y = p.own_start + gid.y;
    if (y >= p.own_end) {
        return;
    }
    let x = 2u * gid.x + ((y + p.colour) & 1u);
    if (x >= p.fine_w) {
        return;
    }
    let i = fine_index(x, y);
    if (is_fixed(i)) {
        return;
    }
    let n = neighbours(x, y);
    if (n.y > 0.0) {
        u[i] = (rhs(i) + n.x) / n.y;
    }
}

// p.sweeps red-black sweeps of an untiled level, one invocation per cell (x, y) of one
// workgroup. Every colour's updates read only the other colour's cells, so the storage barrier
// between colours makes this the same as 2 * p.sweeps relax dispatches.
fn sweeps_in_workgroup(x: u32, y: u32) {
    let inside = x < p.fine_w && y < p.fine_h;
    for (var s = 0u; s < p.sweeps; s += 1u) {
        for (var colour = 0u; colour < 2u; colour += 1u) {
            if (inside && ((x + y + colour) & 1u) == 0u) {
                let i = fine_index(x, y);
                if (!is_fixed(i)) {
                    let n = neighbours(x, y);
                    if (n.y > 0.0) {
                        u[i] = (rhs(i) + n.x) / n.y;
                    }
                }
            }
            storageBarrier();
        }
    }
}

// A level of at most 16 x 16 cells: its few pre- or post-smoothing sweeps in one dispatch.
@compute @workgroup_size(16, 16, 1)
fn relax_small(@builtin(local_invocation_id) lid: vec3<u32>) {
    sweeps_in_workgroup(lid.x, lid.y);
}

// The coarsest level (at most 4 x 4 cells): its many sweeps in a workgroup of its own size,
// so each of the barriers waits for 16 invocations, not 256 (drivers that run a workgroup's
// invocations in turn, as lavapipe does, pay per invocation at every barrier).
@compute @workgroup_size(4, 4, 1)
fn solve_coarsest(@builtin(local_invocation_id) lid: vec3<u32>) {
    sweeps_in_workgroup(lid.x, lid.y);
}

// Tile smoothing. A red-black half-sweep reads only the other colour, so after k half-sweeps a
// cell's value depends on the cells within k steps of it. A workgroup loads its TILE x TILE
// cells with HALO = 2 * TILE_SWEEPS rings around them, runs the half-sweeps in workgroup
// memory on a shrinking window (half-sweep k updates the cells at least k rings in, whose
// neighbours are still exact), and writes its own tile. Every update is the arithmetic of
// relax, in the same order, on the same values: the same bits as 2 * p.sweeps relax
// dispatches, with one dispatch and one barrier per half-sweep instead of a dispatch each.
// The output goes to another buffer, since neighbouring workgroups read this tile's cells as
// their halo.
const TILE: u32 = 32u;
const TILE_SWEEPS: u32 = 2u;
const HALO: u32 = 2u * TILE_SWEEPS;
const SIDE: u32 = TILE + 2u * HALO;
const SIDE_CELLS: u32 = SIDE * SIDE;
const TILE_THREADS: u32 = 256u;
// Per loaded cell: its value, and whether it is on the level (bit 0) and fixed (bit 1).
var<workgroup> tile_u: array<f32, SIDE_CELLS>;
var<workgroup> tile_state: array<u32, SIDE_CELLS>;

// The half-sweep of `colour` on cell k of the tile (at least one ring in), as relax does it.
fn tile_update(k: u32, gx: u32, gy: u32) {
    var sum = 0.0;
    var count = 0.0;
    // Left, right, up, down, as `neighbours` sums them.
    if ((tile_state[k - 1u] & 1u) == 1u) {
        sum += tile_u[k - 1u];
        count += 1.0;
    }
    if ((tile_state[k + 1u] & 1u) == 1u) {
        sum += tile_u[k + 1u];
        count += 1.0;
    }
    if ((tile_state[k - SIDE] & 1u) == 1u) {
        sum += tile_u[k - SIDE];
        count += 1.0;
    }
    if ((tile_state[k + SIDE] & 1u) == 1u) {
        sum += tile_u[k + SIDE];
        count += 1.0;
    }
    if (count > 0.0) {
        tile_u[k] = (rhs(fine_index(gx, gy)) + sum) / count;
    }
}

@compute @workgroup_size(16, 16, 1)
fn smooth_tile(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    // Level coordinates of the loaded window's first cell, HALO before the tile's (may be
    // negative: those cells are off the level).
    let x0 = i32(wg.x * TILE) - i32(HALO);
    let y0 = i32(wg.y * TILE) - i32(HALO);
    for (var k = li; k < SIDE_CELLS; k += TILE_THREADS) {
        let gx = x0 + i32(k % SIDE);
        let gy = y0 + i32(k / SIDE);
        var value = 0.0;
        var state = 0u;
        if (gx >= 0 && gy >= 0 && u32(gx) < p.fine_w && u32(gy) < p.fine_h) {
            let i = fine_index(u32(gx), u32(gy));
            value = u[i];
            state = 1u;
            if (is_fixed(i)) {
                state = 3u;
            }
        }
        tile_u[k] = value;
        tile_state[k] = state;
    }
    workgroupBarrier();
    for (var step = 0u; step < 2u * p.sweeps; step += 1u) {
        let colour = step & 1u;
        // Half-sweep `step` updates the cells at least step + 1 rings in.
        let lo = step + 1u;
        let hi = SIDE - step - 1u;
        for (var k = li; k < SIDE_CELLS; k += TILE_THREADS) {
            let tx = k % SIDE;
            let ty = k / SIDE;
            let gx = u32(x0 + i32(tx));
            let gy = u32(y0 + i32(ty));
            let inner = tx >= lo && tx < hi && ty >= lo && ty < hi;
            if (inner && tile_state[k] == 1u && ((gx + gy + colour) & 1u) == 0u) {
                tile_update(k, gx, gy);
            }
        }
        workgroupBarrier();
    }
    // The tile's own cells, fixed ones included, so that smoothed holds the whole level.
    for (var k = li; k < TILE * TILE; k += TILE_THREADS) {
        let gx = wg.x * TILE + k % TILE;
        let gy = wg.y * TILE + k / TILE;
        if (gx < p.fine_w && gy < p.fine_h) {
            smoothed[fine_index(gx, gy)] = tile_u[(k / TILE + HALO) * SIDE + k % TILE + HALO];
        }
    }
}

@compute @workgroup_size(16, 16, 1)
fn restrict_residual(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let cy = p.own_start / 2u + gid.y;
    if (cx >= p.coarse_w || 2u * cy >= p.own_end) {
        return;
    }
    var sum = 0.0;
    for (var y = 2u * cy; y < min(2u * cy + 2u, p.fine_h); y += 1u) {
        for (var x = 2u * cx; x < min(2u * cx + 2u, p.fine_w); x += 1u) {
            sum += residual_at(x, y);
        }
    }
    coarse[coarse_index(cx, cy)] = sum;
}

// (near, far) coarse indices along one axis; the far one weighs 1/4 (clamped at the border).
fn axis(x: u32, n: u32) -> vec2<u32> {
    let near = min(x / 2u, n - 1u);
    var far = near;
    if ((x & 1u) == 0u) {
        if (near > 0u) {
            far = near - 1u;
        }
    } else {
        far = min(near + 1u, n - 1u);
    }
    return vec2<u32>(near, far);
}

fn interpolate(x: u32, y: u32) -> f32 {
    let ax = axis(x, p.coarse_w);
    let ay = axis(y, p.coarse_h);
    let near = coarse[coarse_index(ax.x, ay.x)] * 0.75 + coarse[coarse_index(ax.y, ay.x)] * 0.25;
    let far = coarse[coarse_index(ax.x, ay.y)] * 0.75 + coarse[coarse_index(ax.y, ay.y)] * 0.25;
    return near * 0.75 + far * 0.25;
}

@compute @workgroup_size(16, 16, 1)
fn prolong_add(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = p.own_start + gid.y;
    if (x >= p.fine_w || y >= p.own_end) {
        return;
    }
    let i = fine_index(x, y);
    if (!is_fixed(i)) {
        u[i] += interpolate(x, y);
    }
}

@compute @workgroup_size(16, 16, 1)
fn prolong_replace(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = p.own_start + gid.y;
    if (x >= p.fine_w || y >= p.own_end) {
        return;
    }
    let i = fine_index(x, y);
    if (!is_fixed(i)) {
        u[i] = interpolate(x, y);
    }
}

@compute @workgroup_size(16, 16, 1)
fn residual_max(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = p.own_start + gid.y;
    if (x >= p.fine_w || y >= p.own_end) {
        return;
    }
    let i = fine_index(x, y);
    if (is_fixed(i)) {
        return;
    }
    let n = neighbours(x, y);
    let r = rhs(i) + differences(x, y);
    // Non-negative floats order like their bits, so atomicMax on the bits is a float max.
    atomicMax(&result[0], bitcast<u32>(abs(r) / n.y));
}

@compute @workgroup_size(16, 16, 1)
fn correction_max(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = p.own_start + gid.y;
    if (x >= p.fine_w || y >= p.own_end) {
        return;
    }
    atomicMax(&result[1], bitcast<u32>(abs(u[fine_index(x, y)])));
}

// Building the hierarchy on the GPU, the twin of `restrict_rows` in
// `src/diffusion/multigrid/hierarchy.rs`: only the finest level is uploaded and each coarser
// level is built from the one above it. Constraint-aware restriction of the problem: a coarse
// cell is fixed when any of its 2 x 2 children is, and then holds the mean of the fixed
// children's heights (so rivers and ridges stay connected lines on every level); otherwise it
// starts at the mean of its children. The coarse right-hand side of a Laplace problem is zero
// (its buffer is created zeroed). Several fine bands may write one coarse buffer, and a word of
// fixed bits may hold cells of two of them: the bits are set with atomicOr.
@compute @workgroup_size(16, 16, 1)
fn restrict_problem(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let cy = p.own_start / 2u + gid.y;
    if (cx >= p.coarse_w || 2u * cy >= p.own_end) {
        return;
    }
    var fixed_sum = 0.0;
    var fixed_n = 0u;
    var free_sum = 0.0;
    var free_n = 0u;
    // Children in the CPU's order (rows, then columns), so the sums round the same way.
    for (var y = 2u * cy; y < min(2u * cy + 2u, p.fine_h); y += 1u) {
        for (var x = 2u * cx; x < min(2u * cx + 2u, p.fine_w); x += 1u) {
            let i = fine_index(x, y);
            if (is_fixed(i)) {
                fixed_sum += u[i];
                fixed_n += 1u;
            } else {
                free_sum += u[i];
                free_n += 1u;
            }
        }
    }
    let c = coarse_index(cx, cy);
    if (fixed_n > 0u) {
        atomicOr(&coarse_fixed[c >> 5u], 1u << (c & 31u));
        coarse[c] = fixed_sum / f32(fixed_n);
    } else {
        coarse[c] = free_sum / f32(max(free_n, 1u));
    }
}
