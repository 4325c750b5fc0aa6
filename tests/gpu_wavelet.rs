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
    pollster::block_on(wavelet::amplify_on(
        backend,
        source,
        params,
        mask,
        &JobCtx::detached(),
    ))
    .expect("amplify")
    .field
}

#[test]
fn gpu_synthesis_matches_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
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
                let on_gpu = run(&gpu, &source, &params, mask);
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
