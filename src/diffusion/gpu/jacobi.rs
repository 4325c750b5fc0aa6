//! The Jacobi sweep on the GPU (`shaders/jacobi.wgsl`).
//!
//! Buffers: two `f32` fields (ping-pong), the fixed-cell bit mask and a uniform with the
//! size; one dispatch of 16 x 16 workgroups per sweep. A field larger than one storage
//! binding is tiled into bands of rows ([`super::bands`]), one dispatch per band and a ghost
//! row exchange after each sweep; the result is the same bits. Sweeps are submitted in batches so a
//! browser's GPU watchdog never sees one huge submission, and between batches the job
//! awaits the queue (never blocking the browser), reports progress and honours cancel.

use wgpu::util::DeviceExt;

use super::bands::{self, Band};
use super::{JACOBI, WORKGROUP, bind};
use crate::diffusion::{Constraints, DiffusionError};
use crate::gpu::{GpuContext, GpuError, wait_for_submitted_work};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// The one entry point.
pub(super) const ENTRIES: [&str; 1] = ["jacobi_sweep"];

/// Cell updates per submission: keeps each submission well under a second on slow GPUs.
const CELLS_PER_SUBMIT: u64 = 1 << 26;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    row0: u32,
    own_start: u32,
    own_end: u32,
    _pad: [u32; 3],
}

/// One band's ping-pong fields and bind groups: `groups[k]` reads `fields[k]` and writes
/// `fields[1 - k]`.
struct JacobiBand {
    rows: Band,
    fields: [wgpu::Buffer; 2],
    groups: [wgpu::BindGroup; 2],
}

pub(in crate::diffusion) async fn jacobi(
    gpu: &GpuContext,
    problem: &Constraints,
    sweeps: u32,
    ctx: &JobCtx,
) -> Result<Heightfield, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    gpu.check_compute()?;
    let plan = bands::plan(&[(w, h)], gpu.caps.max_storage_bytes())?;
    let device = &gpu.device;

    let [pipeline] = gpu.pipelines(&JACOBI, ENTRIES).await?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let field_usage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let initial = problem.initial().data();
    let jacobi_bands: Vec<JacobiBand> = plan[0]
        .iter()
        .map(|rows| {
            let init = |label: &str, contents: &[u8], usage| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
            };
            let params = init(
                "jacobi params",
                bytemuck::bytes_of(&Params {
                    width: w as u32,
                    height: h as u32,
                    row0: rows.stored.start as u32,
                    own_start: rows.owned.start as u32,
                    own_end: rows.owned.end as u32,
                    _pad: [0; 3],
                }),
                wgpu::BufferUsages::UNIFORM,
            );
            let words = bands::fixed_words(problem.fixed(), rows);
            let fixed = init(
                "fixed cells",
                bytemuck::cast_slice(&words),
                wgpu::BufferUsages::STORAGE,
            );
            let values = &initial[rows.stored.start * w..rows.stored.end * w];
            let fields = ["field a", "field b"]
                .map(|label| init(label, bytemuck::cast_slice(values), field_usage));
            let groups = [0usize, 1].map(|k| {
                bind(
                    device,
                    &pipeline,
                    &[
                        (0, &params),
                        (1, &fixed),
                        (2, &fields[k]),
                        (3, &fields[1 - k]),
                    ],
                )
            });
            JacobiBand {
                rows: rows.clone(),
                fields,
                groups,
            }
        })
        .collect();
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()).into());
    }
    let rows: Vec<Band> = jacobi_bands.iter().map(|b| b.rows.clone()).collect();
    // The buffers sweep `s` writes, band by band.
    let written = |s: u32| -> Vec<&wgpu::Buffer> {
        jacobi_bands
            .iter()
            .map(|b| &b.fields[1 - (s % 2) as usize])
            .collect()
    };

    let per_submit = (CELLS_PER_SUBMIT / (w * h) as u64).clamp(1, 4096) as u32;
    let mut done = 0u32;
    while done < sweeps {
        let batch = per_submit.min(sweeps - done);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("jacobi sweeps"),
        });
        let sweep = |pass: &mut wgpu::ComputePass, s: u32| {
            for band in &jacobi_bands {
                pass.set_bind_group(0, &band.groups[(s % 2) as usize], &[]);
                pass.dispatch_workgroups(
                    (w as u32).div_ceil(WORKGROUP),
                    (band.rows.owned.len() as u32).div_ceil(WORKGROUP),
                    1,
                );
            }
        };
        let pass_descriptor = wgpu::ComputePassDescriptor {
            label: Some("jacobi sweeps"),
            timestamp_writes: None,
        };
        if rows.len() == 1 {
            // Untiled: the whole batch in one pass, no ghost rows to exchange.
            let mut pass = encoder.begin_compute_pass(&pass_descriptor);
            pass.set_pipeline(&pipeline);
            for s in done..done + batch {
                sweep(&mut pass, s);
            }
        } else {
            for s in done..done + batch {
                {
                    let mut pass = encoder.begin_compute_pass(&pass_descriptor);
                    pass.set_pipeline(&pipeline);
                    sweep(&mut pass, s);
                }
                bands::exchange_ghost_rows(&mut encoder, &rows, &written(s), w);
            }
        }
        gpu.submit(encoder.finish());
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
    let latest: Vec<&wgpu::Buffer> = jacobi_bands
        .iter()
        .map(|b| &b.fields[(sweeps % 2) as usize])
        .collect();
    let data = bands::read_owned_rows(gpu, &rows, &latest, w).await?;
    Ok(Heightfield::from_vec(w, h, data).map_err(|e| GpuError::Readback(e.to_string()))?)
}
