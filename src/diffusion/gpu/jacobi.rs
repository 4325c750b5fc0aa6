//! The Jacobi sweep on the GPU (`shaders/jacobi.wgsl`).
//!
//! Buffers: two `f32` fields (ping-pong), the fixed-cell bit mask and a uniform with the
//! size; one dispatch of 16 x 16 workgroups per sweep. Sweeps are submitted in batches so a
//! browser's GPU watchdog never sees one huge submission, and between batches the job
//! awaits the queue (never blocking the browser), reports progress and honours cancel.

use wgpu::util::DeviceExt;

use super::WORKGROUP;
use crate::diffusion::{Constraints, DiffusionError};
use crate::gpu::{GpuContext, GpuError, read_f32_buffer, wait_for_submitted_work};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

const SHADER: &str = include_str!("../../../shaders/jacobi.wgsl");

/// Cell updates per submission: keeps each submission well under a second on slow GPUs.
const CELLS_PER_SUBMIT: u64 = 1 << 26;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    _pad: [u32; 2],
}

pub(in crate::diffusion) async fn jacobi(
    gpu: &GpuContext,
    problem: &Constraints,
    sweeps: u32,
    ctx: &JobCtx,
) -> Result<Heightfield, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    gpu.check_field(w, h)?;
    let device = &gpu.device;

    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("jacobi.wgsl"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("jacobi sweep"),
        layout: None,
        module: &module,
        entry_point: Some("jacobi_sweep"),
        compilation_options: Default::default(),
        cache: None,
    });
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("jacobi params"),
        contents: bytemuck::bytes_of(&Params {
            width: w as u32,
            height: h as u32,
            _pad: [0; 2],
        }),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let fixed = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("fixed cells"),
        contents: bytemuck::cast_slice(problem.fixed().words()),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let field_usage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let fields = [0, 1].map(|k| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(if k == 0 { "field a" } else { "field b" }),
            contents: bytemuck::cast_slice(problem.initial().data()),
            usage: field_usage,
        })
    });
    let layout = pipeline.get_bind_group_layout(0);
    // bind_groups[k] reads fields[k] and writes fields[1 - k].
    let bind_groups = [0usize, 1].map(|k| {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("jacobi ping-pong"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: fixed.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: fields[k].as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: fields[1 - k].as_entire_binding(),
                },
            ],
        })
    });
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }

    let groups = (
        (w as u32).div_ceil(WORKGROUP),
        (h as u32).div_ceil(WORKGROUP),
    );
    let per_submit = (CELLS_PER_SUBMIT / (w * h) as u64).clamp(1, 4096) as u32;
    let mut done = 0u32;
    while done < sweeps {
        let batch = per_submit.min(sweeps - done);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("jacobi sweeps"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("jacobi sweeps"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            for s in done..done + batch {
                pass.set_bind_group(0, &bind_groups[(s % 2) as usize], &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        if let Some(err) = scope.pop().await {
            return Err(GpuError::Validation(err.to_string()).into());
        }
        wait_for_submitted_work(gpu).await?;
        done += batch;
        ctx.checkpoint(
            done as f32 / sweeps.max(1) as f32,
            &format!("Jacobi sweep {done} of {sweeps} (GPU)"),
        )
        .await?;
    }

    // After an even number of sweeps the latest values are in fields[0].
    let latest = &fields[(sweeps % 2) as usize];
    let data = read_f32_buffer(gpu, latest, w * h).await?;
    Ok(Heightfield::from_vec(w, h, data).map_err(|e| GpuError::Readback(e.to_string()))?)
}
