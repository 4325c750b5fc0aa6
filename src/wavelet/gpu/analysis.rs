//! The wavelet statistics on the GPU (`shaders/wavelet_analysis.wgsl`): the forward
//! transform, the global analysis (GSA, eqs. 6-7) and, at the local scope, the per-cell fits
//! (LSA, eq. 8) and the standard-deviation tables the synthesis reads, all from the source
//! buffer the synthesis uses too. The tables never leave the GPU.
//!
//! Sequence (one submission each, then a small read of per-workgroup sums):
//! 1. copy the source, lift it forward over every level it allows (wavelet.wgsl's `lift`
//!    with the CPU's steps; their coefficients are powers of two, so a fused multiply-add
//!    rounds as the CPU's multiply and add do), `energy` per level; read the sums: the CPU adds
//!    them in f64 and fits the lines ([`Analysis::from_energies`]), as the CPU path does;
//! 2. local scope: `window_rows` and `window_logs` per band and analysed level, then
//!    `slope_stats`; read the sums: the shrinkage's centre and kept share per band
//!    ([`LocalDesign::shrinkage`]);
//! 3. `local_sigma`; read the calibration sums (not as written); `sigma_finish`.
//!
//! So the global scope reads back once and the local scope three times (twice with eq. 8 as
//! written, which has no calibration), each time a few floats per 256 cells, however many
//! levels are analysed. Sums of squares run in f32 within a workgroup and in f64 across
//! them, so the statistics agree with the CPU's within float rounding (`tests/gpu_wavelet.rs`;
//! f32 squares limit heights to about 1e19, and the shrinkage's spread `E[s^2] - E[s]^2` from
//! f32 sums loses digits only when the slopes barely vary, where the shrinkage keeps little
//! of them anyway). Cost: O(source cells x (levels + window)) work.

use wgpu::util::DeviceExt;

use super::{Params as SynthesisParams, SHADER as SYNTHESIS_SHADER, gpu_err, lift_steps};
use crate::gpu::{GpuContext, GpuError, Shader, bind_buffers, read_f32_buffer};
use crate::wavelet::WaveletError;
use crate::wavelet::analysis::MAX_LOCAL_GAMMA;
use crate::wavelet::analysis::{Analysis, AnalysisParams, LocalDesign};
use crate::wavelet::lifting::{self, Band};
use crate::wavelet::synthesis::{self, AmplifyFailure, AmplifyParams, Scope, SigmaTables};

pub(super) const SHADER: Shader = Shader {
    name: "wavelet_analysis.wgsl",
    source: include_str!("../../../shaders/wavelet_analysis.wgsl"),
};

/// The entry points, in the order of [`statistics`].
pub(super) const ENTRIES: [&str; 6] = [
    "energy",
    "window_rows",
    "window_logs",
    "slope_stats",
    "local_sigma",
    "sigma_finish",
];

const WORKGROUP: u32 = 16;
/// Analysed levels a local fit may use on the GPU (the shader's table size).
const MAX_FIT_LEVELS: u32 = 16;

/// Largest height magnitude (metres) the kernels take. A detail coefficient is at most about
/// 4 times it; its square (1.6e25), summed over a window of 65^2 coefficients and scaled by
/// the 16th level's squared normalisation (2^30), stays below f32's 3.4e38.
pub const MAX_HEIGHT: f32 = 1e12;
/// Per-workgroup sums the kernels write at most (3 bands x 3 new levels), the tables'
/// count: `MAX_SUMS` in the shader and the size of `Params::tables`.
const MAX_SUMS: usize = 9;
const _: () = assert!(MAX_SUMS == 3 * synthesis::MAX_LEVELS as usize);

/// Mirrors `Params` in `wavelet_analysis.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    stride: u32,
    px: u32,
    py: u32,
    nx: u32,
    ny: u32,
    window: u32,
    offset: u32,
    levels: u32,
    new_levels: u32,
    as_written: u32,
    floor: f32,
    bias: f32,
    norm2: f32,
    mean_depth: f32,
    sxx: f32,
    partial_offset: u32,
    _pad: [u32; 2],
    geometry: [[u32; 4]; 48],
    shrink: [[f32; 4]; 3],
    tables: [[f32; 4]; 9],
}

/// Standard deviations of the new coefficients, as the synthesis's `fill` reads them.
pub(super) enum Sigmas {
    /// One per new level and band (global scope): `(k - 1) * 3 + band`.
    Global(Vec<f32>),
    /// `3 K` tables of one value per source cell, on the GPU (local scope).
    PerCell(wgpu::Buffer),
}

/// The global analysis and the synthesis's standard deviations.
pub(super) struct Statistics {
    pub analysis: Analysis,
    pub sigmas: Sigmas,
}

/// Builds the analysis kernels on `gpu` now.
pub(super) async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&SHADER, ENTRIES).await.map(|_| ())
}

/// Workgroups covering an `nx x ny` grid.
fn groups(nx: usize, ny: usize) -> (u32, u32) {
    (
        (nx as u32).div_ceil(WORKGROUP),
        (ny as u32).div_ceil(WORKGROUP),
    )
}

/// Coefficients of a band of parity `p` along an axis of `n` sub-grid samples.
fn band_len(n: usize, p: usize) -> usize {
    if p == 0 { n.div_ceil(2) } else { n / 2 }
}

/// The per-workgroup sums in `partials` (`count` lanes per workgroup) added per lane in f64.
fn lane_sums(partials: &[f32], count: usize) -> Vec<f64> {
    let mut sums = vec![0.0f64; count];
    for chunk in partials.chunks_exact(count) {
        for (sum, v) in sums.iter_mut().zip(chunk) {
            *sum += f64::from(*v);
        }
    }
    sums
}

/// Pops `scope`, a validation error becoming a [`GpuError`]. The scopes here only span work
/// recorded without waiting: in the page other jobs push and pop scopes of their own while
/// this one waits for a readback, and WebGPU's scopes must be popped in reverse order.
async fn close(scope: wgpu::ErrorScopeGuard) -> Result<(), GpuError> {
    match scope.pop().await {
        Some(err) => Err(GpuError::Validation(err.to_string())),
        None => Ok(()),
    }
}

/// The dispatches of one submission, recorded in order into one compute pass.
struct Batch<'a> {
    gpu: &'a GpuContext,
    encoder: wgpu::CommandEncoder,
    work: Vec<(wgpu::ComputePipeline, wgpu::BindGroup, (u32, u32))>,
}

impl<'a> Batch<'a> {
    fn new(gpu: &'a GpuContext) -> Self {
        let encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wavelet analysis"),
            });
        Self {
            gpu,
            encoder,
            work: Vec::new(),
        }
    }

    fn push(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        uniform: &[u8],
        buffers: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) {
        let params = self
            .gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("wavelet analysis params"),
                contents: uniform,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let mut entries = vec![(0, &params)];
        entries.extend_from_slice(buffers);
        let group = bind_buffers(&self.gpu.device, pipeline, "wavelet analysis", &entries);
        self.work.push((pipeline.clone(), group, groups));
    }

    fn submit(mut self) {
        {
            let mut pass = self
                .encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wavelet analysis"),
                    timestamp_writes: None,
                });
            for (pipeline, group, (gx, gy)) in &self.work {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(*gx, *gy, 1);
            }
        }
        self.gpu.submit(self.encoder.finish());
    }
}

fn storage(gpu: &GpuContext, label: &str, floats: usize, copy_src: bool) -> wgpu::Buffer {
    let mut usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
    if copy_src {
        usage |= wgpu::BufferUsages::COPY_SRC;
    }
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (floats.max(1) * 4) as u64,
        usage,
        mapped_at_creation: false,
    })
}

/// Workgroups of the `energy` kernel at each of `levels` levels of a `width x height` grid.
fn energy_groups((width, height): (usize, usize), levels: u32) -> Vec<(u32, u32)> {
    (0..levels)
        .map(|t| {
            let s = 1usize << t;
            groups(lifting::count_at(width, s), lifting::count_at(height, s))
        })
        .collect()
}

/// The per-workgroup sums the energies of `levels` levels need.
fn energy_floats(size: (usize, usize), levels: u32) -> usize {
    energy_groups(size, levels)
        .iter()
        .map(|(gx, gy)| (gx * gy) as usize * 3)
        .sum()
}

/// The forward transform of the `width x height` field in `source` over `levels` levels
/// (seed 001's CDF 5/3 lifting, the CPU's steps) in a new buffer, and GSA steps 1-2 (eqs.
/// 6-7) from its levels' energies: one submission, then one read of per-workgroup sums
/// (`partials` holds [`energy_floats`]), added in f64 on the CPU.
async fn forward_and_energies(
    gpu: &GpuContext,
    (lift, energy): (&wgpu::ComputePipeline, &wgpu::ComputePipeline),
    source: &wgpu::Buffer,
    (width, height): (usize, usize),
    levels: u32,
    analysis_params: &AnalysisParams,
    partials: &wgpu::Buffer,
) -> Result<(wgpu::Buffer, Analysis), GpuError> {
    let cells = width * height;
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let data = storage(gpu, "wavelet analysis transform", cells, false);
    let energy_groups = energy_groups((width, height), levels);
    let energy_floats = energy_floats((width, height), levels);
    let mut batch = Batch::new(gpu);
    batch
        .encoder
        .copy_buffer_to_buffer(source, 0, &data, 0, (cells * 4) as u64);
    for t in 0..levels {
        for step in lift_steps(1 << t, true) {
            let p = SynthesisParams {
                out_w: width as u32,
                out_h: height as u32,
                ..step
            };
            let n = |len: usize| groups(lifting::count_at(len, p.stride as usize), 1).0;
            batch.push(
                lift,
                bytemuck::bytes_of(&p),
                &[(4, &data)],
                (n(width), n(height)),
            );
        }
    }
    let mut offset = 0u32;
    for (t, &(gx, gy)) in energy_groups.iter().enumerate() {
        let s = 1usize << t;
        let p = Params {
            width: width as u32,
            height: height as u32,
            stride: s as u32,
            nx: lifting::count_at(width, s) as u32,
            ny: lifting::count_at(height, s) as u32,
            partial_offset: offset,
            ..bytemuck::Zeroable::zeroed()
        };
        batch.push(
            energy,
            bytemuck::bytes_of(&p),
            &[(1, &data), (4, partials)],
            (gx, gy),
        );
        offset += gx * gy * 3;
    }
    batch.submit();
    close(scope).await?;
    let sums = read_f32_buffer(gpu, partials, energy_floats).await?;
    let mut energies = Vec::with_capacity(levels as usize);
    let mut start = 0;
    for (depth, &(gx, gy)) in (1..).zip(&energy_groups) {
        let len = (gx * gy) as usize * 3;
        let raw = lane_sums(&sums[start..start + len], 3);
        start += len;
        energies.push(Band::ALL.map(|band| raw[band.index()] * band.normalisation(depth).powi(2)));
    }
    let analysis = Analysis::from_energies(width, height, &energies, analysis_params);
    Ok((data, analysis))
}

/// The forward transform of the `width x height` field in `source` (a `STORAGE | COPY_SRC`
/// buffer without voids) over every level it allows, on the GPU, with its global analysis
/// (what [`crate::wavelet::analysis::analyze_transformed`] gives, to float rounding): the
/// transform stays on the GPU (`STORAGE`, the CPU's [`lifting::forward`] layout). `None`
/// for a grid too small for two levels. One submission and one small readback.
pub async fn transform(
    gpu: &GpuContext,
    source: &wgpu::Buffer,
    size: (usize, usize),
    analysis_params: &AnalysisParams,
) -> Result<Option<(wgpu::Buffer, Analysis)>, GpuError> {
    let levels = lifting::max_levels(size.0, size.1);
    if levels < 2 {
        return Ok(None);
    }
    let [lift] = gpu.pipelines(&SYNTHESIS_SHADER, ["lift"]).await?;
    let [energy] = gpu.pipelines(&SHADER, ["energy"]).await?;
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let partials = storage(
        gpu,
        "wavelet analysis sums",
        energy_floats(size, levels),
        true,
    );
    close(scope).await?;
    forward_and_energies(
        gpu,
        (&lift, &energy),
        source,
        size,
        levels,
        analysis_params,
        &partials,
    )
    .await
    .map(Some)
}

/// The statistics of the `width x height` source in `source` (a `STORAGE | COPY_SRC`
/// buffer) for `params`, over `levels` analysed levels (see
/// [`crate::wavelet::analysis::analysable_levels`]). `None` where the local fit asks for more
/// levels than the kernels hold: the caller computes the statistics on the CPU.
pub(super) async fn statistics(
    gpu: &GpuContext,
    source: &wgpu::Buffer,
    (width, height): (usize, usize),
    levels: u32,
    params: &AmplifyParams,
) -> Result<Option<Statistics>, AmplifyFailure> {
    if !(1..=synthesis::MAX_LEVELS).contains(&params.levels) {
        return Err(crate::wavelet::WaveletError::Levels(params.levels).into());
    }
    let local = match params.scope {
        Scope::Global => None,
        Scope::Local(local) => {
            let design = LocalDesign::new(levels, &local);
            if design.levels > MAX_FIT_LEVELS {
                return Ok(None);
            }
            Some((local, design))
        }
    };
    let [lift] = gpu
        .pipelines(&SYNTHESIS_SHADER, ["lift"])
        .await
        .map_err(gpu_err)?;
    let kernels = gpu.pipelines(&SHADER, ENTRIES).await.map_err(gpu_err)?;

    // 1. Forward transform and the levels' energies.
    let cells = width * height;
    let (cx, cy) = groups(width, height);
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let partials = storage(
        gpu,
        "wavelet analysis sums",
        energy_floats((width, height), levels).max((cx * cy) as usize * MAX_SUMS),
        true,
    );
    close(scope).await.map_err(gpu_err)?;
    let (data, analysis) = forward_and_energies(
        gpu,
        (&lift, &kernels[0]),
        source,
        (width, height),
        levels,
        &params.analysis,
        &partials,
    )
    .await
    .map_err(gpu_err)?;

    let Some((local, design)) = local else {
        let tables = SigmaTables::build(&analysis, None, params.levels, width, height);
        let sigmas = tables.tables.iter().map(|t| t[0]).collect();
        return Ok(Some(Statistics {
            analysis,
            sigmas: Sigmas::Global(sigmas),
        }));
    };

    // 2. Windowed log-variances per band and level, then the raw slopes' spread.
    let mut geometry = [[0u32; 4]; 48];
    let mut logs_len = 0usize;
    let mut rows_len = 1usize;
    for band in Band::ALL {
        let (px, py) = band.parities();
        for d in 1..=design.levels {
            let s = 1usize << (d - 1);
            let nx = band_len(lifting::count_at(width, s), px);
            let ny = band_len(lifting::count_at(height, s), py);
            geometry[band.index() * MAX_FIT_LEVELS as usize + d as usize - 1] =
                [nx as u32, ny as u32, logs_len as u32, s as u32];
            logs_len += nx * ny;
            rows_len = rows_len.max(nx * ny);
        }
    }
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let rows = storage(gpu, "wavelet analysis window rows", rows_len, false);
    let logs = storage(gpu, "wavelet analysis window logs", logs_len, false);
    let fit_base = Params {
        width: width as u32,
        height: height as u32,
        window: design.window as u32,
        levels: design.levels,
        new_levels: params.levels,
        as_written: u32::from(local.as_written),
        bias: design.log_bias as f32,
        mean_depth: design.mean_depth as f32,
        sxx: design.sxx as f32,
        geometry,
        ..bytemuck::Zeroable::zeroed()
    };
    let mut batch = Batch::new(gpu);
    for band in Band::ALL {
        let (px, py) = band.parities();
        for d in 1..=design.levels {
            let [nx, ny, offset, stride] =
                geometry[band.index() * MAX_FIT_LEVELS as usize + d as usize - 1];
            let p = Params {
                stride,
                px: px as u32,
                py: py as u32,
                nx,
                ny,
                offset,
                floor: LocalDesign::floor(&analysis, d, band.index()) as f32,
                norm2: band.normalisation(d as i32).powi(2) as f32,
                ..fit_base
            };
            let g = groups(nx as usize, ny as usize);
            batch.push(
                &kernels[1],
                bytemuck::bytes_of(&p),
                &[(1, &data), (2, &rows)],
                g,
            );
            batch.push(
                &kernels[2],
                bytemuck::bytes_of(&p),
                &[(2, &rows), (3, &logs)],
                g,
            );
        }
    }
    batch.push(
        &kernels[3],
        bytemuck::bytes_of(&fit_base),
        &[(3, &logs), (4, &partials)],
        (cx, cy),
    );
    batch.submit();
    close(scope).await.map_err(gpu_err)?;
    let slope_floats = (cx * cy) as usize * 6;
    let sums = read_f32_buffer(gpu, &partials, slope_floats)
        .await
        .map_err(gpu_err)?;
    let sums = lane_sums(&sums, 6);
    drop((data, rows));

    // 3. Eq. 8 per cell and new level; calibration of each level's mean energy.
    let mut shrink = [[0f32; 4]; 3];
    for band in Band::ALL {
        let b = band.index();
        let (centre, keep) =
            design.shrinkage(&analysis, b, sums[2 * b], sums[2 * b + 1], cells as f64);
        shrink[b] = [
            centre as f32,
            keep as f32,
            if analysis.fits[b].is_some() { 1.0 } else { 0.0 },
            MAX_LOCAL_GAMMA as f32,
        ];
    }
    let mut tables = [[0f32; 4]; 9];
    for k in 1..=params.levels {
        let depth = 1 - k as i32;
        for band in Band::ALL {
            let reference = analysis.fits[band.index()].map_or(0.0, |l| l.log2_variance(depth));
            tables[(k as usize - 1) * 3 + band.index()] =
                [reference as f32, 0.0, band.normalisation(depth) as f32, 0.0];
        }
    }
    let table_count = 3 * params.levels as usize;
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let sigma = storage(gpu, "wavelet sigma", table_count * cells, true);
    let sigma_params = Params {
        shrink,
        tables,
        ..fit_base
    };
    let mut batch = Batch::new(gpu);
    batch.push(
        &kernels[4],
        bytemuck::bytes_of(&sigma_params),
        &[(3, &logs), (4, &partials), (5, &sigma)],
        (cx, cy),
    );
    batch.submit();
    close(scope).await.map_err(gpu_err)?;
    if !local.as_written {
        let sums = read_f32_buffer(gpu, &partials, (cx * cy) as usize * table_count)
            .await
            .map_err(gpu_err)?;
        for (t, sum) in lane_sums(&sums, table_count).into_iter().enumerate() {
            // Each level's mean of 2^(log2 var - line) over the map; the shift brings it to 1.
            tables[t][1] = -(sum / cells as f64).max(1e-300).log2() as f32;
        }
        let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut batch = Batch::new(gpu);
        batch.push(
            &kernels[5],
            bytemuck::bytes_of(&Params {
                tables,
                ..sigma_params
            }),
            &[(5, &sigma)],
            (cx, cy),
        );
        batch.submit();
        close(scope).await.map_err(gpu_err)?;
    }
    Ok(Some(Statistics {
        analysis,
        sigmas: Sigmas::PerCell(sigma),
    }))
}

/// Reads the per-cell tables back in the CPU's layout (tests compare them with
/// [`crate::wavelet::synthesis::prepare`]).
pub(super) async fn read_tables(
    gpu: &GpuContext,
    statistics: &Statistics,
    levels: u32,
    (width, height): (usize, usize),
) -> Result<SigmaTables, WaveletError> {
    let tables = match &statistics.sigmas {
        Sigmas::Global(values) => values.iter().map(|v| vec![*v]).collect(),
        Sigmas::PerCell(buffer) => {
            let cells = width * height;
            let data = read_f32_buffer(gpu, buffer, 3 * levels as usize * cells)
                .await
                .map_err(|e| WaveletError::Gpu(e.to_string()))?;
            data.chunks_exact(cells).map(<[f32]>::to_vec).collect()
        }
    };
    Ok(SigmaTables {
        levels,
        tables,
        source_width: width,
        source_height: height,
    })
}
