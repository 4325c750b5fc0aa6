//! Creating the device: from eframe's render state, or headless.

use std::fmt;
use std::sync::Arc;

use serde::Serialize;
use thiserror::Error;

use super::caps::{Capabilities, requested_features, requested_limits};
use super::kernels::Kernels;

/// Why the GPU path is unavailable or failed.
#[derive(Debug, Error)]
pub enum GpuError {
    #[error("no GPU adapter found: {0}")]
    NoAdapter(String),
    #[error("the GPU adapter refused to create a device: {0}")]
    RequestDevice(String),
    #[error("this GPU has no compute shaders ({backend} backend)")]
    NoCompute { backend: String },
    #[error(
        "a {width}x{height} field ({bytes} bytes) exceeds this GPU's storage limit of {limit} bytes"
    )]
    TooLarge {
        width: usize,
        height: usize,
        bytes: u64,
        limit: u64,
    },
    #[error(
        "a {width}x{height} field cannot be split into bands this GPU holds: its storage limit of \
         {limit} bytes is under {rows} rows of {width} cells"
    )]
    CannotTile {
        width: usize,
        height: usize,
        rows: usize,
        limit: u64,
    },
    #[error("the GPU reported an error: {0}")]
    Validation(String),
    #[error("reading results back from the GPU failed: {0}")]
    Readback(String),
    #[error("the GPU device was lost: {0}")]
    DeviceLost(String),
}

/// Adapter facts shown to the user (`strahler info`, status bar, `window.strahler.status()`).
#[derive(Clone, Debug, Serialize)]
pub struct AdapterSummary {
    pub name: String,
    /// "Vulkan", "Metal", "Dx12", "Gl" or "BrowserWebGpu".
    pub backend: String,
    /// "DiscreteGpu", "IntegratedGpu", "VirtualGpu", "Cpu" or "Other".
    pub device_type: String,
    pub driver: String,
}

impl AdapterSummary {
    /// Whether this is a software rasteriser: the adapter says it is a CPU, or its name or
    /// driver names one of the known ones (a SwiftShader a browser was told to use may call
    /// itself "Other").
    pub fn is_software(&self) -> bool {
        let named = |text: &str| {
            let text = text.to_ascii_lowercase();
            [
                "swiftshader",
                "llvmpipe",
                "lavapipe",
                "softpipe",
                "microsoft basic render",
            ]
            .iter()
            .any(|soft| text.contains(soft))
        };
        self.device_type == "Cpu" || named(&self.name) || named(&self.driver)
    }

    fn of(info: &wgpu::AdapterInfo) -> Self {
        Self {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_owned(),
        }
    }
}

/// A device and queue plus what they can do, and the kernels built on that device
/// ([`GpuContext::pipelines`]). Cheap to share behind an `Arc`; clones share the kernels.
#[derive(Clone)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub backend: wgpu::Backend,
    pub caps: Capabilities,
    pub(super) kernels: Arc<Kernels>,
    /// Run every stage with a WGSL version here, software rasteriser or not
    /// ([`GpuContext::runs_heavy_stages`]).
    all_stages: bool,
    /// Whether kernels trade dispatches for workgroup barriers, when set
    /// ([`GpuContext::prefers_tiles`]).
    tiles: Option<bool>,
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter)
            .field("caps", &self.caps)
            .field("stats", &self.stats())
            .finish_non_exhaustive()
    }
}

impl GpuContext {
    /// Whether the adapter is a software rasteriser (Mesa's lavapipe, or the browser's
    /// fallback adapter such as SwiftShader): correct, but slower than the CPU for work
    /// like erosion.
    pub fn is_software(&self) -> bool {
        self.adapter.is_software()
    }

    /// Whether stages whose GPU version only pays on real hardware (erosion: hundreds of
    /// dependent passes per step; the wavelet statistics: dozens of small dispatches) run on
    /// this device: a hardware GPU, or any once [`GpuContext::with_all_stages`] asked for
    /// every stage. "Compute on: auto" never hands a software rasteriser to the stages
    /// (`BackendChoice::resolve` takes the CPU beside one); this guard is for contexts given
    /// to the stages directly (benches, tests).
    pub fn runs_heavy_stages(&self) -> bool {
        !self.is_software() || self.all_stages
    }

    /// The same device with every stage on the GPU, software rasteriser or not (tests of
    /// the WGSL stages on lavapipe; `--backend gpu`).
    pub fn with_all_stages(mut self) -> Self {
        self.all_stages = true;
        self
    }

    /// Whether kernels that do in one dispatch, in workgroup memory with barriers, what would
    /// otherwise take several dispatches (the multigrid's tile smoothing) should: yes on
    /// hardware, where a dispatch costs microseconds of latency and a barrier almost nothing;
    /// no on a software rasteriser, which runs a workgroup's invocations in turn and switches
    /// between them at every barrier (lavapipe, 2 cores: a 1024^2 multigrid solve takes
    /// 0.9 s with a dispatch per half-sweep, 3.8 s with tiles). [`GpuContext::with_tiles`]
    /// decides instead.
    pub fn prefers_tiles(&self) -> bool {
        self.tiles.unwrap_or(!self.is_software())
    }

    /// The same device with tiled kernels on or off whatever the adapter (tests, and
    /// `strahler bench diffusion --smoothing`, which compares both).
    pub fn with_tiles(mut self, tiles: bool) -> Self {
        self.tiles = Some(tiles);
        self
    }

    /// Shares a device created elsewhere, e.g. the one eframe draws with (see
    /// [`device_descriptor`], which the app passes to eframe so that device carries the
    /// adapter's full limits).
    pub fn from_device(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Self {
        log_uncaptured_errors(device);
        let info = adapter.get_info();
        Self {
            device: device.clone(),
            queue: queue.clone(),
            adapter: AdapterSummary::of(&info),
            backend: info.backend,
            caps: Capabilities::of(adapter, device),
            kernels: Arc::default(),
            all_stages: false,
            tiles: None,
        }
    }

    /// Creates a device without a window. Backends come from `WGPU_BACKEND` if set, else the
    /// primary ones (Vulkan, Metal, DX12); on this project's CI that finds Mesa's lavapipe.
    pub async fn headless() -> Result<Self, GpuError> {
        Self::headless_with_limits(|_| {}).await
    }

    /// [`GpuContext::headless`] with the device's limits changed by `adjust` first, e.g. a
    /// small storage binding to exercise the tiled kernels as a small GPU would.
    pub async fn headless_with_limits(
        adjust: impl FnOnce(&mut wgpu::Limits),
    ) -> Result<Self, GpuError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // OpenGL rarely offers compute and only adds driver noise when probed headless.
        descriptor.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(descriptor);
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                ..Default::default()
            })
            .await
            .map_err(|err| GpuError::NoAdapter(err.to_string()))?;
        let (device, queue) = adapter
            .request_device(&{
                let mut descriptor = device_descriptor(&adapter);
                adjust(&mut descriptor.required_limits);
                descriptor
            })
            .await
            .map_err(|err| GpuError::RequestDevice(err.to_string()))?;
        log_uncaptured_errors(&device);
        let info = adapter.get_info();
        let context = Self {
            caps: Capabilities::of(&adapter, &device),
            device,
            queue,
            adapter: AdapterSummary::of(&info),
            backend: info.backend,
            kernels: Arc::default(),
            all_stages: false,
            tiles: None,
        };
        if !context.caps.compute {
            return Err(GpuError::NoCompute {
                backend: context.adapter.backend,
            });
        }
        Ok(context)
    }

    /// Fails with [`GpuError::NoCompute`] unless the device runs compute shaders (kernels
    /// that tile large fields into bands need nothing more).
    pub fn check_compute(&self) -> Result<(), GpuError> {
        if self.caps.compute {
            Ok(())
        } else {
            Err(GpuError::NoCompute {
                backend: self.adapter.backend.clone(),
            })
        }
    }

    /// Fails with [`GpuError::NoCompute`] or [`GpuError::TooLarge`] unless a `width` x
    /// `height` `f32` field can be processed in one binding.
    pub fn check_field(&self, width: usize, height: usize) -> Result<(), GpuError> {
        self.check_compute()?;
        if !self.caps.fits_field(width, height) {
            return Err(GpuError::TooLarge {
                width,
                height,
                bytes: (width as u64) * (height as u64) * 4,
                limit: self.caps.max_storage_bytes(),
            });
        }
        Ok(())
    }
}

/// Logs the errors on `device` that no error scope captured, instead of wgpu's default
/// handler, which panics natively. The stages capture their validation errors with scopes
/// and fall back to the CPU; what is left over (a buffer the GPU has no memory for, an error
/// while drawing) must not end the app and lose the user's work. Shared devices (the one
/// eframe draws with) get it too.
fn log_uncaptured_errors(device: &wgpu::Device) {
    device.on_uncaptured_error(Arc::new(|err: wgpu::Error| {
        log::error!("uncaptured GPU error: {err}");
    }));
}

/// The device descriptor used everywhere: the adapter's real limits (so 4096^2 fields and
/// larger fit where the hardware allows), WebGL2's limits on the GL backend, and timestamp
/// queries where the adapter has them.
pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    wgpu::DeviceDescriptor {
        label: Some("strahler device"),
        required_features: requested_features(adapter),
        required_limits: requested_limits(adapter),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::AdapterSummary;

    fn adapter(name: &str, device_type: &str, driver: &str) -> AdapterSummary {
        AdapterSummary {
            name: name.into(),
            backend: "Vulkan".into(),
            device_type: device_type.into(),
            driver: driver.into(),
        }
    }

    /// Software rasterisers are known by their type or by name; hardware is not.
    #[test]
    fn software_adapters_are_known_by_type_or_name() {
        assert!(adapter("llvmpipe (LLVM 19.1.7, 256 bits)", "Cpu", "llvmpipe").is_software());
        assert!(adapter("SwiftShader Device (Subzero)", "Other", "").is_software());
        assert!(adapter("", "Other", "SwiftShader driver").is_software());
        assert!(!adapter("NVIDIA H200", "DiscreteGpu", "NVIDIA 570.86").is_software());
        assert!(!adapter("", "Other", "").is_software());
    }
}
