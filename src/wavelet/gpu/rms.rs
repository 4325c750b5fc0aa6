//! The detail's RMS measured on the GPU, in the synthesis's submission: `detail_rms` in
//! `shaders/wavelet.wgsl`, the same measure as [`crate::wavelet::synthesis::detail_rms`]
//! (in f32 per workgroup, the workgroups' sums added in f64 here). Cost: O(output cells) on
//! the GPU and a readback of 16 bytes per 16 x 128 cells, instead of an O(output cells) pass
//! on the CPU (in row bands natively: 160-240 ms for a 4093^2 output on two cores; on one
//! thread in the page, several times that).

use crate::gpu::{GpuContext, GpuError, bind_buffers, read_f32_buffer};
use crate::wavelet::synthesis::DetailRms;

/// The kernel's entry point.
pub(super) const ENTRY: [&str; 1] = ["detail_rms"];
/// Rows of 16 cells each invocation sums (`RMS_ROWS` in the shader).
const ROWS: u32 = 8;
const WORKGROUP: u32 = 16;

/// One measure of a `width x height` output: its dispatch and its partial sums' buffer.
pub(super) struct Measure {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    groups: (u32, u32),
    partials: wgpu::Buffer,
}

/// The synthesis's buffers the measure reads: its parameters (`fill`'s), the source, the
/// mask and the output.
pub(super) struct Inputs<'a> {
    pub params: &'a wgpu::Buffer,
    pub source: &'a wgpu::Buffer,
    pub mask: &'a wgpu::Buffer,
    pub out: &'a wgpu::Buffer,
}

impl Measure {
    /// Binds the measure of a `width x height` output (`pipeline`: [`ENTRY`]'s).
    pub(super) fn new(
        gpu: &GpuContext,
        pipeline: wgpu::ComputePipeline,
        inputs: &Inputs,
        width: usize,
        height: usize,
    ) -> Self {
        let groups = (
            (width as u32).div_ceil(WORKGROUP),
            (height as u32).div_ceil(WORKGROUP * ROWS),
        );
        let partials = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("detail rms partials"),
            size: u64::from(groups.0 * groups.1) * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = bind_buffers(
            &gpu.device,
            &pipeline,
            "detail rms",
            &[
                (0, inputs.params),
                (1, inputs.source),
                (3, inputs.mask),
                (4, inputs.out),
                (5, &partials),
            ],
        );
        Self {
            pipeline,
            group,
            groups,
            partials,
        }
    }

    /// Records the measure (after the synthesis's last dispatch).
    pub(super) fn record(&self, pass: &mut wgpu::ComputePass) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }

    /// Reads the workgroups' sums back (one small readback) and adds them up; `None` where
    /// a sum is not finite (f32 overflowed), for the CPU's f64 measure to take over.
    pub(super) async fn read(&self, gpu: &GpuContext) -> Result<Option<DetailRms>, GpuError> {
        let count = (self.groups.0 * self.groups.1) as usize;
        let sums = read_f32_buffer(gpu, &self.partials, count * 4).await?;
        let mut total = [0.0f64; 4];
        for entry in sums.chunks_exact(4) {
            for (t, &v) in total.iter_mut().zip(entry) {
                *t += f64::from(v);
            }
        }
        if total.iter().any(|t| !t.is_finite()) {
            return Ok(None);
        }
        Ok(Some(DetailRms::from_sums(total)))
    }
}
