//! The diffusion kernels on the GPU: the paper's Jacobi sweep (`shaders/jacobi.wgsl`) and
//! the multigrid solver (`shaders/multigrid.wgsl`). Both mirror the CPU code operation for
//! operation, so results agree to rounding.

mod bands;
mod jacobi;
mod multigrid;
mod post;

pub(super) use jacobi::jacobi;
pub(super) use multigrid::multigrid;
pub(super) use post::post_filter;

/// Side of the square workgroups every diffusion kernel uses.
const WORKGROUP: u32 = 16;

/// Builds a compute pipeline for `entry` of `module` with the layout derived from the shader.
fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A bind group of whole buffers at bindings `(index, buffer)` for `pipeline`'s group 0.
fn bind(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<_> = entries
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}
