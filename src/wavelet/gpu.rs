//! The synthesis and inverse transform on the GPU (`shaders/wavelet.wgsl`): one `fill`
//! dispatch writes the source samples and every synthetic coefficient (same counter-based
//! Gaussians as the CPU, same eq. 9 mask factor), then four `lift` dispatches per new level
//! undo the lifting steps. The statistics (analysis, local fits) stay on the CPU: they work on
//! the source, a `4^K`-th of the output. Results equal the CPU's within float rounding (the
//! GPU's `log`/`cos` are not bit-identical to `libm`'s).

use wgpu::util::DeviceExt;

use super::synthesis::{Amplified, AmplifyFailure, AmplifyParams, check, prepare};
use super::{WaveletError, mask::Mask, rng};
use crate::gpu::{GpuContext, GpuError, Shader, read_f32_buffer, wait_for_submitted_work};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

const SHADER: Shader = Shader {
    name: "wavelet.wgsl",
    source: include_str!("../../shaders/wavelet.wgsl"),
};
const WORKGROUP: u32 = 16;

#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    out_w: u32,
    out_h: u32,
    src_w: u32,
    src_h: u32,
    levels: u32,
    key: u32,
    has_mask: u32,
    mask_w: u32,
    mask_h: u32,
    stride: u32,
    axis: u32,
    parity: u32,
    coef: f32,
    sigma_per_cell: u32,
    _pad: [u32; 2],
}

/// The entry points: the synthesis fill, then the inverse lifting steps.
const ENTRIES: [&str; 2] = ["fill", "lift"];

/// Builds the wavelet kernels on `gpu` now (see [`crate::gpu::GpuContext::pipelines`]).
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&SHADER, ENTRIES).await.map(|_| ())
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

fn gpu_err(e: GpuError) -> AmplifyFailure {
    AmplifyFailure::Wavelet(WaveletError::Gpu(e.to_string()))
}

/// [`super::amplify`] on the GPU.
pub async fn amplify(
    gpu: &GpuContext,
    source: &Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
    ctx: &JobCtx,
) -> Result<Amplified, AmplifyFailure> {
    let (ow, oh) = check(source, params)?;
    gpu.check_field(ow, oh).map_err(gpu_err)?;
    ctx.checkpoint(0.0, "analysing the wavelet statistics")
        .await?;
    let mut clock = web_time::Instant::now();
    let (analysis, sigma) = prepare(source, params)?;
    let analysis_ms = super::synthesis::lap(&mut clock);
    ctx.checkpoint(0.2, "drawing detail coefficients (GPU)")
        .await?;
    let (sw, sh) = (source.width(), source.height());
    let per_cell = sigma.tables.iter().any(|t| t.len() > 1);
    let sigma_data: Vec<f32> = if per_cell {
        sigma
            .tables
            .iter()
            .flat_map(|t| {
                if t.len() == 1 {
                    vec![t[0]; sw * sh]
                } else {
                    t.clone()
                }
            })
            .collect()
    } else {
        sigma.tables.iter().map(|t| t[0]).collect()
    };
    let mask = mask.filter(|m| !m.is_clear());
    let (mask_data, mask_w, mask_h) = match mask {
        Some(m) => (m.values().to_vec(), m.width(), m.height()),
        None => (vec![0.0], 1, 1),
    };
    let base = Params {
        out_w: ow as u32,
        out_h: oh as u32,
        src_w: sw as u32,
        src_h: sh as u32,
        levels: params.levels,
        key: rng::seed_key(params.seed),
        has_mask: u32::from(mask.is_some()),
        mask_w: mask_w as u32,
        mask_h: mask_h as u32,
        sigma_per_cell: u32::from(per_cell),
        ..Default::default()
    };

    let device = &gpu.device;
    let [fill, lift] = gpu.pipelines(&SHADER, ENTRIES).await.map_err(gpu_err)?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let storage = |label: &str, data: &[f32]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let source_buf = storage("wavelet source", source.data());
    let sigma_buf = storage("wavelet sigma", &sigma_data);
    let mask_buf = storage("wavelet mask", &mask_data);
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("wavelet output"),
        size: (ow * oh * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let uniform = |p: &Params| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("wavelet params"),
            contents: bytemuck::bytes_of(p),
            usage: wgpu::BufferUsages::UNIFORM,
        })
    };
    let fill_params = uniform(&base);
    let fill_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("wavelet fill"),
        layout: &fill.get_bind_group_layout(0),
        entries: &[
            entry(0, &fill_params),
            entry(1, &source_buf),
            entry(2, &sigma_buf),
            entry(3, &mask_buf),
            entry(4, &out),
        ],
    });
    // Inverse lifting, coarsest new level first: along y (update, predict), then along x.
    let mut lifts = Vec::new();
    for t in (0..params.levels).rev() {
        let stride = 1u32 << t;
        for axis in [1u32, 0] {
            for (parity, coef) in [(0u32, -0.25f32), (1, 0.5)] {
                let p = Params {
                    stride,
                    axis,
                    parity,
                    coef,
                    ..base
                };
                let buffer = uniform(&p);
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("wavelet lift"),
                    layout: &lift.get_bind_group_layout(0),
                    entries: &[entry(0, &buffer), entry(4, &out)],
                });
                let n = |len: usize| ((len as u32 - 1) / stride + 1).div_ceil(WORKGROUP);
                lifts.push((buffer, group, n(ow), n(oh)));
            }
        }
    }
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("wavelet synthesis"),
    });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wavelet synthesis"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&fill);
        pass.set_bind_group(0, &fill_group, &[]);
        pass.dispatch_workgroups(
            (ow as u32).div_ceil(WORKGROUP),
            (oh as u32).div_ceil(WORKGROUP),
            1,
        );
        pass.set_pipeline(&lift);
        for (_, group, gx, gy) in &lifts {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(*gx, *gy, 1);
        }
    }
    gpu.submit(encoder.finish());
    if let Some(err) = scope.pop().await {
        return Err(gpu_err(GpuError::Validation(err.to_string())));
    }
    wait_for_submitted_work(gpu).await.map_err(gpu_err)?;
    ctx.checkpoint(0.9, "reading the terrain back from the GPU")
        .await?;
    let data = read_f32_buffer(gpu, &out, ow * oh).await.map_err(gpu_err)?;
    let field =
        Heightfield::from_vec(ow, oh, data).map_err(|e| WaveletError::Internal(e.to_string()))?;
    // The GPU's fill and lifting run in one submission: all of it counts as `inverse`.
    let timings = super::synthesis::Timings {
        analysis: analysis_ms,
        fill: 0.0,
        inverse: super::synthesis::lap(&mut clock),
    };
    Ok(Amplified {
        field,
        analysis,
        timings,
    })
}
