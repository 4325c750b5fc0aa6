//! Filling a height field from fixed cells by Laplace diffusion (seed paper 000, Sec. V-C).
//!
//! The paper evolves `du/dt = D Δu + f` (eq. 6) with the 5-point operator
//! `Δ = 4U(i,j) - U(i+1,j) - U(i-1,j) - U(i,j-1) - U(i,j+1)` (eq. 7) until the free cells
//! stop changing; fixed cells (skeleton and enrichment points) keep their heights. The
//! fixed point is the discrete harmonic field: `Δu = 0` on every free cell. At the map
//! border missing neighbours are left out of the sum (zero flux, Neumann), so a border cell
//! is the mean of the neighbours it has.
//!
//! This module holds the problem type, the CPU reference sweep and the WGSL sweep
//! (`shaders/jacobi.wgsl`); the multigrid solver of the diffusion issue builds on them.

mod constraints;
mod cpu;
pub mod demo;
mod gpu;
pub mod multigrid;
pub mod offload;
pub mod post;
pub mod selftest;

use thiserror::Error;
use web_time::Instant;

pub use constraints::{Constraints, ConstraintsError, FixedMask};
pub use cpu::{jacobi_sweep, max_update};
pub use gpu::warm as warm_gpu;

/// How the GPU multigrid smooths a `w` x `h` problem with `params` on `gpu`: `"tiles"` (each
/// pre- or post-smoothing one dispatch, in workgroup memory) or `"sweeps"` (a dispatch per
/// half-sweep); the same bits either way.
pub fn gpu_smoothing(
    gpu: &crate::gpu::GpuContext,
    w: usize,
    h: usize,
    params: &MultigridParams,
) -> &'static str {
    if gpu::smooths_in_tiles(gpu, w, h, params) {
        "tiles"
    } else {
        "sweeps"
    }
}
pub use multigrid::{MultigridParams, Solved};
pub use post::PostFilter;

use crate::compute::Backend;
use crate::gpu::GpuError;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// Why a diffusion run stopped without a result.
#[derive(Debug, Error)]
pub enum DiffusionError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The page's Web Worker failed on the solve (its message).
    #[error("diffusion in the Web Worker: {0}")]
    Worker(String),
    #[error("diffusion was cancelled")]
    Cancelled(#[from] Cancelled),
    #[error("nothing to diffuse from: no cell is fixed (give at least one known height)")]
    NoFixedCells,
    #[error("the right-hand side is {}x{} but the field is {}x{}", rhs.0, rhs.1, field.0, field.1)]
    RhsSize {
        rhs: (usize, usize),
        field: (usize, usize),
    },
}

/// How to solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Full multigrid + V-cycles to the residual tolerance (the default).
    Multigrid(MultigridParams),
    /// Exactly this many Jacobi sweeps: the paper's baseline (it runs 5500).
    Jacobi { sweeps: u32 },
}

impl Method {
    pub fn key(&self) -> &'static str {
        match self {
            Method::Multigrid(_) => "multigrid",
            Method::Jacobi { .. } => "jacobi",
        }
    }
}

/// Where a filled field is: on the CPU, or still on the GPU that solved it
/// ([`fill_keeping`]).
#[derive(Clone, Debug)]
pub enum FieldOut {
    Cpu(Heightfield),
    Gpu(crate::gpu::GpuField),
}

impl FieldOut {
    /// The field on the CPU: read back from `backend`'s GPU if it is there (one readback).
    pub async fn into_cpu(self, backend: &Backend) -> Result<Heightfield, GpuError> {
        match (self, backend) {
            (FieldOut::Cpu(field), _) => Ok(field),
            (FieldOut::Gpu(field), Backend::Gpu(gpu)) => field.read(gpu).await,
            (FieldOut::Gpu(field), Backend::Cpu) => {
                unreachable!("a CPU backend leaves no field on a GPU: {field:?}")
            }
        }
    }
}

/// A filled field and the numbers a report needs (`F`: the field, or where it is).
#[derive(Clone, Debug)]
pub struct Filled<F = Heightfield> {
    pub field: F,
    /// "multigrid" or "jacobi".
    pub method: &'static str,
    /// "cpu" or "gpu".
    pub backend: &'static str,
    /// V-cycles after the full-multigrid start (0 for Jacobi).
    pub cycles: u32,
    /// Relaxation sweeps on the full-size grid.
    pub sweeps: u32,
    /// All relaxation work in full-size sweep equivalents.
    pub work_sweeps: f32,
    /// Final `max |r_i| / n_i` over free cells, in height units.
    pub residual: f32,
    /// `residual` over the fixed cells' height range.
    pub relative_residual: f32,
    /// Whether the tolerances were met (always true for Jacobi, which runs a fixed count).
    pub converged: bool,
    /// Estimated remaining error over the range (multigrid only).
    pub estimated_error: Option<f32>,
    pub millis: f64,
}

impl<F> Filled<F> {
    /// The same solve with its field mapped (moved to the CPU, unwrapped...).
    pub fn map_field<G>(self, f: impl FnOnce(F) -> G) -> Filled<G> {
        match self.try_map_field(|field| Ok::<G, std::convert::Infallible>(f(field))) {
            Ok(filled) => filled,
            Err(never) => match never {},
        }
    }

    /// [`Self::map_field`] with a mapping that may fail.
    pub fn try_map_field<G, E>(self, f: impl FnOnce(F) -> Result<G, E>) -> Result<Filled<G>, E> {
        Ok(Filled {
            field: f(self.field)?,
            method: self.method,
            backend: self.backend,
            cycles: self.cycles,
            sweeps: self.sweeps,
            work_sweeps: self.work_sweeps,
            residual: self.residual,
            relative_residual: self.relative_residual,
            converged: self.converged,
            estimated_error: self.estimated_error,
            millis: self.millis,
        })
    }
}

/// Fills `problem` with `method` on `backend`: the diffusion stage's entry point. The time
/// includes reading the field back from the GPU.
pub async fn fill(
    backend: &Backend,
    problem: &Constraints,
    method: Method,
    ctx: &JobCtx,
) -> Result<Filled, DiffusionError> {
    let start = Instant::now();
    let filled = fill_keeping(backend, problem, method, ctx).await?;
    let field = filled.field.into_cpu(backend).await?;
    Ok(Filled {
        field,
        method: filled.method,
        backend: filled.backend,
        cycles: filled.cycles,
        sweeps: filled.sweeps,
        work_sweeps: filled.work_sweeps,
        residual: filled.residual,
        relative_residual: filled.relative_residual,
        converged: filled.converged,
        estimated_error: filled.estimated_error,
        millis: start.elapsed().as_secs_f64() * 1e3,
    })
}

/// Fields of at most this many cells are solved on the calling thread in the page, not in
/// its Web Worker: an edit's coarse 128^2 pass solves in a few milliseconds, but the worker's
/// answer waited for the page's thread, which right after an edit is painting a frame
/// (120-210 ms where the page is composited in software), and only then could the erosion
/// be sent; the page's edits reached the map a frame later. The bits are the same
/// wherever it runs.
#[cfg_attr(not(target_arch = "wasm32"), allow(dead_code))]
const ON_THIS_THREAD_CELLS: usize = 1 << 15;

/// [`fill`] that leaves the field on the GPU where it was solved there in one buffer (a
/// multigrid solve on a GPU backend of a field that fits one binding), for a next GPU stage
/// to work on in place; otherwise the field comes back on the CPU.
pub async fn fill_keeping(
    backend: &Backend,
    problem: &Constraints,
    method: Method,
    ctx: &JobCtx,
) -> Result<Filled<FieldOut>, DiffusionError> {
    #[cfg(target_arch = "wasm32")]
    if matches!(backend, Backend::Cpu) && problem.width() * problem.height() > ON_THIS_THREAD_CELLS
    {
        use crate::jobs::worker::{CallError, call};
        match call(
            offload::KIND,
            offload::task_into_parcel(problem, method),
            ctx,
        )
        .await
        {
            Ok(parcel) => {
                let filled = offload::result_from_parcel(parcel)
                    .map_err(|e| DiffusionError::Worker(e.to_string()))?;
                return Ok(filled.map_field(FieldOut::Cpu));
            }
            Err(CallError::Unavailable(reason)) => {
                log::info!("diffusion on the page's thread: {reason}");
            }
            Err(CallError::Cancelled(c)) => return Err(c.into()),
            Err(CallError::Failed(message)) => return Err(DiffusionError::Worker(message)),
        }
    }
    solve_here(backend, problem, method, ctx).await
}

/// [`fill_keeping`] on this thread (in the page's Web Worker, the worker's own).
async fn solve_here(
    backend: &Backend,
    problem: &Constraints,
    method: Method,
    ctx: &JobCtx,
) -> Result<Filled<FieldOut>, DiffusionError> {
    let start = Instant::now();
    match method {
        // Exactly `sweeps` sweeps: O(sweeps x cells), two buffers and the mask.
        Method::Jacobi { sweeps } => {
            let field = match backend {
                Backend::Cpu => cpu::jacobi(problem, sweeps, ctx).await?,
                Backend::Gpu(gpu) => gpu::jacobi(gpu, problem, sweeps, ctx).await?,
            };
            let residual = max_update(&field, problem.fixed());
            let scale = fixed_height_range(problem).max(f32::MIN_POSITIVE);
            Ok(Filled {
                method: method.key(),
                backend: backend.key(),
                cycles: 0,
                sweeps,
                work_sweeps: sweeps as f32,
                residual,
                relative_residual: residual / scale,
                converged: true,
                estimated_error: None,
                millis: start.elapsed().as_secs_f64() * 1e3,
                field: FieldOut::Cpu(field),
            })
        }
        Method::Multigrid(params) => {
            let solved = match backend {
                Backend::Cpu => multigrid::solve(problem, None, &params, ctx)
                    .await?
                    .map_field(FieldOut::Cpu),
                Backend::Gpu(gpu) => gpu::multigrid(gpu, problem, &params, ctx).await?,
            };
            Ok(Filled {
                method: method.key(),
                backend: backend.key(),
                cycles: solved.cycles,
                sweeps: solved.fine_sweeps,
                work_sweeps: solved.work_sweeps,
                residual: solved.residual,
                relative_residual: solved.relative_residual,
                converged: solved.converged,
                estimated_error: Some(solved.estimated_error),
                millis: start.elapsed().as_secs_f64() * 1e3,
                field: solved.field,
            })
        }
    }
}

/// Applies the post-filters ([`post`]) on `backend`; `protected` marks river and valley
/// cells, which (with a margin) keep their heights.
pub async fn post_filter(
    backend: &Backend,
    field: &Heightfield,
    protected: &[bool],
    filter: &PostFilter,
    seed: u64,
) -> Result<Heightfield, DiffusionError> {
    let weights = post::protection(protected, field.width(), field.height(), filter.protect);
    Ok(match backend {
        Backend::Cpu => post::apply_cpu(field, &weights, filter, seed),
        Backend::Gpu(gpu) => gpu::post_filter(gpu, field, &weights, filter, seed).await?,
    })
}

/// [`post_filter`] of a field that may still be on the GPU ([`fill_keeping`]): on a GPU
/// backend a field there is filtered there into a new buffer (no transfer), a field on the
/// CPU goes through [`post_filter`].
pub async fn post_filter_keeping(
    backend: &Backend,
    field: FieldOut,
    protected: &[bool],
    filter: &PostFilter,
    seed: u64,
) -> Result<FieldOut, DiffusionError> {
    match (field, backend) {
        (FieldOut::Gpu(field), Backend::Gpu(gpu)) => {
            let weights = post::protection(protected, field.width, field.height, filter.protect);
            let out = gpu::post_filter_on(gpu, &field, &weights, filter, seed).await?;
            Ok(FieldOut::Gpu(out))
        }
        (FieldOut::Gpu(field), Backend::Cpu) => {
            unreachable!("a CPU backend leaves no field on a GPU: {field:?}")
        }
        (FieldOut::Cpu(field), backend) => {
            let fitting = backend.fitting(field.width(), field.height());
            let out = post_filter(&fitting, &field, protected, filter, seed).await?;
            Ok(FieldOut::Cpu(out))
        }
    }
}

/// Height range of the fixed cells: the scale tolerances and errors are relative to.
pub fn fixed_height_range(problem: &Constraints) -> f32 {
    let mut range: Option<(f32, f32)> = None;
    for (i, &v) in problem.initial().data().iter().enumerate() {
        if problem.fixed().is_fixed_index(i) {
            range = Some(match range {
                None => (v, v),
                Some((lo, hi)) => (lo.min(v), hi.max(v)),
            });
        }
    }
    range.map_or(0.0, |(lo, hi)| hi - lo)
}

/// The void-filling problem of a DEM: finite cells fixed, NaN (no-data) cells free, starting
/// at the mean of the fixed heights. Solving it is the harmonic fill of the voids.
pub fn void_problem(field: &Heightfield) -> Constraints {
    let (w, h) = (field.width(), field.height());
    let mut fixed = FixedMask::new(w, h);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, v) in field.data().iter().enumerate() {
        if v.is_finite() {
            fixed.fix(i % w, i / w);
            sum += f64::from(*v);
            n += 1;
        }
    }
    let mean = if n > 0 { (sum / n as f64) as f32 } else { 0.0 };
    let initial: Vec<f32> = field
        .data()
        .iter()
        .map(|v| if v.is_finite() { *v } else { mean })
        .collect();
    let initial = Heightfield::from_vec(w, h, initial).expect("same size as the input");
    Constraints::new(initial, fixed).expect("fixed cells are finite by construction")
}
