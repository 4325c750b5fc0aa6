// Stream-power erosion with uplift, hillslope diffusion and talus on the GPU
// (`src/erosion/gpu.rs` drives these kernels; `src/erosion/` is the CPU reference).
//
//   dh/dt = U - K A^m S^n + kappa lap(h)          (Braun & Willett 2013, eq. 1)
//
// One time step, every kernel one thread per cell on 16 x 16 workgroups:
// 1. `receivers`: the CPU's rule in `flow.rs`: D8 steepest descent, ties to the first
//    direction in D8 order, or (params.random) one lower neighbour drawn in proportion to
//    the slopes (Freeman 1991's weights) from lowbias32(cell ^ route_key), the step's key;
//    base-level cells and pits get NONE; a guided cell (a grown branch, `guide`) its guided
//    neighbour.
// 2. Lakes (Planchon & Darboux 2001): `root_init` + `root_jump` (pointer jumping) find the
//    terminal cell of every flow path; cells whose path ends in a pit start at BIG, the rest
//    at their height, and `lake_pass` lowers the water level W_i towards
//    max(h_i, min_j W_j + eps) (Jacobi, iterated within 16 x 16 tiles in workgroup memory). `lake_apply` fills the cells that found an outlet.
// 3. Drainage area by pointer jumping (`area_init`, `area_jump`): with M the donor-to-
//    receiver matrix (nilpotent on a forest), A = (I - M)^-1 a = prod_k (I + M^(2^k)) a, so
//    log2(cells) passes, each adding every cell's partial sum to the cell 2^k hops downstream
//    (integer cell counts, atomicAdd: exact and deterministic).
// 4. The implicit update h_i' = (h_i + dt U_i + F_i h_r') / (1 + F_i), F_i = K_i dt A^m / L^n
//    (Braun & Willett eq. 22 for n = 1) is the linear recurrence h_i' = b_i + c_i h_r' along
//    the receiver tree, solved by the same pointer jumping (`implicit_init`,
//    `implicit_jump`: b_i += c_i b_p, c_i *= c_p); `implicit_polish` then runs Jacobi passes
//    of the CPU's exact rule (no downhill slope: uplift only; n != 1: Newton).
// 5. `diffuse_red` / `diffuse_black`: red-black over-relaxation (SOR) of backward-Euler
//    diffusion, then two sweeps of `smooth_red` / `smooth_black` (Gauss-Seidel), exactly
//    the CPU's sweeps (`diffusion.rs`).
// 6. `talus_share` + `talus_apply`: the CPU's talus relaxation (`thermal.rs`) in Jacobi form.
// 7. `apply_floor`: no cell below the near-river floor.

struct Params {
    width: u32,
    height: u32,
    // The step's key of the random receivers, and whether they are drawn (1) or steepest (0).
    route_key: u32,
    random: u32,
    // r = kappa dt / cell^2 of the diffusion.
    r: f32,
    // Talus limits of the drop to an axis and to a diagonal neighbour, metres.
    limit_axis: f32,
    limit_diag: f32,
    // Slope exponent n.
    n: f32,
    // K dt / L^n for an axis and a diagonal step; A^m with A = cells * cell_area.
    coef_axis: f32,
    coef_diag: f32,
    cell_area: f32,
    m: f32,
    // Layered rock (`src/erosion/strata.rs`): the beds' period in metres (0: no beds) and
    // the logarithm of the soft beds' erodibility over the hard beds'.
    strata_period: f32,
    strata_ln_contrast: f32,
    // Whether `guide` holds guided receivers (1) or nothing (0).
    guided: u32,
    // The diffusion's over-relaxation factor (`src/erosion/diffusion.rs`).
    omega: f32,
    // The cell's width (m) and the weakening where water gathers (`src/erosion/gathering.rs`):
    // the specific catchment area it starts from (m) and the weakest factor.
    cell: f32,
    gather_from_m: f32,
    gather_weakest: f32,
    pad: f32,
}

const NONE: u32 = 0xffffffffu;
// Larger than any height: "no outlet found yet".
const BIG: f32 = 3.0e38;
const NEWTON_MAX_ITERS: u32 = 40u;

@group(0) @binding(0) var<uniform> params: Params;

// The cell of this invocation, or NONE outside the grid.
fn cell_of(gid: vec3<u32>) -> u32 {
    if (gid.x >= params.width || gid.y >= params.height) {
        return NONE;
    }
    return gid.y * params.width + gid.x;
}

// Neighbour `d` (D8 order of `src/erosion/grid.rs`) of (x, y), or NONE off the map.
fn neighbour(x: u32, y: u32, d: u32) -> u32 {
    let k = select(d, d + 1u, d >= 4u);
    let nx = i32(x) + i32(k % 3u) - 1;
    let ny = i32(y) + i32(k / 3u) - 1;
    if (nx < 0 || ny < 0 || nx >= i32(params.width) || ny >= i32(params.height)) {
        return NONE;
    }
    return u32(ny) * params.width + u32(nx);
}

fn diagonal(d: u32) -> bool {
    return d == 0u || d == 2u || d == 5u || d == 7u;
}

// ---- 1. receivers -------------------------------------------------------------------

@group(0) @binding(1) var<storage, read> base_bits: array<u32>;
@group(0) @binding(2) var<storage, read> heights: array<f32>;
@group(0) @binding(3) var<storage, read_write> receivers_out: array<u32>;
// Guided receivers (`src/erosion/guide.rs`): a D8 code per cell in 4 bits, 8 cells a word,
// 8 where the cell picks its own; read only when params.guided is 1.
@group(0) @binding(4) var<storage, read> guide: array<u32>;

fn is_base(i: u32) -> bool {
    return ((base_bits[i >> 5u] >> (i & 31u)) & 1u) == 1u;
}

@compute @workgroup_size(16, 16, 1)
fn receivers(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    if (is_base(i)) {
        receivers_out[i] = NONE;
        return;
    }
    if (params.guided != 0u) {
        let code = (guide[i >> 3u] >> ((i & 7u) * 4u)) & 15u;
        if (code < 8u) {
            receivers_out[i] = neighbour(gid.x, gid.y, code);
            return;
        }
    }
    let hi = heights[i];
    var best = NONE;
    var steepest = 0.0;
    var slope: array<f32, 8>;
    // Running sums of max(slope, 0) in D8 order: the `max` stands between the slope's
    // product and the add, so no driver fuses them, and the sums are the CPU's bits.
    var running: array<f32, 8>;
    var total = 0.0;
    for (var d = 0u; d < 8u; d++) {
        let j = neighbour(gid.x, gid.y, d);
        var s = 0.0;
        if (j != NONE) {
            s = (hi - heights[j]) * select(1.0, 0.70710678118654752, diagonal(d));
        }
        slope[d] = s;
        total += max(s, 0.0);
        running[d] = total;
        if (s > steepest) {
            steepest = s;
            best = j;
        }
    }
    if (params.random != 0u && best != NONE) {
        // The lower neighbour whose share of the slopes' sum holds u * sum.
        let pick = f32(hash32(i ^ params.route_key) >> 8u) * (1.0 / 16777216.0) * total;
        for (var d = 0u; d < 8u; d++) {
            if (slope[d] > 0.0) {
                best = neighbour(gid.x, gid.y, d);
                if (pick < running[d]) {
                    break;
                }
            }
        }
    }
    receivers_out[i] = best;
}

// Chris Wellons' lowbias32 integer hash (the CPU's `flow::hash32`).
fn hash32(v: u32) -> u32 {
    var x = v;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// ---- pointer jumping (roots and drainage area) ----------------------------------------

@group(0) @binding(1) var<storage, read> ptr_in: array<u32>;
@group(0) @binding(2) var<storage, read_write> ptr_out: array<u32>;

// The terminal cell of each path: itself where there is no receiver.
@compute @workgroup_size(16, 16, 1)
fn root_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let r = ptr_in[i];
    ptr_out[i] = select(r, i, r == NONE);
}

@compute @workgroup_size(16, 16, 1)
fn root_jump(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    ptr_out[i] = ptr_in[ptr_in[i]];
}

// ---- 2. lakes (Planchon & Darboux) ------------------------------------------------------

@group(0) @binding(3) var<storage, read> roots: array<u32>;
@group(0) @binding(4) var<storage, read_write> level_out: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn lake_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    level_out[i] = select(BIG, heights[i], is_base(roots[i]));
}

// The next f32 above `v` (one ulp, as the CPU's Priority-Flood + epsilon), at least 1e-6 m
// higher near zero where GPUs flush denormals.
fn next_up(v: f32) -> f32 {
    let bits = bitcast<u32>(v);
    var up: f32;
    if (v > 0.0) {
        up = bitcast<f32>(bits + 1u);
    } else if (v < 0.0) {
        up = bitcast<f32>(bits - 1u);
    } else {
        up = 1.0e-6;
    }
    return max(up, v + 1.0e-6);
}

@group(0) @binding(2) var<storage, read> lake_heights: array<f32>;
@group(0) @binding(3) var<storage, read> level_in: array<f32>;
@group(0) @binding(4) var<storage, read_write> level_next: array<f32>;

// One global pass: each 16 x 16 tile loads its cells and a one-cell halo into workgroup
// memory and runs LOCAL_ITERS Jacobi iterations of Planchon-Darboux there (the halo held at
// the last global pass's levels), so a level travels up to 16 cells per pass instead of one.
// Deterministic: Jacobi with two buffers in workgroup memory, barriers between iterations.
const TILE_SIDE: u32 = 18u;
const TILE_CELLS: u32 = 324u;
const LOCAL_ITERS: u32 = 24u;
var<workgroup> tile_h: array<f32, 324>;
var<workgroup> tile_w: array<array<f32, 324>, 2>;
var<workgroup> open_count: atomic<u32>;
var<workgroup> open_flag: u32;
var<workgroup> changed_count: atomic<u32>;
var<workgroup> changed_flag: u32;

@compute @workgroup_size(16, 16, 1)
fn lake_pass(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let ox = i32(wid.x * 16u) - 1;
    let oy = i32(wid.y * 16u) - 1;
    for (var t = lid.y * 16u + lid.x; t < TILE_CELLS; t += 256u) {
        let gx = ox + i32(t % TILE_SIDE);
        let gy = oy + i32(t / TILE_SIDE);
        var hv = BIG;
        var wv = BIG;
        if (gx >= 0 && gy >= 0 && gx < i32(params.width) && gy < i32(params.height)) {
            let g = u32(gy) * params.width + u32(gx);
            hv = lake_heights[g];
            wv = level_in[g];
        }
        tile_h[t] = hv;
        tile_w[0][t] = wv;
        tile_w[1][t] = wv;
    }
    workgroupBarrier();
    let gx = wid.x * 16u + lid.x;
    let gy = wid.y * 16u + lid.y;
    let inside = gx < params.width && gy < params.height;
    let k = (lid.y + 1u) * TILE_SIDE + lid.x + 1u;
    let hi = tile_h[k];
    // Most tiles hold no lake: nothing in them can change.
    if (inside && tile_w[0][k] > hi) {
        atomicAdd(&open_count, 1u);
    }
    workgroupBarrier();
    if (lid.x == 0u && lid.y == 0u) {
        open_flag = atomicLoad(&open_count);
    }
    if (workgroupUniformLoad(&open_flag) == 0u) {
        if (inside) {
            level_next[gy * params.width + gx] = tile_w[0][k];
        }
        return;
    }
    // The halo is fixed during a pass, so once an iteration changes no cell of the tile the
    // tile is at its fixed point and the remaining iterations would change nothing: stop
    // (a filled lake keeps its tile open, and most passes find it already settled). Both
    // buffers then hold the fixed point.
    var last = LOCAL_ITERS % 2u;
    for (var it = 0u; it < LOCAL_ITERS; it++) {
        let src = it % 2u;
        let before = tile_w[src][k];
        var w = before;
        if (inside && w > hi) {
            for (var d = 0u; d < 8u; d++) {
                let c = select(d, d + 1u, d >= 4u);
                let kj = (lid.y + c / 3u) * TILE_SIDE + lid.x + c % 3u;
                let wj = tile_w[src][kj];
                if (wj >= BIG) {
                    continue;
                }
                let e = next_up(wj);
                if (hi >= e) {
                    w = hi;
                    break;
                }
                w = min(w, e);
            }
        }
        tile_w[1u - src][k] = w;
        if (w != before) {
            atomicAdd(&changed_count, 1u);
        }
        workgroupBarrier();
        if (lid.x == 0u && lid.y == 0u) {
            changed_flag = atomicExchange(&changed_count, 0u);
        }
        if (workgroupUniformLoad(&changed_flag) == 0u) {
            last = 1u - src;
            break;
        }
    }
    if (inside) {
        level_next[gy * params.width + gx] = tile_w[last][k];
    }
}

@group(0) @binding(1) var<storage, read> level: array<f32>;
@group(0) @binding(2) var<storage, read_write> filled: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn lake_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let w = level[i];
    if (w < BIG) {
        filled[i] = max(filled[i], w);
    }
}

// ---- 3. drainage area -------------------------------------------------------------------

@group(0) @binding(1) var<storage, read> area_receivers: array<u32>;
@group(0) @binding(2) var<storage, read_write> jump_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> cells_out: array<u32>;

@compute @workgroup_size(16, 16, 1)
fn area_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    jump_out[i] = area_receivers[i];
    cells_out[i] = 1u;
}

@group(0) @binding(1) var<storage, read> jump_in: array<u32>;
@group(0) @binding(2) var<storage, read> cells_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> jump_next: array<u32>;
// A copy of `cells_in` before the dispatch.
@group(0) @binding(4) var<storage, read_write> cells_next: array<atomic<u32>>;

@compute @workgroup_size(16, 16, 1)
fn area_jump(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let p = jump_in[i];
    if (p == NONE) {
        jump_next[i] = NONE;
        return;
    }
    atomicAdd(&cells_next[p], cells_in[i]);
    jump_next[i] = jump_in[p];
}

// ---- 4. implicit incision ---------------------------------------------------------------

// start = h + dt U off base level (`uplift` holds dt U).
@group(0) @binding(2) var<storage, read> lift_heights: array<f32>;
@group(0) @binding(3) var<storage, read> uplift_dt: array<f32>;
@group(0) @binding(4) var<storage, read_write> start_out: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn lift(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let h = lift_heights[i];
    start_out[i] = select(h + uplift_dt[i], h, is_base(i));
}

@group(0) @binding(1) var<storage, read> inc_receivers: array<u32>;
@group(0) @binding(2) var<storage, read> inc_cells: array<u32>;
@group(0) @binding(3) var<storage, read> inc_start: array<f32>;
@group(0) @binding(4) var<storage, read_write> coef_out: array<f32>;
@group(0) @binding(5) var<storage, read_write> bc_out: array<vec2<f32>>;
// Each cell's factor on K (rock hardness; 1 where the rock is uniform).
@group(0) @binding(6) var<storage, read> inc_erodibility: array<f32>;

// The beds' hardness at phase `phase` of a period, and its integral from phase 0 to `p`
// (`src/erosion/strata.rs`, with its constants HARD_FRACTION 0.35, EDGE_FRACTION 0.15).
fn strata_hardness(phase: f32) -> f32 {
    return smoothstep(0.0, 0.15, phase) * (1.0 - smoothstep(0.35, 0.5, phase));
}

fn strata_ramp(s: f32) -> f32 {
    let t = clamp(s, 0.0, 1.0);
    return 0.15 * t * t * t * (1.0 - 0.5 * t);
}

fn strata_integral(p: f32) -> f32 {
    let falling = clamp(p - 0.35, 0.0, 0.15);
    return strata_ramp(p / 0.15) + max(min(p, 0.35) - 0.15, 0.0) + falling
        - strata_ramp(falling / 0.15);
}

// The factor on K of cell `i` at height `h` (its start height): the CPU's
// `Strata::factor_of_cell`, the mean hardness of the beds its neighbourhood exposes, from its
// lowest neighbour within two cells to its highest, at the start of the step.
fn strata_factor(i: u32, h: f32) -> f32 {
    if (params.strata_period <= 0.0) {
        return 1.0;
    }
    let x = i32(i % params.width);
    let y = i32(i / params.width);
    var lowest = h;
    var highest = h;
    // The neighbours within two cells (the CPU's REACH).
    for (var ny = max(y - 2, 0); ny <= min(y + 2, i32(params.height) - 1); ny++) {
        for (var nx = max(x - 2, 0); nx <= min(x + 2, i32(params.width) - 1); nx++) {
            let z = inc_start[u32(ny) * params.width + u32(nx)];
            lowest = min(lowest, z);
            highest = max(highest, z);
        }
    }
    let lo = lowest;
    let hi = highest;
    var a = lo / params.strata_period;
    var b = hi / params.strata_period;
    var hard: f32;
    if (b - a > 1.0e-3) {
        let first = floor(a);
        a = a - first;
        b = b - first;
        let whole = floor(b);
        hard = (whole * 0.35 + strata_integral(b - whole) - strata_integral(a)) / (b - a);
    } else {
        let t = 0.5 * (lo + hi) / params.strata_period;
        hard = strata_hardness(t - floor(t));
    }
    return exp(params.strata_ln_contrast * (0.5 - hard));
}

// Receiver of `i` as a D8 direction, found from the indices (8 if none).
fn direction(i: u32, r: u32) -> u32 {
    let w = params.width;
    let dx = i32(r % w) - i32(i % w);
    let dy = i32(r / w) - i32(i / w);
    let k = u32((dy + 1) * 3 + (dx + 1));
    return select(k, k - 1u, k > 4u);
}

@compute @workgroup_size(16, 16, 1)
fn implicit_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let r = inc_receivers[i];
    let hi = inc_start[i];
    if (r == NONE) {
        coef_out[i] = 0.0;
        bc_out[i] = vec2<f32>(hi, 0.0);
        return;
    }
    let a = f32(inc_cells[i]) * params.cell_area;
    let diag = diagonal(direction(i, r));
    let f = select(params.coef_axis, params.coef_diag, diag) * pow(a, params.m)
        * inc_erodibility[i] * strata_factor(i, hi);
    coef_out[i] = f;
    // n != 1: F linearised around the slope at the start of the step (Picard).
    var fl = f;
    if (params.n != 1.0) {
        let len = select(1.0, 1.41421356237309505, diag);
        let s = max(hi - inc_start[r], 1.0e-3) / len;
        fl = f * pow(s, params.n - 1.0);
    }
    let damp = 1.0 / (1.0 + fl);
    bc_out[i] = vec2<f32>(hi * damp, fl * damp);
}

@group(0) @binding(1) var<storage, read> bc_ptr_in: array<u32>;
@group(0) @binding(2) var<storage, read> bc_in: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> bc_ptr_out: array<u32>;
@group(0) @binding(4) var<storage, read_write> bc_next: array<vec2<f32>>;

@compute @workgroup_size(16, 16, 1)
fn implicit_jump(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let p = bc_ptr_in[i];
    let bc = bc_in[i];
    if (p == NONE) {
        bc_ptr_out[i] = NONE;
        bc_next[i] = bc;
        return;
    }
    let q = bc_in[p];
    bc_next[i] = vec2<f32>(bc.x + bc.y * q.x, bc.y * q.y);
    bc_ptr_out[i] = bc_ptr_in[p];
}

@group(0) @binding(1) var<storage, read> bc_done: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> solved: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn implicit_take(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    solved[i] = bc_done[i].x;
}

// x - c + f x^n = 0 for x in (0, c] (the CPU's `newton` in `stream_power.rs`).
fn newton(c: f32, f: f32, n: f32) -> f32 {
    var lo = 0.0;
    var hi = c;
    var x = c;
    for (var it = 0u; it < NEWTON_MAX_ITERS; it++) {
        let xn1 = pow(x, n - 1.0);
        let g = x - c + f * xn1 * x;
        if (g > 0.0) {
            hi = x;
        } else {
            lo = x;
        }
        let dg = 1.0 + n * f * xn1;
        var next = x - g / dg;
        if (!(next > lo && next < hi)) {
            next = 0.5 * (lo + hi);
        }
        let done = abs(next - x) <= 1.0e-7 * c;
        x = next;
        if (done) {
            break;
        }
    }
    return x;
}

@group(0) @binding(1) var<storage, read> pol_start: array<f32>;
@group(0) @binding(2) var<storage, read> pol_coef: array<f32>;
@group(0) @binding(3) var<storage, read> pol_receivers: array<u32>;
@group(0) @binding(4) var<storage, read> pol_in: array<f32>;
@group(0) @binding(5) var<storage, read_write> pol_out: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn implicit_polish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let hi = pol_start[i];
    let r = pol_receivers[i];
    let f = pol_coef[i];
    if (r == NONE || f == 0.0) {
        pol_out[i] = hi;
        return;
    }
    let hr = pol_in[r];
    if (hi <= hr) {
        pol_out[i] = hi; // no downhill slope: uplift only
    } else if (params.n == 1.0) {
        pol_out[i] = hr + (hi - hr) * (1.0 / (1.0 + f));
    } else {
        pol_out[i] = hr + newton(hi - hr, f, params.n);
    }
}

// ---- 5. hillslope diffusion -------------------------------------------------------------

@group(0) @binding(2) var<storage, read> rhs: array<f32>;
@group(0) @binding(3) var<storage, read_write> diffused: array<f32>;

// One colour of a sweep: over-relaxed by `params.omega`, or plain Gauss-Seidel (the last
// two sweeps, `diffusion.rs`).
fn diffuse(gid: vec3<u32>, colour: u32, over_relaxed: bool) {
    let i = cell_of(gid);
    if (i == NONE || ((gid.x + gid.y) & 1u) != colour || is_base(i)) {
        return;
    }
    let w = params.width;
    let r = params.r;
    var sum = 0.0;
    var k = 0.0;
    // Up, left, right, down: the CPU's order.
    if (gid.y > 0u) {
        sum += diffused[i - w];
        k += 1.0;
    }
    if (gid.x > 0u) {
        sum += diffused[i - 1u];
        k += 1.0;
    }
    if (gid.x + 1u < w) {
        sum += diffused[i + 1u];
        k += 1.0;
    }
    if (gid.y + 1u < params.height) {
        sum += diffused[i + w];
        k += 1.0;
    }
    let gauss_seidel = (rhs[i] + r * sum) * (1.0 / (1.0 + r * k));
    if (over_relaxed) {
        diffused[i] = diffused[i] + params.omega * (gauss_seidel - diffused[i]);
    } else {
        diffused[i] = gauss_seidel;
    }
}

@compute @workgroup_size(16, 16, 1)
fn diffuse_red(@builtin(global_invocation_id) gid: vec3<u32>) {
    diffuse(gid, 0u, true);
}

@compute @workgroup_size(16, 16, 1)
fn diffuse_black(@builtin(global_invocation_id) gid: vec3<u32>) {
    diffuse(gid, 1u, true);
}

@compute @workgroup_size(16, 16, 1)
fn smooth_red(@builtin(global_invocation_id) gid: vec3<u32>) {
    diffuse(gid, 0u, false);
}

@compute @workgroup_size(16, 16, 1)
fn smooth_black(@builtin(global_invocation_id) gid: vec3<u32>) {
    diffuse(gid, 1u, false);
}

// ---- 6. talus ---------------------------------------------------------------------------

@group(0) @binding(2) var<storage, read> talus_heights: array<f32>;
@group(0) @binding(3) var<storage, read_write> share_out: array<f32>;

fn limit(d: u32) -> f32 {
    return select(params.limit_axis, params.limit_diag, diagonal(d));
}

// Half the largest excess drop of free cell (x, y) over the talus (0 if none), and the sum
// of its positive excesses.
fn excess(x: u32, y: u32) -> vec2<f32> {
    let i = y * params.width + x;
    let hi = talus_heights[i];
    var most = 0.0;
    var total = 0.0;
    for (var d = 0u; d < 8u; d++) {
        let j = neighbour(x, y, d);
        if (j == NONE) {
            continue;
        }
        let e = hi - talus_heights[j] - limit(d);
        if (e > 0.0) {
            most = max(most, e);
            total += e;
        }
    }
    return vec2<f32>(0.5 * most, total);
}

// share_i = moved_i / total_i: neighbour j gets share_i * e_ij.
@compute @workgroup_size(16, 16, 1)
fn talus_share(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    if (is_base(i)) {
        share_out[i] = 0.0;
        return;
    }
    let e = excess(gid.x, gid.y);
    share_out[i] = select(0.0, e.x / e.y, e.x > 0.0);
}

@group(0) @binding(3) var<storage, read> share_in: array<f32>;
@group(0) @binding(4) var<storage, read_write> talus_out: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn talus_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let hi = talus_heights[i];
    if (is_base(i)) {
        talus_out[i] = hi; // what reaches base level leaves the map
        return;
    }
    var h = hi - excess(gid.x, gid.y).x;
    for (var d = 0u; d < 8u; d++) {
        let j = neighbour(gid.x, gid.y, d);
        if (j == NONE) {
            continue;
        }
        let s = share_in[j];
        let e = talus_heights[j] - hi - limit(d);
        if (s > 0.0 && e > 0.0) {
            h += s * e;
        }
    }
    talus_out[i] = h;
}

// ---- 7. the near-river floor ------------------------------------------------------------

@group(0) @binding(1) var<storage, read> floor_in: array<f32>;
@group(0) @binding(2) var<storage, read_write> floored: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn apply_floor(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    floored[i] = max(floored[i], floor_in[i]);
}

// ---- 4b. the threshold-slope limit -----------------------------------------------------
// The CPU's `slope_limit.rs` in Jacobi form: each pass lowers every free cell to
// min_j (h_j + strength_i tan(talus) |x_i - x_j|) over the 8 neighbours and the 8 knight's moves (the
// 5 x 5 mask), reading one buffer and writing the other. The CPU's two raster scans carry a
// cut across the whole map in one step; a pass here carries it two cells, so the host runs
// a bounded number a step (LIMIT_PASSES) and the steps after go on from there.

@group(0) @binding(2) var<storage, read> lim_in: array<f32>;
@group(0) @binding(3) var<storage, read_write> lim_out: array<f32>;
// Each cell's rock strength: its factor on the talus slope's tangent (1: the talus angle).
@group(0) @binding(4) var<storage, read> lim_strength: array<f32>;
// The step's drainage area in cells (`area_jump`'s result).
@group(0) @binding(5) var<storage, read> lim_cells: array<u32>;

// The factor on the strength where water gathers (`gathering::factor`): the specific
// catchment area a = A / cell = cells * cell past `gather_from_m`, to the fourth root, never
// under `gather_weakest`.
fn gathering(cells: u32) -> f32 {
    let ratio = f32(cells) * params.cell / params.gather_from_m;
    if (ratio <= 1.0) {
        return 1.0;
    }
    return max(1.0 / sqrt(sqrt(ratio)), params.gather_weakest);
}

@compute @workgroup_size(16, 16, 1)
fn slope_limit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = cell_of(gid);
    if (i == NONE) {
        return;
    }
    let h = lim_in[i];
    if (is_base(i)) {
        lim_out[i] = h;
        return;
    }
    // limit_axis = tan(talus) * cell; the knight's move is sqrt(5) cells.
    let knight = params.limit_axis * 2.2360679774997897;
    let strength = lim_strength[i] * gathering(lim_cells[i]);
    var cap = h;
    for (var dy = -2; dy <= 2; dy++) {
        for (var dx = -2; dx <= 2; dx++) {
            let ax = abs(dx);
            let ay = abs(dy);
            // The 5 x 5 mask: the 8 neighbours and the 8 knight's moves.
            if ((ax == 0 && ay == 0) || (ax == 2 && ay != 1) || (ay == 2 && ax != 1)) {
                continue;
            }
            let nx = i32(gid.x) + dx;
            let ny = i32(gid.y) + dy;
            if (nx < 0 || ny < 0 || nx >= i32(params.width) || ny >= i32(params.height)) {
                continue;
            }
            var rise = params.limit_axis;
            if (ax + ay == 2) {
                rise = params.limit_diag;
            } else if (ax + ay == 3) {
                rise = knight;
            }
            cap = min(cap, lim_in[u32(ny) * params.width + u32(nx)] + rise * strength);
        }
    }
    lim_out[i] = cap;
}
