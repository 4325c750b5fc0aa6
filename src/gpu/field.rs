//! A field that stays on the GPU between two stages.

use super::{GpuContext, GpuError, read_f32_buffer};
use crate::heightfield::Heightfield;

/// A `width` x `height` field of `f32`, row-major, in one buffer of the device that made it
/// (`STORAGE | COPY_SRC | COPY_DST` where a stage hands it on): what a GPU stage hands the
/// next one instead of reading it back.
#[derive(Clone, Debug)]
pub struct GpuField {
    pub buffer: wgpu::Buffer,
    pub width: usize,
    pub height: usize,
    /// The device the buffer belongs to: a field is only used on it ([`GpuField::is_on`]).
    device: wgpu::Device,
}

impl GpuField {
    /// `buffer`, of at least `width * height` floats, on `gpu`.
    pub fn new(gpu: &GpuContext, buffer: wgpu::Buffer, width: usize, height: usize) -> Self {
        Self {
            buffer,
            width,
            height,
            device: gpu.device.clone(),
        }
    }

    /// Whether this field lives on `gpu`'s device (a cached stage output may come from a
    /// device since replaced) and has the given size.
    pub fn is_on(&self, gpu: &GpuContext, width: usize, height: usize) -> bool {
        self.device == gpu.device && (self.width, self.height) == (width, height)
    }

    /// Replaces the field's values with `data` (one upload, queued before any later work on
    /// `gpu`): for a stage that changed a few cells on the CPU after reading the field, so the
    /// next stage still finds the terrain on the GPU. Only for a field no cache holds yet.
    pub fn write(&self, gpu: &GpuContext, data: &[f32]) {
        debug_assert_eq!(data.len(), self.width * self.height);
        gpu.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(data));
    }

    /// Reads the field back to the CPU (one readback).
    pub async fn read(&self, gpu: &GpuContext) -> Result<Heightfield, GpuError> {
        let data = read_f32_buffer(gpu, &self.buffer, self.width * self.height).await?;
        Heightfield::from_vec(self.width, self.height, data)
            .map_err(|e| GpuError::Readback(e.to_string()))
    }
}
