//! The erosion solver on the GPU (`shaders/erosion.wgsl`): the same equation and time steps
//! as [`Eroder`](super::Eroder), parallel per cell in the spirit of Schott et al. (2023),
//! "Large-scale terrain authoring through interactive erosion simulation", ACM TOG 42(5).
//!
//! One step (all on the GPU, no readback; the host only records dispatches):
//! 1. **Receivers**: the CPU's rule (`flow.rs`) with the same `f32` slopes, so the same
//!    heights give the same receivers: D8 steepest descent (ties to the first direction in
//!    D8 order, strict descent), or, with a seed, one lower neighbour drawn in proportion
//!    to the slopes from the same hash of the seed, the step and the cell.
//! 2. **Lakes**: where a flow path ends in a pit (found by pointer jumping to each path's
//!    terminal cell), the water level is found by Planchon & Darboux (2001), "A fast, simple
//!    and versatile algorithm to fill the depressions of digital elevation models", Catena
//!    46: W = h where the path reaches base level, W = +inf in the pits' catchments, then
//!    parallel passes `W_i = max(h_i, min_j W_j + eps)`, eps one `f32` ulp as the CPU's
//!    Priority-Flood + epsilon. Every finite W has a strictly descending path to base level
//!    at every pass, so a bounded number of passes ([`LAKE_PASSES`], each iterating
//!    within 16 x 16 tiles in workgroup memory so that a level crosses a tile per pass) is
//!    safe: a lake whose
//!    level is not found by then stays a pit for this step (a local sink, as if it were
//!    dry), and the next step tries again. The lakes found are filled (instant
//!    sedimentation, as on the CPU) and receivers are recomputed.
//! 3. **Drainage area** to convergence every step, not carried over from the previous step
//!    with a few propagation passes as Schott et al. do: their steps are short (interactive
//!    rates), ours are the preset's 20 steps of 10^4-10^5 years, and drainage carried with k
//!    passes per step would travel only k cells per step. Instead of the O(path length)
//!    Jacobi propagation `A_i = a + sum_donors A_j` we use pointer jumping: with `M` the
//!    donor-to-receiver matrix (nilpotent on the receiver forest),
//!    `A = (I - M)^-1 a = prod_k (I + M^(2^k)) a`, so `ceil(log2 cells)` passes, each adding
//!    every cell's partial sum to the cell `2^k` hops downstream. Areas are integer cell
//!    counts summed with `atomicAdd`: exact, and the same on every run.
//! 4. **Incision**, the implicit stream-power update of Braun & Willett (2013), eq. 22 for
//!    `n = 1`: `h_i' = (h_i + dt U_i + F_i h_r') / (1 + F_i)`, `F_i = K dt A_i^m / L_ir`.
//!    This is the linear recurrence `h_i' = b_i + c_i h_r'` along the receiver tree, which
//!    the CPU solves in stack order; here it is solved by the same pointer jumping (`b_i +=
//!    c_i b_p`, `c_i *= c_p`), exact in `log2` passes where Jacobi iteration of the update
//!    would need as many passes as the longest river is long (its contraction `F / (1 + F)`
//!    is close to 1 on channels). [`POLISH_PASSES`] Jacobi passes of the CPU's exact rule
//!    follow: a cell whose receiver ends higher gets its uplift only, and for `n != 1` (where
//!    the jumping uses `F` linearised around the step's initial slope) Newton's method.
//! 5. **Hillslope diffusion**: the CPU's red-black over-relaxation sweeps of backward Euler,
//!    one dispatch per colour (a colour's cells are independent); the last step's covers
//!    half the step, as the CPU's (`diffusion::Creep`: the step's `r` and `omega` go in the
//!    parameters written before each step).
//! 6. **Talus**: the CPU's relaxation in Jacobi form (every cell sheds half its largest
//!    excess at once and gathers what its neighbours shed): the CPU updates in place in scan
//!    order, which is sequential.
//! 7. The near-river floor.
//! 8. After the last step only, the threshold-slope limit's passes once more, as the CPU
//!    solver ends (its last pass, `mod.rs`).
//!
//! After the last step the heights and the last step's drainage area are read back once, as
//! the CPU solver leaves them; the erosion stage then conditions the surface
//! (Priority-Flood + epsilon of the basins of any pit left, as after the CPU solver), so its
//! guarantees (no pit, every cell reaching an outlet) hold whatever the GPU's lakes left.
//!
//! 4b. **Threshold-slope limit** (with a talus angle): the CPU's `slope_limit.rs` in Jacobi
//!    form, [`LIMIT_PASSES`] passes a step over the same 5 x 5 mask and the same rock
//!    strength factors (`slope_limit.rs`' [`super::SlopeStrength`]), weakened where water
//!    gathers by the step's drainage area as on the CPU (`gathering.rs`, the same factor).
//!    The CPU's two raster scans carry a cut across the whole map in one step; the passes
//!    carry it 32 cells a step, and the following steps go on, so a slope left steeper
//!    after the last step is one the CPU would have cut farther than 16 cells from where it
//!    started.
//!
//! Why it is not bit-exact with the CPU: talus and the slope limit in Jacobi form, `f32` on the GPU where the
//! CPU's incision works in `f64`, the tree solved in another order (other rounding), lakes
//! filled by bounded passes; a different bit can flip a receiver at a near-tie, and then
//! the drainage network (and the valleys it carves) differs locally.
//!
//! Memory: 16 four-byte fields per cell on the GPU (about 64 MiB at 1024^2).

use wgpu::util::DeviceExt;

use super::diffusion::Creep;
use super::flow::step_key;
use super::params::ErosionParams;
use super::thermal::THERMAL_PASSES;
use super::{ErosionError, check_finite, check_grid, check_len};
use crate::gpu::{
    GpuContext, GpuError, GpuField, Shader, read_bytes, read_f32_buffer, wait_for_submitted_work,
};
use crate::jobs::{Cancelled, JobCtx};

/// The erosion kernels, built once per device by [`GpuContext::pipelines`].
pub(super) const EROSION: Shader = Shader {
    name: "erosion.wgsl",
    source: include_str!("../../shaders/erosion.wgsl"),
};

/// Entry points of `shaders/erosion.wgsl`, in the order [`Kernels`] takes them.
const ENTRIES: [&str; 21] = [
    "receivers",
    "root_init",
    "root_jump",
    "lake_init",
    "lake_pass",
    "lake_apply",
    "area_init",
    "area_jump",
    "lift",
    "implicit_init",
    "implicit_jump",
    "implicit_take",
    "implicit_polish",
    "diffuse_red",
    "diffuse_black",
    "talus_share",
    "talus_apply",
    "apply_floor",
    "slope_limit",
    "smooth_red",
    "smooth_black",
];

/// Planchon–Darboux passes per step for the lakes, each 24 iterations within 16 x 16 tiles
/// (a level crosses up to 16 cells of a tile per pass, one tile border per pass): lakes
/// whose level takes more stay pits for the step.
pub const LAKE_PASSES: u32 = 32;
/// Jacobi passes of the exact incision rule after the pointer-jumping solve.
pub const POLISH_PASSES: u32 = 4;
/// Jacobi passes of the threshold-slope limit a step (even: the last writes the heights).
/// Each carries a cut two cells, 32 a step; the CPU's raster scans carry it across the map.
/// With 8 (16 cells a step) the young mountains on a 192^2 real scene stood 1.1% of their
/// relief from the CPU's on the mean at a strength spread of 0.3 and 1.65% at 0.5, where
/// rock failing at lower angles makes longer cuts; with 16, 0.83% at 0.5.
pub const LIMIT_PASSES: u32 = 16;

const WORKGROUP: u32 = 16;

/// Why the GPU solver failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuErosionError {
    #[error("{0}")]
    Input(#[from] ErosionError),
    #[error("{0}")]
    Gpu(#[from] GpuError),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
}

/// What the GPU solver is given (as [`Eroder::new`](super::Eroder::new) and
/// [`Eroder::with_floor`](super::Eroder::with_floor)).
#[derive(Clone, Copy, Debug)]
pub struct GpuInput<'a> {
    pub heights: &'a [f32],
    pub width: usize,
    pub height: usize,
    pub cell_m: f64,
    pub base_level: &'a [bool],
    /// Uplift rate, m/yr (empty: none).
    pub uplift: &'a [f32],
    /// Heights no cell is lowered below after each step, or none.
    pub floor: Option<&'a [f32]>,
    pub params: ErosionParams,
    /// The random receivers' seed ([`Eroder::with_seed`](super::Eroder::with_seed)); `None`:
    /// steepest descent.
    pub seed: Option<u64>,
    /// Each cell's factor on the erodibility
    /// ([`Eroder::with_erodibility`](super::Eroder::with_erodibility)); empty: uniform rock.
    pub erodibility: &'a [f32],
    /// Beds of hard and soft rock ([`Eroder::with_strata`](super::Eroder::with_strata));
    /// `None`: no beds.
    pub strata: Option<super::Strata>,
    /// Each cell's factor on the talus slope's tangent
    /// ([`Eroder::with_slope_limit`](super::Eroder::with_slope_limit)); empty: 1.
    pub strength: &'a [f32],
    /// Whether the last step's pits are filled on the GPU, from the map's border. False where
    /// water also leaves the map inside it (a river mouth): the border-seeded flood would
    /// fill that catchment, so the caller's conditioning fills the pits instead.
    pub fill_pits: bool,
    /// Guided receivers ([`Eroder::with_guide`](super::Eroder::with_guide)): a D8 code per
    /// cell, 8 where the cell picks its own; empty: none.
    pub guide: &'a [u8],
}

/// The GPU solver's result: the heights after the last step with the pits it left (lakes
/// the bounded lake passes did not fill, hillslopes that closed a basin) filled on the GPU
/// (the bits [`crate::terrain::drainage::fill_depressions`] gives, what the stage's
/// conditioning does after the CPU solver), and the drainage area the last step routed.
#[derive(Clone, Debug)]
pub struct GpuEroded {
    pub heights: Vec<f32>,
    /// Drainage area (m^2) of the last step's routing.
    pub area: Vec<f32>,
    /// What the filling raised (`None` when it was left to the CPU: a flood that did not
    /// settle in its passes).
    pub conditioning: Option<crate::terrain::drainage::Conditioning>,
    /// Milliseconds on the GPU side: upload, steps, the two readbacks.
    pub gpu_ms: f64,
    /// `heights`, still on the GPU (what the next GPU stage reads instead of an upload).
    pub on_gpu: GpuField,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    /// The step's routing key ([`step_key`]) and whether receivers are drawn (1) or the
    /// steepest (0).
    route_key: u32,
    random: u32,
    r: f32,
    limit_axis: f32,
    limit_diag: f32,
    n: f32,
    coef_axis: f32,
    coef_diag: f32,
    cell_area: f32,
    m: f32,
    /// Layered rock ([`super::Strata`]): the beds' period in metres (0: no beds) and the
    /// logarithm of their contrast.
    strata_period: f32,
    strata_ln_contrast: f32,
    /// Whether the guide buffer holds guided receivers (1) or nothing (0).
    guided: u32,
    /// The step's diffusion's over-relaxation factor
    /// ([`Diffusion::omega`](super::diffusion::Diffusion::omega)).
    omega: f32,
    /// The cell's width (m) and the weakening where water gathers
    /// ([`super::gathering::FROM_M`], [`super::gathering::WEAKEST`]).
    cell: f32,
    gather_from_m: f32,
    gather_weakest: f32,
    /// Pads the parameters to a whole number of 16 bytes.
    pad: f32,
}

/// The guided receivers' codes packed for the `receivers` kernel: 4 bits a cell, 8 cells a
/// word, cell `i` in bits `4 (i % 8)..`; one word of nothing when there is no guide.
fn pack_guide(guide: &[u8]) -> Vec<u32> {
    if guide.is_empty() {
        return vec![0];
    }
    guide
        .chunks(8)
        .map(|codes| {
            codes
                .iter()
                .enumerate()
                .fold(0u32, |w, (k, c)| w | u32::from(*c & 15) << (4 * k))
        })
        .collect()
}

/// Whether `gpu` can hold the solver's fields for a `width` x `height` grid: its widest
/// field (`b`, `c` of the implicit update) has 8 bytes per cell, as many as a `f32` field of
/// twice the rows, and its kernels bind up to 6 storage buffers.
pub fn fits(gpu: &GpuContext, width: usize, height: usize) -> bool {
    gpu.caps.fits_field(width, height.saturating_mul(2))
        && gpu.caps.max_storage_buffers_per_shader_stage >= 6
}

/// Builds the erosion kernels on `gpu` now (later calls cost a few map lookups).
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&EROSION, ENTRIES).await.map(|_| ())
}

/// Runs all `params.steps` steps on `gpu` and reads the result back; see the module
/// docs. Inputs are validated as in [`Eroder::new`](super::Eroder::new).
pub async fn erode(
    gpu: &GpuContext,
    input: GpuInput<'_>,
    ctx: &JobCtx,
) -> Result<GpuEroded, GpuErosionError> {
    erode_with(gpu, input, ctx, None).await
}

/// The phases of a step, as [`profile`] times them.
pub const PHASES: [&str; 7] = [
    "receivers",
    "lakes",
    "area",
    "incision",
    "diffusion",
    "talus",
    "floor",
];

/// [`erode`] with every phase of every step submitted on its own and waited for, so the
/// wall time of each phase (summed over the steps, milliseconds, in [`PHASES`]' order) can
/// be read (`strahler bench erosion --phases`). Slower than [`erode`]: for finding where
/// the time goes, not for use.
pub async fn profile(
    gpu: &GpuContext,
    input: GpuInput<'_>,
) -> Result<(GpuEroded, [f64; 7]), GpuErosionError> {
    let mut times = [0.0; 7];
    let out = erode_with(gpu, input, &JobCtx::detached(), Some(&mut times)).await?;
    Ok((out, times))
}

/// Submits what `encoder` holds, waits for it and adds the wall time since `clock` to `slot`
/// (profiling only). The step's error scope is closed before the wait and opened again
/// after it, so no scope stays open while other work may push its own.
async fn flush(
    gpu: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    clock: &mut web_time::Instant,
    slot: &mut f64,
    scope: &mut Option<wgpu::ErrorScopeGuard>,
) -> Result<(), GpuError> {
    let done = std::mem::replace(
        encoder,
        gpu.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("erosion step"),
            }),
    );
    gpu.submit(done.finish());
    close(scope.take()).await?;
    wait_for_submitted_work(gpu).await?;
    *slot += clock.elapsed().as_secs_f64() * 1e3;
    *clock = web_time::Instant::now();
    *scope = Some(gpu.device.push_error_scope(wgpu::ErrorFilter::Validation));
    Ok(())
}

/// Pops `scope`, if open, a validation error becoming a [`GpuError`].
async fn close(scope: Option<wgpu::ErrorScopeGuard>) -> Result<(), GpuError> {
    match scope {
        Some(scope) => match scope.pop().await {
            Some(err) => Err(GpuError::Validation(err.to_string())),
            None => Ok(()),
        },
        None => Ok(()),
    }
}

async fn erode_with(
    gpu: &GpuContext,
    input: GpuInput<'_>,
    ctx: &JobCtx,
    mut profile: Option<&mut [f64; 7]>,
) -> Result<GpuEroded, GpuErosionError> {
    let clock = web_time::Instant::now();
    let GpuInput {
        heights,
        width: w,
        height: h,
        cell_m,
        base_level,
        uplift,
        floor,
        params: p,
        seed,
        erodibility,
        strata,
        strength,
        fill_pits,
        guide,
    } = input;
    let grid = check_grid(w, h, cell_m)?;
    let n = grid.len();
    check_len("heights", heights.len(), n)?;
    check_len("base_level", base_level.len(), n)?;
    if !uplift.is_empty() {
        check_len("uplift", uplift.len(), n)?;
    }
    check_finite("heights", heights)?;
    check_finite("uplift", uplift)?;
    if let Some(f) = floor {
        check_len("floor", f.len(), n)?;
        check_finite("floor", f)?;
    }
    super::check_factors("erodibility", erodibility, n)?;
    super::check_factors("slope strength", strength, n)?;
    if !guide.is_empty() {
        check_len("guide", guide.len(), n)?;
    }
    p.validate()
        .map_err(|(field, problem)| ErosionError::InvalidParam { field, problem })?;
    if !base_level.contains(&true) {
        return Err(ErosionError::NoBaseLevel.into());
    }
    gpu.check_compute()?;
    if !fits(gpu, w, h) {
        return Err(GpuError::TooLarge {
            width: w,
            height: h,
            bytes: n as u64 * 8,
            limit: gpu.caps.max_storage_bytes(),
        }
        .into());
    }

    let k = gpu.pipelines(&EROSION, ENTRIES).await?;
    let device = &gpu.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);

    let dt = p.years / f64::from(p.steps);
    let creep = Creep::new(p.diffusivity * dt / (cell_m * cell_m), p.steps);
    let tan = p.talus_deg.map_or(0.0, |t| t.to_radians().tan());
    let kdt = p.erodibility * dt;
    let uniform = Params {
        width: w as u32,
        height: h as u32,
        route_key: 0,
        random: u32::from(seed.is_some()),
        r: creep.of_step(0).r(),
        limit_axis: (tan * cell_m) as f32,
        limit_diag: (tan * std::f64::consts::SQRT_2 * cell_m) as f32,
        n: p.n as f32,
        coef_axis: (kdt / cell_m.powf(p.n)) as f32,
        coef_diag: (kdt / (std::f64::consts::SQRT_2 * cell_m).powf(p.n)) as f32,
        cell_area: (cell_m * cell_m) as f32,
        m: p.m as f32,
        strata_period: strata.map_or(0.0, |s| s.period_m),
        strata_ln_contrast: strata.map_or(0.0, |s| s.ln_contrast),
        guided: u32::from(!guide.is_empty()),
        omega: creep.of_step(0).omega(),
        cell: cell_m as f32,
        gather_from_m: super::gathering::FROM_M,
        gather_weakest: super::gathering::WEAKEST,
        pad: 0.0,
    };
    let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let rw =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let empty = |label: &str, bytes_per_cell: u64| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: n as u64 * bytes_per_cell,
            usage: rw,
            mapped_at_creation: false,
        })
    };
    let params = init(
        "erosion params",
        bytemuck::bytes_of(&uniform),
        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    );
    let mut words = vec![0u32; n.div_ceil(32)];
    for (i, _) in base_level.iter().enumerate().filter(|(_, b)| **b) {
        words[i / 32] |= 1 << (i % 32);
    }
    let base = init(
        "base level",
        bytemuck::cast_slice(&words),
        wgpu::BufferUsages::STORAGE,
    );
    let heights_buf = init("heights", bytemuck::cast_slice(heights), rw);
    // No uplift: a zeroed buffer (wgpu zeroes new buffers), nothing to upload.
    let uplift_buf = if uplift.is_empty() {
        empty("uplift dt", 4)
    } else {
        let uplift_dt: Vec<f32> = uplift.iter().map(|u| (f64::from(*u) * dt) as f32).collect();
        init("uplift dt", bytemuck::cast_slice(&uplift_dt), rw)
    };
    let floor_buf = floor.map(|f| init("floor", bytemuck::cast_slice(f), rw));
    // Uniform rock, one talus angle: factors of 1.
    let ones = if erodibility.is_empty() || strength.is_empty() {
        vec![1.0f32; n]
    } else {
        Vec::new()
    };
    let erodibility = if erodibility.is_empty() {
        &ones
    } else {
        erodibility
    };
    let erodibility_buf = init("erodibility", bytemuck::cast_slice(erodibility), rw);
    let strength = if strength.is_empty() { &ones } else { strength };
    let strength_buf = init("slope strength", bytemuck::cast_slice(strength), rw);
    let guide_buf = init(
        "guide",
        bytemuck::cast_slice(&pack_guide(guide)),
        wgpu::BufferUsages::STORAGE,
    );
    let rcv = empty("receivers", 4);
    let ptr = [empty("jump a", 4), empty("jump b", 4)];
    let cells = [empty("cells a", 4), empty("cells b", 4)];
    let level = [empty("level a", 4), empty("level b", 4)];
    let start = empty("start", 4);
    let tmp = empty("scratch", 4);
    let coef = empty("coef", 4);
    let bc = [empty("bc a", 8), empty("bc b", 8)];

    // Every kernel reads the parameters at binding 0.
    let b = |pipe: usize, entries: &[(u32, &wgpu::Buffer)]| -> wgpu::BindGroup {
        let all: Vec<(u32, &wgpu::Buffer)> = std::iter::once((0, &params))
            .chain(entries.iter().copied())
            .collect();
        crate::gpu::bind_buffers(device, &k[pipe], ENTRIES[pipe], &all)
    };
    // Bind groups, built once for the whole run.
    let g_receivers = b(
        0,
        &[(1, &base), (2, &heights_buf), (3, &rcv), (4, &guide_buf)],
    );
    let g_root_init = b(1, &[(1, &rcv), (2, &ptr[0])]);
    let g_root_jump = [0, 1].map(|s| b(2, &[(1, &ptr[s]), (2, &ptr[1 - s])]));
    let levels = levels(n);
    let root = (levels % 2) as usize; // where the roots end up
    let g_lake_init = b(
        3,
        &[
            (1, &base),
            (2, &heights_buf),
            (3, &ptr[root]),
            (4, &level[0]),
        ],
    );
    let g_lake_pass =
        [0, 1].map(|s| b(4, &[(2, &heights_buf), (3, &level[s]), (4, &level[1 - s])]));
    let lake_last = (LAKE_PASSES % 2) as usize;
    let g_lake_apply = b(5, &[(1, &level[lake_last]), (2, &heights_buf)]);
    let g_area_init = b(6, &[(1, &rcv), (2, &ptr[0]), (3, &cells[0])]);
    let g_area_jump = [0, 1].map(|s| {
        b(
            7,
            &[
                (1, &ptr[s]),
                (2, &cells[s]),
                (3, &ptr[1 - s]),
                (4, &cells[1 - s]),
            ],
        )
    });
    // Pointer jumping starts in buffer 0 and ends in buffer `levels % 2`.
    let area_last = (levels % 2) as usize;
    let g_lift = b(
        8,
        &[(1, &base), (2, &heights_buf), (3, &uplift_buf), (4, &start)],
    );
    let g_implicit_init = b(
        9,
        &[
            (1, &rcv),
            (2, &cells[area_last]),
            (3, &start),
            (4, &coef),
            (5, &bc[0]),
            (6, &erodibility_buf),
        ],
    );
    let g_implicit_jump = [0, 1].map(|s| {
        b(
            10,
            &[(1, &ptr[s]), (2, &bc[s]), (3, &ptr[1 - s]), (4, &bc[1 - s])],
        )
    });
    let g_implicit_take = b(11, &[(1, &bc[area_last]), (2, &heights_buf)]);
    let g_polish = b(
        12,
        &[
            (1, &start),
            (2, &coef),
            (3, &rcv),
            (4, &heights_buf),
            (5, &tmp),
        ],
    );
    let g_diffuse = [13, 14].map(|e| b(e, &[(1, &base), (2, &start), (3, &heights_buf)]));
    let g_smooth = [19, 20].map(|e| b(e, &[(1, &base), (2, &start), (3, &heights_buf)]));
    let g_talus_share = b(15, &[(1, &base), (2, &heights_buf), (3, &tmp)]);
    let g_talus_apply = b(16, &[(1, &base), (2, &heights_buf), (3, &tmp), (4, &coef)]);
    let g_floor = floor_buf
        .as_ref()
        .map(|f| b(17, &[(1, f), (2, &heights_buf)]));
    // The slope limit reads one of the heights and `tmp` and writes the other; it weakens
    // the rock's strength by the step's drainage area (the cells it counts).
    let g_limit = [(&heights_buf, &tmp), (&tmp, &heights_buf)].map(|(from, to)| {
        b(
            18,
            &[
                (1, &base),
                (2, from),
                (3, to),
                (4, &strength_buf),
                (5, &cells[area_last]),
            ],
        )
    });
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }

    let groups = (
        (w as u32).div_ceil(WORKGROUP),
        (h as u32).div_ceil(WORKGROUP),
    );
    let bytes = n as u64 * 4;
    let steps = p.steps;
    let limit_passes: Vec<(usize, &wgpu::BindGroup)> = (0..LIMIT_PASSES)
        .map(|l| (18, &g_limit[(l % 2) as usize]))
        .collect();
    for step in 0..steps {
        // The step's routing key and creep (half a step's on the last, as on the CPU).
        let step_creep = creep.of_step(step);
        let of_step = Params {
            route_key: seed.map_or(0, |seed| step_key(seed, step)),
            r: step_creep.r(),
            omega: step_creep.omega(),
            ..uniform
        };
        gpu.queue
            .write_buffer(&params, 0, bytemuck::bytes_of(&of_step));
        let mut scope = Some(device.push_error_scope(wgpu::ErrorFilter::Validation));
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("erosion step"),
        });
        let run = |encoder: &mut wgpu::CommandEncoder, list: &[(usize, &wgpu::BindGroup)]| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("erosion"),
                timestamp_writes: None,
            });
            for (pipe, group) in list {
                pass.set_pipeline(&k[*pipe]);
                pass.set_bind_group(0, *group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        };
        // 1-2. Receivers, lakes, receivers again.
        let mut phase_clock = web_time::Instant::now();
        let mut list = vec![(0, &g_receivers), (1, &g_root_init)];
        for l in 0..levels {
            list.push((2, &g_root_jump[(l % 2) as usize]));
        }
        run(&mut encoder, &list);
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[0], &mut scope).await?;
        }
        let mut list = vec![(3, &g_lake_init)];
        for l in 0..LAKE_PASSES {
            list.push((4, &g_lake_pass[(l % 2) as usize]));
        }
        list.extend([(5, &g_lake_apply), (0, &g_receivers), (6, &g_area_init)]);
        run(&mut encoder, &list);
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[1], &mut scope).await?;
        }
        // 3. Drainage area: each level adds to a copy of the partial sums.
        for l in 0..levels {
            let s = (l % 2) as usize;
            encoder.copy_buffer_to_buffer(&cells[s], 0, &cells[1 - s], 0, bytes);
            run(&mut encoder, &[(7, &g_area_jump[s])]);
        }
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[2], &mut scope).await?;
        }
        // 4. Incision.
        run(&mut encoder, &[(8, &g_lift), (9, &g_implicit_init)]);
        encoder.copy_buffer_to_buffer(&rcv, 0, &ptr[0], 0, bytes);
        let mut list = Vec::new();
        for l in 0..levels {
            list.push((10, &g_implicit_jump[(l % 2) as usize]));
        }
        list.push((11, &g_implicit_take));
        run(&mut encoder, &list);
        for _ in 0..POLISH_PASSES {
            run(&mut encoder, &[(12, &g_polish)]);
            encoder.copy_buffer_to_buffer(&tmp, 0, &heights_buf, 0, bytes);
        }
        // 4b. The threshold-slope limit (the CPU's, in Jacobi passes).
        if p.talus_deg.is_some() {
            run(&mut encoder, &limit_passes);
        }
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[3], &mut scope).await?;
        }
        // 5. Diffusion: the right-hand side is the heights after incision.
        if p.diffusivity > 0.0 {
            encoder.copy_buffer_to_buffer(&heights_buf, 0, &start, 0, bytes);
            let mut list = Vec::new();
            for sweep in 0..step_creep.sweeps() {
                let colours = if step_creep.over_relaxed(sweep) {
                    [(13, &g_diffuse[0]), (14, &g_diffuse[1])]
                } else {
                    [(19, &g_smooth[0]), (20, &g_smooth[1])]
                };
                list.extend(colours);
            }
            run(&mut encoder, &list);
        }
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[4], &mut scope).await?;
        }
        // 6. Talus (the share in `tmp`, the new heights in `coef`, no longer needed).
        if p.talus_deg.is_some() {
            for _ in 0..THERMAL_PASSES {
                run(&mut encoder, &[(15, &g_talus_share), (16, &g_talus_apply)]);
                encoder.copy_buffer_to_buffer(&coef, 0, &heights_buf, 0, bytes);
            }
        }
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[5], &mut scope).await?;
        }
        // 7. The floor.
        if let Some(g) = &g_floor {
            run(&mut encoder, &[(17, g)]);
        }
        // 8. After the last step, the limit once more (the CPU solver's last pass, which
        // repeats its pair of scans up to FINAL_LIMIT_PAIRS times).
        if step + 1 == steps && p.talus_deg.is_some() {
            for _ in 0..super::FINAL_LIMIT_PAIRS {
                run(&mut encoder, &limit_passes);
            }
        }
        if let Some(t) = profile.as_deref_mut() {
            flush(gpu, &mut encoder, &mut phase_clock, &mut t[6], &mut scope).await?;
        }
        gpu.submit(encoder.finish());
        close(scope).await?;
        wait_for_submitted_work(gpu).await?;
        ctx.checkpoint(
            0.1 + 0.8 * (step + 1) as f32 / steps as f32,
            &format!("eroding: step {} of {steps} (GPU)", step + 1),
        )
        .await?;
    }
    // The last step's pits (lakes the bounded passes left, hillslopes that closed a
    // basin) are filled here, on the GPU, as the stage's conditioning would fill them on
    // the CPU (the same bits), so the surface comes back drained.
    let conditioning = if !fill_pits {
        None
    } else {
        match crate::terrain::drainage::gpu::fill_buffer(gpu, &heights_buf, w, h, ctx).await {
            Ok(result) => Some(result),
            Err(crate::terrain::drainage::gpu::GpuFloodError::Cancelled(c)) => {
                return Err(c.into());
            }
            Err(err) => {
                log::info!("the eroded surface is conditioned on the CPU: {err}");
                None
            }
        }
    };
    let heights = read_f32_buffer(gpu, &heights_buf, n).await?;
    let counts = read_bytes(gpu, &cells[area_last], n as u64 * 4).await?;
    let cell_area = (cell_m * cell_m) as f32;
    let area = counts
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32 * cell_area)
        .collect();
    Ok(GpuEroded {
        heights,
        area,
        conditioning,
        gpu_ms: clock.elapsed().as_secs_f64() * 1e3,
        on_gpu: GpuField::new(gpu, heights_buf, w, h),
    })
}

/// Pointer-jumping passes that cover any path on `cells` cells: `ceil(log2 cells)`, at
/// least 1.
fn levels(cells: usize) -> u32 {
    (usize::BITS - cells.saturating_sub(1).leading_zeros()).max(1)
}

#[cfg(test)]
mod tests {
    #[test]
    fn levels_cover_every_path() {
        assert_eq!(super::levels(1), 1);
        assert_eq!(super::levels(2), 1);
        assert_eq!(super::levels(3), 2);
        assert_eq!(super::levels(1024 * 1024), 20);
        assert_eq!(super::levels(1024 * 1024 + 1), 21);
    }
}
