//! Post-filters of the filled terrain (seed paper 000, Sec. V-C): Gaussian smoothing and
//! added fBm change the terrain away from the rivers and never their drainage, on the CPU
//! and in WGSL (held to each other on lavapipe); bad settings are named.

mod common;

use std::sync::Arc;

use glam::DVec2;
use strahler::compute::Backend;
use strahler::diffusion::{self, PostFilter};
use strahler::jobs::JobCtx;
use strahler::river::Stroke;
use strahler::scene::{Scene, SceneError};
use strahler::skeleton::CellKind;
use strahler::terrain::{self, Generated, TerrainParams};

fn strokes() -> Vec<Stroke> {
    vec![
        Stroke {
            estuary: DVec2::new(0.5, 1.0),
            toward: DVec2::new(0.5, 0.35),
            phi: 3,
            max_depth: 7,
        },
        Stroke {
            estuary: DVec2::new(0.0, 0.3),
            toward: DVec2::new(0.45, 0.25),
            phi: 2,
            max_depth: 7,
        },
    ]
}

fn generate(post: PostFilter, backend: &Backend) -> Generated {
    let params = TerrainParams {
        size: 256,
        seed: 9,
        post,
        ..Default::default()
    };
    pollster::block_on(terrain::generate(
        &strokes(),
        &params,
        backend,
        &JobCtx::detached(),
    ))
    .expect("generate")
}

fn strong() -> PostFilter {
    PostFilter {
        smooth_sigma: 3.0,
        fbm_amplitude: 40.0,
        ..Default::default()
    }
}

#[test]
fn filters_change_the_slopes_but_not_the_rivers_or_their_drainage() {
    let plain = generate(PostFilter::default(), &Backend::Cpu);
    let filtered = generate(strong(), &Backend::Cpu);
    let kinds = &plain.skeleton.kinds;
    let (a, b) = (plain.terrain.data(), filtered.terrain.data());
    let mut changed = 0;
    for (i, kind) in kinds.iter().enumerate() {
        if *kind == CellKind::River {
            assert_eq!(a[i], b[i], "river cell {i} moved");
        } else if (a[i] - b[i]).abs() > 1.0 {
            changed += 1;
        }
    }
    assert!(changed > a.len() / 4, "only {changed} cells changed");
    // Every river cell's steepest-descent (D8) receiver is the same: the filters left the
    // rivers and their surroundings alone, so the water goes where it went.
    let n = plain.terrain.width();
    let receiver = |z: &[f32], i: usize| {
        let (x, y) = ((i % n) as i64, (i / n) as i64);
        let mut best = (0.0f32, None);
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                let (nx, ny) = (x + dx, y + dy);
                if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= n as i64 || ny >= n as i64 {
                    continue;
                }
                let j = (ny * n as i64 + nx) as usize;
                let drop = (z[i] - z[j]) / ((dx * dx + dy * dy) as f32).sqrt();
                if drop > best.0 {
                    best = (drop, Some(j));
                }
            }
        }
        best.1
    };
    // The filter itself, on the finished terrain (the pipeline's conditioning then floods
    // depressions the noise made elsewhere, which may move flats next to a river).
    let protected: Vec<bool> = kinds
        .iter()
        .map(|k| matches!(k, CellKind::River | CellKind::Valley))
        .collect();
    let filtered_now = pollster::block_on(diffusion::post_filter(
        &Backend::Cpu,
        &plain.terrain,
        &protected,
        &strong(),
        9,
    ))
    .unwrap();
    let c = filtered_now.data();
    for (i, kind) in kinds.iter().enumerate() {
        if *kind == CellKind::River {
            assert_eq!(
                receiver(a, i),
                receiver(c, i),
                "river cell {i} drains elsewhere"
            );
        }
    }
    // The river cells whose descent stays on the river all still do; the few that leave it
    // (1.4% here) may find their way back through the filtered slopes or not.
    let (d0, d1) = (&plain.report.drainage, &filtered.report.drainage);
    assert_eq!(d0.river_cells, d1.river_cells);
    assert!(
        d1.river_fraction >= d0.river_fraction - 1e-3,
        "{d0:?} vs {d1:?}"
    );
    assert!(d1.pit_fraction <= 1e-4, "{d1:?}");
    assert!(filtered.report.stages.iter().any(|s| s.name == "post"));
    assert!(!plain.report.stages.iter().any(|s| s.name == "post"));
}

#[test]
fn smoothing_lowers_the_roughness_and_fbm_adds_relief_of_its_amplitude() {
    let plain = generate(PostFilter::default(), &Backend::Cpu);
    let n = 256;
    let protected = vec![false; n * n];
    let run = |filter: PostFilter| {
        pollster::block_on(diffusion::post_filter(
            &Backend::Cpu,
            &plain.terrain,
            &protected,
            &filter,
            3,
        ))
        .unwrap()
    };
    // Mean squared 5-point Laplacian: the roughness a blur must reduce.
    let roughness = |f: &strahler::heightfield::Heightfield| {
        let mut sum = 0.0f64;
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let l = 4.0 * f.get(x, y).unwrap()
                    - f.get(x - 1, y).unwrap()
                    - f.get(x + 1, y).unwrap()
                    - f.get(x, y - 1).unwrap()
                    - f.get(x, y + 1).unwrap();
                sum += f64::from(l * l);
            }
        }
        sum
    };
    let smooth = run(PostFilter {
        smooth_sigma: 2.0,
        ..Default::default()
    });
    assert!(roughness(&smooth) < 0.5 * roughness(&plain.terrain));
    let noisy = run(PostFilter {
        fbm_amplitude: 10.0,
        ..Default::default()
    });
    let diff: Vec<f32> = noisy
        .data()
        .iter()
        .zip(plain.terrain.data())
        .map(|(a, b)| a - b)
        .collect();
    let max = diff.iter().fold(0.0f32, |m, d| m.max(d.abs()));
    let rms = (diff.iter().map(|d| f64::from(d * d)).sum::<f64>() / diff.len() as f64).sqrt();
    assert!(max <= 10.0 + 1e-3 && rms > 1.0, "max {max}, rms {rms}");
    // Off is the identity.
    assert_eq!(run(PostFilter::default()), *plain.terrain);
}

#[test]
fn gpu_post_filters_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let plain = generate(PostFilter::default(), &Backend::Cpu);
    let protected: Vec<bool> = plain
        .skeleton
        .kinds
        .iter()
        .map(|k| *k == CellKind::River)
        .collect();
    for filter in [
        strong(),
        PostFilter {
            smooth_sigma: 1.3,
            ..Default::default()
        },
        PostFilter {
            fbm_amplitude: 15.0,
            fbm_octaves: 6,
            ..Default::default()
        },
    ] {
        let run = |backend: &Backend| {
            pollster::block_on(diffusion::post_filter(
                backend,
                &plain.terrain,
                &protected,
                &filter,
                5,
            ))
            .unwrap()
        };
        let (cpu, on_gpu) = (run(&Backend::Cpu), run(&gpu));
        let (lo, hi) = cpu.finite_range().unwrap();
        let err = cpu.max_abs_diff(&on_gpu).unwrap();
        assert!(
            err <= 1e-4 * (hi - lo),
            "{filter:?}: CPU/GPU differ by {err}"
        );
    }
}

#[test]
fn bad_post_filter_settings_are_named() {
    let mut scene = Scene::default();
    scene.params.post.smooth_sigma = -1.0;
    let err = scene.validate().unwrap_err();
    assert!(
        matches!(&err, SceneError::Invalid { field, .. } if field == "params.post.smooth_sigma"),
        "{err}"
    );
    let text = r#"{"version": 1, "params": {"post": {"fbm_octaves": 40}}}"#;
    let err = Scene::from_json(text).unwrap_err();
    assert!(err.to_string().contains("params.post.fbm_octaves"), "{err}");
    let text = r#"{"version": 1, "params": {"post": {"blur": 2}}}"#;
    assert!(Scene::from_json(text).is_err());
}
