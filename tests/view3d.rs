//! The 3D view rendered headlessly (lavapipe on CI): no cracks between chunks of different
//! levels, fewer triangles from afar, the shading options visibly at work, and the rasters
//! made on the GPU like the CPU's. With `STRAHLER_SHOTS=<folder>` the last test also writes
//! its two pictures there.

mod common;

use strahler::gpu::GpuContext;
use strahler::heightfield::Heightfield;
use strahler::view3d::maps::Rasters;
use strahler::view3d::renderer::CLEAR;
use strahler::view3d::{Camera, CameraMode, Renderer, TerrainMaps, View3dSettings};

const CELL: f32 = 10.0;
const SIZE: [u32; 2] = [320, 240];

/// Hills plus hash noise of +-40 m per cell: rough enough that any T-junction between
/// chunks of different levels opens a visible gap.
fn rough_terrain(n: usize) -> Heightfield {
    let data = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
            let mut v = (i as u32).wrapping_mul(2_654_435_761);
            v ^= v >> 15;
            v = v.wrapping_mul(2_246_822_519);
            v ^= v >> 13;
            let noise = (v & 0xffff) as f32 / 65535.0 - 0.5;
            300.0 * (5.0 * x).sin() * (4.0 * y).cos() + 400.0 + 80.0 * noise
        })
        .collect();
    Heightfield::from_vec(n, n, data).unwrap()
}

fn renderer(ctx: &GpuContext, field: &Heightfield) -> Renderer {
    let mut r = Renderer::new(&ctx.device);
    let maps = TerrainMaps::new(field, CELL, r.max_texture_side());
    // A river along the middle column, for the water layer.
    let n = field.width();
    let middle = (n / 2) as f32;
    let river = strahler::skeleton::RiverPiece {
        a: [middle, 0.0],
        b: [middle, (n - 1) as f32],
        order: 4,
    };
    let water = strahler::view3d::maps::water_mask(&[river], n, CELL);
    r.set_terrain(&ctx.device, &ctx.queue, maps, Some((&water, n)));
    r
}

fn pixels(ctx: &GpuContext, r: &Renderer) -> Vec<[u8; 4]> {
    let (bytes, size) = pollster::block_on(r.read_color(ctx)).unwrap();
    assert_eq!(size, SIZE);
    bytes
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect()
}

fn is_sky(p: &[u8; 4]) -> bool {
    CLEAR
        .iter()
        .zip(p)
        .all(|(c, &v)| (c * 255.0 - f64::from(v)).abs() <= 1.5)
}

/// An eye 250 m above the middle of the map looking 50 degrees down: the whole picture is
/// ground, so any sky-coloured pixel is a crack.
fn looking_down(maps: &TerrainMaps, exaggeration: f32) -> Camera {
    let (w, h) = maps.extent();
    let mut c = Camera::overview(w, h, 0.0);
    c.set_mode(CameraMode::Fly, 1.0);
    c.yaw = 0.7;
    c.pitch = -50f32.to_radians();
    c.position = glam::Vec3::new(
        0.5 * w,
        0.6 * h,
        maps.ground(0.5 * w, 0.6 * h) * exaggeration + 250.0,
    );
    c
}

#[test]
fn skirts_hide_every_crack_between_levels() {
    let Some(ctx) = common::gpu() else { return };
    let field = rough_terrain(513);
    let mut r = renderer(&ctx, &field);
    let camera = looking_down(r.maps().unwrap(), 2.0);
    let mut settings = View3dSettings {
        pixels_per_quad: 10.0,
        ..Default::default()
    };
    let stats = r
        .render(&ctx.device, &ctx.queue, SIZE, &camera, &settings)
        .unwrap();
    // The picture mixes levels: synthetic detail near the eye, the field's cells and coarser
    // chunks further away.
    assert!(stats.finest_level < 0, "{stats:?}");
    let sky_with_skirts = pixels(&ctx, &r).iter().filter(|p| is_sky(p)).count();

    // The same view without skirts shows the gaps this test is looking for.
    settings.skirts = false;
    r.render(&ctx.device, &ctx.queue, SIZE, &camera, &settings)
        .unwrap();
    let sky_without = pixels(&ctx, &r).iter().filter(|p| is_sky(p)).count();
    assert_eq!(sky_with_skirts, 0, "cracks with skirts ({stats:?})");
    assert!(sky_without > 0, "no crack to hide: the test proves nothing");
}

#[test]
fn the_view_draws_fewer_triangles_from_afar() {
    let Some(ctx) = common::gpu() else { return };
    let field = rough_terrain(1025);
    let mut r = renderer(&ctx, &field);
    let settings = View3dSettings::default();
    let (w, h) = r.maps().unwrap().extent();
    let mut camera = Camera::overview(w, h, 400.0);
    let mut count = |distance: f32| {
        camera.distance = distance * w;
        r.render(&ctx.device, &ctx.queue, SIZE, &camera, &settings)
            .unwrap()
    };
    let near = count(0.05);
    let far = count(3.0);
    assert!(
        near.triangles >= 2 * far.triangles,
        "near {near:?}, far {far:?}"
    );
    assert!(near.finest_level < far.finest_level);
}

#[test]
fn snow_and_the_water_plane_change_the_picture() {
    let Some(ctx) = common::gpu() else { return };
    let field = rough_terrain(257);
    let mut r = renderer(&ctx, &field);
    let (w, h) = r.maps().unwrap().extent();
    let camera = Camera::overview(w, h, 400.0);
    let mut settings = View3dSettings::default();
    let mut shot = |s: &View3dSettings| {
        r.render(&ctx.device, &ctx.queue, SIZE, &camera, s).unwrap();
        pixels(&ctx, &r)
    };
    let plain = shot(&settings);
    let white = |px: &[[u8; 4]]| {
        px.iter()
            .filter(|p| p[0] > 200 && p[1] > 200 && p[2] > 200 && !is_sky(p))
            .count()
    };
    let blue = |px: &[[u8; 4]]| {
        px.iter()
            .filter(|p| !is_sky(p) && p[2] as i32 > p[0] as i32 + 30)
            .count()
    };
    // Terrain is drawn and lit: many distinct colours, little sky from this overview.
    let sky = plain.iter().filter(|p| is_sky(p)).count();
    assert!(sky < plain.len() / 2, "{sky} sky pixels");
    settings.snow = true;
    settings.snow_line = 0.5;
    let snowy = shot(&settings);
    assert!(white(&snowy) > white(&plain) + 500, "snow did not show");
    settings.snow = false;
    settings.water_plane = true;
    settings.water_level = 400.0;
    let flooded = shot(&settings);
    assert!(
        blue(&flooded) > blue(&plain) + 2000,
        "no water plane: {} vs {}",
        blue(&flooded),
        blue(&plain)
    );
}

/// A texture's texels, tightly packed rows of `texel` bytes.
fn read_texture(ctx: &GpuContext, texture: &wgpu::Texture, texel: u32) -> Vec<u8> {
    pollster::block_on(strahler::gpu::read_texture(ctx, texture, texel)).unwrap()
}

fn half_to_f32(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((bits >> 10) & 0x1f);
    let frac = f32::from(bits & 0x3ff);
    sign * match exp {
        0 => frac * 2f32.powi(-24),
        _ => (1.0 + frac / 1024.0) * 2f32.powi(exp - 15),
    }
}

/// The 3D view's rasters made on the GPU (`view3d::gpu_maps`) are the CPU's to rounding:
/// the control points (in the textures and read back for the camera) within 1e-5 of the
/// height range, the gradients within a half float's rounding, the roughness within one
/// step, H within 1e-4; the chunk tree the same. On odd, non-square, reduced and tiny fields.
#[test]
fn maps_made_on_the_gpu_are_the_cpus() {
    let Some(ctx) = common::gpu() else { return };
    let square = rough_terrain(301);
    let data = square.data()[..301 * 177].to_vec();
    let cases = [
        (square.clone(), 4096),
        (Heightfield::from_vec(301, 177, data).unwrap(), 4096),
        // Reduced by 3 to fit 128 texels.
        (square, 128),
        (rough_terrain(3), 4096),
    ];
    for (k, (field, max_side)) in cases.iter().enumerate() {
        let cpu = TerrainMaps::new(field, CELL, *max_side);
        let gpu = gpu_maps(&ctx, field, None, *max_side);
        assert_eq!((gpu.width, gpu.height), (cpu.width, cpu.height), "case {k}");
        // H from the GPU's energies (f32 sums per workgroup) agrees to rounding.
        assert!(
            (gpu.hurst - cpu.hurst).abs() <= 1e-4,
            "case {k}: H {}",
            gpu.hurst
        );
        assert_eq!((gpu.zmin, gpu.zmax), (cpu.zmin, cpu.zmax));
        let Some((gradients, roughness)) = cpu.cpu_rasters() else {
            panic!("the CPU's maps hold their rasters");
        };
        let rasters = match &gpu.rasters {
            Rasters::Gpu(r) => r,
            // Too small for a wavelet transform: made on the CPU.
            Rasters::Cpu { .. } => {
                assert_eq!(k, 3, "only the tiny field stays on the CPU");
                continue;
            }
        };
        let range = cpu.zmax - cpu.zmin;
        let textured: Vec<f32> =
            bytemuck::pod_collect_to_vec(&read_texture(&ctx, &rasters.control, 4));
        for (name, control) in [("read back", &gpu.control), ("texture", &textured)] {
            let worst = control
                .iter()
                .zip(&cpu.control)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(worst <= 1e-5 * range, "case {k}, {name}: off by {worst}");
        }
        assert_eq!(gpu.tree.top_level(), cpu.tree.top_level());
        let halves: Vec<u16> =
            bytemuck::pod_collect_to_vec(&read_texture(&ctx, &rasters.gradients, 4));
        for (pair, cpu_pair) in halves.chunks_exact(2).zip(gradients) {
            for (&a, &b) in pair.iter().zip(cpu_pair) {
                let (a, b) = (half_to_f32(a), half_to_f32(b));
                assert!(
                    (a - b).abs() <= 1e-3 * b.abs().max(1e-3),
                    "case {k}: gradient {a} on the GPU, {b} on the CPU"
                );
            }
        }
        let bytes = read_texture(&ctx, &rasters.roughness, 1);
        let worst = bytes
            .iter()
            .zip(roughness)
            .map(|(&a, &b)| a.abs_diff(b))
            .max()
            .unwrap();
        assert!(worst <= 1, "case {k}: roughness off by {worst} of 255");
        assert!(roughness.iter().any(|&e| e > 50), "case {k}: a rough map");

        // The field already on the GPU (as a stage leaves it) gives the same bits; where
        // the maps need it reduced, it is not used.
        let resident = gpu_maps(
            &ctx,
            field,
            Some(&common::gpu_copy(&ctx, field, 0.0)),
            *max_side,
        );
        assert_eq!(
            resident.control, gpu.control,
            "case {k}: from the GPU's copy"
        );
        let Rasters::Gpu(again) = &resident.rasters else {
            panic!("case {k}: made on the GPU");
        };
        for (a, b, texel) in [
            (&again.gradients, &rasters.gradients, 4),
            (&again.roughness, &rasters.roughness, 1),
        ] {
            assert!(read_texture(&ctx, a, texel) == read_texture(&ctx, b, texel));
        }
        // It is read there rather than uploaded: a copy raised by 100 m raises the control
        // points by 100 m (unless reduced, when the CPU's field is reduced and uploaded).
        let raised = gpu_maps(
            &ctx,
            field,
            Some(&common::gpu_copy(&ctx, field, 100.0)),
            *max_side,
        );
        let shift = raised.control[0] - gpu.control[0];
        let expected = if gpu.width == field.width() {
            100.0
        } else {
            0.0
        };
        assert!(
            (shift - expected).abs() < 1e-2,
            "case {k}: shifted by {shift}"
        );
    }
}

fn gpu_maps(
    ctx: &GpuContext,
    field: &Heightfield,
    on_gpu: Option<&strahler::gpu::GpuField>,
    max_side: usize,
) -> TerrainMaps {
    pollster::block_on(strahler::view3d::gpu_maps::prepare(
        ctx,
        field,
        on_gpu,
        CELL,
        max_side,
        &strahler::jobs::JobCtx::detached(),
    ))
    .unwrap()
}

/// The same terrain drawn from CPU-made and GPU-made maps gives the same picture (to the
/// rasters' rounding).
#[test]
fn the_view_draws_gpu_made_maps_like_the_cpus() {
    let Some(ctx) = common::gpu() else { return };
    let field = rough_terrain(257);
    let mut drawn = Vec::new();
    for on_gpu in [false, true] {
        let mut r = Renderer::new(&ctx.device);
        let maps = if on_gpu {
            pollster::block_on(strahler::view3d::gpu_maps::prepare(
                &ctx,
                &field,
                None,
                CELL,
                r.max_texture_side(),
                &strahler::jobs::JobCtx::detached(),
            ))
            .unwrap()
        } else {
            TerrainMaps::new(&field, CELL, r.max_texture_side())
        };
        // The whole map at an angle, and the sun low enough that the gradients shade it.
        let (w, h) = maps.extent();
        let mut camera = Camera::overview(w, h, 400.0);
        camera.distance = 1.3 * w;
        r.set_terrain(&ctx.device, &ctx.queue, maps, None);
        r.render(
            &ctx.device,
            &ctx.queue,
            SIZE,
            &camera,
            &View3dSettings::default(),
        )
        .unwrap();
        drawn.push(pixels(&ctx, &r));
        let rgba: Vec<u8> = drawn[drawn.len() - 1].concat();
        let name = if on_gpu { "maps-gpu" } else { "maps-cpu" };
        common::save_shot(name, &rgba, SIZE);
    }
    let diffs: Vec<u32> = drawn[0]
        .iter()
        .zip(&drawn[1])
        .map(|(a, b)| {
            (0..3)
                .map(|c| u32::from(a[c].abs_diff(b[c])))
                .max()
                .unwrap()
        })
        .collect();
    // A few pixels on silhouettes may flip between two surfaces; the rest match.
    let mean = diffs.iter().sum::<u32>() as f64 / diffs.len() as f64;
    let off = diffs.iter().filter(|&&d| d > 4).count();
    assert!(
        mean <= 0.1 && off * 500 <= diffs.len(),
        "mean difference {mean}, {off} pixels off by more than 4"
    );
    // Mostly terrain, not sky.
    assert!(drawn[0].iter().filter(|p| is_sky(p)).count() < drawn[0].len() / 2);
}
