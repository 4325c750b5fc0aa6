//! The GPU's own time for submitted work, from timestamp queries where the adapter has them.
//!
//! [`GpuContext::start_timing`] opens a timing scope on a device created with
//! `Features::TIMESTAMP_QUERY` (requested by [`super::device_descriptor`] when the adapter
//! offers it, never required). While it is open, [`GpuContext::submit`] puts two more command
//! buffers into the same `queue.submit`: one before the caller's with an empty compute pass
//! that writes a timestamp at its beginning, one after it with an empty pass that writes one
//! at its end. Both are taken once everything before them has finished (on Vulkan at the
//! bottom of the pipe), so each pair spans the submission's work on the GPU and the
//! submissions' spans do not overlap; time the GPU spends idle between submissions (the CPU
//! encoding, waiting, reading back) is in no span. [`GpuContext::stop_timing`] resolves every
//! query, reads them back once and returns each submission's span ([`GpuTiming`]); that
//! submission and readback are not counted in [`super::GpuStats`]' `submissions` and
//! `readbacks`, which stay those of the timed work.
//!
//! Query sets hold at most `wgpu::QUERY_SET_MAX_QUERIES` (4096) queries, 2048 submissions; a
//! scope adds a set whenever the last one is full. With no scope open `submit` only loads
//! one atomic flag: no query, no extra command buffer.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use super::readback::map_staging;
use super::{GpuContext, GpuError};

/// Queries per query set: the most wgpu allows.
const QUERIES_PER_SET: u32 = wgpu::QUERY_SET_MAX_QUERIES;

/// The timing state of a device, shared by every clone of its [`GpuContext`].
#[derive(Default)]
pub(super) struct Timer {
    /// Whether a scope is open (checked by every submission without taking the lock).
    open: AtomicBool,
    scope: Mutex<Option<Scope>>,
}

/// An open timing scope: its query sets, how many submissions it bracketed, and the laps.
struct Scope {
    sets: Vec<wgpu::QuerySet>,
    timed: u32,
    /// Lap names with the number of submissions timed when each lap ended.
    laps: Vec<(String, u32)>,
}

/// What one timing scope measured: the GPU time of each submission, in order, and the
/// submissions' split into laps ([`GpuContext::timing_lap`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GpuTiming {
    /// Nanoseconds from the first timestamp to the second of each submission.
    pub submission_ns: Vec<f64>,
    /// Each lap's name and the range of `submission_ns` it covers.
    pub laps: Vec<(String, std::ops::Range<usize>)>,
}

impl GpuTiming {
    /// The GPU time of every timed submission together, in milliseconds.
    pub fn ms(&self) -> f64 {
        self.submission_ns.iter().sum::<f64>() / 1e6
    }

    /// The GPU time of the laps named `name`, in milliseconds; `None` when they submitted
    /// nothing (the stage ran on the CPU) or there is no such lap.
    pub fn lap_ms(&self, name: &str) -> Option<f64> {
        let ranges: Vec<_> = self
            .laps
            .iter()
            .filter(|(lap, range)| lap == name && !range.is_empty())
            .map(|(_, range)| range.clone())
            .collect();
        (!ranges.is_empty()).then(|| {
            ranges
                .into_iter()
                .map(|range| self.submission_ns[range].iter().sum::<f64>())
                .sum::<f64>()
                / 1e6
        })
    }
}

/// A poisoned lock only means another thread panicked meanwhile; the scope is still valid.
fn lock(scope: &Mutex<Option<Scope>>) -> std::sync::MutexGuard<'_, Option<Scope>> {
    scope
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A command buffer with one empty compute pass that writes timestamp `index` of `set` at
/// its beginning (`begin`) or at its end.
fn timestamp(
    device: &wgpu::Device,
    set: &wgpu::QuerySet,
    index: u32,
    begin: bool,
) -> wgpu::CommandBuffer {
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("timestamp"),
    });
    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("timestamp"),
        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: begin.then_some(index),
            end_of_pass_write_index: (!begin).then_some(index),
        }),
    });
    encoder.finish()
}

impl Timer {
    /// With a scope open: the command buffers to submit before and after the next one, which
    /// take its timestamps. `None` (after one atomic load) when no scope is open.
    pub(super) fn bracket(&self, device: &wgpu::Device) -> Option<[wgpu::CommandBuffer; 2]> {
        if !self.open.load(Ordering::Acquire) {
            return None;
        }
        let mut guard = lock(&self.scope);
        let scope = guard.as_mut()?;
        let first = 2 * scope.timed;
        let set = (first / QUERIES_PER_SET) as usize;
        if set == scope.sets.len() {
            scope
                .sets
                .push(device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("submission timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: QUERIES_PER_SET,
                }));
        }
        let index = first % QUERIES_PER_SET;
        let set = &scope.sets[set];
        let commands = [
            timestamp(device, set, index, true),
            timestamp(device, set, index + 1, false),
        ];
        scope.timed += 1;
        Some(commands)
    }
}

impl GpuContext {
    /// Whether this device takes timestamp queries (`Features::TIMESTAMP_QUERY`), so
    /// [`GpuContext::start_timing`] can measure.
    pub fn has_timestamps(&self) -> bool {
        self.caps.timestamp_query
    }

    /// Opens a timing scope: from now on every [`GpuContext::submit`] on this device (on any
    /// clone of this context) is timed on the GPU until [`GpuContext::stop_timing`]. Returns
    /// false, and times nothing, where the device has no timestamp queries. A scope already
    /// open is dropped unread.
    pub fn start_timing(&self) -> bool {
        if !self.has_timestamps() {
            return false;
        }
        let timer = &self.kernels.timer;
        *lock(&timer.scope) = Some(Scope {
            sets: Vec::new(),
            timed: 0,
            laps: Vec::new(),
        });
        timer.open.store(true, Ordering::Release);
        true
    }

    /// Ends a lap of the open scope: the submissions since the previous lap (or the start)
    /// belong to `name` in [`GpuTiming::laps`]. Does nothing with no scope open.
    pub fn timing_lap(&self, name: &str) {
        let timer = &self.kernels.timer;
        if !timer.open.load(Ordering::Acquire) {
            return;
        }
        if let Some(scope) = lock(&timer.scope).as_mut() {
            let timed = scope.timed;
            scope.laps.push((name.to_owned(), timed));
        }
    }

    /// Closes the open scope and reads its timestamps back (one submission and one readback,
    /// neither counted in [`GpuContext::stats`]; natively this waits for the timed work).
    /// `None` when no scope was open, e.g. because the device has no timestamp queries.
    pub async fn stop_timing(&self) -> Result<Option<GpuTiming>, GpuError> {
        let timer = &self.kernels.timer;
        timer.open.store(false, Ordering::Release);
        let Some(scope) = lock(&timer.scope).take() else {
            return Ok(None);
        };
        let timed = scope.timed as usize;
        let mut start = 0;
        let laps = scope
            .laps
            .iter()
            .map(|(name, end)| {
                let range = start..*end as usize;
                start = *end as usize;
                (name.clone(), range)
            })
            .collect();
        if timed == 0 {
            return Ok(Some(GpuTiming {
                submission_ns: Vec::new(),
                laps,
            }));
        }

        // Full sets hold 2048 pairs, so the sets resolved one after the other fill the
        // buffer without a gap (each set's offset, 32 KiB, is a multiple of the 256-byte
        // alignment resolving needs).
        let bytes = timed as u64 * 2 * u64::from(wgpu::QUERY_SIZE);
        let errors = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let resolved = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("resolved timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp staging"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("resolve timestamps"),
            });
        let mut queries = 2 * scope.timed;
        for (k, set) in scope.sets.iter().enumerate() {
            let count = queries.min(QUERIES_PER_SET);
            let offset = k as u64 * u64::from(QUERIES_PER_SET) * u64::from(wgpu::QUERY_SIZE);
            encoder.resolve_query_set(set, 0..count, &resolved, offset);
            queries -= count;
        }
        encoder.copy_buffer_to_buffer(&resolved, 0, &staging, 0, bytes);
        // Straight to the queue: the timed work's counters stay as they were.
        self.queue.submit([encoder.finish()]);
        if let Some(err) = errors.pop().await {
            return Err(GpuError::Validation(err.to_string()));
        }
        let raw = map_staging(self, &staging, bytes).await?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&raw);
        let period = f64::from(self.queue.get_timestamp_period());
        // A clock that steps back (some drivers) gives 0 for that submission, never less.
        let submission_ns = ticks
            .chunks_exact(2)
            .map(|pair| pair[1].saturating_sub(pair[0]) as f64 * period)
            .collect();
        Ok(Some(GpuTiming {
            submission_ns,
            laps,
        }))
    }
}
