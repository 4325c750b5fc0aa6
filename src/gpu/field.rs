//! A field that stays on the GPU between two stages.

use super::{GpuContext, GpuError, read_f32_buffer};
use crate::heightfield::Heightfield;

/// A `width` x `height` field of `f32`, row-major, in one buffer of the device that made it
/// (`STORAGE | COPY_SRC | COPY_DST`): what a GPU stage hands the next one instead of reading
/// it back.
#[derive(Clone, Debug)]
pub struct GpuField {
    pub buffer: wgpu::Buffer,
    pub width: usize,
    pub height: usize,
}

impl GpuField {
    /// Reads the field back to the CPU (one readback).
    pub async fn read(&self, gpu: &GpuContext) -> Result<Heightfield, GpuError> {
        let data = read_f32_buffer(gpu, &self.buffer, self.width * self.height).await?;
        Heightfield::from_vec(self.width, self.height, data)
            .map_err(|e| GpuError::Readback(e.to_string()))
    }
}
