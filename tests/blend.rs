//! Poisson blending (seed paper 000, Sec. VI, eq. 9): the multigrid answer against a direct
//! dense solve of the same equations, exactness for a reference equal to the source plus a
//! constant, zero flux where the block meets the map edge, transforms, the scene block, and
//! CPU/GPU agreement on lavapipe.

mod common;

use std::sync::Arc;

use strahler::blend::{self, BlendBlock, BlendError, BlockRect, Transform, guide};
use strahler::compute::Backend;
use strahler::diffusion::MultigridParams;
use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;
use strahler::wavelet::fbm;

fn solve(
    backend: &Backend,
    target: &Heightfield,
    rect: BlockRect,
    guide: &Heightfield,
) -> Heightfield {
    let mut out = target.clone();
    pollster::block_on(blend::solve_block(
        backend,
        &mut out,
        rect,
        guide,
        (&MultigridParams::default(), 0.0),
        &JobCtx::detached(),
    ))
    .expect("blend");
    out
}

/// Eq. 9 assembled and solved directly (dense Gaussian elimination in f64): on every unknown
/// cell `sum_j (T_i - T_j) = sum_j (R_i - R_j)` over its neighbours on the map; the frame
/// cells with terrain beyond them keep S.
fn direct(target: &Heightfield, rect: BlockRect, guide: &Heightfield) -> Heightfield {
    let (tw, th) = (target.width(), target.height());
    let (w, h) = (rect.width, rect.height);
    let fixed = |x: usize, y: usize| {
        let (gx, gy) = (rect.col + x, rect.row + y);
        (x == 0 && gx > 0)
            || (y == 0 && gy > 0)
            || (x + 1 == w && gx + 1 < tw)
            || (y + 1 == h && gy + 1 < th)
    };
    let mut index = vec![usize::MAX; w * h];
    let mut n = 0;
    for y in 0..h {
        for x in 0..w {
            if !fixed(x, y) {
                index[y * w + x] = n;
                n += 1;
            }
        }
    }
    let s = |x: usize, y: usize| f64::from(target.data()[(rect.row + y) * tw + rect.col + x]);
    let r = |x: usize, y: usize| f64::from(guide.data()[y * w + x]);
    let mut a = vec![0.0f64; n * n];
    let mut b = vec![0.0f64; n];
    for y in 0..h {
        for x in 0..w {
            let i = index[y * w + x];
            if i == usize::MAX {
                continue;
            }
            let (gx, gy) = ((rect.col + x) as i64, (rect.row + y) as i64);
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (gx + dx, gy + dy);
                if nx < 0 || ny < 0 || nx >= tw as i64 || ny >= th as i64 {
                    continue; // off the map: zero flux
                }
                let (bx, by) = ((x as i64 + dx) as usize, (y as i64 + dy) as usize);
                assert!(
                    bx < w && by < h,
                    "an unknown's neighbour must be in the block"
                );
                a[i * n + i] += 1.0;
                b[i] += r(x, y) - r(bx, by);
                match index[by * w + bx] {
                    usize::MAX => b[i] += s(bx, by),
                    j => a[i * n + j] -= 1.0,
                }
            }
        }
    }
    // Gaussian elimination with partial pivoting.
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs()))
            .unwrap();
        if p != k {
            for c in 0..n {
                a.swap(k * n + c, p * n + c);
            }
            b.swap(k, p);
        }
        for i in k + 1..n {
            let f = a[i * n + k] / a[k * n + k];
            if f != 0.0 {
                for c in k..n {
                    a[i * n + c] -= f * a[k * n + c];
                }
                b[i] -= f * b[k];
            }
        }
    }
    let mut x = vec![0.0f64; n];
    for k in (0..n).rev() {
        let mut v = b[k];
        for c in k + 1..n {
            v -= a[k * n + c] * x[c];
        }
        x[k] = v / a[k * n + k];
    }
    let mut out = target.clone();
    for y in 0..h {
        for xx in 0..w {
            if let Some(&i) = index.get(y * w + xx).filter(|&&i| i != usize::MAX) {
                out.data_mut()[(rect.row + y) * tw + rect.col + xx] = x[i] as f32;
            }
        }
    }
    out
}

fn range(f: &Heightfield) -> f32 {
    let (lo, hi) = f.finite_range().unwrap();
    hi - lo
}

fn terrain() -> (Heightfield, Heightfield) {
    let target = fbm::diamond_square(33, 29, 0.6, 3).unwrap();
    let mut reference = fbm::diamond_square(40, 40, 0.9, 4).unwrap();
    reference
        .data_mut()
        .iter_mut()
        .for_each(|v| *v = *v * 3.0 + 500.0);
    (target, reference)
}

#[test]
fn blending_matches_a_direct_solve_inside_and_at_the_map_edges() {
    let (target, reference) = terrain();
    let cases = [
        BlockRect {
            row: 6,
            col: 5,
            height: 15,
            width: 17,
        }, // inside
        BlockRect {
            row: 0,
            col: 9,
            height: 12,
            width: 14,
        }, // touches the north edge
        BlockRect {
            row: 14,
            col: 0,
            height: 15,
            width: 33,
        }, // west, east and south edges
    ];
    for rect in cases {
        let g = guide::window(&reference, 2, 3, rect.height, rect.width, 1.0).unwrap();
        let exact = direct(&target, rect, &g);
        let scale = range(&exact);
        let got = solve(&Backend::Cpu, &target, rect, &g);
        let err = got.max_abs_diff(&exact).unwrap();
        assert!(
            err <= 1e-4 * scale,
            "{rect:?}: error {err} of range {scale}"
        );
        // Outside the block nothing moved.
        for y in 0..target.height() {
            for x in 0..target.width() {
                let inside = (rect.row..rect.row + rect.height).contains(&y)
                    && (rect.col..rect.col + rect.width).contains(&x);
                if !inside {
                    assert_eq!(got.get(x, y), target.get(x, y));
                }
            }
        }
    }
}

#[test]
fn a_reference_equal_to_the_source_plus_a_constant_gives_the_source_back() {
    let (target, _) = terrain();
    let rect = BlockRect {
        row: 4,
        col: 3,
        height: 20,
        width: 22,
    };
    let mut g = guide::window(&target, rect.row, rect.col, rect.height, rect.width, 1.0).unwrap();
    // An offset small enough that `S + c` is exact in f32 for these heights (|S| < 4).
    g.data_mut().iter_mut().for_each(|v| *v += 7.25);
    let got = solve(&Backend::Cpu, &target, rect, &g);
    let err = got.max_abs_diff(&target).unwrap();
    assert!(err <= 1e-5 * range(&target), "error {err}");
}

#[test]
fn the_blended_block_carries_the_reference_features_and_meets_the_terrain_without_a_seam() {
    // A flat terrain and a reference with a sharp cone: the cone appears inside the block,
    // and across the block's frame the terrain's slope stays what it was (zero).
    let target = Heightfield::filled(64, 64, 100.0).unwrap();
    let n = 31;
    let cone: Vec<f32> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 - 15.0, (i / n) as f32 - 15.0);
            (50.0 - 5.0 * (x * x + y * y).sqrt()).max(0.0)
        })
        .collect();
    let reference = Heightfield::from_vec(n, n, cone).unwrap();
    let rect = BlockRect {
        row: 10,
        col: 20,
        height: n,
        width: n,
    };
    let got = solve(&Backend::Cpu, &target, rect, &reference);
    let centre = got.get(35, 25).unwrap();
    let corner = got.get(21, 11).unwrap();
    assert!(centre - corner > 40.0, "cone height {}", centre - corner);
    // The frame keeps the terrain exactly.
    assert_eq!(got.get(20, 10), Some(100.0));
    assert_eq!(got.get(50, 40), Some(100.0));
}

/// The feathered edge (`blend::poisson`'s module docs): a rough reference blended into a
/// tilted plane. Eq. 9 alone leaves a crease along the frame, the slope jumping from the
/// plane's to the reference's; with a quarter of the side feathered the crease falls to a
/// tenth or less and to no more than the block's own texture, the middle beyond the band is
/// eq. 9's solution to the bit, and every cell lies between the terrain and that solution.
#[test]
fn a_feathered_block_meets_the_terrain_with_its_slope() {
    let n = 64;
    let plane: Vec<f32> = (0..n * n).map(|i| 100.0 + (i % n) as f32).collect();
    let target = Heightfield::from_vec(n, n, plane).unwrap();
    let mut reference = fbm::diamond_square(33, 33, 0.9, 7).unwrap();
    reference.data_mut().iter_mut().for_each(|v| *v *= 40.0);
    let rect = BlockRect {
        row: 15,
        col: 15,
        height: 33,
        width: 33,
    };
    let run = |feather: f32| {
        let mut out = target.clone();
        pollster::block_on(blend::solve_block(
            &Backend::Cpu,
            &mut out,
            rect,
            &reference,
            (&MultigridParams::default(), feather),
            &JobCtx::detached(),
        ))
        .expect("blend");
        out
    };
    let (sharp, feathered) = (run(0.0), run(0.25));
    let at = |f: &Heightfield, x: usize, y: usize| f.get(x, y).unwrap();
    // Second differences across the west and east sides (the plane's are zero).
    let crease = |f: &Heightfield| {
        let mut sum = 0.0f32;
        for y in 16..47 {
            for x in [15usize, 47] {
                sum += (at(f, x + 1, y) - 2.0 * at(f, x, y) + at(f, x - 1, y)).abs();
            }
        }
        sum / 62.0
    };
    // The same in the block's middle, beyond the band of 8 cells.
    let texture = |f: &Heightfield| {
        let mut sum = 0.0f32;
        for y in 24..39 {
            for x in 24..39 {
                sum += (at(f, x + 1, y) - 2.0 * at(f, x, y) + at(f, x - 1, y)).abs();
            }
        }
        sum / 225.0
    };
    let (c0, c1, t1) = (crease(&sharp), crease(&feathered), texture(&feathered));
    assert!(c1 <= 0.1 * c0, "crease {c1} feathered, {c0} by eq. 9 alone");
    assert!(c1 <= t1, "crease {c1} against the block's texture {t1}");
    for y in 0..n {
        for x in 0..n {
            let (s, t0, t) = (at(&target, x, y), at(&sharp, x, y), at(&feathered, x, y));
            let middle = (23..40).contains(&x) && (23..40).contains(&y);
            if middle {
                assert_eq!(t, t0, "({x}, {y}) beyond the band");
            }
            assert!(t >= s.min(t0) - 1e-3 && t <= s.max(t0) + 1e-3, "({x}, {y})");
        }
    }
}

#[test]
fn bad_blocks_get_specific_errors() {
    let (target, reference) = terrain();
    let mut t = target.clone();
    let run = |t: &mut Heightfield, rect: BlockRect, g: &Heightfield| {
        pollster::block_on(blend::solve_block(
            &Backend::Cpu,
            t,
            rect,
            g,
            (&MultigridParams::default(), 0.0),
            &JobCtx::detached(),
        ))
    };
    let g = guide::window(&reference, 0, 0, 5, 5, 1.0).unwrap();
    let outside = BlockRect {
        row: 30,
        col: 0,
        height: 5,
        width: 5,
    };
    assert!(matches!(
        run(&mut t, outside, &g),
        Err(BlendError::BlockOutside { .. })
    ));
    let whole = BlockRect {
        row: 0,
        col: 0,
        height: 29,
        width: 33,
    };
    let gw = guide::window(&reference, 0, 0, 29, 33, 1.0).unwrap();
    assert!(matches!(
        run(&mut t, whole, &gw),
        Err(BlendError::NoBoundary)
    ));
    let mut holey = g.clone();
    holey.data_mut()[7] = f32::NAN;
    let inside = BlockRect {
        row: 3,
        col: 3,
        height: 5,
        width: 5,
    };
    assert!(matches!(
        run(&mut t, inside, &holey),
        Err(BlendError::ReferenceVoid { row: 1, col: 2 })
    ));
    assert!(matches!(
        guide::window(&reference, 38, 0, 5, 5, 1.0),
        Err(BlendError::WindowOutside { .. })
    ));
    assert_eq!(t, target, "failed blends leave the terrain untouched");
}

#[test]
fn a_scene_block_round_trips_and_applies_its_transform() {
    let (mut target, reference) = terrain();
    let piece = guide::window(&reference, 0, 0, 12, 20, 1.0).unwrap();
    let mut block =
        BlendBlock::new("test.tif [0,0 12x20]", &piece, [0.25, 0.25, 0.75, 0.6]).unwrap();
    block.quarter_turns = 1;
    block.mirror = true;
    block.z_scale = 2.0;
    // Through the scene file, whose schema the scene owns.
    let scene = strahler::scene::Scene {
        blend: vec![block.clone()],
        ..Default::default()
    };
    let back = strahler::scene::Scene::from_json(&scene.to_json()).unwrap();
    assert_eq!(back.blend, [block.clone()]);
    assert!(block.validate().is_ok());
    // The stored reference is within one 16-bit step of the original.
    let decoded = block.reference().unwrap();
    let step = range(&piece) / 65535.0;
    assert!(decoded.max_abs_diff(&piece).unwrap() <= step * 0.51 + 1e-3);

    let rect = block.rect_on(target.width(), target.height());
    assert_eq!(
        rect,
        BlockRect {
            row: 7,
            col: 8,
            height: 11,
            width: 17
        }
    );
    let g = block.guide(rect).unwrap();
    let turned = Transform {
        quarter_turns: 1,
        mirror: true,
        z_scale: 2.0,
    }
    .apply(&decoded);
    assert_eq!((turned.width(), turned.height()), (12, 20));
    assert_eq!(g, guide::resample(&turned, 17, 11));
    let before = target.clone();
    let solves = pollster::block_on(blend::apply_blocks(
        &Backend::Cpu,
        &mut target,
        &[block.clone()],
        &JobCtx::detached(),
    ))
    .unwrap();
    assert_eq!(solves.len(), 1);
    assert!(solves[0].converged);
    assert_ne!(target, before);

    let mut bad = block;
    bad.rect = [0.5, 0.2, 0.4, 0.9];
    assert_eq!(bad.validate().unwrap_err().0, "rect");
}

#[test]
fn gpu_blending_matches_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let gpu = Backend::Gpu(Arc::new(gpu));
    let target = fbm::diamond_square(129, 97, 0.7, 5).unwrap();
    let reference = fbm::diamond_square(80, 80, 0.9, 6).unwrap();
    for rect in [
        BlockRect {
            row: 10,
            col: 20,
            height: 61,
            width: 70,
        },
        BlockRect {
            row: 0,
            col: 0,
            height: 50,
            width: 64,
        },
    ] {
        let g = guide::window(&reference, 5, 5, rect.height, rect.width, 1.5).unwrap();
        let cpu = solve(&Backend::Cpu, &target, rect, &g);
        let on_gpu = solve(&gpu, &target, rect, &g);
        let err = cpu.max_abs_diff(&on_gpu).unwrap();
        assert!(
            err <= 1e-4 * range(&cpu),
            "{rect:?}: CPU/GPU differ by {err}"
        );
    }
}
