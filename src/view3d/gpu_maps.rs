//! The 3D view's rasters made on the GPU it draws with (`shaders/view3d_maps.wgsl`), for a
//! hardware GPU that computes: the B-spline's control points, the gradients and the roughness
//! are written straight into the textures the renderer binds, and only the control points
//! come back (the camera's ground height and the chunk tree need them on the CPU).
//!
//! What stays on the CPU, as in [`super::maps`]: reducing a field larger than the texture
//! limit, `H` (one wavelet transform and its spectral fit) and the finest level's squared
//! detail with its mean. What moves to the GPU: the tridiagonal solves (one invocation per
//! row, then per column), the differences and the roughness's 9 x 9 windows. The rasters
//! agree with the CPU's to rounding (`tests/view3d.rs`): the solves run in f32 instead of
//! f64, the windows sum in f32, and the GPU rounds the half floats and the bytes.
//!
//! Cost: O(cells) on the CPU (the transform, the squares, the chunk tree), O(cells x 81) on
//! the GPU; two fields go up (heights and squares) and one comes back (control points). A
//! terrain a GPU stage left on this GPU (a [`GpuField`]) is read there: only the squares go
//! up.

use thiserror::Error;
use wgpu::util::DeviceExt;

use super::maps::{Base, ROUGHNESS_RADIUS, Rasters, Spectral, TerrainMaps};
use super::subdivision;
use crate::gpu::{
    GpuContext, GpuError, GpuField, Shader, bind_buffers, padded_row_bytes, read_bytes,
};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

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
}

/// Whether the app makes the 3D maps on `gpu` rather than on the CPU: on hardware (a
/// software rasteriser runs the windows slower than the CPU: 3.4 s against 0.6 s at 4096^2
/// on lavapipe) where the CPU path has one thread (the page). With threads, the CPU path
/// runs everything in bands and is as fast as this one's serial CPU share (the transform
/// for `H`, the squares, the chunk tree: about 0.3 s at 4096^2 on one core).
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
/// prepared on the CPU. Checks the job between the CPU's steps.
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
    let mut base = Base::of(field, cell, max_side);
    let (w, h) = (base.width, base.height);
    let control_stride = stride(w, 4);
    gpu.check_field(control_stride, h)?;
    let Some(spectral) = Spectral::of(&base.heights, w, h) else {
        return Ok(TerrainMaps::new(field, cell, max_side));
    };
    job.checkpoint(0.5, "3D view: surface maps on the GPU")
        .await?;
    let params = Params {
        w: w as u32,
        h: h as u32,
        control_stride: control_stride as u32,
        gradient_stride: stride(w, 4) as u32,
        roughness_stride: (stride(w, 1) / 4) as u32,
        radius: ROUGHNESS_RADIUS as u32,
        cell: base.cell,
        // No detail: a roughness of 0 everywhere, as on the CPU.
        scale: spectral.scale().unwrap_or(0.0) as f32,
    };
    let hurst = spectral.hurst;
    // The CPU copies go once they are uploaded (a 4096^2 field is 64 MiB each).
    let heights = std::mem::take(&mut base.heights);
    let unchanged =
        (w, h) == (field.width(), field.height()) && field.data().iter().all(|z| z.is_finite());
    let heights = match on_gpu {
        Some(f) if unchanged && f.is_on(gpu, w, h) => Heights::OnGpu(f.buffer.clone()),
        _ => Heights::Upload(heights),
    };
    let (rasters, control) = run(gpu, heights, spectral.squares, &params).await?;
    job.checkpoint(0.9, "3D view: surface maps on the GPU")
        .await?;
    Ok(base.finish(Rasters::Gpu(rasters), control, hurst))
}

/// The heights the kernels read.
enum Heights {
    /// On the CPU, to upload.
    Upload(Vec<f32>),
    /// Already on the GPU (`w * h` floats, row-major).
    OnGpu(wgpu::Buffer),
}

/// The kernels, the textures and the readback of the control points (unpadded, row-major).
/// `heights` and `squares` are dropped once uploaded, and every buffer but the control
/// points' once the work is submitted (wgpu keeps them until the GPU is done with them).
async fn run(
    gpu: &GpuContext,
    heights: Heights,
    squares: Vec<f32>,
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
    let heights_buffer = match heights {
        Heights::Upload(heights) => upload("3D maps heights", bytemuck::cast_slice(&heights)),
        Heights::OnGpu(buffer) => buffer,
    };
    let squares_buffer = upload("3D maps detail", bytemuck::cast_slice(&squares));
    drop(squares);
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
            &[(0, &uniform), (5, &packed_roughness), (6, &squares_buffer)],
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
    };
    gpu.submit(encoder.finish());
    drop((heights_buffer, squares_buffer, row_factors, column_factors));
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
