//! The blended terrain kept on the GPU the terrain before it was on.
//!
//! Blending changes only the blocks' cells, so the terrain's GPU copy follows the CPU's
//! result without a readback: the previous stage's buffer is copied on the device (it stays
//! in that stage's cache entry) and each block's rows are copied over it from one upload of
//! the blocks. Cost: O(map cells) device copy plus O(block cells) upload.

use wgpu::util::DeviceExt;

use super::BlockRect;
use crate::gpu::{GpuContext, GpuError, GpuField};
use crate::heightfield::Heightfield;

/// `before` (the terrain the blocks were solved into, on `gpu`) with the `blocks` of
/// `after` (the blended terrain, the same size) written over it: `after`, bit for bit, on
/// the GPU. `None` when `before` is not on `gpu` or not `after`'s size.
pub async fn follow(
    gpu: &GpuContext,
    before: &GpuField,
    after: &Heightfield,
    blocks: &[BlockRect],
) -> Result<Option<GpuField>, GpuError> {
    let (w, h) = (after.width(), after.height());
    if !before.is_on(gpu, w, h) || blocks.iter().any(|b| b.check_inside(w, h).is_err()) {
        return Ok(None);
    }
    let device = &gpu.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bytes = (w * h * 4) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("blended terrain"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    // Every block's rows, one after the other (later blocks overwrite earlier ones, in the
    // order they were solved).
    let mut rows = Vec::with_capacity(blocks.iter().map(|b| b.width * b.height).sum());
    for b in blocks {
        for y in b.row..b.row + b.height {
            rows.extend_from_slice(&after.data()[y * w + b.col..y * w + b.col + b.width]);
        }
    }
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("blended terrain"),
    });
    encoder.copy_buffer_to_buffer(&before.buffer, 0, &out, 0, bytes);
    if !rows.is_empty() {
        let upload = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("blended blocks"),
            contents: bytemuck::cast_slice(&rows),
            usage: wgpu::BufferUsages::COPY_SRC,
        });
        let mut at = 0u64;
        for b in blocks {
            let row_bytes = (b.width * 4) as u64;
            for y in b.row..b.row + b.height {
                let offset = ((y * w + b.col) * 4) as u64;
                encoder.copy_buffer_to_buffer(&upload, at, &out, offset, row_bytes);
                at += row_bytes;
            }
        }
    }
    gpu.submit(encoder.finish());
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()));
    }
    Ok(Some(GpuField::new(gpu, out, w, h)))
}
