//! Waiting for the GPU without blocking the browser.
//!
//! Natively the caller is a worker thread (or the command line), so it may `poll` the device
//! until the callback fired. On the web `poll` does nothing: the callback runs from the
//! browser's event loop, so these functions only ever *await* it.

use futures_channel::oneshot;

use super::{GpuContext, GpuError};

/// Resolves when all work submitted so far has finished on the GPU.
pub async fn wait_for_submitted_work(ctx: &GpuContext) -> Result<(), GpuError> {
    let (tx, rx) = oneshot::channel();
    ctx.queue.on_submitted_work_done(move || {
        let _ = tx.send(());
    });
    poll_until_done(ctx)?;
    rx.await
        .map_err(|_| GpuError::DeviceLost("submitted work never completed".into()))
}

/// Copies `source` (a `STORAGE | COPY_SRC` buffer of `len` `f32`s) into a staging buffer,
/// maps it and returns its contents, copied once from the mapped range into the `f32`s.
pub async fn read_f32_buffer(
    ctx: &GpuContext,
    source: &wgpu::Buffer,
    len: usize,
) -> Result<Vec<f32>, GpuError> {
    let bytes = (len * 4) as u64;
    let staging = copy_to_staging(ctx, source, bytes).await?;
    ctx.kernels.count_readback();
    // Every target here is little-endian, as GPU buffers are.
    map_with(ctx, &staging, bytes, bytemuck::pod_collect_to_vec).await
}

/// Copies the first `bytes` bytes of `source` (with `COPY_SRC`) back to the CPU. A copy
/// the device refuses (a buffer without `COPY_SRC`, a range past its end) is an error, not
/// a staging buffer of zeros.
pub async fn read_bytes(
    ctx: &GpuContext,
    source: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u8>, GpuError> {
    let staging = copy_to_staging(ctx, source, bytes).await?;
    read_staging(ctx, &staging, bytes).await
}

/// A new staging buffer with the first `bytes` bytes of `source` copied in (submitted). A
/// copy the device refuses is an error.
async fn copy_to_staging(
    ctx: &GpuContext,
    source: &wgpu::Buffer,
    bytes: u64,
) -> Result<wgpu::Buffer, GpuError> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback staging"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("readback"),
        });
    encoder.copy_buffer_to_buffer(source, 0, &staging, 0, bytes);
    ctx.submit(encoder.finish());
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()));
    }
    Ok(staging)
}

/// The bytes a row of `bytes` takes in a buffer copied to or from a texture: rounded up to
/// the copy alignment (256).
pub fn padded_row_bytes(bytes: u32) -> u32 {
    bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

/// The texels of a 2D `texture` (with `COPY_SRC`) as tightly packed rows of `texel` bytes:
/// copied into a buffer with rows padded to the copy alignment, read back once, the padding
/// dropped. A copy the device refuses is an error.
pub async fn read_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    texel: u32,
) -> Result<Vec<u8>, GpuError> {
    let (w, h) = (texture.width(), texture.height());
    let padded = padded_row_bytes(w * texel);
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture readback"),
        size: u64::from(padded * h),
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("texture readback"),
        });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    ctx.submit(encoder.finish());
    if let Some(err) = scope.pop().await {
        return Err(GpuError::Validation(err.to_string()));
    }
    let bytes = read_bytes(ctx, &buffer, u64::from(padded * h)).await?;
    Ok(bytes
        .chunks_exact(padded as usize)
        .flat_map(|row| row[..(w * texel) as usize].iter().copied())
        .collect())
}

/// Maps the first `bytes` bytes of `staging` (a `MAP_READ | COPY_DST` buffer the caller
/// keeps and reuses, e.g. one per solve), returns them and unmaps it again, so later
/// submissions may copy into it. The work writing it must already be submitted. Counts one
/// readback. Natively this waits for the queue; on the web it only awaits the map callback.
pub async fn read_staging(
    ctx: &GpuContext,
    staging: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u8>, GpuError> {
    ctx.kernels.count_readback();
    map_staging(ctx, staging, bytes).await
}

/// [`read_staging`] without counting a readback (the timing scope's own readback).
pub(super) async fn map_staging(
    ctx: &GpuContext,
    staging: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u8>, GpuError> {
    map_with(ctx, staging, bytes, <[u8]>::to_vec).await
}

/// Maps the first `bytes` bytes of `staging`, hands them to `read` (which copies out what
/// it keeps) and unmaps it again.
async fn map_with<T>(
    ctx: &GpuContext,
    staging: &wgpu::Buffer,
    bytes: u64,
    read: impl FnOnce(&[u8]) -> T,
) -> Result<T, GpuError> {
    let (tx, rx) = oneshot::channel();
    staging.map_async(wgpu::MapMode::Read, 0..bytes, move |result| {
        let _ = tx.send(result);
    });
    poll_until_done(ctx)?;
    rx.await
        .map_err(|_| GpuError::Readback("the map callback was dropped".into()))?
        .map_err(|err| GpuError::Readback(err.to_string()))?;
    let values = read(
        &staging
            .get_mapped_range(0..bytes)
            .map_err(|err| GpuError::Readback(err.to_string()))?,
    );
    staging.unmap();
    Ok(values)
}

#[cfg(not(target_arch = "wasm32"))]
fn poll_until_done(ctx: &GpuContext) -> Result<(), GpuError> {
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|err| GpuError::DeviceLost(err.to_string()))
}

#[cfg(target_arch = "wasm32")]
fn poll_until_done(_ctx: &GpuContext) -> Result<(), GpuError> {
    Ok(())
}
