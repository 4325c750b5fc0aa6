//! The WGSL Jacobi kernel against the CPU reference, on a real wgpu device (lavapipe on CI).

mod common;

use std::sync::Arc;

use strahler::compute::Backend;
use strahler::diffusion::{self, Constraints, FixedMask, demo};
use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;

fn run(backend: &Backend, problem: &Constraints, sweeps: u32) -> Heightfield {
    let method = diffusion::Method::Jacobi { sweeps };
    pollster::block_on(diffusion::fill(
        backend,
        problem,
        method,
        &JobCtx::detached(),
    ))
    .expect("diffusion runs")
    .field
}

fn relative_diff(a: &Heightfield, b: &Heightfield) -> f32 {
    let (lo, hi) = a.finite_range().unwrap();
    a.max_abs_diff(b).unwrap() / (hi - lo).max(f32::MIN_POSITIVE)
}

#[test]
fn gpu_matches_cpu_on_the_demo_problem() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    // 200 is not a multiple of the 16 x 16 workgroup: the edge groups must mask correctly.
    let problem = demo::valley_and_peaks(200);
    for sweeps in [0, 1, 7, 500] {
        let cpu_field = run(&Backend::Cpu, &problem, sweeps);
        let gpu_field = run(&gpu, &problem, sweeps);
        let rel = relative_diff(&cpu_field, &gpu_field);
        assert!(
            rel <= 1e-5,
            "{sweeps} sweeps: GPU differs from CPU by {rel:e}"
        );
    }
}

#[test]
fn gpu_handles_thin_non_square_fields_and_keeps_fixed_cells() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let (w, h) = (37, 5);
    let mut fixed = FixedMask::new(w, h);
    let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
    for (x, y, z) in [(0, 0, 10.0), (36, 4, -4.0), (18, 2, 3.5)] {
        fixed.fix(x, y);
        let i = initial.index(x, y);
        initial.data_mut()[i] = z;
    }
    let problem = Constraints::new(initial, fixed).unwrap();
    let cpu_field = run(&Backend::Cpu, &problem, 301);
    let gpu_field = run(&gpu, &problem, 301);
    assert!(relative_diff(&cpu_field, &gpu_field) <= 1e-5);
    assert_eq!(gpu_field.get(0, 0), Some(10.0));
    assert_eq!(gpu_field.get(36, 4), Some(-4.0));
    assert_eq!(gpu_field.get(18, 2), Some(3.5));
}

#[test]
fn gpu_converges_to_the_harmonic_plane() {
    // u = 3x - 2y + 1 has a zero discrete Laplacian; with the border fixed to it, the GPU
    // iteration must reach it from a zero start.
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let (w, h) = (20, 20);
    let plane = |x: usize, y: usize| 3.0 * x as f32 - 2.0 * y as f32 + 1.0;
    let mut fixed = FixedMask::new(w, h);
    let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
    for y in 0..h {
        for x in 0..w {
            if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                fixed.fix(x, y);
                let i = initial.index(x, y);
                initial.data_mut()[i] = plane(x, y);
            }
        }
    }
    let problem = Constraints::new(initial, fixed).unwrap();
    let out = run(&gpu, &problem, 4000);
    for y in 0..h {
        for x in 0..w {
            let err = (out.get(x, y).unwrap() - plane(x, y)).abs();
            assert!(err < 1e-3, "({x},{y}) off by {err}");
        }
    }
}

#[test]
fn cancelling_stops_a_gpu_run() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let problem = demo::valley_and_peaks(64);
    let handle = strahler::jobs::spawn(
        "cancelled",
        move |ctx| async move {
            let method = diffusion::Method::Jacobi { sweeps: 10_000_000 };
            diffusion::fill(&gpu, &problem, method, &ctx).await
        },
        || {},
    )
    .unwrap();
    handle.cancel();
    let start = std::time::Instant::now();
    let result = loop {
        if let Some(r) = handle.try_take() {
            break r;
        }
        assert!(start.elapsed().as_secs() < 60, "cancel was not honoured");
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    assert!(matches!(
        result,
        Err(diffusion::DiffusionError::Cancelled(_))
    ));
}

#[test]
fn too_large_a_field_is_a_clear_error() {
    let Some(ctx) = common::gpu() else { return };
    let limit = ctx.caps.max_storage_bytes();
    // One row longer than the storage limit allows: must be refused before any allocation.
    let side = ((limit / 4) as f64).sqrt() as usize + 2;
    let err = ctx.check_field(side, side).unwrap_err();
    assert!(err.to_string().contains("exceeds"), "{err}");
}

#[test]
fn cpu_result_is_the_same_bits_every_time() {
    // Same problem, same result bits: the browser self-test compares this checksum with the
    // one the native build prints, so the CPU path must be exactly deterministic.
    let problem = demo::valley_and_peaks(strahler::diffusion::selftest::SIZE);
    let a = run(&Backend::Cpu, &problem, 50);
    let b = run(&Backend::Cpu, &problem, 50);
    assert_eq!(a.checksum(), b.checksum());
}

fn fill(backend: &Backend, problem: &Constraints) -> diffusion::Filled {
    let method = diffusion::Method::Multigrid(diffusion::MultigridParams::default());
    pollster::block_on(diffusion::fill(
        backend,
        problem,
        method,
        &JobCtx::detached(),
    ))
    .expect("multigrid runs")
}

#[test]
fn gpu_multigrid_converges_and_matches_cpu_multigrid() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    // Odd, non-square, not a multiple of the workgroup: every edge case of the hierarchy.
    for (n, fraction) in [(200, 0.015), (97, 0.05)] {
        let problem = demo::skeleton_like(n, fraction, 3);
        let cpu = fill(&Backend::Cpu, &problem);
        let gpu_out = fill(&gpu, &problem);
        assert!(
            cpu.converged && gpu_out.converged,
            "{n}: {cpu:?} {gpu_out:?}"
        );
        assert_eq!(gpu_out.backend, "gpu");
        let rel = relative_diff(&cpu.field, &gpu_out.field);
        assert!(
            rel <= 1e-4,
            "{n}: GPU multigrid differs from CPU by {rel:e}"
        );
        // Fixed cells exact on the GPU too.
        for (i, (&a, &b)) in gpu_out
            .field
            .data()
            .iter()
            .zip(problem.initial().data())
            .enumerate()
        {
            if problem.fixed().is_fixed_index(i) {
                assert_eq!(a, b);
            }
        }
    }
}

#[test]
fn gpu_multigrid_reaches_the_harmonic_solution_of_a_non_square_field() {
    // With the left column at 0 and the right at 100, the exact discrete harmonic field with
    // zero flux top and bottom is the linear ramp in x.
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let (w, h) = (301, 45);
    let mut fixed = FixedMask::new(w, h);
    let mut initial = Heightfield::filled(w, h, 50.0).unwrap();
    for y in 0..h {
        fixed.fix(0, y);
        fixed.fix(w - 1, y);
        let i = initial.index(0, y);
        initial.data_mut()[i] = 0.0;
        let i = initial.index(w - 1, y);
        initial.data_mut()[i] = 100.0;
    }
    let problem = Constraints::new(initial, fixed).unwrap();
    for backend in [Backend::Cpu, gpu] {
        let out = fill(&backend, &problem);
        for y in [0, h / 2, h - 1] {
            for x in 0..w {
                let exact = 100.0 * x as f32 / (w - 1) as f32;
                let err = (out.field.get(x, y).unwrap() - exact).abs();
                assert!(err <= 1e-2, "{}: ({x},{y}) off by {err}", backend.key());
            }
        }
    }
}

/// A device whose storage bindings hold only 64 KiB (16384 cells), as a small GPU would: the
/// wgpu validation layer enforces the limit, so a kernel that bound more would fail.
fn small_gpu() -> Option<strahler::gpu::GpuContext> {
    common::gpu()?;
    let small = pollster::block_on(strahler::gpu::GpuContext::headless_with_limits(|limits| {
        limits.max_storage_buffer_binding_size = 64 * 1024;
        limits.max_buffer_size = 64 * 1024;
    }))
    .expect("a device with smaller limits than the adapter's");
    assert_eq!(small.caps.max_storage_bytes(), 64 * 1024);
    Some(small)
}

/// Fields larger than one binding are tiled into bands of rows with ghost rows: both GPU
/// solvers give exactly the bits they give untiled, and multigrid still converges to the
/// CPU's answer.
#[test]
fn tiled_gpu_solvers_match_the_untiled_ones_bit_for_bit() {
    let Some(small) = small_gpu() else { return };
    let Some(large) = common::gpu() else { return };
    let (small, large) = (Backend::Gpu(Arc::new(small)), Backend::Gpu(Arc::new(large)));
    // 301 x 250 = 75250 cells: 5 bands on the finest level, 5 on the next, then whole levels.
    let (w, h) = (301, 250);
    let square = demo::skeleton_like(w, 0.015, 5);
    // Its top 250 rows: a non-square field.
    let initial = Heightfield::from_vec(w, h, square.initial().data()[..w * h].to_vec()).unwrap();
    let mut fixed = FixedMask::new(w, h);
    for (x, y) in (0..h).flat_map(|y| (0..w).map(move |x| (x, y))) {
        if square.fixed().is_fixed(x, y) {
            fixed.fix(x, y);
        }
    }
    let problem = Constraints::new(initial, fixed).unwrap();

    let tiled = fill(&small, &problem);
    let whole = fill(&large, &problem);
    assert!(
        tiled.converged,
        "tiled multigrid stopped after {} cycles at relative residual {:e}",
        tiled.cycles, tiled.relative_residual
    );
    assert_eq!(tiled.cycles, whole.cycles);
    assert_eq!(tiled.field.checksum(), whole.field.checksum(), "multigrid");
    let cpu = fill(&Backend::Cpu, &problem);
    let rel = relative_diff(&cpu.field, &tiled.field);
    assert!(
        rel <= 1e-4,
        "tiled multigrid differs from the CPU by {rel:e}"
    );

    // 7 sweeps: odd, so the answer is in the second buffer of each band.
    let tiled = run(&small, &problem, 7);
    assert_eq!(
        tiled.checksum(),
        run(&large, &problem, 7).checksum(),
        "Jacobi"
    );
    let rel = relative_diff(&run(&Backend::Cpu, &problem, 7), &tiled);
    assert!(rel <= 1e-5, "tiled Jacobi differs from the CPU by {rel:e}");
}

/// A device that cannot hold even a few rows of the field is told so, before any work.
#[test]
fn a_field_too_wide_to_tile_is_a_clear_error() {
    let Some(small) = small_gpu() else { return };
    let (w, h) = (16384, 4);
    let mut fixed = FixedMask::new(w, h);
    fixed.fix(0, 0);
    let problem = Constraints::new(Heightfield::filled(w, h, 0.0).unwrap(), fixed).unwrap();
    let method = diffusion::Method::Multigrid(diffusion::MultigridParams::default());
    let err = pollster::block_on(diffusion::fill(
        &Backend::Gpu(Arc::new(small)),
        &problem,
        method,
        &JobCtx::detached(),
    ))
    .unwrap_err();
    assert!(
        err.to_string().contains("cannot be split into bands"),
        "{err}"
    );
}

/// A terrain larger than what the GPU holds in one storage binding is still diffused on the
/// GPU, tiled (the report says `gpu`), and comes out as the untiled GPU run's terrain.
#[test]
fn a_terrain_larger_than_one_binding_is_diffused_on_the_gpu_in_bands() {
    let Some(ctx) = common::gpu() else { return };
    let Some(small) = small_gpu() else { return };
    let params = strahler::terrain::TerrainParams {
        size: 256,
        ..Default::default()
    };
    let strokes = [strahler::app::default_stroke()];
    let generate = |backend: &Backend| {
        pollster::block_on(strahler::terrain::generate(
            &strokes,
            &params,
            backend,
            &JobCtx::detached(),
        ))
        .expect("the terrain is generated")
    };
    let tiled = generate(&Backend::Gpu(Arc::new(small)));
    assert_eq!(tiled.report.diffusion.backend, "gpu");
    let whole = generate(&Backend::Gpu(Arc::new(ctx)));
    let rel = relative_diff(&whole.terrain, &tiled.terrain);
    assert!(rel <= 1e-5, "tiled terrain differs by {rel:e}");
}

/// The multigrid's tile smoothing (each pre- or post-smoothing one dispatch, in workgroup
/// memory with a halo) gives exactly the bits of a dispatch per half-sweep: on odd,
/// non-square and thin fields, with one and two sweeps before and after the coarse
/// correction, and the same cycles and verdict (the thin field's V(1,1) stops unconverged
/// on both).
#[test]
fn tile_smoothing_gives_the_bits_of_sweep_by_sweep_smoothing() {
    let Some(gpu) = common::gpu() else { return };
    let tiles = Backend::Gpu(Arc::new(gpu.clone().with_tiles(true)));
    let sweeps = Backend::Gpu(Arc::new(gpu.with_tiles(false)));
    let thin = {
        let (w, h) = (300, 7);
        let mut fixed = FixedMask::new(w, h);
        let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
        for (x, y, z) in [(0, 0, 10.0), (299, 6, -4.0), (150, 3, 3.5), (77, 1, 8.0)] {
            fixed.fix(x, y);
            let i = initial.index(x, y);
            initial.data_mut()[i] = z;
        }
        Constraints::new(initial, fixed).unwrap()
    };
    let problems = [
        demo::skeleton_like(200, 0.015, 3),
        demo::skeleton_like(97, 0.05, 4),
        demo::valley_and_peaks(129),
        thin,
    ];
    for (k, problem) in problems.iter().enumerate() {
        for (pre, post) in [(2, 2), (1, 1), (1, 2), (2, 1)] {
            let params = diffusion::MultigridParams {
                pre_sweeps: pre,
                post_sweeps: post,
                ..Default::default()
            };
            let solve = |backend: &Backend| {
                pollster::block_on(diffusion::fill(
                    backend,
                    problem,
                    diffusion::Method::Multigrid(params),
                    &JobCtx::detached(),
                ))
                .expect("multigrid runs")
            };
            let (a, b) = (solve(&tiles), solve(&sweeps));
            assert_eq!(
                (a.cycles, a.converged),
                (b.cycles, b.converged),
                "problem {k}, V({pre},{post})"
            );
            assert_eq!(
                a.field.checksum(),
                b.field.checksum(),
                "problem {k}, V({pre},{post}): tiles differ from sweeps by {:e}",
                relative_diff(&b.field, &a.field)
            );
        }
    }
}
