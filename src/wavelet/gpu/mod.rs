//! The wavelet path on the GPU: the statistics of the source ([`analysis`],
//! `shaders/wavelet_analysis.wgsl`: forward transform, GSA, and at the local scope LSA's
//! per-cell fits and the standard-deviation tables), then the synthesis
//! (`shaders/wavelet.wgsl`): one `fill` dispatch writes the source samples and every
//! synthetic coefficient (same counter-based Gaussians as the CPU, same eq. 9 mask factor),
//! then four `lift` dispatches per new level undo the lifting steps, and (where the device
//! runs the heavy stages) one `detail_rms` dispatch measures the detail ([`rms`]). The
//! source is uploaded once (or read where a previous stage left it on the GPU); the output
//! is read back once and stays on the GPU for the next stage. Results equal the CPU's within float rounding (the
//! GPU's `log`/`exp2`/`cos` are not bit-identical to `libm`'s, and its sums run in f32 within
//! a workgroup).

mod analysis;
mod rms;

pub use analysis::{MAX_HEIGHT, transform};

use wgpu::util::DeviceExt;

use super::analysis::Analysis;
use super::synthesis::{Amplified, AmplifyFailure, AmplifyParams, SigmaTables, check, prepare};
use super::{WaveletError, mask::Mask, rng};
use crate::gpu::{
    GpuContext, GpuError, GpuField, Shader, read_f32_buffer, wait_for_submitted_work,
};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

pub(super) const SHADER: Shader = Shader {
    name: "wavelet.wgsl",
    source: include_str!("../../../shaders/wavelet.wgsl"),
};
const WORKGROUP: u32 = 16;

/// Mirrors `Params` in `wavelet.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct Params {
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

/// Builds the wavelet kernels on `gpu` now (see [`crate::gpu::GpuContext::pipelines`]): the
/// synthesis's and the statistics' (which a software rasteriser runs when every stage is
/// asked of it, see `statistics`).
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&SHADER, ENTRIES).await?;
    analysis::warm(gpu).await?;
    gpu.pipelines(&SHADER, rms::ENTRY).await?;
    Ok(())
}

/// The four lifting steps of one level at `stride`: forward (analysis: along x, predict then
/// update, then along y) or inverse (along y, undo the update then the prediction, then x),
/// as [`crate::wavelet::lifting`] runs them.
pub(super) fn lift_steps(stride: u32, forward: bool) -> [Params; 4] {
    let step = |axis, parity, coef| Params {
        stride,
        axis,
        parity,
        coef,
        ..Default::default()
    };
    if forward {
        [
            step(0, 1, -0.5),
            step(0, 0, 0.25),
            step(1, 1, -0.5),
            step(1, 0, 0.25),
        ]
    } else {
        [
            step(1, 0, -0.25),
            step(1, 1, 0.5),
            step(0, 0, -0.25),
            step(0, 1, 0.5),
        ]
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

pub(super) fn gpu_err(e: GpuError) -> AmplifyFailure {
    AmplifyFailure::Wavelet(WaveletError::Gpu(e.to_string()))
}

/// The source in a storage buffer the analysis and the synthesis both read.
fn upload_source(gpu: &GpuContext, source: &Heightfield) -> wgpu::Buffer {
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("wavelet source"),
            contents: bytemuck::cast_slice(source.data()),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        })
}

/// The statistics of `source` for `params` on the GPU, or on the CPU where a local fit
/// asks for more levels than the kernels hold, and beside a software rasteriser unless every
/// stage was asked of it ([`GpuContext::runs_heavy_stages`]): lavapipe takes about 4 times
/// as long as the CPU for them (the wavelet benchmark in `docs/performance.md`).
async fn statistics(
    gpu: &GpuContext,
    source: &Heightfield,
    source_buf: &wgpu::Buffer,
    params: &AmplifyParams,
) -> Result<analysis::Statistics, AmplifyFailure> {
    statistics_where(gpu, source, source_buf, params, gpu.runs_heavy_stages()).await
}

/// [`statistics`], on the GPU when `on_gpu` (and the kernels hold the fit and the heights).
async fn statistics_where(
    gpu: &GpuContext,
    source: &Heightfield,
    source_buf: &wgpu::Buffer,
    params: &AmplifyParams,
    on_gpu: bool,
) -> Result<analysis::Statistics, AmplifyFailure> {
    let size = (source.width(), source.height());
    if on_gpu && in_range(source) {
        let levels = super::analysis::analysable_levels(source)?;
        if let Some(statistics) =
            analysis::statistics(gpu, source_buf, size, levels, params).await?
        {
            return Ok(statistics);
        }
    }
    let (analysis, tables) = prepare(source, params)?;
    let sigmas = if tables.tables.iter().all(|t| t.len() == 1) {
        analysis::Sigmas::Global(tables.tables.iter().map(|t| t[0]).collect())
    } else {
        // One source-sized table per new level and band, a band without a fit repeated.
        let cells = size.0 * size.1;
        let mut data = Vec::with_capacity(tables.tables.len() * cells);
        for table in &tables.tables {
            match table.as_slice() {
                [one] => data.resize(data.len() + cells, *one),
                all => data.extend_from_slice(all),
            }
        }
        analysis::Sigmas::PerCell(gpu.device.create_buffer_init(
            &wgpu::util::BufferInitDescriptor {
                label: Some("wavelet sigma"),
                contents: bytemuck::cast_slice(&data),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            },
        ))
    };
    Ok(analysis::Statistics { analysis, sigmas })
}

/// Whether the kernels' f32 sums of squares hold `source`'s heights: those beyond
/// `MAX_HEIGHT` (no terrain, but a mis-scaled or hostile file) could overflow them, so they
/// take the CPU's f64 sums. (Voids are refused by either path.)
fn in_range(source: &Heightfield) -> bool {
    source
        .finite_range()
        .is_some_and(|(lo, hi)| lo.abs().max(hi.abs()) <= analysis::MAX_HEIGHT)
}

/// The global analysis and the standard-deviation tables of the synthesis, computed on the
/// GPU (software rasteriser or not) and read back in [`super::synthesis::prepare`]'s
/// layout (tests hold the two to each other).
pub async fn prepare_on_gpu(
    gpu: &GpuContext,
    source: &Heightfield,
    params: &AmplifyParams,
) -> Result<(Analysis, SigmaTables), AmplifyFailure> {
    let (ow, oh) = check(source, params)?;
    // The tables are smaller than the output (3 K source-sized tables against 4^K).
    gpu.check_field(ow, oh).map_err(gpu_err)?;
    let source_buf = upload_source(gpu, source);
    let statistics = statistics_where(gpu, source, &source_buf, params, true).await?;
    let size = (source.width(), source.height());
    let tables = analysis::read_tables(gpu, &statistics, params.levels, size).await?;
    Ok((statistics.analysis, tables))
}

/// [`super::amplify`] on the GPU.
pub async fn amplify(
    gpu: &GpuContext,
    source: &Heightfield,
    on_gpu: Option<&GpuField>,
    params: &AmplifyParams,
    mask: Option<&Mask>,
    ctx: &JobCtx,
) -> Result<Amplified, AmplifyFailure> {
    let (ow, oh) = check(source, params)?;
    gpu.check_field(ow, oh).map_err(gpu_err)?;
    ctx.checkpoint(0.0, "analysing the wavelet statistics (GPU)")
        .await?;
    let mut clock = web_time::Instant::now();
    // A previous stage's output on this device is the source as it is: no upload.
    let source_buf = match on_gpu {
        Some(f) if f.is_on(gpu, source.width(), source.height()) => f.buffer.clone(),
        _ => upload_source(gpu, source),
    };
    let statistics = statistics(gpu, source, &source_buf, params).await?;
    let analysis_ms = super::synthesis::lap(&mut clock);
    ctx.checkpoint(0.2, "drawing detail coefficients (GPU)")
        .await?;
    let (sw, sh) = (source.width(), source.height());
    let mask = mask.filter(|m| !m.is_clear());
    let (mask_data, mask_w, mask_h) = match mask {
        Some(m) => (m.values().to_vec(), m.width(), m.height()),
        None => (vec![0.0], 1, 1),
    };
    let device = &gpu.device;
    let (sigma_buf, per_cell) = match statistics.sigmas {
        analysis::Sigmas::Global(values) => (
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("wavelet sigma"),
                contents: bytemuck::cast_slice(&values),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            false,
        ),
        analysis::Sigmas::PerCell(buffer) => (buffer, true),
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

    let [fill, lift] = gpu.pipelines(&SHADER, ENTRIES).await.map_err(gpu_err)?;
    // The detail's RMS beside the synthesis where the device runs the heavy stages (as the
    // statistics) and the heights are in the f32 sums' range; elsewhere the caller measures
    // it on the CPU.
    let rms_kernel = if gpu.runs_heavy_stages() && in_range(source) {
        Some(gpu.pipelines(&SHADER, rms::ENTRY).await.map_err(gpu_err)?)
    } else {
        None
    };
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mask_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("wavelet mask"),
        contents: bytemuck::cast_slice(&mask_data),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("wavelet output"),
        size: (ow * oh * 4) as u64,
        // A [`GpuField`] once done: the next stage may copy into one like it.
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
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
    // Inverse lifting, coarsest new level first.
    let mut lifts = Vec::new();
    for t in (0..params.levels).rev() {
        let stride = 1u32 << t;
        for step in lift_steps(stride, false) {
            let p = Params {
                stride: step.stride,
                axis: step.axis,
                parity: step.parity,
                coef: step.coef,
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
    let measure = rms_kernel.map(|[kernel]| {
        let inputs = rms::Inputs {
            params: &fill_params,
            source: &source_buf,
            mask: &mask_buf,
            out: &out,
        };
        rms::Measure::new(gpu, kernel, &inputs, ow, oh)
    });
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
        if let Some(measure) = &measure {
            measure.record(&mut pass);
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
    let rms = match &measure {
        Some(m) => m.read(gpu).await.map_err(gpu_err)?,
        None => None,
    };
    // The GPU's fill and lifting run in one submission: all of it counts as `inverse`.
    let timings = super::synthesis::Timings {
        analysis: analysis_ms,
        fill: 0.0,
        inverse: super::synthesis::lap(&mut clock),
    };
    Ok(Amplified {
        field,
        analysis: statistics.analysis,
        timings,
        gpu: Some(GpuField::new(gpu, out, ow, oh)),
        rms,
    })
}
