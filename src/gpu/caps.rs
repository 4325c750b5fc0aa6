//! What the device can do, decided once when the context is created.

use serde::Serialize;

/// The limits and features later stages check before using the GPU.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Capabilities {
    /// Compute shaders and storage buffers are available (false on WebGL2).
    pub compute: bool,
    pub max_buffer_size: u64,
    pub max_storage_buffer_binding_size: u64,
    pub max_storage_buffers_per_shader_stage: u32,
    pub max_compute_workgroup_size_x: u32,
    pub max_compute_workgroup_size_y: u32,
    pub max_compute_invocations_per_workgroup: u32,
    pub max_compute_workgroups_per_dimension: u32,
    /// The device takes timestamp queries (`Features::TIMESTAMP_QUERY`, requested where the
    /// adapter offers it), so the GPU time of submitted work can be measured.
    pub timestamp_query: bool,
}

impl Capabilities {
    /// Reads the capabilities of a created device.
    pub fn of(adapter: &wgpu::Adapter, device: &wgpu::Device) -> Self {
        let limits = device.limits();
        let downlevel = adapter.get_downlevel_capabilities();
        let compute = downlevel
            .flags
            .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
            && limits.max_storage_buffers_per_shader_stage >= 5
            && limits.max_compute_invocations_per_workgroup >= 256;
        Self {
            compute,
            max_buffer_size: limits.max_buffer_size,
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
            max_compute_workgroup_size_x: limits.max_compute_workgroup_size_x,
            max_compute_workgroup_size_y: limits.max_compute_workgroup_size_y,
            max_compute_invocations_per_workgroup: limits.max_compute_invocations_per_workgroup,
            max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
            timestamp_query: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
        }
    }

    /// The largest storage buffer one binding may hold, in bytes.
    pub fn max_storage_bytes(&self) -> u64 {
        self.max_buffer_size
            .min(self.max_storage_buffer_binding_size)
    }

    /// Whether a `width` x `height` `f32` field fits in one storage binding and one dispatch
    /// of 16 x 16 workgroups.
    pub fn fits_field(&self, width: usize, height: usize) -> bool {
        let bytes = (width as u64) * (height as u64) * 4;
        let groups = |n: usize| (n as u64).div_ceil(16);
        self.compute
            && bytes <= self.max_storage_bytes()
            && groups(width) <= u64::from(self.max_compute_workgroups_per_dimension)
            && groups(height) <= u64::from(self.max_compute_workgroups_per_dimension)
    }

    /// Side of the largest square `f32` field the device holds in one binding.
    pub fn max_square_field(&self) -> u64 {
        ((self.max_storage_bytes() / 4) as f64).sqrt().floor() as u64
    }
}

/// The limits to ask of `adapter`: everything it offers, so 4096^2 (64 MiB) and larger
/// fields fit in one storage binding where the hardware allows it. wgpu's defaults stop at
/// 128 MiB per binding and 256 MiB per buffer.
pub fn requested_limits(adapter: &wgpu::Adapter) -> wgpu::Limits {
    adapter.limits()
}

/// The optional features to ask of `adapter`: timestamp queries where it offers them (to
/// measure the GPU time of submitted work); nothing is required.
pub fn requested_features(adapter: &wgpu::Adapter) -> wgpu::Features {
    adapter.features() & wgpu::Features::TIMESTAMP_QUERY
}
