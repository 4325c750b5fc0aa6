//! Which hardware runs the heavy kernels, and how that is said to the user.
//!
//! Every heavy stage has a CPU reference implementation and a WGSL implementation. A stage
//! receives a [`Backend`] and runs one of them; [`BackendChoice`] is what the user asked for
//! (`--backend auto|cpu|gpu` on the command line, a combo box in the app) and
//! [`BackendChoice::resolve`] turns it into a [`Backend`] given the GPU that was found.

use std::fmt;
use std::sync::Arc;

use serde::Serialize;
use thiserror::Error;

use crate::gpu::GpuContext;

/// Where a kernel runs.
#[derive(Clone, Debug)]
pub enum Backend {
    Cpu,
    Gpu(Arc<GpuContext>),
}

impl Backend {
    /// "cpu" or "gpu".
    pub fn key(&self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// The backend that can hold a `width` x `height` field: a GPU whose storage bindings are
    /// too small for it (see [`crate::gpu::Capabilities::fits_field`]) hands the field to the
    /// CPU, so large terrains work on every device, just slower (the report then says `cpu`).
    pub fn fitting(&self, width: usize, height: usize) -> Backend {
        match self {
            Backend::Gpu(gpu) if !gpu.caps.fits_field(width, height) => {
                log::warn!(
                    "a {width} x {height} field exceeds this GPU's storage binding ({} bytes): \
                     computing it on the CPU",
                    gpu.caps.max_storage_bytes()
                );
                Backend::Cpu
            }
            other => other.clone(),
        }
    }
}

/// What the user asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// The GPU when it has compute shaders, else the CPU.
    #[default]
    Auto,
    Cpu,
    Gpu,
}

/// The user asked for the GPU and there is none that computes.
#[derive(Debug, Error)]
#[error("the GPU backend was requested but {reason}")]
pub struct NoGpuError {
    pub reason: String,
}

impl BackendChoice {
    pub const ALL: [BackendChoice; 3] =
        [BackendChoice::Auto, BackendChoice::Cpu, BackendChoice::Gpu];

    /// Picks the backend. `Gpu` without a computing GPU is an error rather than a silent
    /// fallback, so a user who asked for the GPU learns why they did not get it. `Gpu` also
    /// runs every stage on the GPU, software rasteriser or not. `Auto` takes a hardware GPU
    /// and the CPU beside a software rasteriser (Mesa's lavapipe, the browser's SwiftShader):
    /// one runs on the same cores as the CPU path and every stage is slower there (the
    /// multigrid ten times on lavapipe, docs/performance.md).
    // Shared across job threads natively; the page's threaded build (src/jobs/threads.rs)
    // never moves GPU objects off the thread that made them, where wgpu's are not `Send`.
    #[cfg_attr(target_feature = "atomics", allow(clippy::arc_with_non_send_sync))]
    pub fn resolve(self, path: &ComputePath) -> Result<Backend, NoGpuError> {
        match (self, path) {
            (BackendChoice::Cpu, _) => Ok(Backend::Cpu),
            (BackendChoice::Gpu, ComputePath::Gpu { context, .. }) => Ok(Backend::Gpu(Arc::new(
                context.as_ref().clone().with_all_stages(),
            ))),
            (BackendChoice::Auto, ComputePath::Gpu { context, .. }) if context.is_software() => {
                Ok(Backend::Cpu)
            }
            (_, ComputePath::Gpu { context, .. }) => Ok(Backend::Gpu(Arc::clone(context))),
            (BackendChoice::Auto, ComputePath::Cpu { .. }) => Ok(Backend::Cpu),
            (BackendChoice::Gpu, ComputePath::Cpu { reason }) => Err(NoGpuError {
                reason: reason.to_string(),
            }),
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            BackendChoice::Auto => "auto",
            BackendChoice::Cpu => "cpu",
            BackendChoice::Gpu => "gpu",
        }
    }
}

impl std::str::FromStr for BackendChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(BackendChoice::Auto),
            "cpu" => Ok(BackendChoice::Cpu),
            "gpu" => Ok(BackendChoice::Gpu),
            other => Err(format!("unknown backend {other:?}: use auto, cpu or gpu")),
        }
    }
}

/// Why the compute path is the CPU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CpuReason {
    /// The page fell back to WebGL2 (no `navigator.gpu`, or no adapter).
    BrowserWithoutWebGpu,
    /// A GPU exists but cannot run compute shaders.
    NoComputeShaders { backend: String },
    /// No GPU adapter at all (native), with the error text.
    NoAdapter(String),
}

impl fmt::Display for CpuReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CpuReason::BrowserWithoutWebGpu => write!(f, "this browser has no WebGPU"),
            CpuReason::NoComputeShaders { backend } => {
                write!(f, "the {backend} GPU has no compute shaders")
            }
            CpuReason::NoAdapter(err) => write!(f, "no GPU was found: {err}"),
        }
    }
}

/// The active compute path, decided once at start.
#[derive(Clone, Debug)]
pub enum ComputePath {
    Gpu { context: Arc<GpuContext> },
    Cpu { reason: CpuReason },
}

impl ComputePath {
    /// The path for a context, or the CPU with the reason the context cannot compute.
    // Shared across job threads natively; the page's threaded build (src/jobs/threads.rs)
    // never moves GPU objects off the thread that made them, where wgpu's are not `Send`.
    #[cfg_attr(target_feature = "atomics", allow(clippy::arc_with_non_send_sync))]
    pub fn from_context(context: GpuContext) -> Self {
        if context.caps.compute {
            ComputePath::Gpu {
                context: Arc::new(context),
            }
        } else if cfg!(target_arch = "wasm32") {
            ComputePath::Cpu {
                reason: CpuReason::BrowserWithoutWebGpu,
            }
        } else {
            ComputePath::Cpu {
                reason: CpuReason::NoComputeShaders {
                    backend: context.adapter.backend,
                },
            }
        }
    }

    /// Short machine key: "webgpu", "vulkan", "metal", "dx12", "gl" or "cpu".
    pub fn key(&self) -> String {
        match self {
            ComputePath::Gpu { context } => match context.backend {
                wgpu::Backend::BrowserWebGpu => "webgpu".to_owned(),
                other => format!("{other:?}").to_ascii_lowercase(),
            },
            ComputePath::Cpu { .. } => "cpu".to_owned(),
        }
    }

    pub fn gpu(&self) -> Option<&Arc<GpuContext>> {
        match self {
            ComputePath::Gpu { context } => Some(context),
            ComputePath::Cpu { .. } => None,
        }
    }
}

impl fmt::Display for ComputePath {
    /// "GPU: WebGPU", "GPU: Vulkan (llvmpipe (LLVM 15.0.6, 256 bits))",
    /// "CPU (this browser has no WebGPU)".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ComputePath::Gpu { context } => match context.backend {
                wgpu::Backend::BrowserWebGpu => write!(f, "GPU: WebGPU"),
                backend => write!(f, "GPU: {backend:?} ({})", context.adapter.name),
            },
            ComputePath::Cpu { reason } => write!(f, "CPU ({reason})"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_path_explains_itself_and_refuses_gpu() {
        let path = ComputePath::Cpu {
            reason: CpuReason::BrowserWithoutWebGpu,
        };
        assert_eq!(path.to_string(), "CPU (this browser has no WebGPU)");
        assert_eq!(path.key(), "cpu");
        assert!(matches!(
            BackendChoice::Auto.resolve(&path),
            Ok(Backend::Cpu)
        ));
        let err = BackendChoice::Gpu.resolve(&path).unwrap_err();
        assert!(err.to_string().contains("no WebGPU"), "{err}");
    }

    #[test]
    fn parses_backend_names() {
        assert_eq!("GPU".parse::<BackendChoice>(), Ok(BackendChoice::Gpu));
        assert!(
            "cuda"
                .parse::<BackendChoice>()
                .unwrap_err()
                .contains("auto, cpu or gpu")
        );
    }
}
