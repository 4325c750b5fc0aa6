//! The diffusion kernels on the GPU: the paper's Jacobi sweep (`shaders/jacobi.wgsl`) and
//! the multigrid solver (`shaders/multigrid.wgsl`). Both mirror the CPU code operation for
//! operation, so results agree to rounding.

mod bands;
mod jacobi;
mod multigrid;
mod post;

pub(super) use jacobi::jacobi;
pub(super) use multigrid::{multigrid, smooths_in_tiles};
pub(super) use post::{post_filter, post_filter_on};

use crate::gpu::{GpuContext, GpuError, Shader};

/// Side of the square workgroups every diffusion kernel uses.
const WORKGROUP: u32 = 16;

/// The kernels, built once per device by [`crate::gpu::GpuContext::pipelines`].
const JACOBI: Shader = Shader {
    name: "jacobi.wgsl",
    source: include_str!("../../../shaders/jacobi.wgsl"),
};
const MULTIGRID: Shader = Shader {
    name: "multigrid.wgsl",
    source: include_str!("../../../shaders/multigrid.wgsl"),
};
const POSTFILTER: Shader = Shader {
    name: "postfilter.wgsl",
    source: include_str!("../../../shaders/postfilter.wgsl"),
};

/// Builds every diffusion kernel on `gpu` now, e.g. at start-up, so the first solve does
/// not pay for them. Later calls cost a few map lookups.
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&JACOBI, jacobi::ENTRIES).await?;
    gpu.pipelines(&MULTIGRID, multigrid::ENTRIES).await?;
    gpu.pipelines(&POSTFILTER, post::ENTRIES).await?;
    Ok(())
}

/// A bind group of whole buffers at bindings `(index, buffer)` for `pipeline`'s group 0.
fn bind(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    crate::gpu::bind_buffers(device, pipeline, "diffusion", entries)
}
