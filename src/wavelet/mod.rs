//! Wavelet levels of detail (seed paper 001, Perez et al., "Locally Constrained Synthetic LoDs
//! Generation for Natural Terrain Meshes").
//!
//! - [`lifting`]: the spline-linear (CDF 5/3) wavelet by lifting, 2D, in place, any size.
//! - [`analysis`]: per-level, per-band detail variances and their log2 line fits, globally
//!   (GSA, eqs. 6-7) and per location (LSA, eq. 8).
//! - [`synthesis`]: new levels from Gaussian coefficients and the inverse transform, with the
//!   energy-reduction mask of MGR (eq. 9).
//! - [`directional`]: the new levels' interpolation of the source corrected along its
//!   valleys and crests (edge-directed), so that they are not strings of beads.
//! - [`mask`]: the grey masks users paint, import and export.
//! - [`fbm`]: reference fBm surfaces of known roughness (tests and benchmarks).
//! - [`gpu`]: the statistics (forward transform, GSA, LSA) and the synthesis in WGSL.

pub mod analysis;
pub mod directional;
pub mod fbm;
pub mod gpu;
pub mod lifting;
pub mod mask;
pub mod rng;
pub mod style;
pub mod synthesis;

use thiserror::Error;

pub use analysis::{Analysis, AnalysisParams, LineFit, LocalParams, analyze};
pub use lifting::Band;
pub use mask::{Brush, Mask, MaskError};
pub use synthesis::{Amplified, AmplifyFailure, AmplifyParams, Scope, amplify};

/// [`amplify`] on the chosen backend: the GPU kernels of [`gpu`] or the CPU reference.
pub async fn amplify_on(
    backend: &crate::compute::Backend,
    source: &crate::heightfield::Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
    ctx: &crate::jobs::JobCtx,
) -> Result<Amplified, AmplifyFailure> {
    amplify_from(backend, source, None, params, mask, ctx).await
}

/// [`amplify_on`] of a source that may already be on the backend's GPU: `on_gpu`, the same
/// values as `source` on that device (a previous stage's output), which the GPU path reads
/// instead of uploading `source`. The GPU path's output keeps its buffer
/// ([`Amplified::gpu`]) for the next stage and the 3D view.
pub async fn amplify_from(
    backend: &crate::compute::Backend,
    source: &crate::heightfield::Heightfield,
    on_gpu: Option<&crate::gpu::GpuField>,
    params: &AmplifyParams,
    mask: Option<&Mask>,
    ctx: &crate::jobs::JobCtx,
) -> Result<Amplified, AmplifyFailure> {
    match backend {
        crate::compute::Backend::Cpu => amplify(source, params, mask, ctx).await,
        crate::compute::Backend::Gpu(gpu) => {
            gpu::amplify(gpu, source, on_gpu, params, mask, ctx).await
        }
    }
}

/// Why a terrain could not be analysed or amplified.
#[derive(Debug, Error, PartialEq)]
pub enum WaveletError {
    #[error(
        "the terrain has {cells} no-data cells; fill the voids first (strahler fill, or Fill voids in the app)"
    )]
    NoData { cells: usize },
    #[error("a {width}x{height} terrain is too small for wavelet statistics (at least 3x3 cells)")]
    TooSmall { width: usize, height: usize },
    /// No style can be measured: the reason says which (no relief, or too few cells).
    #[error("no style can be measured on this {width}x{height} DEM: {reason}")]
    NoStyle {
        width: usize,
        height: usize,
        reason: &'static str,
    },
    #[error("levels of detail must be 1 to {max}, got {0}", max = synthesis::MAX_LEVELS)]
    Levels(u32),
    #[error("the local window must be an odd number of coefficients from 1 to 65, got {0}")]
    Window(usize),
    #[error(
        "the output would be {width}x{height} cells, above the limit of {limit}; use fewer levels or a smaller source"
    )]
    OutputTooLarge {
        width: usize,
        height: usize,
        limit: u64,
    },
    #[error("GPU synthesis failed: {0}")]
    Gpu(String),
    #[error("internal error: {0}")]
    Internal(String),
}
