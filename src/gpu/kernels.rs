//! Compute kernels built once per device, and counters of the work the GPU layer does.
//!
//! A [`Shader`] names a WGSL source; [`GpuContext::pipelines`] returns the compute pipelines
//! of its entry points, creating the shader module and each pipeline on first use and
//! handing out the same objects to every later caller on that device (the way wgpu's
//! examples and rerun's renderer keep theirs). Pipelines use the layout derived from the
//! shader, so a bind group made from `pipeline.get_bind_group_layout(0)` fits every cached
//! copy. The cache lives behind the context's `Arc` with a `std::sync::Mutex` (which works on
//! wasm32 too) and is held only while looking up or inserting, never across an `await`.
//!
//! [`GpuStats`] counts what was created and how often the queue was submitted to and read
//! back; benchmarks and tests take the difference of two snapshots. The GPU time of the
//! submissions is measured apart, in a timing scope (`timing.rs`).

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use serde::Serialize;

use super::timing::Timer;
use super::{GpuContext, GpuError};

/// A WGSL shader: its name (the cache key, unique per source) and its source text.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    pub name: &'static str,
    pub source: &'static str,
}

/// Counters of GPU-layer work since the context was created.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct GpuStats {
    /// Shader modules compiled.
    pub modules_created: u64,
    /// Compute pipelines created.
    pub pipelines_created: u64,
    /// Command buffers submitted through [`GpuContext::submit`] (the compute stages' and
    /// the readbacks' submissions).
    pub submissions: u64,
    /// Buffers mapped back to the CPU ([`super::read_bytes`] and what builds on it).
    pub readbacks: u64,
    /// Timestamp queries written around submissions while a timing scope was open
    /// ([`GpuContext::start_timing`]): two per timed submission, none otherwise.
    pub timestamp_queries: u64,
}

impl GpuStats {
    /// What happened between `earlier` and `self`.
    pub fn since(&self, earlier: &GpuStats) -> GpuStats {
        GpuStats {
            modules_created: self.modules_created.saturating_sub(earlier.modules_created),
            pipelines_created: self
                .pipelines_created
                .saturating_sub(earlier.pipelines_created),
            submissions: self.submissions.saturating_sub(earlier.submissions),
            readbacks: self.readbacks.saturating_sub(earlier.readbacks),
            timestamp_queries: self
                .timestamp_queries
                .saturating_sub(earlier.timestamp_queries),
        }
    }
}

/// The per-device cache and counters, shared by every clone of a [`GpuContext`].
#[derive(Default)]
pub(super) struct Kernels {
    modules: Mutex<HashMap<&'static str, wgpu::ShaderModule>>,
    pipelines: Mutex<HashMap<(&'static str, String), wgpu::ComputePipeline>>,
    modules_created: AtomicU64,
    pipelines_created: AtomicU64,
    submissions: AtomicU64,
    readbacks: AtomicU64,
    timestamp_queries: AtomicU64,
    pub(super) timer: Timer,
}

impl Kernels {
    pub(super) fn count_readback(&self) {
        self.readbacks.fetch_add(1, Ordering::Relaxed);
    }
}

/// A poisoned lock only means another thread panicked while inserting; the map is still a
/// valid map of valid objects.
fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl GpuContext {
    /// The compute pipelines of `entries` in `shader`, in order: from the cache, or created
    /// (with the shader module, if it is new) and kept for every later call on this device.
    ///
    /// Creation runs inside its own validation scope; a kernel that fails to build is
    /// reported as [`GpuError::Validation`] and not cached.
    pub async fn pipelines<const N: usize>(
        &self,
        shader: &Shader,
        entries: [&str; N],
    ) -> Result<[wgpu::ComputePipeline; N], GpuError> {
        let cached: Vec<Option<wgpu::ComputePipeline>> = {
            let map = lock(&self.kernels.pipelines);
            entries
                .iter()
                .map(|e| map.get(&(shader.name, (*e).to_owned())).cloned())
                .collect()
        };
        if cached.iter().all(Option::is_some) {
            return Ok(cached
                .into_iter()
                .map(|p| p.expect("checked above"))
                .collect::<Vec<_>>()
                .try_into()
                .unwrap_or_else(|_| unreachable!("one pipeline per entry")));
        }

        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let (module, new_module) = self.module(shader);
        let pipelines: Vec<wgpu::ComputePipeline> = entries
            .iter()
            .zip(cached)
            .map(|(entry, cached)| {
                cached.unwrap_or_else(|| {
                    let pipeline =
                        self.device
                            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                                label: Some(entry),
                                layout: None,
                                module: &module,
                                entry_point: Some(entry),
                                compilation_options: Default::default(),
                                cache: None,
                            });
                    self.kernels
                        .pipelines_created
                        .fetch_add(1, Ordering::Relaxed);
                    pipeline
                })
            })
            .collect();
        if let Some(err) = scope.pop().await {
            if new_module {
                lock(&self.kernels.modules).remove(shader.name);
            }
            return Err(GpuError::Validation(err.to_string()));
        }
        let mut map = lock(&self.kernels.pipelines);
        let pipelines = entries
            .iter()
            .zip(pipelines)
            .map(|(entry, pipeline)| {
                // Another caller may have built the same kernel meanwhile: keep one copy.
                map.entry((shader.name, (*entry).to_owned()))
                    .or_insert(pipeline)
                    .clone()
            })
            .collect::<Vec<_>>();
        Ok(pipelines
            .try_into()
            .unwrap_or_else(|_| unreachable!("one pipeline per entry")))
    }

    /// The shader module of `shader`, and whether this call created it.
    fn module(&self, shader: &Shader) -> (wgpu::ShaderModule, bool) {
        let mut modules = lock(&self.kernels.modules);
        if let Some(module) = modules.get(shader.name) {
            return (module.clone(), false);
        }
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(shader.name),
                source: wgpu::ShaderSource::Wgsl(shader.source.into()),
            });
        self.kernels.modules_created.fetch_add(1, Ordering::Relaxed);
        modules.insert(shader.name, module.clone());
        (module, true)
    }

    /// Submits `commands` to the queue and counts the submission. While a timing scope is
    /// open ([`GpuContext::start_timing`]) the same `queue.submit` also takes a timestamp
    /// before and after them.
    pub fn submit(&self, commands: wgpu::CommandBuffer) -> wgpu::SubmissionIndex {
        self.kernels.submissions.fetch_add(1, Ordering::Relaxed);
        match self.kernels.timer.bracket(&self.device) {
            Some([begin, end]) => {
                self.kernels
                    .timestamp_queries
                    .fetch_add(2, Ordering::Relaxed);
                self.queue.submit([begin, commands, end])
            }
            None => self.queue.submit([commands]),
        }
    }

    /// What this device has created, submitted and read back so far.
    pub fn stats(&self) -> GpuStats {
        let k = &self.kernels;
        GpuStats {
            modules_created: k.modules_created.load(Ordering::Relaxed),
            pipelines_created: k.pipelines_created.load(Ordering::Relaxed),
            submissions: k.submissions.load(Ordering::Relaxed),
            readbacks: k.readbacks.load(Ordering::Relaxed),
            timestamp_queries: k.timestamp_queries.load(Ordering::Relaxed),
        }
    }
}

/// A bind group of whole buffers for group 0 of `pipeline`: `(binding, buffer)` pairs, the
/// layout the pipeline's shader declares (pipelines here derive their layouts).
pub fn bind_buffers(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    label: &str,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}
