//! Driving `shaders/multigrid.wgsl`: the same FMG + V(2,2) algorithm as
//! `crate::diffusion::multigrid`, with every level's sweeps, restrictions and prolongations
//! on the GPU.
//!
//! Only the finest level goes up (its heights and fixed-cell bits); the coarser levels of the
//! hierarchy (constraint-aware restriction of the fixed cells and their heights,
//! `restrict_problem` in `shaders/multigrid.wgsl`) are built on the GPU at the start of the first
//! submission, one pass per level, O(cells) in all. No CPU copy of any level is made, and
//! every iteration runs on the GPU.
//!
//! Convergence checks without a stall per cycle: after every V-cycle two `atomicMax`
//! reductions (the finest level's `max |r_i| / n_i` and the last coarse correction) are
//! copied into that cycle's 8-byte slot of one staging buffer made per solve. The cycles are
//! recorded [`CHECK_EVERY`] to a submission (the full-multigrid start and the first
//! `CHECK_EVERY - 1` cycles share the first), and the staging buffer is mapped once per
//! submission, awaited without blocking the browser. The stopping rule replays every
//! cycle's values in order, so it means what it means on the CPU; the solve ends with the
//! batch in which it fired, up to `CHECK_EVERY - 1` cycles later (more accurate, never less).
//! Readbacks per solve: `ceil((cycles + 1) / CHECK_EVERY)` checks plus the result, at most
//! `cycles / 4 + 2`. Between batches the job reports progress and honours cancel. Memory:
//! per level the unknowns, the right-hand side (not on the finest level of a Laplace
//! problem) and the fixed-cell bits; with tile smoothing (below) a second buffer of
//! unknowns per level larger than one workgroup, about 1.33 x 4 bytes a finest cell more.
//!
//! Smoothing: on hardware ([`GpuContext::prefers_tiles`]) each pre- or post-smoothing of a
//! level larger than one workgroup is one dispatch of `smooth_tile`: every workgroup loads a
//! 32 x 32 tile with a halo of 4 cells into workgroup memory, runs the red-black half-sweeps
//! there on a shrinking window and writes its tile into the level's second buffer (read by
//! the restriction and the prolongation, and read back into the first by the
//! post-smoothing). The same bits as a dispatch per half-sweep (`relax`), which a software
//! rasteriser keeps: there every barrier costs more than the dispatches it saves. Dispatches
//! per V-cycle at 1024^2: about 35 instead of about 70. Per two-sweep smoothing the level is
//! read 1.56 times (the halos) and written once, instead of read four times and half
//! written four times; the halos make it 1.2x the updates.
//!
//! A level larger than one storage binding is tiled into bands of rows ([`super::bands`]):
//! each operator is then one dispatch per band, and the ghost rows are exchanged after each
//! pass that writes the unknowns. Cost: the same O(cells) per cycle plus two row copies per
//! band boundary and pass; the answer is the same bits as untiled.

use wgpu::util::DeviceExt;

use super::bands::{self, Band};
use super::{MULTIGRID, WORKGROUP, bind};
use crate::diffusion::multigrid::hierarchy;
use crate::diffusion::multigrid::{COARSEST_SWEEPS, MultigridParams, Solved, Stopping, Work};
use crate::diffusion::{Constraints, DiffusionError, FieldOut, fixed_height_range};
use crate::gpu::{GpuContext, GpuError, GpuField, read_staging};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// Side of `solve_coarsest`'s workgroup in `shaders/multigrid.wgsl`, which holds one
/// invocation per cell of the coarsest level.
const COARSEST_WORKGROUP: usize = 4;
const _: () = assert!(hierarchy::COARSEST_SIDE <= COARSEST_WORKGROUP);

/// Side of the tile each workgroup of `smooth_tile` smooths, and the most sweeps it runs in
/// one dispatch (`TILE` and `TILE_SWEEPS` in `shaders/multigrid.wgsl`).
const SMOOTH_TILE: u32 = 32;
const TILE_SWEEPS: u32 = 2;

/// V-cycles per submission and per readback of the convergence checks (see the module docs).
const CHECK_EVERY: u32 = 4;

/// The entry points [`Pipelines`] holds, in its order.
pub(super) const ENTRIES: [&str; 10] = [
    "relax",
    "smooth_tile",
    "relax_small",
    "solve_coarsest",
    "restrict_residual",
    "prolong_add",
    "prolong_replace",
    "residual_max",
    "correction_max",
    "restrict_problem",
];

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
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
    /// Red-black sweeps of `solve_coarsest`, `relax_small` and `smooth_tile`.
    sweeps: u32,
    _pad: u32,
}

struct Pipelines {
    relax: wgpu::ComputePipeline,
    /// Every pre- or post-smoothing sweep of an untiled level in one dispatch, tile by tile.
    smooth_tile: wgpu::ComputePipeline,
    /// Every sweep of a level within one workgroup in one dispatch.
    relax_small: wgpu::ComputePipeline,
    /// Every sweep of the coarsest level in one dispatch of a 4 x 4 workgroup.
    solve_coarsest: wgpu::ComputePipeline,
    restrict: wgpu::ComputePipeline,
    prolong_add: wgpu::ComputePipeline,
    prolong_replace: wgpu::ComputePipeline,
    residual_max: wgpu::ComputePipeline,
    correction_max: wgpu::ComputePipeline,
    /// Builds a coarse level of the problem from the one above it.
    restrict_problem: wgpu::ComputePipeline,
}

impl Pipelines {
    /// The solver's kernels from the device's cache.
    async fn of(gpu: &GpuContext) -> Result<Self, GpuError> {
        let [
            relax,
            smooth_tile,
            relax_small,
            solve_coarsest,
            restrict,
            prolong_add,
            prolong_replace,
            residual_max,
            correction_max,
            restrict_problem,
        ] = gpu.pipelines(&MULTIGRID, ENTRIES).await?;
        Ok(Self {
            relax,
            smooth_tile,
            relax_small,
            solve_coarsest,
            restrict,
            prolong_add,
            prolong_replace,
            residual_max,
            correction_max,
            restrict_problem,
        })
    }
}

/// One band of a level: its rows, its unknowns and the bind groups of every operator that
/// writes its rows.
struct GpuBand {
    rows: Band,
    u: wgpu::Buffer,
    /// The fixed-cell bits of the stored rows (bit `i % 32` of word `i / 32`); on a coarse
    /// level, valid on the owned rows (ghost rows' bits are never read). Held for the tests,
    /// which read the built levels back; the kernels reach it through the bind groups.
    #[cfg(test)]
    fixed: wgpu::Buffer,
    /// Relax with colour 0 and 1.
    relax: [wgpu::BindGroup; 2],
    /// Tile smoothing of an untiled level larger than one workgroup, when the V-cycle's
    /// sweeps allow it: the pre-smoothing reads `u` and writes the level's second buffer, the
    /// post-smoothing reads that and writes `u` back. Between them (restriction, the coarse
    /// correction's prolongation) the second buffer is the level's current one.
    smooth: Option<[wgpu::BindGroup; 2]>,
    /// All of the coarsest level's sweeps in one dispatch (the coarsest level only).
    coarsest: Option<wgpu::BindGroup>,
    /// On a level that fits one workgroup: `relax_small` with a number of sweeps, so a
    /// relaxation of that many sweeps is one dispatch (empty on larger levels).
    small_relax: Vec<(u32, wgpu::BindGroup)>,
    /// Operators between this band and the next coarser level (absent on the coarsest).
    restrict: Option<wgpu::BindGroup>,
    prolong_add: Option<wgpu::BindGroup>,
    prolong_replace: Option<wgpu::BindGroup>,
    /// Builds the next coarser level's problem from this band (absent on the coarsest).
    build: Option<wgpu::BindGroup>,
}

impl GpuBand {
    /// Workgroups covering the owned rows, `columns` wide.
    fn groups(&self, columns: u32) -> (u32, u32) {
        (
            columns.div_ceil(WORKGROUP),
            (self.rows.owned.len() as u32).div_ceil(WORKGROUP),
        )
    }

    /// Workgroups covering the coarse parents of the owned rows.
    fn coarse_groups(&self, coarse_w: u32) -> (u32, u32) {
        let rows = self.rows.owned.end.div_ceil(2) - self.rows.owned.start / 2;
        (
            coarse_w.div_ceil(WORKGROUP),
            (rows as u32).div_ceil(WORKGROUP),
        )
    }
}

struct GpuLevel {
    w: u32,
    h: u32,
    bands: Vec<GpuBand>,
}

impl GpuLevel {
    fn cells(&self) -> usize {
        (self.w * self.h) as usize
    }

    fn is_tiled(&self) -> bool {
        self.bands.len() > 1
    }

    /// The bands' rows and their unknowns' buffers, in order.
    fn unknowns(&self) -> (Vec<Band>, Vec<&wgpu::Buffer>) {
        self.bands.iter().map(|b| (b.rows.clone(), &b.u)).unzip()
    }

    /// Brings every ghost row up to date after a pass wrote the unknowns.
    fn exchange(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.is_tiled() {
            let (rows, buffers) = self.unknowns();
            bands::exchange_ghost_rows(encoder, &rows, &buffers, self.w as usize);
        }
    }
}

/// Solves `problem` on `gpu` (FMG start, then batches of V-cycles with their checks, see the
/// module docs). The solution stays on the GPU when the finest level is one buffer (the
/// field fits one binding), for the next GPU stage or a readback
/// ([`crate::diffusion::FieldOut::into_cpu`]); a tiled solve reads its bands back.
pub(in crate::diffusion) async fn multigrid(
    gpu: &GpuContext,
    problem: &Constraints,
    params: &MultigridParams,
    ctx: &JobCtx,
) -> Result<Solved<FieldOut>, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    gpu.check_compute()?;
    if problem.fixed().count() == 0 {
        return Err(DiffusionError::NoFixedCells);
    }
    let scale = fixed_height_range(problem).max(f32::MIN_POSITIVE);
    let device = &gpu.device;

    let pipes = Pipelines::of(gpu).await?;
    let sweeps = [params.pre_sweeps, params.post_sweeps];
    let (levels, checks, result) = prepare(gpu, &pipes, problem, sweeps, ctx).await?;

    let finest = w * h;
    let mut stats = Work::default();
    let last = levels.len() - 1;

    // Per cycle, the reductions land in a slot of one staging buffer, read once per batch.
    let slots = CHECK_EVERY.min(params.max_cycles.saturating_add(1)).max(1);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("multigrid checks staging"),
        size: u64::from(slots) * 8,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let batch = Batch {
        pipes: &pipes,
        levels: &levels,
        checks: &checks,
        result: &result,
        staging: &staging,
    };

    // The coarse levels, the full-multigrid start and the first cycles, one submission: the
    // start's checks in slot 0, then the cycles'.
    let mut encoder = device.create_command_encoder(&Default::default());
    build_levels(&mut encoder, &pipes, &levels);
    solve_coarsest(
        &mut encoder.begin_compute_pass(&Default::default()),
        &pipes,
        &levels[last],
    );
    stats.add(levels[last].cells(), finest, COARSEST_SWEEPS);
    for l in (0..last).rev() {
        prolong(&mut encoder, &pipes.prolong_replace, &levels[l], |b| {
            b.prolong_replace.as_ref()
        });
        v_cycle(&mut encoder, &pipes, &levels, l, params, &mut stats, finest);
    }
    batch.check(&mut encoder, 0);
    let first = (slots - 1).min(params.max_cycles);
    batch.cycles(&mut encoder, 1, first, params, &mut stats, finest);
    gpu.submit(encoder.finish());
    let values = batch.read(gpu, first + 1).await?;
    let (residual, correction) = values[0];
    let mut stop = Stopping::new(params, scale, residual, correction);
    for &(residual, correction) in &values[1..] {
        stop.record(residual, correction);
    }
    // Then batches of up to CHECK_EVERY cycles, one submission and one readback each.
    while stop.keep_going() {
        ctx.checkpoint(
            stop.progress(),
            &format!("multigrid on the GPU, {}", stop.describe()),
        )
        .await?;
        let n = CHECK_EVERY.min(params.max_cycles - stop.cycles);
        let mut encoder = device.create_command_encoder(&Default::default());
        batch.cycles(&mut encoder, 0, n, params, &mut stats, finest);
        gpu.submit(encoder.finish());
        for (residual, correction) in batch.read(gpu, n).await? {
            stop.record(residual, correction);
        }
    }
    let field = if let [band] = levels[0].bands.as_slice() {
        FieldOut::Gpu(GpuField::new(gpu, band.u.clone(), w, h))
    } else {
        let (rows, buffers) = levels[0].unknowns();
        let data = bands::read_owned_rows(gpu, &rows, &buffers, w).await?;
        FieldOut::Cpu(
            Heightfield::from_vec(w, h, data).map_err(|e| GpuError::Readback(e.to_string()))?,
        )
    };
    ctx.set_progress(1.0, "multigrid: done");
    Ok(Solved {
        field,
        cycles: stop.cycles,
        fine_sweeps: stats.fine_sweeps,
        work_sweeps: stats.work_sweeps,
        residual: stop.residual,
        relative_residual: stop.relative_residual(),
        estimated_error: stop.relative_estimate(),
        converged: stop.converged(),
    })
}

/// The solver's levels on `gpu`: every band's buffers and bind groups, the finest level's
/// heights written (in slices, with the job's ticks between them), the coarser levels still
/// to be built by [`build_levels`] at the start of the first submission.
async fn prepare(
    gpu: &GpuContext,
    pipes: &Pipelines,
    problem: &Constraints,
    sweeps: [u32; 2],
    ctx: &JobCtx,
) -> Result<(Vec<GpuLevel>, Checks, wgpu::Buffer), DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    let dims = hierarchy::dims(w, h);
    let plan = bands::plan(&dims, gpu.caps.max_storage_bytes())?;
    if plan[0].len() > 1 {
        log::info!(
            "a {w} x {h} field exceeds one storage binding ({} bytes): multigrid in {} bands",
            gpu.caps.max_storage_bytes(),
            plan[0].len()
        );
    }
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let pending = std::cell::RefCell::new(Vec::new());
    let prepared = upload(gpu, pipes, problem, &dims, plan, sweeps, &pending);
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }
    // The heights go up in slices of 1 MiB with the job's ticks between them: one 64 MiB
    // copy would hold the browser's main thread.
    for (buffer, data) in pending.take() {
        for (k, part) in data.chunks(1 << 20).enumerate() {
            gpu.queue.write_buffer(&buffer, (k << 20) as u64, part);
            ctx.tick(0.0, "multigrid: uploading the problem").await?;
        }
    }
    Ok(prepared)
}

/// Bind groups of the two reductions read after each cycle, one per band.
struct Checks {
    residual: Vec<wgpu::BindGroup>,
    /// Over level 1's correction; empty when the finest level is the coarsest.
    correction: Vec<wgpu::BindGroup>,
}

/// Buffers created empty and the bytes still to be written into them.
type Pending<'a> = std::cell::RefCell<Vec<(wgpu::Buffer, &'a [u8])>>;

/// Creates every band's buffers and bind groups; returns the levels with the reductions'
/// bind groups and their result buffer. The finest level's unknowns are created empty and
/// listed in `pending` with their contents (the problem's heights), for the caller to write;
/// its fixed bits go up with their buffer. Every coarser level's buffers start zeroed, for
/// [`build_levels`] to fill. A level that fits one workgroup also gets `relax_small`'s
/// bind groups for each of `sweeps` (the V-cycle's pre- and post-sweeps), so that its
/// relaxation is one dispatch.
fn upload<'a>(
    gpu: &GpuContext,
    pipes: &Pipelines,
    problem: &'a Constraints,
    dims: &[(usize, usize)],
    plan: Vec<Vec<Band>>,
    sweeps: [u32; 2],
    pending: &Pending<'a>,
) -> (Vec<GpuLevel>, Checks, wgpu::Buffer) {
    let device = &gpu.device;
    let storage = |label: &str, data: &[u8], extra: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: data,
            usage: wgpu::BufferUsages::STORAGE | extra,
        })
    };
    let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let zeroed = |label: &str, bytes: usize| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4) as u64,
            usage: wgpu::BufferUsages::STORAGE | copy,
            mapped_at_creation: false,
        })
    };
    // Bound where a Laplace problem's finest level has no right-hand side (never read).
    let dummy = storage("no rhs", &[0u8; 16], wgpu::BufferUsages::empty());
    let result = storage("residual and correction max", &[0u8; 8], copy);
    let finest_rows = |band: &Band| -> &'a [u8] {
        let w = problem.width();
        bytemuck::cast_slice(&problem.initial().data()[band.stored.start * w..band.stored.end * w])
    };
    // Per level and band: unknowns, right-hand side (none on the finest), fixed bits.
    let per_band = |make: &dyn Fn(usize, usize, &Band) -> wgpu::Buffer| -> Vec<Vec<wgpu::Buffer>> {
        dims.iter()
            .zip(&plan)
            .enumerate()
            .map(|(l, (&(w, _), bands))| bands.iter().map(|b| make(l, w, b)).collect())
            .collect()
    };
    let us = per_band(&|l, w, band| {
        if l == 0 {
            let buffer = zeroed("u", band.stored_cells(w) * 4);
            pending
                .borrow_mut()
                .push((buffer.clone(), finest_rows(band)));
            buffer
        } else {
            zeroed("u", band.stored_cells(w) * 4)
        }
    });
    let bs = per_band(&|l, w, band| {
        if l == 0 {
            dummy.clone()
        } else {
            zeroed("b", band.stored_cells(w) * 4)
        }
    });
    let fixed = per_band(&|l, w, band| {
        if l == 0 {
            let words = bands::fixed_words(problem.fixed(), band);
            storage("fixed", bytemuck::cast_slice(&words), copy)
        } else {
            zeroed("fixed", band.stored_cells(w).div_ceil(32) * 4)
        }
    });

    let tile_smoothing = tiles_apply(gpu, &plan, sweeps);
    let mut residual = Vec::new();
    let mut correction = Vec::new();
    let mut levels = Vec::with_capacity(dims.len());
    for (l, &(level_w, level_h)) in dims.iter().enumerate() {
        let coarse = dims.get(l + 1);
        let mut gpu_bands = Vec::with_capacity(plan[l].len());
        for (k, band) in plan[l].iter().enumerate() {
            let ck = plan.get(l + 1).map(|c| bands::coarse_band(c, k));
            let make_params = |colour: u32, sweeps: u32| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("multigrid params"),
                    contents: bytemuck::bytes_of(&Params {
                        fine_w: level_w as u32,
                        fine_h: level_h as u32,
                        coarse_w: coarse.map_or(0, |c| c.0 as u32),
                        coarse_h: coarse.map_or(0, |c| c.1 as u32),
                        colour,
                        has_rhs: u32::from(l > 0),
                        fine_row0: band.stored.start as u32,
                        coarse_row0: ck.map_or(0, |ck| plan[l + 1][ck].stored.start as u32),
                        own_start: band.owned.start as u32,
                        own_end: band.owned.end as u32,
                        sweeps,
                        _pad: 0,
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                })
            };
            let params = [0, 1].map(|colour| make_params(colour, COARSEST_SWEEPS));
            let (u, f, b) = (&us[l][k], &fixed[l][k], &bs[l][k]);
            let relax = [0, 1].map(|c| {
                bind(
                    device,
                    &pipes.relax,
                    &[(0, &params[c]), (1, f), (2, u), (3, b)],
                )
            });
            let coarsest = (l + 1 == dims.len()).then(|| {
                bind(
                    device,
                    &pipes.solve_coarsest,
                    &[(0, &params[0]), (1, f), (2, u), (3, b)],
                )
            });
            let fits_workgroup = plan[l].len() == 1
                && level_w <= WORKGROUP as usize
                && level_h <= WORKGROUP as usize;
            let small_relax = if fits_workgroup {
                let mut groups: Vec<(u32, wgpu::BindGroup)> = Vec::new();
                for n in sweeps {
                    if n > 0 && groups.iter().all(|(s, _)| *s != n) {
                        let params = make_params(0, n);
                        let group = bind(
                            device,
                            &pipes.relax_small,
                            &[(0, &params), (1, f), (2, u), (3, b)],
                        );
                        groups.push((n, group));
                    }
                }
                groups
            } else {
                Vec::new()
            };
            let smoothed = (tile_smoothing && !fits_workgroup)
                .then(|| zeroed("u smoothed", band.stored_cells(level_w) * 4));
            let smooth = smoothed.as_ref().map(|second| {
                let [pre, post] = sweeps.map(|n| make_params(0, n));
                [
                    bind(
                        device,
                        &pipes.smooth_tile,
                        &[(0, &pre), (1, f), (2, u), (3, b), (7, second)],
                    ),
                    bind(
                        device,
                        &pipes.smooth_tile,
                        &[(0, &post), (1, f), (2, second), (3, b), (7, u)],
                    ),
                ]
            });
            // The level's unknowns between its pre- and post-smoothing.
            let current = smoothed.as_ref().unwrap_or(u);
            let (restrict, prolong_add, prolong_replace, build) = match ck {
                Some(ck) => {
                    let coarse_b = &bs[l + 1][ck];
                    let coarse_u = &us[l + 1][ck];
                    let coarse_fixed = &fixed[l + 1][ck];
                    let base = [(0, &params[0]), (1, f)];
                    let group = |pipeline, unknowns, extra: &[(u32, &wgpu::Buffer)]| {
                        let mut entries = vec![base[0], base[1], (2, unknowns)];
                        entries.extend_from_slice(extra);
                        Some(bind(device, pipeline, &entries))
                    };
                    (
                        group(&pipes.restrict, current, &[(3, b), (4, coarse_b)]),
                        group(&pipes.prolong_add, current, &[(4, coarse_u)]),
                        group(&pipes.prolong_replace, u, &[(4, coarse_u)]),
                        group(
                            &pipes.restrict_problem,
                            u,
                            &[(4, coarse_u), (6, coarse_fixed)],
                        ),
                    )
                }
                None => (None, None, None, None),
            };
            if l == 1 {
                correction.push(bind(
                    device,
                    &pipes.correction_max,
                    &[(0, &params[0]), (2, u), (5, &result)],
                ));
            }
            if l == 0 {
                residual.push(bind(
                    device,
                    &pipes.residual_max,
                    &[(0, &params[0]), (1, f), (2, u), (3, b), (5, &result)],
                ));
            }
            gpu_bands.push(GpuBand {
                rows: band.clone(),
                u: u.clone(),
                #[cfg(test)]
                fixed: f.clone(),
                relax,
                smooth,
                coarsest,
                small_relax,
                restrict,
                prolong_add,
                prolong_replace,
                build,
            });
        }
        levels.push(GpuLevel {
            w: level_w as u32,
            h: level_h as u32,
            bands: gpu_bands,
        });
    }
    (
        levels,
        Checks {
            residual,
            correction,
        },
        result,
    )
}

/// Builds every coarse level's problem from the one above it, finest first: one pass per
/// level (so each reads the level the previous pass wrote), then the new level's ghost rows.
/// O(cells) in all.
fn build_levels(encoder: &mut wgpu::CommandEncoder, pipes: &Pipelines, levels: &[GpuLevel]) {
    for pair in levels.windows(2) {
        let (fine, coarse) = (&pair[0], &pair[1]);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipes.restrict_problem);
            for band in &fine.bands {
                let Some(group) = &band.build else { continue };
                let (x, y) = band.coarse_groups(coarse.w);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        coarse.exchange(encoder);
    }
}

/// One dispatch of `pipeline` per band of `level` with the group `group` picks, over the
/// band's owned rows.
fn prolong(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::ComputePipeline,
    level: &GpuLevel,
    group: impl Fn(&GpuBand) -> Option<&wgpu::BindGroup>,
) {
    prolong_in(
        &mut encoder.begin_compute_pass(&Default::default()),
        pipeline,
        level,
        group,
    );
    level.exchange(encoder);
}

/// [`prolong`]'s dispatches in `pass` (an untiled level: no ghost rows to exchange).
fn prolong_in(
    pass: &mut wgpu::ComputePass,
    pipeline: &wgpu::ComputePipeline,
    level: &GpuLevel,
    group: impl Fn(&GpuBand) -> Option<&wgpu::BindGroup>,
) {
    pass.set_pipeline(pipeline);
    for band in &level.bands {
        let Some(group) = group(band) else { continue };
        let (x, y) = band.groups(level.w);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// Coarse right-hand side of `levels[l + 1]` from the residual of `levels[l]`, band by band,
/// in `pass`.
fn restrict(pass: &mut wgpu::ComputePass, pipes: &Pipelines, fine: &GpuLevel, coarse_w: u32) {
    pass.set_pipeline(&pipes.restrict);
    for band in &fine.bands {
        let Some(group) = &band.restrict else {
            continue;
        };
        let (x, y) = band.coarse_groups(coarse_w);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// `sweeps` red-black sweeps on `level`: each colour's threads cover half the columns. An
/// untiled level runs all of them in one pass ([`relax_in`]); a tiled one exchanges ghost
/// rows after each colour.
fn relax(
    encoder: &mut wgpu::CommandEncoder,
    pipes: &Pipelines,
    level: &GpuLevel,
    sweeps: u32,
    phase: Phase,
) {
    if !level.is_tiled() {
        relax_in(
            &mut encoder.begin_compute_pass(&Default::default()),
            pipes,
            level,
            sweeps,
            phase,
        );
        return;
    }
    let columns = level.w.div_ceil(2);
    for _ in 0..sweeps {
        for colour in 0..2 {
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipes.relax);
                for band in &level.bands {
                    let (x, y) = band.groups(columns);
                    pass.set_bind_group(0, &band.relax[colour], &[]);
                    pass.dispatch_workgroups(x, y, 1);
                }
            }
            level.exchange(encoder);
        }
    }
}

/// [`relax`] of an untiled level in `pass`. A level within one workgroup runs every sweep in
/// one dispatch, with a storage barrier between colours (the same bits as 2 x `sweeps`
/// dispatches, see `sweeps_in_workgroup` in the shader), and with tiles every sweep of a
/// larger one in one dispatch (`smooth_tile`).
fn relax_in(
    pass: &mut wgpu::ComputePass,
    pipes: &Pipelines,
    level: &GpuLevel,
    sweeps: u32,
    phase: Phase,
) {
    if sweeps == 0 {
        return;
    }
    let [band] = level.bands.as_slice() else {
        unreachable!("an untiled level has one band");
    };
    if let Some(groups) = &band.smooth {
        pass.set_pipeline(&pipes.smooth_tile);
        pass.set_bind_group(0, &groups[phase as usize], &[]);
        pass.dispatch_workgroups(
            level.w.div_ceil(SMOOTH_TILE),
            level.h.div_ceil(SMOOTH_TILE),
            1,
        );
        return;
    }
    if let Some((_, group)) = band.small_relax.iter().find(|(n, _)| *n == sweeps) {
        pass.set_pipeline(&pipes.relax_small);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
        return;
    }
    let (x, y) = band.groups(level.w.div_ceil(2));
    pass.set_pipeline(&pipes.relax);
    for _ in 0..sweeps {
        for group in &band.relax {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
}

/// Which smoothing of a V-cycle a relaxation is (the tile smoothing's buffers differ).
#[derive(Clone, Copy)]
enum Phase {
    Pre = 0,
    Post = 1,
}

/// [`COARSEST_SWEEPS`] red-black sweeps on the coarsest level (at most 4 x 4 cells) in one
/// dispatch of one workgroup, with a storage barrier between colours: the bits of as many
/// `relax` dispatches, without the 2 x `COARSEST_SWEEPS` dispatches' overhead per cycle.
fn solve_coarsest(pass: &mut wgpu::ComputePass, pipes: &Pipelines, level: &GpuLevel) {
    pass.set_pipeline(&pipes.solve_coarsest);
    for band in &level.bands {
        let group = band
            .coarsest
            .as_ref()
            .expect("the coarsest level has its bind group");
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
}

/// Encodes one V-cycle from level `top` (correction scheme, as on the CPU). The coarser
/// levels' unknowns are cleared first (each is zero when the cycle reaches it, as before).
/// Where no level is tiled the whole cycle is one compute pass: no ghost rows to exchange
/// between its dispatches, and fewer passes cost less on drivers that pay per pass.
fn v_cycle(
    encoder: &mut wgpu::CommandEncoder,
    pipes: &Pipelines,
    levels: &[GpuLevel],
    top: usize,
    params: &MultigridParams,
    stats: &mut Work,
    finest: usize,
) {
    let last = levels.len() - 1;
    for level in &levels[top + 1..] {
        for band in &level.bands {
            encoder.clear_buffer(&band.u, 0, None);
        }
    }
    // The work in the CPU solver's order (the sums are `f32`).
    for level in &levels[top..last] {
        stats.add(level.cells(), finest, params.pre_sweeps);
    }
    stats.add(levels[last].cells(), finest, COARSEST_SWEEPS);
    for level in levels[top..last].iter().rev() {
        stats.add(level.cells(), finest, params.post_sweeps);
    }
    if levels.iter().any(GpuLevel::is_tiled) {
        for l in top..last {
            relax(encoder, pipes, &levels[l], params.pre_sweeps, Phase::Pre);
            restrict(
                &mut encoder.begin_compute_pass(&Default::default()),
                pipes,
                &levels[l],
                levels[l + 1].w,
            );
        }
        solve_coarsest(
            &mut encoder.begin_compute_pass(&Default::default()),
            pipes,
            &levels[last],
        );
        for l in (top..last).rev() {
            prolong(encoder, &pipes.prolong_add, &levels[l], |b| {
                b.prolong_add.as_ref()
            });
            relax(encoder, pipes, &levels[l], params.post_sweeps, Phase::Post);
        }
        return;
    }
    let mut pass = encoder.begin_compute_pass(&Default::default());
    for l in top..last {
        relax_in(&mut pass, pipes, &levels[l], params.pre_sweeps, Phase::Pre);
        restrict(&mut pass, pipes, &levels[l], levels[l + 1].w);
    }
    solve_coarsest(&mut pass, pipes, &levels[last]);
    for l in (top..last).rev() {
        prolong_in(&mut pass, &pipes.prolong_add, &levels[l], |b| {
            b.prolong_add.as_ref()
        });
        relax_in(
            &mut pass,
            pipes,
            &levels[l],
            params.post_sweeps,
            Phase::Post,
        );
    }
}

/// Whether the levels `plan` smooth tile by tile: where the device prefers it, no level is
/// tiled into bands (a tile's halo would cross the bands' ghost rows) and the (pre, post)
/// `sweeps` fit one dispatch's halo.
fn tiles_apply(gpu: &GpuContext, plan: &[Vec<Band>], sweeps: [u32; 2]) -> bool {
    gpu.prefers_tiles()
        && plan.iter().all(|bands| bands.len() == 1)
        && sweeps.iter().all(|n| (1..=TILE_SWEEPS).contains(n))
}

/// Whether a `w` x `h` solve with `params` on `gpu` smooths tile by tile (module docs).
pub(in crate::diffusion) fn smooths_in_tiles(
    gpu: &GpuContext,
    w: usize,
    h: usize,
    params: &MultigridParams,
) -> bool {
    bands::plan(&hierarchy::dims(w, h), gpu.caps.max_storage_bytes())
        .is_ok_and(|plan| tiles_apply(gpu, &plan, [params.pre_sweeps, params.post_sweeps]))
}

/// What encodes V-cycles with their convergence checks and reads the checks back.
struct Batch<'a> {
    pipes: &'a Pipelines,
    levels: &'a [GpuLevel],
    checks: &'a Checks,
    /// The reductions' target, cleared before each check.
    result: &'a wgpu::Buffer,
    /// One 8-byte slot per cycle of a batch, mapped once per batch.
    staging: &'a wgpu::Buffer,
}

impl Batch<'_> {
    /// Encodes `n` V-cycles from the finest level, each followed by its checks into slots
    /// `first..first + n`.
    fn cycles(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        first: u32,
        n: u32,
        params: &MultigridParams,
        stats: &mut Work,
        finest: usize,
    ) {
        for slot in first..first + n {
            v_cycle(encoder, self.pipes, self.levels, 0, params, stats, finest);
            self.check(encoder, slot);
        }
    }

    /// Encodes `max |r_i| / n_i` on the finest level and the largest coarse correction of the
    /// last cycle, reduced on the GPU into `result` and copied into staging slot `slot`.
    fn check(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        let (pipes, levels, checks) = (self.pipes, self.levels, self.checks);
        encoder.clear_buffer(self.result, 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipes.residual_max);
            for (band, group) in levels[0].bands.iter().zip(&checks.residual) {
                let (x, y) = band.groups(levels[0].w);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            if let Some(level) = levels.get(1) {
                pass.set_pipeline(&pipes.correction_max);
                for (band, group) in level.bands.iter().zip(&checks.correction) {
                    let (x, y) = band.groups(level.w);
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(x, y, 1);
                }
            }
        }
        encoder.copy_buffer_to_buffer(self.result, 0, self.staging, u64::from(slot) * 8, 8);
    }

    /// The (residual, correction) pairs of slots `0..n`, after their submission: one
    /// readback of `8 n` bytes.
    async fn read(&self, gpu: &GpuContext, n: u32) -> Result<Vec<(f32, f32)>, DiffusionError> {
        let bytes = read_staging(gpu, self.staging, u64::from(n) * 8).await?;
        let words: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(words.chunks_exact(2).map(|w| (w[0], w[1])).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diffusion::FixedMask;
    use crate::gpu::read_bytes;

    /// A problem with scattered fixed cells and lines, heights from a hash.
    fn problem(w: usize, h: usize) -> Constraints {
        let mut fixed = FixedMask::new(w, h);
        let mut heights = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let hash = (x * 7919 + y * 104_729) ^ (x * y * 31);
                heights[y * w + x] = (hash % 1000) as f32 * 0.37;
                if hash % 13 == 0 || x == w / 3 || y == 2 * h / 3 {
                    fixed.fix(x, y);
                }
            }
        }
        let initial = Heightfield::from_vec(w, h, heights).expect("sizes match");
        Constraints::new(initial, fixed).expect("valid problem")
    }

    /// Every level the GPU builds holds the CPU hierarchy's fixed bits exactly and its
    /// heights to rounding (WGSL's division is not correctly rounded), untiled and in bands.
    #[test]
    fn levels_built_on_the_gpu_are_the_cpu_hierarchy() {
        let contexts = [
            pollster::block_on(GpuContext::headless()),
            pollster::block_on(GpuContext::headless_with_limits(|limits| {
                limits.max_storage_buffer_binding_size = 16 * 1024;
            })),
        ];
        for gpu in contexts {
            let gpu = match gpu {
                Ok(gpu) => gpu,
                Err(err) => {
                    crate::gpu::skip::no_adapter(&err);
                    return;
                }
            };
            let problem = problem(77, 150);
            let ctx = JobCtx::detached();
            let cpu = pollster::block_on(hierarchy::for_problem(&problem, None, &ctx))
                .expect("not cancelled");
            let pipes = pollster::block_on(Pipelines::of(&gpu)).expect("kernels");
            let (levels, _, _) =
                pollster::block_on(prepare(&gpu, &pipes, &problem, [2, 2], &ctx)).expect("levels");
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            build_levels(&mut encoder, &pipes, &levels);
            gpu.submit(encoder.finish());

            assert_eq!(levels.len(), cpu.len());
            let tiled = levels[0].is_tiled();
            for (l, (gpu_level, cpu_level)) in levels.iter().zip(&cpu).enumerate() {
                let w = cpu_level.w;
                for band in &gpu_level.bands {
                    let cells = band.rows.stored_cells(w);
                    let u: Vec<f32> = bytemuck::pod_collect_to_vec(
                        &pollster::block_on(read_bytes(&gpu, &band.u, cells as u64 * 4))
                            .expect("u"),
                    );
                    let words: Vec<u32> = bytemuck::pod_collect_to_vec(
                        &pollster::block_on(read_bytes(
                            &gpu,
                            &band.fixed,
                            cells.div_ceil(32) as u64 * 4,
                        ))
                        .expect("fixed bits"),
                    );
                    for row in band.rows.owned.clone() {
                        for x in 0..w {
                            let (i, j) = (row * w + x, (row - band.rows.stored.start) * w + x);
                            let fixed = (words[j / 32] >> (j % 32)) & 1 == 1;
                            assert_eq!(fixed, cpu_level.fixed.is_fixed_index(i), "level {l}");
                            let (a, b) = (u[j], cpu_level.u[i]);
                            assert!(
                                (a - b).abs() <= 1e-6 * b.abs().max(1.0),
                                "level {l} ({x}, {row}): {a} on the GPU, {b} on the CPU"
                            );
                        }
                    }
                    // Ghost rows mirror their neighbours' heights.
                    for row in band.rows.stored.clone() {
                        let j = (row - band.rows.stored.start) * w;
                        let i = row * w;
                        for x in 0..w {
                            let (a, b) = (u[j + x], cpu_level.u[i + x]);
                            assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "level {l}");
                        }
                    }
                }
            }
            if gpu.caps.max_storage_bytes() <= 16 * 1024 {
                assert!(tiled, "the small device tiles the finest level");
            }
        }
    }

    /// Tile smoothing is set up on every untiled level larger than one workgroup when the
    /// device prefers tiles and the sweeps fit a tile's halo; never otherwise. (That the tiles
    /// give the sweeps' bits is `tests/gpu_diffusion.rs`.)
    #[test]
    fn tile_smoothing_is_set_up_where_it_applies() {
        let gpu = match pollster::block_on(GpuContext::headless()) {
            Ok(gpu) => gpu,
            Err(err) => {
                crate::gpu::skip::no_adapter(&err);
                return;
            }
        };
        let Ok(small) = pollster::block_on(GpuContext::headless_with_limits(|limits| {
            limits.max_storage_buffer_binding_size = 16 * 1024;
        })) else {
            panic!("a device with smaller limits");
        };
        let problem = problem(77, 150);
        let ctx = JobCtx::detached();
        let smoothed = |gpu: GpuContext, sweeps: [u32; 2]| -> Vec<bool> {
            let pipes = pollster::block_on(Pipelines::of(&gpu)).expect("kernels");
            let (levels, _, _) =
                pollster::block_on(prepare(&gpu, &pipes, &problem, sweeps, &ctx)).expect("levels");
            levels
                .iter()
                .map(|level| level.bands.iter().all(|b| b.smooth.is_some()))
                .collect()
        };
        // 77 x 150 -> 39 x 75 -> 20 x 38 -> 10 x 19 -> 5 x 10 -> 3 x 5 -> 2 x 3: the first
        // four do not fit a 16 x 16 workgroup.
        let expected = [true, true, true, true, false, false, false];
        assert_eq!(smoothed(gpu.clone().with_tiles(true), [2, 2]), expected);
        assert_eq!(smoothed(gpu.clone().with_tiles(true), [1, 2]), expected);
        let none = [false; 7];
        assert_eq!(smoothed(gpu.clone().with_tiles(false), [2, 2]), none);
        assert_eq!(smoothed(gpu.clone().with_tiles(true), [3, 2]), none);
        assert_eq!(smoothed(gpu.with_tiles(true), [0, 2]), none);
        // Levels in bands of rows sweep.
        assert_eq!(smoothed(small.with_tiles(true), [2, 2]), none);
    }
}
