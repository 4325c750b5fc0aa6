//! Close-ups of the 3D view below the field's resolution (seed 004's subdivision and
//! detail, levels -1 and -2), where the smooth surface replaces the bilinear one: no crack
//! opens where the stride crosses 1. With `STRAHLER_SHOTS=<folder>` the pictures are also
//! written there as PNGs, to look at.

mod common;

use strahler::gpu::GpuContext;
use strahler::heightfield::Heightfield;
use strahler::view3d::renderer::CLEAR;
use strahler::view3d::{Camera, CameraMode, Renderer, TerrainMaps, View3dSettings};

const CELL: f32 = 30.0;
const SIZE: [u32; 2] = [640, 400];

/// Ridges and valleys a few cells wide (so a bilinear mesh shows its facets up close),
/// with a little cell-scale roughness.
fn ridges(n: usize) -> Heightfield {
    let data = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            let mut v = (i as u32).wrapping_mul(2_654_435_761);
            v ^= v >> 15;
            let noise = (v & 0xff) as f32 / 255.0 - 0.5;
            400.0
                + 60.0 * (0.45 * x + 0.2 * y).sin() * (0.3 * y).cos()
                + 120.0 * (x / n as f32)
                + 6.0 * noise
        })
        .collect();
    Heightfield::from_vec(n, n, data).unwrap()
}

fn shot(
    ctx: &GpuContext,
    r: &mut Renderer,
    camera: &Camera,
    settings: &View3dSettings,
    name: &str,
) -> (Vec<[u8; 4]>, i32) {
    let stats = r
        .render(&ctx.device, &ctx.queue, SIZE, camera, settings)
        .unwrap();
    let (bytes, size) = pollster::block_on(r.read_color(ctx)).unwrap();
    common::save_shot(name, &bytes, size);
    let px = bytes
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect();
    (px, stats.finest_level)
}

fn is_sky(p: &[u8; 4]) -> bool {
    CLEAR
        .iter()
        .zip(p)
        .all(|(c, &v)| (c * 255.0 - f64::from(v)).abs() <= 1.5)
}

#[test]
fn close_ups_below_the_fields_resolution_are_crack_free() {
    let Some(ctx) = common::gpu() else { return };
    let field = ridges(129);
    let mut r = Renderer::new(&ctx.device);
    let maps = TerrainMaps::new(&field, CELL, r.max_texture_side());
    r.set_terrain(&ctx.device, &ctx.queue, maps, None);
    let maps = r.maps().unwrap();
    let (w, h) = maps.extent();
    let mut camera = Camera::overview(w, h, 0.0);
    camera.set_mode(CameraMode::Fly, 1.0);
    camera.yaw = 0.9;
    let (x, y) = (0.45 * w, 0.5 * h);
    let ground = maps.ground(x, y) * 2.0;
    let base = View3dSettings {
        sun_elevation: 20.0,
        sun_azimuth: 250.0,
        rivers: false,
        ..Default::default()
    };
    // Looking down: the whole picture is ground, so a sky pixel is a crack.
    camera.pitch = -50f32.to_radians();
    camera.position = glam::Vec3::new(x, y, ground + 120.0);
    for (name, amplitude) in [("down_subdivision", 0.0), ("down_detail", 0.15)] {
        let settings = View3dSettings {
            detail_amplitude: amplitude,
            ..base
        };
        let (px, finest) = shot(&ctx, &mut r, &camera, &settings, name);
        assert!(finest < 0, "{name}: finest level {finest}");
        let sky = px.iter().filter(|p| is_sky(p)).count();
        assert_eq!(sky, 0, "{name}: {sky} sky pixels through cracks");
    }
    // Grazing views of the same ground, to look at.
    camera.pitch = -12f32.to_radians();
    camera.position = glam::Vec3::new(x, y, ground + 60.0);
    for (name, amplitude) in [("grazing_subdivision", 0.0), ("grazing_detail", 0.15)] {
        let settings = View3dSettings {
            detail_amplitude: amplitude,
            ..base
        };
        shot(&ctx, &mut r, &camera, &settings, name);
    }
}
