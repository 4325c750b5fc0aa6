//! Depression filling on the GPU (`shaders/conditioning.wgsl`) against the CPU's
//! Priority-Flood + epsilon: the same heights to the bit and the same counts, on terrains
//! with pits, flats, wide basins, winding valleys, heights around zero and real designs.

mod common;

use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;
use strahler::terrain::drainage::{self, gpu::GpuFloodError};

/// Numerical Recipes LCG in [0, 1).
struct Lcg(u32);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
}

fn field(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Heightfield {
    Heightfield::from_vec(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect()).unwrap()
}

/// Terrains whose depressions the flood has to fill, with what they test.
fn terrains() -> Vec<(&'static str, Heightfield)> {
    let mut rng = Lcg(7);
    let noise: Vec<f32> = (0..200 * 150).map(|_| rng.next()).collect();
    let mut rng = Lcg(11);
    let bumps: Vec<f32> = (0..97 * 131).map(|_| rng.next()).collect();
    vec![
        // Every cell a pit or a sill: many small lakes that spill into each other.
        ("noise", field(200, 150, |x, y| 10.0 * noise[y * 200 + x])),
        // A ramp with bowls: lakes on a slope, odd sizes (not whole tiles).
        (
            "bowls on a ramp",
            field(97, 131, |x, y| {
                let bowl = ((x as f32 * 0.3).sin() * (y as f32 * 0.25).cos()) * 20.0;
                x as f32 * 0.5 + bowl + bumps[y * 97 + x]
            }),
        ),
        // A cone upside down: one pit whose basin is the whole map, flooded across many
        // tiles (the level travels from the border to the middle).
        (
            "one wide basin",
            field(160, 160, |x, y| {
                let (dx, dy) = (x as f32 - 80.0, y as f32 - 80.0);
                (dx * dx + dy * dy).sqrt() + 100.0
            }),
        ),
        // A flat table with a rim: the flood must build a gradient across the flat.
        (
            "walled flat",
            field(70, 70, |x, y| {
                if x < 3 || y < 3 || x > 66 || y > 66 {
                    5.0
                } else {
                    1.0
                }
            }),
        ),
        // A spiral wall: the water's way out winds around (many flood passes).
        ("spiral", spiral(96)),
        // Heights around zero, both zeros and negative values: the key order at zero.
        (
            "around zero",
            field(64, 48, |x, y| {
                let v = ((x * 7 + y * 13) % 11) as f32 - 5.0;
                if v == 0.0 && x % 2 == 0 {
                    -0.0
                } else {
                    v * 1e-3
                }
            }),
        ),
    ]
}

/// A spiral corridor cut into a plateau, its mouth at the border, its floor falling inward
/// (so the corridor is one long depression the flood fills from the mouth).
fn spiral(n: usize) -> Heightfield {
    let mut z = vec![50.0f32; n * n];
    let (mut x, mut y) = (0i64, 2i64);
    let (mut dx, mut dy) = (1i64, 0i64);
    let mut lo = 2i64;
    let mut hi = n as i64 - 3;
    let mut depth = 40.0f32;
    for _ in 0..n * n {
        if x >= 0 && y >= 0 && (x as usize) < n && (y as usize) < n {
            z[y as usize * n + x as usize] = depth;
        }
        depth -= 0.01;
        let (nx, ny) = (x + dx, y + dy);
        let turn = match (dx, dy) {
            (1, 0) => nx > hi,
            (0, 1) => ny > hi,
            (-1, 0) => nx < lo,
            _ => ny < lo + 2,
        };
        if turn {
            if (dx, dy) == (0, -1) {
                lo += 2;
                hi -= 2;
                if lo >= hi {
                    break;
                }
            }
            (dx, dy) = (-dy, dx);
        }
        x += dx;
        y += dy;
    }
    Heightfield::from_vec(n, n, z).unwrap()
}

fn gpu_fill(gpu: &strahler::gpu::GpuContext, f: &mut Heightfield) -> drainage::Conditioning {
    pollster::block_on(drainage::gpu::fill_depressions(gpu, f, &JobCtx::detached()))
        .expect("the GPU floods it")
}

#[test]
fn the_gpu_flood_is_the_priority_flood_to_the_bit() {
    let Some(gpu) = common::gpu() else { return };
    for (name, terrain) in terrains() {
        let mut cpu = terrain.clone();
        let expected = drainage::fill_depressions(&mut cpu);
        let mut on_gpu = terrain.clone();
        let got = gpu_fill(&gpu, &mut on_gpu);
        assert!(expected.raised_cells > 0, "{name}: nothing to fill");
        assert_eq!(got.raised_cells, expected.raised_cells, "{name}");
        assert_eq!(
            got.max_raise.to_bits(),
            expected.max_raise.to_bits(),
            "{name}"
        );
        let differ = cpu
            .data()
            .iter()
            .zip(on_gpu.data())
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ, 0,
            "{name}: {differ} cells differ from the CPU's flood"
        );
        assert!(!drainage::has_pits(&on_gpu), "{name}: pits left");
    }
}

/// A terrain that drains already comes back untouched, and one with no-data cells is
/// refused and left as it was (the pipeline then floods it on the CPU).
#[test]
fn drained_terrains_stay_and_no_data_is_refused() {
    let Some(gpu) = common::gpu() else { return };
    let ramp = field(50, 40, |x, y| (x + 2 * y) as f32);
    let mut f = ramp.clone();
    let got = gpu_fill(&gpu, &mut f);
    assert_eq!(got.raised_cells, 0);
    assert_eq!(f.data(), ramp.data());

    let mut holed = field(40, 40, |x, y| ((x * y) % 7) as f32);
    holed.data_mut()[41 * 3] = f32::NAN;
    let before: Vec<u32> = holed.data().iter().map(|v| v.to_bits()).collect();
    let err = pollster::block_on(drainage::gpu::fill_depressions(
        &gpu,
        &mut holed,
        &JobCtx::detached(),
    ))
    .expect_err("NaN cells are refused");
    assert!(matches!(err, GpuFloodError::NoData(1)), "{err}");
    let after: Vec<u32> = holed.data().iter().map(|v| v.to_bits()).collect();
    assert_eq!(before, after);
}

/// The hydrology stage on a GPU that runs the heavy stages floods on the GPU: in the
/// diffusion's own buffer before the one readback (no post-filter), or after the
/// post-filters (one upload). Either way the terrain is the one the CPU's flood gives after
/// the same GPU diffusion (same checksum), with the same counts.
#[test]
fn the_hydrology_stage_floods_on_the_gpu_with_the_same_bits() {
    use std::sync::Arc;
    use strahler::compute::Backend;
    use strahler::gpu::GpuContext;
    use strahler::pipeline::{Pipeline, RunOptions};
    use strahler::scene::Scene;

    let Some(gpu) = common::gpu() else { return };
    if !gpu.is_software() {
        // A hardware GPU floods on the GPU by default: no CPU flood after the same GPU
        // diffusion to compare with here (the flood's bits are compared above).
        return;
    }
    for fbm in [0.0, 30.0] {
        let mut scene = Scene {
            size: 192,
            rivers: vec![strahler::scene::RiverStroke {
                estuary: [0.5, 1.0],
                toward: [0.5, 0.4],
                phi: 3,
                depth: 5,
            }],
            erosion: None,
            ..Scene::default()
        };
        scene.params.post.fbm_amplitude = fbm;
        let run = |backend: Backend| {
            pollster::block_on(Pipeline::new().run(
                &scene,
                &RunOptions::for_scene(&scene),
                &backend,
                &JobCtx::detached(),
            ))
            .expect("the pipeline runs")
        };
        // Fresh devices, so each run builds the kernels it uses. Beside lavapipe the flood
        // stays on the CPU unless every stage is asked for.
        let fresh = || pollster::block_on(GpuContext::headless()).expect("a device");
        let plain = fresh();
        let on_cpu = run(Backend::Gpu(Arc::new(plain.clone())));
        let all = fresh().with_all_stages();
        let on_gpu = run(Backend::Gpu(Arc::new(all.clone())));
        let a = &on_cpu.hydrology.report;
        let b = &on_gpu.hydrology.report;
        assert!(
            a.conditioning.raised_cells > 0,
            "fbm {fbm}: {:?}",
            a.conditioning
        );
        assert_eq!(a.checksum, b.checksum, "fbm {fbm}");
        assert_eq!(a.conditioning.raised_cells, b.conditioning.raised_cells);
        assert_eq!(
            a.conditioning.max_raise.to_bits(),
            b.conditioning.max_raise.to_bits()
        );
        assert_eq!(b.drainage.pit_cells, 0);
        // And the flood did run on the GPU: its five kernels were built for it.
        let built = |g: &GpuContext| g.stats().pipelines_created;
        assert_eq!(built(&all), built(&plain) + 5, "fbm {fbm}");
    }
}
