//! The post-filters on the GPU (`shaders/postfilter.wgsl`): two blur passes and one combine
//! pass (fBm in WGSL from the CPU's permutation table), in one submission.

use wgpu::util::DeviceExt;

use super::{POSTFILTER, WORKGROUP, bind};
use crate::diffusion::post::{PostFilter, gaussian_taps};
use crate::gpu::{GpuContext, GpuError, GpuField};
use crate::heightfield::Heightfield;
use crate::noise::Perlin;

/// The entry points, in the order `post_filter` takes them.
pub(super) const ENTRIES: [&str; 3] = ["blur_x", "blur_y", "combine"];

#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    w: u32,
    h: u32,
    radius: u32,
    smooth: u32,
    amplitude: f32,
    frequency: f32,
    octaves: u32,
    roughness: f32,
    _pad: [u32; 4],
}

/// [`crate::diffusion::post::apply_cpu`] on the GPU: one upload, one readback.
pub async fn post_filter(
    gpu: &GpuContext,
    field: &Heightfield,
    weights: &[f32],
    filter: &PostFilter,
    seed: u64,
) -> Result<Heightfield, GpuError> {
    let (w, h) = (field.width(), field.height());
    gpu.check_field(w, h)?;
    let buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("post field"),
            contents: bytemuck::cast_slice(field.data()),
            usage: wgpu::BufferUsages::STORAGE,
        });
    let input = GpuField::new(gpu, buffer, w, h);
    post_filter_on(gpu, &input, weights, filter, seed)
        .await?
        .read(gpu)
        .await
}

/// [`post_filter`] of a field already on the GPU, into a new one there (no transfer but
/// the small tables).
pub async fn post_filter_on(
    gpu: &GpuContext,
    input: &GpuField,
    weights: &[f32],
    filter: &PostFilter,
    seed: u64,
) -> Result<GpuField, GpuError> {
    let (w, h) = (input.width, input.height);
    gpu.check_field(w, h)?;
    let smooth = filter.smooth_sigma > 0.0;
    let taps = if smooth {
        gaussian_taps(filter.smooth_sigma)
    } else {
        vec![1.0]
    };
    let perm: Vec<u32> = Perlin::new(seed)
        .permutation()
        .iter()
        .map(|&p| u32::from(p))
        .collect();
    let params = Params {
        w: w as u32,
        h: h as u32,
        radius: (taps.len() / 2) as u32,
        smooth: u32::from(smooth),
        amplitude: filter.fbm_amplitude,
        frequency: filter.fbm_frequency,
        octaves: filter.fbm_octaves,
        roughness: filter.fbm_roughness,
        _pad: [0; 4],
    };

    let device = &gpu.device;
    let [blur_x, blur_y, combine] = gpu.pipelines(&POSTFILTER, ENTRIES).await?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let storage = wgpu::BufferUsages::STORAGE;
    let uniform = init(
        "post params",
        bytemuck::bytes_of(&params),
        wgpu::BufferUsages::UNIFORM,
    );
    let u = &input.buffer;
    let taps_buf = init("post taps", bytemuck::cast_slice(&taps), storage);
    let perm_buf = init("post perm", bytemuck::cast_slice(&perm), storage);
    let weights_buf = init("post weights", bytemuck::cast_slice(weights), storage);
    let scratch = |label: &str, usage: wgpu::BufferUsages| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (w * h * 4) as u64,
            usage,
            mapped_at_creation: false,
        })
    };
    let tmp = scratch("post tmp", storage);
    let out = scratch(
        "post out",
        storage | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );

    let x_group = bind(
        device,
        &blur_x,
        &[(0, &uniform), (1, u), (2, &taps_buf), (5, &tmp)],
    );
    let y_group = bind(
        device,
        &blur_y,
        &[(0, &uniform), (2, &taps_buf), (5, &tmp), (6, &out)],
    );
    let c_group = bind(
        device,
        &combine,
        &[
            (0, &uniform),
            (1, u),
            (3, &perm_buf),
            (4, &weights_buf),
            (6, &out),
        ],
    );
    let (gx, gy) = (
        (w as u32).div_ceil(WORKGROUP),
        (h as u32).div_ceil(WORKGROUP),
    );
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("post-filters"),
    });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("post-filters"),
            timestamp_writes: None,
        });
        if smooth {
            pass.set_pipeline(&blur_x);
            pass.set_bind_group(0, &x_group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
            pass.set_pipeline(&blur_y);
            pass.set_bind_group(0, &y_group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        pass.set_pipeline(&combine);
        pass.set_bind_group(0, &c_group, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }
    gpu.submit(encoder.finish());
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()));
    }
    Ok(GpuField::new(gpu, out, w, h))
}
