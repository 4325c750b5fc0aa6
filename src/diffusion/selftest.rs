//! The compute self-test: the demo diffusion problem on the CPU and, when there is one, on
//! the GPU, compared. `strahler info --check`, `window.strahler.selfTest()` and the browser
//! tests use it; the CPU checksum must be the same on every platform.

use serde::Serialize;

use crate::compute::{Backend, ComputePath};
use crate::diffusion::{self, DiffusionError, Filled, Method, MultigridParams, demo};
use crate::jobs::JobCtx;

/// Grid side and sweep count of the self-test (small enough for a browser's CPU path).
pub const SIZE: usize = 128;
pub const SWEEPS: u32 = 400;

/// One backend's run.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    pub backend: &'static str,
    /// "multigrid" or "jacobi".
    pub method: &'static str,
    pub millis: f64,
    pub cycles: u32,
    pub sweeps: u32,
    /// Final residual over the fixed heights' range.
    pub relative_residual: f32,
    pub converged: bool,
    /// FNV-1a of the result's bits (see `Heightfield::checksum`).
    pub checksum: String,
    pub max_update: f32,
    pub min: f32,
    pub max: f32,
}

impl From<&Filled> for RunSummary {
    fn from(r: &Filled) -> Self {
        let (min, max) = r.field.finite_range().unwrap_or((f32::NAN, f32::NAN));
        Self {
            backend: r.backend,
            method: r.method,
            millis: r.millis,
            cycles: r.cycles,
            sweeps: r.sweeps,
            relative_residual: r.relative_residual,
            converged: r.converged,
            checksum: r.field.checksum(),
            max_update: r.residual,
            min,
            max,
        }
    }
}

/// The self-test's result.
#[derive(Clone, Debug, Serialize)]
pub struct SelfTest {
    /// The compute path key ("webgpu", "vulkan", ..., "cpu").
    pub compute: String,
    pub size: usize,
    pub sweeps: u32,
    pub cpu: RunSummary,
    pub gpu: Option<RunSummary>,
    /// Largest |GPU - CPU| over all cells, when the GPU ran.
    pub max_abs_diff: Option<f32>,
    /// `max_abs_diff` divided by the field's height range.
    pub relative_diff: Option<f32>,
    /// The same problem solved by multigrid on both backends, compared.
    pub multigrid: MultigridCheck,
}

/// The multigrid solve of the self-test problem on each backend.
#[derive(Clone, Debug, Serialize)]
pub struct MultigridCheck {
    pub cpu: RunSummary,
    pub gpu: Option<RunSummary>,
    /// Largest |GPU - CPU| over the height range, when the GPU ran.
    pub relative_diff: Option<f32>,
}

/// Runs the self-test on the CPU and, if `path` has one, the GPU.
pub async fn run(path: &ComputePath, ctx: &JobCtx) -> Result<SelfTest, DiffusionError> {
    let problem = demo::valley_and_peaks(SIZE);
    let jacobi = Method::Jacobi { sweeps: SWEEPS };
    let multigrid = Method::Multigrid(MultigridParams::default());
    let cpu = diffusion::fill(&Backend::Cpu, &problem, jacobi, ctx).await?;
    let cpu_mg = diffusion::fill(&Backend::Cpu, &problem, multigrid, ctx).await?;
    let mut gpu_summary = None;
    let mut max_abs_diff = None;
    let mut relative_diff = None;
    let mut gpu_mg = None;
    let mut mg_diff = None;
    if let Some(context) = path.gpu() {
        let backend = Backend::Gpu(context.clone());
        let gpu = diffusion::fill(&backend, &problem, jacobi, ctx).await?;
        let diff = gpu.field.max_abs_diff(&cpu.field).unwrap_or(f32::INFINITY);
        max_abs_diff = Some(diff);
        relative_diff = Some(diff / range(&cpu));
        gpu_summary = Some(RunSummary::from(&gpu));
        let mg = diffusion::fill(&backend, &problem, multigrid, ctx).await?;
        let diff = mg
            .field
            .max_abs_diff(&cpu_mg.field)
            .unwrap_or(f32::INFINITY);
        mg_diff = Some(diff / range(&cpu_mg));
        gpu_mg = Some(RunSummary::from(&mg));
    }
    Ok(SelfTest {
        compute: path.key(),
        size: SIZE,
        sweeps: SWEEPS,
        cpu: RunSummary::from(&cpu),
        gpu: gpu_summary,
        max_abs_diff,
        relative_diff,
        multigrid: MultigridCheck {
            cpu: RunSummary::from(&cpu_mg),
            gpu: gpu_mg,
            relative_diff: mg_diff,
        },
    })
}

fn range(filled: &Filled) -> f32 {
    filled
        .field
        .finite_range()
        .map(|(lo, hi)| hi - lo)
        .unwrap_or(1.0)
        .max(f32::MIN_POSITIVE)
}
