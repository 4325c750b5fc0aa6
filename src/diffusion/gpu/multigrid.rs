//! Driving `shaders/multigrid.wgsl`: the same FMG + V(2,2) algorithm as
//! `crate::diffusion::multigrid`, with every level's sweeps, restrictions and prolongations
//! on the GPU.
//!
//! The level hierarchy (constraint-aware restriction of the fixed cells and their heights) is
//! built once on the CPU in O(cells) and uploaded; all iterations run on the GPU.
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
//! problem) and the fixed-cell bits.
//!
//! A level larger than one storage binding is tiled into bands of rows ([`super::bands`]):
//! each operator is then one dispatch per band, and the ghost rows are exchanged after each
//! pass that writes the unknowns. Cost: the same O(cells) per cycle plus two row copies per
//! band boundary and pass; the answer is the same bits as untiled.

use wgpu::util::DeviceExt;

use super::bands::{self, Band};
use super::{MULTIGRID, WORKGROUP, bind};
use crate::diffusion::multigrid::hierarchy::{self, Level};
use crate::diffusion::multigrid::{COARSEST_SWEEPS, MultigridParams, Solved, Stopping, Work};
use crate::diffusion::{Constraints, DiffusionError, fixed_height_range};
use crate::gpu::{GpuContext, GpuError, read_staging};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// V-cycles per submission and per readback of the convergence checks (see the module docs).
const CHECK_EVERY: u32 = 4;

/// The entry points [`Pipelines`] holds, in its order.
pub(super) const ENTRIES: [&str; 7] = [
    "relax",
    "solve_coarsest",
    "restrict_residual",
    "prolong_add",
    "prolong_replace",
    "residual_max",
    "correction_max",
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
    /// Red-black sweeps of `solve_coarsest`.
    sweeps: u32,
    _pad: u32,
}

struct Pipelines {
    relax: wgpu::ComputePipeline,
    solve_coarsest: wgpu::ComputePipeline,
    restrict: wgpu::ComputePipeline,
    prolong_add: wgpu::ComputePipeline,
    prolong_replace: wgpu::ComputePipeline,
    residual_max: wgpu::ComputePipeline,
    correction_max: wgpu::ComputePipeline,
}

impl Pipelines {
    /// The solver's kernels from the device's cache.
    async fn of(gpu: &GpuContext) -> Result<Self, GpuError> {
        let [
            relax,
            solve_coarsest,
            restrict,
            prolong_add,
            prolong_replace,
            residual_max,
            correction_max,
        ] = gpu.pipelines(&MULTIGRID, ENTRIES).await?;
        Ok(Self {
            relax,
            solve_coarsest,
            restrict,
            prolong_add,
            prolong_replace,
            residual_max,
            correction_max,
        })
    }
}

/// One band of a level: its rows, its unknowns and the bind groups of every operator that
/// writes its rows.
struct GpuBand {
    rows: Band,
    u: wgpu::Buffer,
    /// Relax with colour 0 and 1.
    relax: [wgpu::BindGroup; 2],
    /// All of the coarsest level's sweeps in one dispatch (the coarsest level only).
    coarsest: Option<wgpu::BindGroup>,
    /// Operators between this band and the next coarser level (absent on the coarsest).
    restrict: Option<wgpu::BindGroup>,
    prolong_add: Option<wgpu::BindGroup>,
    prolong_replace: Option<wgpu::BindGroup>,
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

pub(in crate::diffusion) async fn multigrid(
    gpu: &GpuContext,
    problem: &Constraints,
    params: &MultigridParams,
    ctx: &JobCtx,
) -> Result<Solved, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    gpu.check_compute()?;
    if problem.fixed().count() == 0 {
        return Err(DiffusionError::NoFixedCells);
    }
    let scale = fixed_height_range(problem).max(f32::MIN_POSITIVE);
    let device = &gpu.device;

    let cpu_levels = hierarchy::for_problem(problem, None, ctx).await?;
    let dims: Vec<(usize, usize)> = cpu_levels.iter().map(Level::dims).collect();
    let plan = bands::plan(&dims, gpu.caps.max_storage_bytes())?;
    if plan[0].len() > 1 {
        log::info!(
            "a {w} x {h} field exceeds one storage binding ({} bytes): multigrid in {} bands",
            gpu.caps.max_storage_bytes(),
            plan[0].len()
        );
    }

    let pipes = Pipelines::of(gpu).await?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let pending = std::cell::RefCell::new(Vec::new());
    let (levels, checks, result) = upload(gpu, &pipes, &cpu_levels, plan, &pending);
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }
    // The heights go up in slices of 1 MiB with the job's ticks between them: one 64 MiB
    // copy would hold the browser's main thread.
    for (buffer, data) in pending.take() {
        for (k, part) in data.chunks(1 << 20).enumerate() {
            gpu.queue.write_buffer(&buffer, (k << 20) as u64, part);
            ctx.tick(0.0, "multigrid: uploading the levels").await?;
        }
    }
    drop(cpu_levels);

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

    // Full-multigrid start and the first cycles, one submission: the start's checks in slot 0,
    // then the cycles'.
    let mut encoder = device.create_command_encoder(&Default::default());
    solve_coarsest(&mut encoder, &pipes, &levels[last]);
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
    let (rows, buffers) = levels[0].unknowns();
    let data = bands::read_owned_rows(gpu, &rows, &buffers, w).await?;
    ctx.set_progress(1.0, "multigrid: done");
    Ok(Solved {
        field: Heightfield::from_vec(w, h, data).map_err(|e| GpuError::Readback(e.to_string()))?,
        cycles: stop.cycles,
        fine_sweeps: stats.fine_sweeps,
        work_sweeps: stats.work_sweeps,
        residual: stop.residual,
        relative_residual: stop.relative_residual(),
        estimated_error: stop.relative_estimate(),
        converged: stop.converged(),
    })
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
/// bind groups and their result buffer. The unknowns and right-hand sides are created empty
/// and listed in `pending` with their contents, for the caller to write.
fn upload<'a>(
    gpu: &GpuContext,
    pipes: &Pipelines,
    cpu: &'a [Level],
    plan: Vec<Vec<Band>>,
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
    let field = |label: &str, data: &'a [u8]| {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: data.len() as u64,
            usage: wgpu::BufferUsages::STORAGE | copy,
            mapped_at_creation: false,
        });
        pending.borrow_mut().push((buffer.clone(), data));
        buffer
    };
    // Bound where a Laplace problem's finest level has no right-hand side (never read).
    let dummy = storage("no rhs", &[0u8; 16], wgpu::BufferUsages::empty());
    let result = storage("residual and correction max", &[0u8; 8], copy);
    let rows = |values: &'a [f32], w: usize, band: &Band| -> &'a [u8] {
        bytemuck::cast_slice(&values[band.stored.start * w..band.stored.end * w])
    };
    // Per level and band: unknowns, right-hand side (if any), fixed bits.
    let us: Vec<Vec<wgpu::Buffer>> = cpu
        .iter()
        .zip(&plan)
        .map(|(l, bands)| {
            bands
                .iter()
                .map(|b| field("u", rows(&l.u, l.w, b)))
                .collect()
        })
        .collect();
    let bs: Vec<Vec<Option<wgpu::Buffer>>> = cpu
        .iter()
        .zip(&plan)
        .map(|(l, bands)| {
            bands
                .iter()
                .map(|b| (!l.b.is_empty()).then(|| field("b", rows(&l.b, l.w, b))))
                .collect()
        })
        .collect();
    let fixed: Vec<Vec<wgpu::Buffer>> = cpu
        .iter()
        .zip(&plan)
        .map(|(l, bands)| {
            bands
                .iter()
                .map(|b| {
                    let words = bands::fixed_words(&l.fixed, b);
                    storage(
                        "fixed",
                        bytemuck::cast_slice(&words),
                        wgpu::BufferUsages::empty(),
                    )
                })
                .collect()
        })
        .collect();

    let mut residual = Vec::new();
    let mut correction = Vec::new();
    let mut levels = Vec::with_capacity(cpu.len());
    for (l, level) in cpu.iter().enumerate() {
        let coarse = cpu.get(l + 1);
        let mut gpu_bands = Vec::with_capacity(plan[l].len());
        for (k, band) in plan[l].iter().enumerate() {
            let ck = plan.get(l + 1).map(|c| bands::coarse_band(c, k));
            let make_params = |colour: u32| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("multigrid params"),
                    contents: bytemuck::bytes_of(&Params {
                        fine_w: level.w as u32,
                        fine_h: level.h as u32,
                        coarse_w: coarse.map_or(0, |c| c.w as u32),
                        coarse_h: coarse.map_or(0, |c| c.h as u32),
                        colour,
                        has_rhs: u32::from(bs[l][k].is_some()),
                        fine_row0: band.stored.start as u32,
                        coarse_row0: ck.map_or(0, |ck| plan[l + 1][ck].stored.start as u32),
                        own_start: band.owned.start as u32,
                        own_end: band.owned.end as u32,
                        sweeps: COARSEST_SWEEPS,
                        _pad: 0,
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                })
            };
            let params = [make_params(0), make_params(1)];
            let (u, f) = (&us[l][k], &fixed[l][k]);
            let b = bs[l][k].as_ref().unwrap_or(&dummy);
            let relax = [0, 1].map(|c| {
                bind(
                    device,
                    &pipes.relax,
                    &[(0, &params[c]), (1, f), (2, u), (3, b)],
                )
            });
            let coarsest = (l + 1 == cpu.len()).then(|| {
                bind(
                    device,
                    &pipes.solve_coarsest,
                    &[(0, &params[0]), (1, f), (2, u), (3, b)],
                )
            });
            let (restrict, prolong_add, prolong_replace) = match ck {
                Some(ck) => {
                    let coarse_b = bs[l + 1][ck].as_ref().unwrap_or(&dummy);
                    let coarse_u = &us[l + 1][ck];
                    let base = [(0, &params[0]), (1, f), (2, u)];
                    let with = |pipeline, extra| {
                        Some(bind(device, pipeline, &[base[0], base[1], base[2], extra]))
                    };
                    (
                        Some(bind(
                            device,
                            &pipes.restrict,
                            &[base[0], base[1], base[2], (3, b), (4, coarse_b)],
                        )),
                        with(&pipes.prolong_add, (4, coarse_u)),
                        with(&pipes.prolong_replace, (4, coarse_u)),
                    )
                }
                None => (None, None, None),
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
                relax,
                coarsest,
                restrict,
                prolong_add,
                prolong_replace,
            });
        }
        levels.push(GpuLevel {
            w: level.w as u32,
            h: level.h as u32,
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

/// One dispatch of `pipeline` per band of `level` with the group `group` picks, over the
/// band's owned rows.
fn prolong(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::ComputePipeline,
    level: &GpuLevel,
    group: impl Fn(&GpuBand) -> Option<&wgpu::BindGroup>,
) {
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        for band in &level.bands {
            let Some(group) = group(band) else { continue };
            let (x, y) = band.groups(level.w);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
    level.exchange(encoder);
}

/// Coarse right-hand side of `levels[l + 1]` from the residual of `levels[l]`, band by band.
fn restrict(encoder: &mut wgpu::CommandEncoder, pipes: &Pipelines, fine: &GpuLevel, coarse_w: u32) {
    let mut pass = encoder.begin_compute_pass(&Default::default());
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
/// untiled level runs all of them in one pass; a tiled one exchanges ghost rows after each
/// colour.
fn relax(encoder: &mut wgpu::CommandEncoder, pipes: &Pipelines, level: &GpuLevel, sweeps: u32) {
    if sweeps == 0 {
        return;
    }
    let columns = level.w.div_ceil(2);
    let colour_pass = |pass: &mut wgpu::ComputePass, colour: usize| {
        for band in &level.bands {
            let (x, y) = band.groups(columns);
            pass.set_bind_group(0, &band.relax[colour], &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
    };
    if !level.is_tiled() {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipes.relax);
        for _ in 0..sweeps {
            colour_pass(&mut pass, 0);
            colour_pass(&mut pass, 1);
        }
        return;
    }
    for _ in 0..sweeps {
        for colour in 0..2 {
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipes.relax);
                colour_pass(&mut pass, colour);
            }
            level.exchange(encoder);
        }
    }
}

/// [`COARSEST_SWEEPS`] red-black sweeps on the coarsest level (at most 4 x 4 cells) in one
/// dispatch of one workgroup, with a storage barrier between colours: the bits of as many
/// `relax` dispatches, without the 2 x `COARSEST_SWEEPS` dispatches' overhead per cycle.
fn solve_coarsest(encoder: &mut wgpu::CommandEncoder, pipes: &Pipelines, level: &GpuLevel) {
    let mut pass = encoder.begin_compute_pass(&Default::default());
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

/// Encodes one V-cycle from level `top` (correction scheme, as on the CPU).
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
    for l in top..last {
        relax(encoder, pipes, &levels[l], params.pre_sweeps);
        stats.add(levels[l].cells(), finest, params.pre_sweeps);
        restrict(encoder, pipes, &levels[l], levels[l + 1].w);
        for band in &levels[l + 1].bands {
            encoder.clear_buffer(&band.u, 0, None);
        }
    }
    solve_coarsest(encoder, pipes, &levels[last]);
    stats.add(levels[last].cells(), finest, COARSEST_SWEEPS);
    for l in (top..last).rev() {
        prolong(encoder, &pipes.prolong_add, &levels[l], |b| {
            b.prolong_add.as_ref()
        });
        relax(encoder, pipes, &levels[l], params.post_sweeps);
        stats.add(levels[l].cells(), finest, params.post_sweeps);
    }
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
