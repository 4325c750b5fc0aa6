// Building the multigrid hierarchy on the GPU: the twin of `restrict_rows` in
// `src/diffusion/multigrid/hierarchy.rs`. Only the finest level is uploaded; each coarser level
// is restricted from the one above it here, level by level.
//
// Constraint-aware restriction of the problem: a coarse cell is fixed when any of its 2 x 2
// children is, and then holds the mean of the fixed children's heights (so rivers and ridges
// stay connected lines on every level); otherwise it starts at the mean of its children. The
// coarse right-hand side of a Laplace problem is zero (its buffer is created zeroed).
//
// Banded levels (`src/diffusion/gpu/bands.rs`) as in `multigrid.wgsl`: coordinates are global,
// the buffers hold rows fine_row0.. (coarse_row0..), and a dispatch covers the parents of the
// fine rows own_start..own_end. Several fine bands may write one coarse buffer, and a word of
// fixed bits may hold cells of two of them: the bits are set with atomicOr into a buffer
// created zeroed.
//
// Entry point (16 x 16 workgroups, one invocation per coarse cell):
//   restrict_problem   coarse fixed bits and u from the fine level's

struct Params {
    fine_w: u32,
    fine_h: u32,
    coarse_w: u32,
    coarse_h: u32,
    colour: u32,
    has_rhs: u32,
    fine_row0: u32,
    coarse_row0: u32,
    own_start: u32,
    own_end: u32,
    sweeps: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> fine_fixed: array<u32>;
@group(0) @binding(2) var<storage, read> fine_u: array<f32>;
@group(0) @binding(3) var<storage, read_write> coarse_fixed: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> coarse_u: array<f32>;

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
            let i = (y - p.fine_row0) * p.fine_w + x;
            if (((fine_fixed[i >> 5u] >> (i & 31u)) & 1u) == 1u) {
                fixed_sum += fine_u[i];
                fixed_n += 1u;
            } else {
                free_sum += fine_u[i];
                free_n += 1u;
            }
        }
    }
    let c = (cy - p.coarse_row0) * p.coarse_w + cx;
    if (fixed_n > 0u) {
        atomicOr(&coarse_fixed[c >> 5u], 1u << (c & 31u));
        coarse_u[c] = fixed_sum / f32(fixed_n);
    } else {
        coarse_u[c] = free_sum / f32(max(free_n, 1u));
    }
}
