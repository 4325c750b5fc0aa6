//! [`super::fill_depressions`] on the GPU (`shaders/conditioning.wgsl`): the same bits, by
//! Planchon & Darboux's iteration from above on ordered integer keys (the shader's header
//! has the argument). One upload of the heights, about `log2(cells)` pointer-jumping passes,
//! flood passes until one lowers nothing (each tile of 16 x 16 settling in workgroup memory,
//! so a level crosses up to 16 cells a pass), their counts read back every
//! [`PASSES_PER_READ`] passes, and the heights read back only when a cell was raised.
//!
//! Cost: O(cells) a pass; the passes grow with the widest depression basin over 16 (a
//! designed terrain needs a handful, a rough one a few dozen). Memory on the GPU: 16 bytes a
//! cell (heights, levels, two pointer fields).

use wgpu::util::DeviceExt;

use super::Conditioning;
use crate::gpu::{GpuContext, GpuError, Shader, read_f32_buffer, read_staging};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

const SHADER: Shader = Shader {
    name: "conditioning.wgsl",
    source: include_str!("../../../shaders/conditioning.wgsl"),
};

/// The entry points, in the order of the pipelines.
const ENTRIES: [&str; 5] = ["receivers", "jump", "init", "flood", "apply"];

/// Flood passes submitted between two reads of their counts.
pub const PASSES_PER_READ: u32 = 8;

const WORKGROUP: u32 = 16;
/// Words of the shader's `stats`: NaN cells, cells lowered by the last pass, cells raised,
/// largest raise.
const STATS_WORDS: u64 = 4;

/// Why the GPU did not condition the terrain (the caller floods it on the CPU instead).
#[derive(Debug, thiserror::Error)]
pub enum GpuFloodError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("{0} cells have no height (NaN): they are flooded on the CPU")]
    NoData(u32),
    #[error("the flood did not settle in {0} passes")]
    Unsettled(u32),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    _pad: [u32; 2],
}

/// Whether `gpu` holds a `width` x `height` field's four fields (one binding each) and the
/// kernels' four storage bindings.
pub fn fits(gpu: &GpuContext, width: usize, height: usize) -> bool {
    gpu.caps.fits_field(width, height) && gpu.caps.max_storage_buffers_per_shader_stage >= 4
}

/// Builds the kernels on `gpu` now (later calls cost a few map lookups).
pub async fn warm(gpu: &GpuContext) -> Result<(), GpuError> {
    gpu.pipelines(&SHADER, ENTRIES).await.map(|_| ())
}

/// Floods the depressions of `field` on `gpu`: afterwards every interior cell has a strictly
/// lower neighbour, with the same heights, to the bit, as [`super::fill_depressions`] gives
/// (and the same counts). A field with NaN cells is refused ([`GpuFloodError::NoData`]) and
/// left as it was. One upload; one readback, when a cell was raised.
pub async fn fill_depressions(
    gpu: &GpuContext,
    field: &mut Heightfield,
    ctx: &JobCtx,
) -> Result<Conditioning, GpuFloodError> {
    let (w, h) = (field.width(), field.height());
    check(gpu, w, h)?;
    let heights = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("conditioning heights"),
        size: (w * h) as u64 * 4,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // The heights go up in slices of 1 MiB with the job's ticks between them.
    let bytes: &[u8] = bytemuck::cast_slice(field.data());
    for (part, chunk) in bytes.chunks(1 << 20).enumerate() {
        gpu.queue.write_buffer(&heights, (part << 20) as u64, chunk);
        ctx.tick(0.95, "filling depressions (GPU)").await?;
    }
    let result = fill_buffer(gpu, &heights, w, h, ctx).await?;
    if result.raised_cells > 0 {
        let data = read_f32_buffer(gpu, &heights, w * h).await?;
        field.data_mut().copy_from_slice(&data);
    }
    Ok(result)
}

fn check(gpu: &GpuContext, w: usize, h: usize) -> Result<(), GpuError> {
    gpu.check_compute()?;
    if fits(gpu, w, h) {
        Ok(())
    } else {
        Err(GpuError::TooLarge {
            width: w,
            height: h,
            bytes: (w * h) as u64 * 4,
            limit: gpu.caps.max_storage_bytes(),
        })
    }
}

/// [`fill_depressions`] of the `w` x `h` heights already in `heights` (row-major `f32`, a
/// `STORAGE` buffer of `gpu`), in place: for a stage whose result is on the GPU (the
/// erosion solver), so the filled surface needs no trip through the CPU. A buffer with NaN
/// cells is refused and left as it was.
pub async fn fill_buffer(
    gpu: &GpuContext,
    heights: &wgpu::Buffer,
    w: usize,
    h: usize,
    ctx: &JobCtx,
) -> Result<Conditioning, GpuFloodError> {
    let n = w * h;
    check(gpu, w, h)?;
    let k = gpu.pipelines(&SHADER, ENTRIES).await?;
    let device = &gpu.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let rw =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("conditioning params"),
        contents: bytemuck::bytes_of(&Params {
            width: w as u32,
            height: h as u32,
            _pad: [0; 2],
        }),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let empty = |label: &str, bytes: u64| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: rw,
            mapped_at_creation: false,
        })
    };
    let level = empty("conditioning levels", n as u64 * 4);
    let ptr = [
        empty("descent a", n as u64 * 4),
        empty("descent b", n as u64 * 4),
    ];
    let stats = empty("conditioning stats", STATS_WORDS * 4);
    // One slot of four bytes per pass of a read (the cells it lowered), then the NaN count.
    let slots = u64::from(PASSES_PER_READ) + 1;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("conditioning staging"),
        size: slots * 4,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // Every kernel reads the parameters at binding 0.
    let bind = |pipe: usize, entries: &[(u32, &wgpu::Buffer)]| {
        let all: Vec<(u32, &wgpu::Buffer)> = std::iter::once((0, &params))
            .chain(entries.iter().copied())
            .collect();
        crate::gpu::bind_buffers(device, &k[pipe], ENTRIES[pipe], &all)
    };
    let jumps = jumps(n);
    let roots = &ptr[(jumps % 2) as usize];
    let g_receivers = bind(0, &[(1, heights), (4, &ptr[0]), (5, &stats)]);
    let g_jump = [0, 1].map(|s| bind(1, &[(3, &ptr[s]), (4, &ptr[1 - s])]));
    let g_init = bind(2, &[(1, heights), (2, &level), (3, roots)]);
    let g_flood = bind(3, &[(1, heights), (2, &level), (5, &stats)]);
    let g_apply = bind(4, &[(1, heights), (2, &level), (5, &stats)]);
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }

    let groups = (
        (w as u32).div_ceil(WORKGROUP),
        (h as u32).div_ceil(WORKGROUP),
    );
    let run = |encoder: &mut wgpu::CommandEncoder, list: &[(usize, &wgpu::BindGroup)]| {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        for (pipe, group) in list {
            pass.set_pipeline(&k[*pipe]);
            pass.set_bind_group(0, *group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
    };
    let mut encoder = device.create_command_encoder(&Default::default());
    let mut list = vec![(0, &g_receivers)];
    list.extend((0..jumps).map(|j| (1, &g_jump[(j % 2) as usize])));
    list.push((2, &g_init));
    run(&mut encoder, &list);
    encoder.copy_buffer_to_buffer(&stats, 0, &staging, u64::from(PASSES_PER_READ) * 4, 4);

    // Flood passes until one lowers nothing. A level crosses at least one tile a pass: a
    // valley that winds through the tiles many times over (a spiral) takes more passes than
    // this, and is flooded on the CPU instead.
    let max_passes = 16 * (groups.0 + groups.1) + 64;
    let mut passes = 0u32;
    loop {
        for slot in 0..PASSES_PER_READ {
            encoder.clear_buffer(&stats, 4, Some(4));
            run(&mut encoder, &[(3, &g_flood)]);
            encoder.copy_buffer_to_buffer(&stats, 4, &staging, u64::from(slot) * 4, 4);
        }
        gpu.submit(encoder.finish());
        let counts: Vec<u32> =
            bytemuck::pod_collect_to_vec(&read_staging(gpu, &staging, slots * 4).await?);
        if passes == 0 && counts[PASSES_PER_READ as usize] > 0 {
            return Err(GpuFloodError::NoData(counts[PASSES_PER_READ as usize]));
        }
        passes += PASSES_PER_READ;
        if counts[..PASSES_PER_READ as usize].contains(&0) {
            break;
        }
        if passes >= max_passes {
            return Err(GpuFloodError::Unsettled(passes));
        }
        ctx.tick(0.95, "filling depressions (GPU)").await?;
        encoder = device.create_command_encoder(&Default::default());
    }

    let mut encoder = device.create_command_encoder(&Default::default());
    run(&mut encoder, &[(4, &g_apply)]);
    encoder.copy_buffer_to_buffer(&stats, 8, &staging, 0, 8);
    gpu.submit(encoder.finish());
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&read_staging(gpu, &staging, 8).await?);
    Ok(Conditioning {
        raised_cells: words[0] as usize,
        max_raise: f32::from_bits(words[1]),
    })
}

/// Pointer-jumping passes that reach the end of any descent on `cells` cells:
/// `ceil(log2 cells)`, at least 1.
fn jumps(cells: usize) -> u32 {
    (usize::BITS - cells.saturating_sub(1).leading_zeros()).max(1)
}
