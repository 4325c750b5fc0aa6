//! The 3D view rendered headlessly (lavapipe on CI): no cracks between chunks of different
//! levels, fewer triangles from afar, and the shading options visibly at work.

mod common;

use strahler::gpu::GpuContext;
use strahler::heightfield::Heightfield;
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
    let mut order = vec![0u8; n * n];
    for y in 0..n {
        order[y * n + n / 2] = 4;
    }
    let water = strahler::view3d::maps::water_mask(&order, n, CELL);
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
