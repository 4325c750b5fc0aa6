//! Kernels are built once per device: a second solve (multigrid, Jacobi, post-filter,
//! wavelet amplify) on the same `GpuContext` creates no shader module and no pipeline, and
//! gives the same bits as the first and as a solve on a fresh device. On lavapipe in CI.

mod common;

use std::sync::Arc;

use strahler::compute::Backend;
use strahler::diffusion::{self, Method, MultigridParams, PostFilter, demo};
use strahler::gpu::{GpuContext, GpuStats};
use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;
use strahler::wavelet::{self, AmplifyParams, LocalParams, Scope, fbm};

fn bits(field: &Heightfield) -> Vec<u32> {
    field.data().iter().map(|v| v.to_bits()).collect()
}

/// Runs `work` on `gpu` and returns its result with the counters' change.
fn counted<T>(gpu: &Arc<GpuContext>, work: impl FnOnce(&Backend) -> T) -> (T, GpuStats) {
    let before = gpu.stats();
    let out = work(&Backend::Gpu(gpu.clone()));
    (out, gpu.stats().since(&before))
}

fn multigrid(backend: &Backend) -> (Heightfield, u32) {
    let problem = demo::skeleton_like(96, 0.015, 7);
    let out = pollster::block_on(diffusion::fill(
        backend,
        &problem,
        Method::Multigrid(MultigridParams::default()),
        &JobCtx::detached(),
    ))
    .expect("multigrid");
    (out.field, out.cycles)
}

fn jacobi(backend: &Backend) -> Heightfield {
    let problem = demo::skeleton_like(64, 0.015, 3);
    pollster::block_on(diffusion::fill(
        backend,
        &problem,
        Method::Jacobi { sweeps: 50 },
        &JobCtx::detached(),
    ))
    .expect("jacobi")
    .field
}

fn post(backend: &Backend) -> Heightfield {
    let field = fbm::diamond_square(80, 48, 0.6, 5).unwrap();
    let protected = vec![false; 80 * 48];
    let filter = PostFilter {
        smooth_sigma: 2.0,
        fbm_amplitude: 10.0,
        ..Default::default()
    };
    pollster::block_on(diffusion::post_filter(
        backend, &field, &protected, &filter, 5,
    ))
    .expect("post-filter")
}

fn amplify(backend: &Backend) -> Heightfield {
    let source = fbm::diamond_square(41, 33, 0.7, 8).unwrap();
    let params = AmplifyParams {
        levels: 2,
        scope: Scope::Local(LocalParams::default()),
        seed: 4,
        ..Default::default()
    };
    pollster::block_on(wavelet::amplify_on(
        backend,
        &source,
        &params,
        None,
        &JobCtx::detached(),
    ))
    .expect("amplify")
    .field
}

#[test]
fn a_second_solve_builds_no_kernels_and_gives_the_same_bits() {
    // Every stage on the device, so that the wavelet statistics run there on lavapipe too.
    let Some(gpu) = common::gpu() else { return };
    let gpu = Arc::new(gpu.with_all_stages());
    let Some(fresh) = common::gpu() else { return };
    let fresh = Arc::new(fresh.with_all_stages());

    // Multigrid: ten kernels of one module (the V-cycles' and the level builder) on the
    // first solve, none after.
    let ((first, cycles), built) = counted(&gpu, multigrid);
    assert_eq!((built.modules_created, built.pipelines_created), (1, 10));
    assert!(built.submissions > 0 && built.readbacks > 0, "{built:?}");
    let ((second, again), reused) = counted(&gpu, multigrid);
    assert_eq!((reused.modules_created, reused.pipelines_created), (0, 0));
    assert_eq!(cycles, again);
    assert_eq!(bits(&first), bits(&second));
    // The same work counts the same submissions and readbacks.
    assert_eq!(
        (built.submissions, built.readbacks),
        (reused.submissions, reused.readbacks)
    );
    assert_no_stall_per_cycle(cycles, reused);

    let (first, built) = counted(&gpu, jacobi);
    assert_eq!((built.modules_created, built.pipelines_created), (1, 1));
    let (second, reused) = counted(&gpu, jacobi);
    assert_eq!((reused.modules_created, reused.pipelines_created), (0, 0));
    assert_eq!(bits(&first), bits(&second));

    let (first, built) = counted(&gpu, post);
    assert_eq!((built.modules_created, built.pipelines_created), (1, 3));
    let (second, reused) = counted(&gpu, post);
    assert_eq!((reused.modules_created, reused.pipelines_created), (0, 0));
    assert_eq!(bits(&first), bits(&second));

    // The wavelet path: the analysis's six kernels and the synthesis's two and its RMS
    // measure, in two modules.
    let (first, built) = counted(&gpu, amplify);
    assert_eq!((built.modules_created, built.pipelines_created), (2, 9));
    let (second, reused) = counted(&gpu, amplify);
    assert_eq!((reused.modules_created, reused.pipelines_created), (0, 0));
    assert_eq!(bits(&first), bits(&second));

    // A device that builds its kernels afresh gives the same bits as the cached ones.
    let backend = Backend::Gpu(fresh.clone());
    assert_eq!(
        bits(&multigrid(&backend).0),
        bits(&multigrid(&Backend::Gpu(gpu.clone())).0)
    );
    assert_eq!(
        bits(&post(&backend)),
        bits(&post(&Backend::Gpu(gpu.clone())))
    );
    assert_eq!(
        bits(&amplify(&backend)),
        bits(&amplify(&Backend::Gpu(gpu.clone())))
    );
    assert_eq!(gpu.stats().pipelines_created, 23);
    assert_eq!(gpu.stats().modules_created, 5);
}

/// The convergence checks are read once per batch of 4 V-cycles (the full-multigrid start
/// shares the first batch), and each batch is one submission: at most `cycles / 4 + 2`
/// readbacks (the `+ 2`: a batch begun and the result), never one per cycle.
fn assert_no_stall_per_cycle(cycles: u32, work: GpuStats) {
    let cycles = u64::from(cycles);
    assert!(
        cycles >= 4,
        "the test problem needs several batches: {cycles}"
    );
    assert!(
        4 * work.readbacks <= cycles + 8,
        "{} readbacks for {cycles} cycles: {work:?}",
        work.readbacks
    );
    assert!(
        4 * work.submissions <= cycles + 8,
        "{} submissions for {cycles} cycles: {work:?}",
        work.submissions
    );
}

/// Solves of several sizes and a tiled one keep to the readback budget, and a second solve of
/// each creates no pipeline.
#[test]
fn multigrid_reads_back_once_per_batch_of_cycles() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Arc::new(gpu);
    let solve = |n: usize, seed: u64| {
        move |backend: &Backend| {
            let problem = demo::skeleton_like(n, 0.015, seed);
            pollster::block_on(diffusion::fill(
                backend,
                &problem,
                Method::Multigrid(MultigridParams::default()),
                &JobCtx::detached(),
            ))
            .expect("multigrid")
        }
    };
    for (n, seed) in [(64, 1), (129, 2), (200, 3)] {
        let (first, _) = counted(&gpu, solve(n, seed));
        let (second, work) = counted(&gpu, solve(n, seed));
        assert!(second.converged, "{n}: {second:?}");
        assert_eq!(work.pipelines_created, 0, "{n}: {work:?}");
        assert_eq!(first.cycles, second.cycles);
        assert_no_stall_per_cycle(second.cycles, work);
    }
    // Tiled in bands (64 KiB per binding): the same budget, the same cycles as untiled.
    let small = Arc::new(
        pollster::block_on(GpuContext::headless_with_limits(|limits| {
            limits.max_storage_buffer_binding_size = 64 * 1024;
            limits.max_buffer_size = 64 * 1024;
        }))
        .expect("a device with small bindings"),
    );
    let (_, _) = counted(&small, solve(200, 3));
    let (tiled, work) = counted(&small, solve(200, 3));
    assert_eq!(work.pipelines_created, 0, "{work:?}");
    assert!(tiled.converged, "{tiled:?}");
    assert_eq!(
        tiled.cycles,
        solve(200, 3)(&Backend::Gpu(gpu.clone())).cycles
    );
    // The checks keep to the budget; the result comes back band by band: 200 rows in bands
    // of 78 (81 rows of 200 cells fit in 64 KiB, less two ghost rows, even) are 3 readbacks
    // and 3 submissions where an untiled field needs 1.
    let checks = GpuStats {
        readbacks: work.readbacks - 2,
        submissions: work.submissions - 2,
        ..work
    };
    assert_no_stall_per_cycle(tiled.cycles, checks);
}

#[test]
fn warming_builds_every_kernel_once() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Arc::new(gpu);
    pollster::block_on(diffusion::warm_gpu(&gpu)).expect("diffusion kernels");
    pollster::block_on(wavelet::gpu::warm(&gpu)).expect("wavelet kernels");
    let warmed = gpu.stats();
    // The diffusion's, the synthesis's, the wavelet statistics' module and six kernels and
    // the detail's RMS measure, on any device: a software rasteriser runs them when every
    // stage is asked of it ("Compute on: gpu"), and the first run there builds none.
    let expected = (5, 23);
    assert_eq!((warmed.modules_created, warmed.pipelines_created), expected);
    // Clones of the context share the cache.
    let clone = Arc::new((*gpu).clone());
    let ((_, _), built) = counted(&clone, multigrid);
    let (_, built_post) = counted(&clone, post);
    assert_eq!(
        (built.pipelines_created, built_post.pipelines_created),
        (0, 0)
    );
    pollster::block_on(diffusion::warm_gpu(&gpu)).expect("again");
    assert_eq!(gpu.stats().pipelines_created, expected.1);
    // The same device with every stage asked of it shares the cache: nothing new to build.
    let all = gpu.as_ref().clone().with_all_stages();
    pollster::block_on(wavelet::gpu::warm(&all)).expect("statistics kernels");
    assert_eq!(
        (all.stats().modules_created, all.stats().pipelines_created),
        expected
    );
}

/// A readback the device refuses is an error naming why, never a buffer of zeros taken for
/// a terrain.
#[test]
fn a_refused_readback_is_an_error() {
    let Some(gpu) = common::gpu() else { return };
    let hidden = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("storage without COPY_SRC"),
        size: 64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let result = pollster::block_on(strahler::gpu::read_f32_buffer(&gpu, &hidden, 16));
    assert!(
        matches!(result, Err(strahler::gpu::GpuError::Validation(_))),
        "{result:?}"
    );
}

/// A device the app shares (eframe's, handed over with `GpuContext::from_device`) logs the
/// errors no error scope captured, where wgpu's default handler would panic natively and end
/// the app with the user's unsaved work; the device goes on working.
#[test]
fn a_shared_device_survives_an_uncaptured_error() {
    if common::gpu().is_none() {
        return;
    }
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    descriptor.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    let instance = wgpu::Instance::new(descriptor);
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("the adapter common::gpu found");
    let (device, queue) =
        pollster::block_on(adapter.request_device(&strahler::gpu::device_descriptor(&adapter)))
            .expect("a device");
    let gpu = GpuContext::from_device(&adapter, &device, &queue);
    // A buffer mapped both ways is invalid without a feature the app does not ask for; no
    // error scope is open.
    let _refused = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("mapped both ways"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::MAP_WRITE,
        mapped_at_creation: false,
    });
    let field = fbm::diamond_square(17, 9, 0.7, 2).unwrap();
    let copy = common::gpu_copy(&gpu, &field, 0.0);
    let back = pollster::block_on(copy.read(&gpu)).expect("the device still works");
    assert!(bits(&back) == bits(&field));
}
