//! The compute self-test: the demo diffusion problem on the CPU and, when there is one, on
//! the GPU, compared. `strahler info --check`, `window.strahler.selfTest()` and the browser
//! tests use it; the CPU checksum must be the same on every platform.

use serde::Serialize;

use super::{Backend, ComputePath};
use crate::diffusion::{self, DiffusionError, Relaxed, demo};
use crate::jobs::JobCtx;

/// Grid side and sweep count of the self-test (small enough for a browser's CPU path).
pub const SIZE: usize = 128;
pub const SWEEPS: u32 = 400;

/// One backend's run.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    pub backend: &'static str,
    pub millis: f64,
    /// FNV-1a of the result's bits (see `Heightfield::checksum`).
    pub checksum: String,
    pub max_update: f32,
    pub min: f32,
    pub max: f32,
}

impl From<&Relaxed> for RunSummary {
    fn from(r: &Relaxed) -> Self {
        let (min, max) = r.field.finite_range().unwrap_or((f32::NAN, f32::NAN));
        Self {
            backend: r.backend,
            millis: r.millis,
            checksum: r.field.checksum(),
            max_update: r.max_update,
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
}

/// Runs the self-test on the CPU and, if `path` has one, the GPU.
pub async fn run(path: &ComputePath, ctx: &JobCtx) -> Result<SelfTest, DiffusionError> {
    let problem = demo::valley_and_peaks(SIZE);
    let cpu = diffusion::jacobi(&Backend::Cpu, &problem, SWEEPS, ctx).await?;
    let mut gpu_summary = None;
    let mut max_abs_diff = None;
    let mut relative_diff = None;
    if let Some(context) = path.gpu() {
        let gpu = diffusion::jacobi(&Backend::Gpu(context.clone()), &problem, SWEEPS, ctx).await?;
        let diff = gpu.field.max_abs_diff(&cpu.field).unwrap_or(f32::INFINITY);
        let range = cpu
            .field
            .finite_range()
            .map(|(lo, hi)| hi - lo)
            .unwrap_or(1.0)
            .max(f32::MIN_POSITIVE);
        max_abs_diff = Some(diff);
        relative_diff = Some(diff / range);
        gpu_summary = Some(RunSummary::from(&gpu));
    }
    Ok(SelfTest {
        compute: path.key(),
        size: SIZE,
        sweeps: SWEEPS,
        cpu: RunSummary::from(&cpu),
        gpu: gpu_summary,
        max_abs_diff,
        relative_diff,
    })
}
