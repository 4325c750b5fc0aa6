//! The WGSL synthesis and inverse transform (`shaders/wavelet.wgsl`) against the CPU
//! reference, on lavapipe in CI: global and local scope, with and without a mask, odd and
//! non-square sizes, 1 to 3 levels.

mod common;

use std::sync::Arc;

use strahler::compute::Backend;
use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;
use strahler::wavelet::{self, AmplifyParams, LocalParams, Mask, Scope, fbm};

fn run(
    backend: &Backend,
    source: &Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
) -> Heightfield {
    amplified(backend, source, params, mask).field
}

fn amplified(
    backend: &Backend,
    source: &Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
) -> wavelet::Amplified {
    pollster::block_on(wavelet::amplify_on(
        backend,
        source,
        params,
        mask,
        &JobCtx::detached(),
    ))
    .expect("amplify")
}

#[test]
fn gpu_synthesis_matches_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    // As the app's auto backend uses the device (beside a software rasteriser the statistics
    // run on the CPU) and with every stage on it.
    for gpu in [gpu.clone(), gpu.with_all_stages()] {
        synthesis_matches_the_cpu(&Backend::Gpu(Arc::new(gpu)));
    }
}

fn synthesis_matches_the_cpu(gpu: &Backend) {
    let source = fbm::diamond_square(97, 61, 0.7, 8).unwrap();
    let (lo, hi) = source.finite_range().unwrap();
    let mut stripe = Mask::new(50, 40).unwrap();
    stripe.paint_segment(
        glam::DVec2::new(0.2, 0.1),
        glam::DVec2::new(0.8, 0.9),
        &wavelet::Brush {
            radius: 4.0,
            ..Default::default()
        },
    );
    for levels in 1..=3 {
        for scope in [Scope::Global, Scope::Local(LocalParams::default())] {
            for mask in [None, Some(&stripe)] {
                let params = AmplifyParams {
                    levels,
                    scope,
                    seed: 12,
                    ..Default::default()
                };
                let cpu = run(&Backend::Cpu, &source, &params, mask);
                let out = amplified(gpu, &source, &params, mask);
                check_rms(gpu, &source, &out, levels, mask);
                let on_gpu = out.field;
                assert_eq!(
                    (cpu.width(), cpu.height()),
                    (on_gpu.width(), on_gpu.height())
                );
                let diff = cpu.max_abs_diff(&on_gpu).unwrap();
                assert!(
                    diff <= 1e-4 * (hi - lo),
                    "levels {levels} {scope:?} mask {}: GPU differs by {diff} (range {})",
                    mask.is_some(),
                    hi - lo
                );
            }
        }
    }
}

/// The detail's RMS the GPU measured beside the synthesis (where it runs the heavy stages)
/// is the CPU's measure of the same output, free and under the mask.
fn check_rms(
    gpu: &Backend,
    source: &Heightfield,
    out: &wavelet::Amplified,
    levels: u32,
    mask: Option<&Mask>,
) {
    let Backend::Gpu(context) = gpu else {
        unreachable!("a GPU backend")
    };
    let Some(measured) = out.rms else {
        assert!(!context.runs_heavy_stages(), "the GPU measures the RMS");
        return;
    };
    let cpu = wavelet::synthesis::detail_rms(source, &out.field, levels, mask);
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b.max(1e-6);
    assert!(cpu.unmasked > 0.0, "{cpu:?}");
    assert!(
        near(measured.unmasked, cpu.unmasked),
        "{measured:?} against {cpu:?}"
    );
    assert_eq!(
        measured.masked.is_some(),
        cpu.masked.is_some(),
        "{measured:?} {cpu:?}"
    );
    if let (Some(a), Some(b)) = (measured.masked, cpu.masked) {
        assert!(near(a, b), "{measured:?} against {cpu:?}");
    }
}

/// The statistics computed on the GPU (forward transform, GSA, LSA fits, calibrated tables)
/// against the CPU's, on rough and smooth, odd and non-square sources, at every scope.
#[test]
fn gpu_statistics_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let rough = fbm::diamond_square(97, 61, 0.7, 8).unwrap();
    let smooth = fbm::diamond_square(65, 80, 0.95, 3).unwrap();
    let scopes = [
        Scope::Global,
        Scope::Local(LocalParams::default()),
        Scope::Local(LocalParams {
            window: 1,
            ..Default::default()
        }),
        Scope::Local(LocalParams {
            window: 9,
            levels: 4,
            as_written: false,
        }),
        Scope::Local(LocalParams {
            as_written: true,
            ..Default::default()
        }),
    ];
    for source in [&rough, &smooth] {
        for scope in scopes {
            for levels in [1, 3] {
                let params = AmplifyParams {
                    levels,
                    scope,
                    ..Default::default()
                };
                let (cpu, cpu_tables) = wavelet::synthesis::prepare(source, &params).unwrap();
                let (on_gpu, gpu_tables) =
                    pollster::block_on(wavelet::gpu::prepare_on_gpu(&gpu, source, &params))
                        .expect("GPU statistics");
                let what = format!(
                    "{}x{} {scope:?} levels {levels}",
                    source.width(),
                    source.height()
                );
                assert_eq!(cpu.levels.len(), on_gpu.levels.len(), "{what}");
                for (c, g) in cpu.levels.iter().zip(&on_gpu.levels) {
                    assert_eq!((c.counts, c.fitted), (g.counts, g.fitted), "{what}");
                    for (a, b) in c.variances.iter().zip(&g.variances) {
                        assert!(
                            (a - b).abs() <= 1e-5 * a.abs().max(1e-12),
                            "{what}: {a} vs {b}"
                        );
                    }
                }
                for (c, g) in cpu.fits.iter().zip(&on_gpu.fits) {
                    let (c, g) = (c.expect("a fit"), g.expect("a fit"));
                    assert!((c.gamma - g.gamma).abs() < 1e-5, "{what}: {c:?} vs {g:?}");
                    assert!((c.intercept - g.intercept).abs() < 1e-4, "{what}");
                }
                assert_eq!(cpu_tables.tables.len(), gpu_tables.tables.len(), "{what}");
                for (t, (c, g)) in cpu_tables.tables.iter().zip(&gpu_tables.tables).enumerate() {
                    assert_eq!(c.len(), g.len(), "{what}: table {t}");
                    let worst = c
                        .iter()
                        .zip(g)
                        .map(|(a, b)| {
                            (f64::from(*a) - f64::from(*b)).abs() / f64::from(a.abs()).max(1e-12)
                        })
                        .fold(0.0f64, f64::max);
                    assert!(
                        worst < 2e-3,
                        "{what}: table {t} differs by {worst} (relative)"
                    );
                }
            }
        }
    }
}

/// A flat source has no fit: the GPU gives zero detail, as the CPU does; a source with
/// voids is refused before anything is uploaded.
#[test]
fn gpu_statistics_of_flat_and_void_sources() {
    let Some(gpu) = common::gpu() else { return };
    let flat = Heightfield::filled(40, 33, 250.0).unwrap();
    let params = AmplifyParams {
        levels: 2,
        scope: Scope::Local(LocalParams::default()),
        ..Default::default()
    };
    let (analysis, tables) =
        pollster::block_on(wavelet::gpu::prepare_on_gpu(&gpu, &flat, &params)).unwrap();
    assert!(analysis.fits.iter().all(Option::is_none));
    assert!(tables.tables.iter().flatten().all(|s| *s == 0.0));
    let mut holed = flat.clone();
    holed.data_mut()[7] = f32::NAN;
    assert!(matches!(
        pollster::block_on(wavelet::gpu::prepare_on_gpu(&gpu, &holed, &params)),
        Err(wavelet::AmplifyFailure::Wavelet(
            wavelet::WaveletError::NoData { cells: 1 }
        ))
    ));
}

/// The whole amplification reads back a few small sums and the output, however many levels
/// the source has: twice at the global scope, four times at the local one.
#[test]
fn gpu_amplify_reads_back_a_fixed_number_of_times() {
    let Some(gpu) = common::gpu() else { return };
    // Beside a software rasteriser the app's auto backend keeps the statistics on the CPU:
    // the output is the one read.
    if gpu.is_software() {
        let source = fbm::diamond_square(65, 65, 0.8, 5).unwrap();
        let before = gpu.stats();
        run(
            &Backend::Gpu(Arc::new(gpu.clone())),
            &source,
            &AmplifyParams::default(),
            None,
        );
        assert_eq!(gpu.stats().since(&before).readbacks, 1);
    }
    let gpu = Arc::new(gpu.with_all_stages());
    let backend = Backend::Gpu(gpu.clone());
    // With every stage on the GPU: the statistics' readbacks, the output's and the detail's
    // RMS sums.
    for (side, scope, expected) in [
        (33, Scope::Global, 3),
        (257, Scope::Global, 3),
        (33, Scope::Local(LocalParams::default()), 5),
        (257, Scope::Local(LocalParams::default()), 5),
    ] {
        let source = fbm::diamond_square(side, side, 0.8, 5).unwrap();
        let params = AmplifyParams {
            levels: 2,
            scope,
            ..Default::default()
        };
        let before = gpu.stats();
        run(&backend, &source, &params, None);
        let used = gpu.stats().since(&before);
        assert_eq!(used.readbacks, expected, "{side}^2 {scope:?}: {used:?}");
    }
}

/// Heights far beyond any terrain (a mis-scaled file) would overflow the kernels' f32 sums:
/// the statistics and the detail's RMS then come from the CPU's f64 ones, and the detail
/// stays finite.
#[test]
fn gpu_statistics_of_huge_heights_come_from_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = gpu.with_all_stages();
    let mut huge = fbm::diamond_square(65, 65, 0.7, 3).unwrap();
    huge.data_mut().iter_mut().for_each(|v| *v *= 1e20);
    let params = AmplifyParams {
        levels: 1,
        scope: Scope::Local(LocalParams::default()),
        ..Default::default()
    };
    let (_, cpu) = wavelet::synthesis::prepare(&huge, &params).unwrap();
    let (_, on_gpu) =
        pollster::block_on(wavelet::gpu::prepare_on_gpu(&gpu, &huge, &params)).unwrap();
    assert!(
        cpu.tables == on_gpu.tables,
        "the tables of heights near 1e20 m were not the CPU's"
    );
    let out = amplified(&Backend::Gpu(Arc::new(gpu)), &huge, &params, None);
    assert!(out.field.data().iter().all(|v| v.is_finite()));
    // And the detail's RMS is left to the CPU's f64 measure, which stays finite.
    assert!(out.rms.is_none(), "{:?}", out.rms);
    let rms = wavelet::synthesis::detail_rms(&huge, &out.field, params.levels, None);
    assert!(rms.unmasked.is_finite() && rms.unmasked > 0.0, "{rms:?}");
}
