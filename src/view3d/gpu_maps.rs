//! The 3D view's rasters made on the GPU it draws with (`shaders/view3d_maps.wgsl`), for a
//! hardware GPU that computes: the B-spline's control points, the gradients and the roughness
//! are written straight into the textures the renderer binds, and only the control points
//! come back (the camera's ground height and the chunk tree need them on the CPU).
//!
//! What stays on the CPU: reducing a field larger than the texture limit (as in
//! [`super::maps`]), the line fits of `H` from the levels' energies and the chunk tree. What
//! runs on the GPU: the heights' forward wavelet transform and its levels' energies (the
//! wavelet analysis's kernels, [`wavelet::gpu::transform`]: one small readback of sums),
//! the tridiagonal solves (one invocation per row, then per column), the differences and the
//! roughness's 9 x 9 windows of the finest detail squared. The rasters agree with the CPU's
//! to rounding (`tests/view3d.rs`): the solves run in f32 instead of f64, the energies and
//! the windows sum in f32, and the GPU rounds the half floats and the bytes.
//!
//! Cost: O(cells) on the CPU (the height range and the chunk tree), O(cells x 81) on the
//! GPU; the heights go up (unless a GPU stage left the terrain on this GPU, a [`GpuField`],
//! which is read there) and the control points come back.

use thiserror::Error;
use wgpu::util::DeviceExt;

use super::maps::{
    Base, ROUGHNESS_RADIUS, Rasters, TerrainMaps, finest_mean, hurst_from_gamma, roughness_scale,
};
use super::subdivision;
use crate::gpu::{
    GpuContext, GpuError, GpuField, Shader, bind_buffers, padded_row_bytes, read_bytes,
};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::wavelet::{self, AnalysisParams, lifting, lifting::Band};

const SHADER: Shader = Shader {
    name: "view3d_maps.wgsl",
    source: include_str!("../../shaders/view3d_maps.wgsl"),
};

/// The kernels of [`SHADER`], in the order `run` takes them.
const ENTRIES: [&str; 4] = ["spline_rows", "spline_columns", "gradients", "roughness"];

/// The textures [`prepare`] fills, bound by the renderer as they are.
#[derive(Clone, Debug)]
pub struct GpuRasters {
    /// The B-spline control points (`R32Float`).
    pub control: wgpu::Texture,
    /// `(dz/dx, dz/dy)` (`Rg16Float`).
    pub gradients: wgpu::Texture,
    /// Eq. 5's roughness (`R8Unorm`).
    pub roughness: wgpu::Texture,
    /// Whether the heights were read from a stage's GPU copy (else uploaded).
    pub from_gpu_copy: bool,
}

/// Why the GPU did not prepare the maps (the caller prepares them on the CPU instead).
#[derive(Debug, Error)]
pub enum GpuMapsError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    w: u32,
    h: u32,
    control_stride: u32,
    gradient_stride: u32,
    roughness_stride: u32,
    radius: u32,
    cell: f32,
    scale: f32,
    /// The finest level's normalisation by cell parity, `x odd + 2 y odd` (0 on the coarse
    /// cells): the roughness squares the transform's detail times these.
    norms: [f32; 4],
}

/// Whether the app makes the 3D maps on `gpu` rather than on the CPU: on hardware (a
/// software rasteriser runs the transform and the windows slower than the CPU: 4.3 s
/// against 0.6 s at 4096^2 on lavapipe) where the CPU path has one thread (the page). With
/// threads, the CPU path runs everything in bands.
pub fn pays_on(gpu: &GpuContext) -> bool {
    gpu.runs_heavy_stages() && crate::parallel::threads() == 1
}

/// Builds the kernels now (at start-up), so the first terrain does not wait for them.
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&SHADER, ENTRIES).await?;
    Ok(())
}

/// The row stride, in elements of `bytes` each, of `texels` of them in a buffer copied into
/// a texture.
fn stride(texels: usize, bytes: usize) -> usize {
    padded_row_bytes((texels * bytes) as u32) as usize / bytes
}

/// [`TerrainMaps::new`] of `field` on `gpu`, the device the view draws with: the same maps
/// to rounding, with [`Rasters::Gpu`]. `on_gpu`, if given, is `field` on a GPU (a stage's
/// output): used as it is where it is on `gpu` and the maps need it unchanged (no
/// reduction, no void), instead of an upload. A grid too small for a wavelet transform is
/// prepared on the CPU. Checks the job between the steps.
pub async fn prepare(
    gpu: &GpuContext,
    field: &Heightfield,
    on_gpu: Option<&GpuField>,
    cell: f32,
    max_side: usize,
    job: &JobCtx,
) -> Result<TerrainMaps, GpuMapsError> {
    job.checkpoint(0.0, "3D view: surface maps on the GPU")
        .await?;
    // Heights the kernels' f32 sums of squares cannot hold (no terrain, but a mis-scaled or
    // hostile file) take the CPU's f64 sums.
    let range = field.finite_range();
    let in_range = range.is_none_or(|(lo, hi)| lo.abs().max(hi.abs()) <= wavelet::gpu::MAX_HEIGHT);
    if !in_range {
        return Ok(TerrainMaps::new(field, cell, max_side));
    }
    // A stage's copy is used where the maps need the field as it is (not reduced, no void)
    // and the transform can copy it.
    let as_it_is = |f: &&GpuField| {
        f.is_on(gpu, field.width(), field.height())
            && f.buffer.usage().contains(wgpu::BufferUsages::COPY_SRC)
            && Base::factor(field, max_side) == 1
            && field.data().iter().all(|z| z.is_finite())
    };
    // The heights on the GPU: the stage's buffer, or the (reduced, filled) field uploaded;
    // the CPU's copy goes once uploaded (a 4096^2 field is 64 MiB).
    let copy = on_gpu.filter(as_it_is);
    let from_gpu_copy = copy.is_some();
    let (base, heights) = match copy {
        Some(f) => {
            let base = Base::unchanged(field, cell, range);
            gpu.check_field(stride(base.width, 4), base.height)?;
            (base, f.buffer.clone())
        }
        None => {
            let mut base = Base::of(field, cell, max_side);
            if lifting::max_levels(base.width, base.height) < 2 {
                return Ok(TerrainMaps::new(field, cell, max_side));
            }
            gpu.check_field(stride(base.width, 4), base.height)?;
            let heights = std::mem::take(&mut base.heights);
            let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
            let buffer = gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("3D maps heights"),
                    contents: bytemuck::cast_slice(&heights),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                });
            if let Some(err) = scope.pop().await {
                return Err(GpuError::Validation(err.to_string()).into());
            }
            (base, buffer)
        }
    };
    let (w, h) = (base.width, base.height);
    let control_stride = stride(w, 4);
    // H and the roughness's scale from the transform's global analysis (seed 001, eqs. 6-7).
    let Some((transform, analysis)) =
        wavelet::gpu::transform(gpu, &heights, (w, h), &AnalysisParams::default()).await?
    else {
        return Ok(TerrainMaps::new(field, cell, max_side));
    };
    job.checkpoint(0.5, "3D view: surface maps on the GPU")
        .await?;
    let norm = |x_odd, y_odd| Band::at(x_odd, y_odd).map_or(0.0, |b| b.normalisation(1) as f32);
    let params = Params {
        w: w as u32,
        h: h as u32,
        control_stride: control_stride as u32,
        gradient_stride: stride(w, 4) as u32,
        roughness_stride: (stride(w, 1) / 4) as u32,
        radius: ROUGHNESS_RADIUS as u32,
        cell: base.cell,
        // No detail: a roughness of 0 everywhere, as on the CPU.
        scale: roughness_scale(finest_mean(&analysis)).unwrap_or(0.0) as f32,
        norms: [
            norm(false, false),
            norm(true, false),
            norm(false, true),
            norm(true, true),
        ],
    };
    let hurst = hurst_from_gamma(analysis.pooled_gamma());
    let (mut rasters, control) = run(gpu, heights, transform, &params).await?;
    rasters.from_gpu_copy = from_gpu_copy;
    job.checkpoint(0.9, "3D view: surface maps on the GPU")
        .await?;
    Ok(base.finish(Rasters::Gpu(rasters), control, hurst))
}

/// The kernels, the textures and the readback of the control points (unpadded, row-major),
/// from the heights and their forward wavelet transform on the GPU. Every buffer but the
/// control points' is dropped once the work is submitted (wgpu keeps them until the GPU is
/// done with them).
async fn run(
    gpu: &GpuContext,
    heights_buffer: wgpu::Buffer,
    transform: wgpu::Buffer,
    p: &Params,
) -> Result<(GpuRasters, Vec<f32>), GpuError> {
    let [rows, columns, gradients, roughness] = gpu.pipelines(&SHADER, ENTRIES).await?;
    let device = &gpu.device;
    let (w, h) = (p.w as usize, p.h as usize);
    let storage = wgpu::BufferUsages::STORAGE;
    let upload = |label, contents: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: storage,
        })
    };
    let output = |label, bytes: usize| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes as u64,
            usage: storage | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    };
    let factors = |n: usize| -> Vec<f32> {
        let (pivot, upper) = subdivision::thomas_factors(n);
        pivot.iter().chain(&upper).map(|&v| v as f32).collect()
    };
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("3D maps params"),
        contents: bytemuck::bytes_of(p),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let row_factors = upload("3D maps row factors", bytemuck::cast_slice(&factors(w)));
    let column_factors = upload("3D maps column factors", bytemuck::cast_slice(&factors(h)));
    let control_bytes = p.control_stride as usize * h * 4;
    let control = output("3D maps control points", control_bytes);
    let packed_gradients = output("3D maps gradients", p.gradient_stride as usize * h * 4);
    let packed_roughness = output("3D maps roughness", p.roughness_stride as usize * h * 4);

    let bind = |pipeline, entries: &[(u32, &wgpu::Buffer)]| {
        bind_buffers(device, pipeline, "3D maps", entries)
    };
    let groups = [
        bind(
            &rows,
            &[
                (0, &uniform),
                (1, &heights_buffer),
                (2, &control),
                (3, &row_factors),
            ],
        ),
        bind(
            &columns,
            &[(0, &uniform), (2, &control), (4, &column_factors)],
        ),
        bind(
            &gradients,
            &[(0, &uniform), (1, &heights_buffer), (5, &packed_gradients)],
        ),
        bind(
            &roughness,
            &[(0, &uniform), (5, &packed_roughness), (6, &transform)],
        ),
    ];
    let (w32, h32) = (p.w, p.h);
    let dispatches = [
        (&rows, h32.div_ceil(64), 1),
        (&columns, w32.div_ceil(64), 1),
        (&gradients, w32.div_ceil(16), h32.div_ceil(16)),
        (&roughness, w32.div_ceil(4).div_ceil(16), h32.div_ceil(16)),
    ];
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for ((pipeline, x, y), group) in dispatches.into_iter().zip(&groups) {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
    let mut texture = |label, format, source: &wgpu::Buffer, row_bytes: u32| {
        let size = wgpu::Extent3d {
            width: w32,
            height: h32,
            depth_or_array_layers: 1,
        };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            // COPY_SRC: they can be read back (the tests compare them with the CPU's).
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        encoder.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer: source,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
                    rows_per_image: Some(h32),
                },
            },
            texture.as_image_copy(),
            size,
        );
        texture
    };
    let rasters = GpuRasters {
        control: texture(
            "terrain3d control points",
            wgpu::TextureFormat::R32Float,
            &control,
            p.control_stride * 4,
        ),
        gradients: texture(
            "terrain3d gradients",
            wgpu::TextureFormat::Rg16Float,
            &packed_gradients,
            p.gradient_stride * 4,
        ),
        roughness: texture(
            "terrain3d roughness",
            wgpu::TextureFormat::R8Unorm,
            &packed_roughness,
            p.roughness_stride * 4,
        ),
        from_gpu_copy: false,
    };
    gpu.submit(encoder.finish());
    drop((heights_buffer, transform, row_factors, column_factors));
    drop((packed_gradients, packed_roughness, groups));
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()));
    }
    let bytes = read_bytes(gpu, &control, control_bytes as u64).await?;
    drop(control);
    // The rows close up in place: one copy of the control points at a time.
    let mut points: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
    drop(bytes);
    let stride = p.control_stride as usize;
    if stride != w {
        for y in 1..h {
            points.copy_within(y * stride..y * stride + w, y * w);
        }
    }
    points.truncate(w * h);
    Ok((rasters, points))
}
