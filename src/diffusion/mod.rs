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

use thiserror::Error;
use web_time::Instant;

pub use constraints::{Constraints, ConstraintsError, FixedMask};
pub use cpu::{jacobi_sweep, max_update};

use crate::compute::Backend;
use crate::gpu::GpuError;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// Why a diffusion run stopped without a result.
#[derive(Debug, Error)]
pub enum DiffusionError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("diffusion was cancelled")]
    Cancelled(#[from] Cancelled),
}

/// The outcome of a relaxation run.
#[derive(Clone, Debug)]
pub struct Relaxed {
    pub field: Heightfield,
    pub sweeps: u32,
    /// Largest change a further Jacobi sweep would make to a free cell (metres).
    pub max_update: f32,
    /// Wall time of the run in milliseconds, readback included.
    pub millis: f64,
    /// "cpu" or "gpu".
    pub backend: &'static str,
}

/// Runs exactly `sweeps` Jacobi sweeps of eq. 7 on `backend`.
///
/// Cost: O(`sweeps` x cells) arithmetic on either backend, O(cells) memory (two buffers and
/// a bit mask). Progress is reported to `ctx` and cancellation honoured between batches.
pub async fn jacobi(
    backend: &Backend,
    problem: &Constraints,
    sweeps: u32,
    ctx: &JobCtx,
) -> Result<Relaxed, DiffusionError> {
    let start = Instant::now();
    let field = match backend {
        Backend::Cpu => cpu::jacobi(problem, sweeps, ctx).await?,
        Backend::Gpu(gpu) => gpu::jacobi(gpu, problem, sweeps, ctx).await?,
    };
    let max_update = max_update(&field, problem.fixed());
    Ok(Relaxed {
        field,
        sweeps,
        max_update,
        millis: start.elapsed().as_secs_f64() * 1e3,
        backend: backend.key(),
    })
}
