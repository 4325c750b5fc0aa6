//! The GPU layer: one [`GpuContext`] per process, created either from eframe's wgpu render
//! state (the app shares the device egui draws with) or headlessly (command line, tests).
//!
//! Capabilities are decided once, at creation ([`Capabilities`]); stages ask them before they
//! choose the GPU path. Compute kernels are built once per device and cached on the context
//! ([`GpuContext::pipelines`]), which also counts its work ([`GpuContext::stats`]) and,
//! where the adapter has timestamp queries, measures its GPU time
//! ([`GpuContext::start_timing`]). Nothing here depends on egui or on the stages above.

mod caps;
mod context;
mod field;
mod kernels;
mod readback;
pub mod skip;
mod timing;

pub use caps::Capabilities;
pub use context::{AdapterSummary, GpuContext, GpuError, device_descriptor};
pub use field::GpuField;
pub use kernels::{GpuStats, Shader, bind_buffers};
pub use readback::{
    padded_row_bytes, read_bytes, read_f32_buffer, read_staging, read_texture,
    wait_for_submitted_work,
};
pub use timing::GpuTiming;
