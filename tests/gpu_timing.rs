//! Issue 18, point 6: the GPU's own time of the submitted work, from timestamp queries. A
//! timed solve reports GPU time above zero and within its wall time, one span per submission;
//! timing adds no counted submission or readback, and with no scope open no query at all.
//! On lavapipe in CI (Mesa's lavapipe offers timestamp queries, so there the tests must run).

mod common;

use std::sync::Arc;
use std::time::Instant;

use strahler::compute::Backend;
use strahler::diffusion::{self, Method, MultigridParams, demo};
use strahler::gpu::GpuContext;
use strahler::jobs::JobCtx;

/// A GPU with timestamp queries, or `None` (with a message) where the adapter has none. An
/// adapter known to offer them (lavapipe, which CI names) must have them.
fn timed_gpu() -> Option<Arc<GpuContext>> {
    let gpu = common::gpu()?;
    if !gpu.has_timestamps() {
        assert!(
            !gpu.adapter.name.contains("llvmpipe"),
            "lavapipe offers timestamp queries, but the device has none: {gpu:?}"
        );
        eprintln!(
            "skipping: the adapter {} offers no timestamp queries (wgpu::Features::TIMESTAMP_QUERY), \
             so there is no GPU time to measure",
            gpu.adapter.name
        );
        return None;
    }
    Some(Arc::new(gpu))
}

fn multigrid(backend: &Backend, n: usize) -> diffusion::Filled {
    let problem = demo::skeleton_like(n, 0.015, 5);
    pollster::block_on(diffusion::fill(
        backend,
        &problem,
        Method::Multigrid(MultigridParams::default()),
        &JobCtx::detached(),
    ))
    .expect("multigrid")
}

#[test]
fn a_timed_multigrid_solve_reports_gpu_time_within_its_wall_time() {
    let Some(gpu) = timed_gpu() else { return };
    let backend = Backend::Gpu(gpu.clone());
    // Build the kernels outside the measurement.
    let untimed_first = multigrid(&backend, 129);

    let before = gpu.stats();
    let untimed = multigrid(&backend, 129);
    let plain = gpu.stats().since(&before);
    assert_eq!(plain.timestamp_queries, 0, "no scope, no query: {plain:?}");
    assert_eq!(untimed.cycles, untimed_first.cycles);

    let before = gpu.stats();
    assert!(gpu.start_timing());
    let start = Instant::now();
    let timed = multigrid(&backend, 129);
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let timing = pollster::block_on(gpu.stop_timing())
        .expect("timestamps read back")
        .expect("a scope was open");
    let work = gpu.stats().since(&before);

    // Timing changes neither the work nor what the solver's counters say about it.
    assert_eq!(timed.cycles, untimed.cycles);
    assert_eq!(
        (work.submissions, work.readbacks, work.pipelines_created),
        (plain.submissions, plain.readbacks, 0),
        "{work:?} against {plain:?}"
    );
    // One span per submission, two queries each; nothing after the scope closed.
    assert_eq!(timing.submission_ns.len() as u64, work.submissions);
    assert_eq!(work.timestamp_queries, 2 * work.submissions);
    assert!(timing.laps.is_empty());
    let gpu_ms = timing.ms();
    assert!(
        gpu_ms > 0.0 && gpu_ms <= wall_ms,
        "GPU time {gpu_ms} ms for a solve of {wall_ms} ms wall clock: {timing:?}"
    );
    assert!(
        timing
            .submission_ns
            .iter()
            .all(|ns| ns.is_finite() && *ns >= 0.0)
    );

    // Closed: later submissions write no query, and there is nothing more to read.
    let before = gpu.stats();
    multigrid(&backend, 129);
    assert_eq!(gpu.stats().since(&before).timestamp_queries, 0);
    assert_eq!(pollster::block_on(gpu.stop_timing()).unwrap(), None);
}

/// More submissions than one query set holds (4096 queries, 2048 submissions): the scope
/// takes another set and every submission gets its span; laps split them, and a lap that
/// submitted nothing (a CPU stage) has no GPU time.
#[test]
fn many_submissions_span_several_query_sets_and_laps_split_them() {
    let Some(gpu) = timed_gpu() else { return };
    let backend = Backend::Gpu(gpu.clone());
    multigrid(&backend, 64);

    assert!(gpu.start_timing());
    gpu.timing_lap("cpu stage");
    const EMPTY: usize = 2100;
    for k in 0..EMPTY {
        let encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        gpu.submit(encoder.finish());
        if k % 256 == 255 {
            pollster::block_on(strahler::gpu::wait_for_submitted_work(&gpu)).unwrap();
        }
    }
    gpu.timing_lap("empty");
    let before = gpu.stats();
    multigrid(&backend, 64);
    let solve = gpu.stats().since(&before);
    gpu.timing_lap("solve");
    let timing = pollster::block_on(gpu.stop_timing()).unwrap().unwrap();

    let total = EMPTY + solve.submissions as usize;
    assert_eq!(timing.submission_ns.len(), total);
    let laps: Vec<_> = timing
        .laps
        .iter()
        .map(|(name, range)| (name.as_str(), range.clone()))
        .collect();
    assert_eq!(
        laps,
        [
            ("cpu stage", 0..0),
            ("empty", 0..EMPTY),
            ("solve", EMPTY..total)
        ]
    );
    assert_eq!(timing.lap_ms("cpu stage"), None);
    assert_eq!(timing.lap_ms("no such lap"), None);
    let solve_ms = timing.lap_ms("solve").expect("the solve submitted work");
    assert!(solve_ms > 0.0, "{solve_ms}");
    let empty_ms = timing.lap_ms("empty").expect("timed");
    assert!(
        (empty_ms + solve_ms - timing.ms()).abs() <= 1e-9 * timing.ms().max(1.0),
        "the laps add up to the whole"
    );
    // Spans of the second query set were read back too (not left at zero): the solve's
    // submissions come after the first 2048.
    assert!(
        timing.submission_ns[EMPTY..].iter().any(|ns| *ns > 0.0),
        "{:?}",
        &timing.submission_ns[EMPTY..]
    );
}
