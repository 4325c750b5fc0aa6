//! `strahler bench view3d`: the 3D view's cost per terrain size and camera distance:
//! preparing the terrain's textures (once per terrain, in a background job: on the CPU, and
//! on the GPU with `view3d::gpu_maps`, textures and the control points' readback included),
//! choosing the
//! chunks (eq. 7, every frame, CPU) and drawing a 1280 x 720 frame on the GPU (submission to
//! completion, mean of 20 after a warm-up).

use std::time::Instant;

use crate::gpu::{GpuContext, wait_for_submitted_work};
use crate::view3d::{Camera, Renderer, TerrainMaps, View3dSettings};
use crate::wavelet::fbm;

const FRAME: [u32; 2] = [1280, 720];
const FRAMES: usize = 20;

/// `strahler bench view3d`'s options.
#[derive(Debug, clap::Args)]
pub struct View3dArgs {
    #[command(flatten)]
    pub sizes: super::Sizes,
}

pub fn run(args: &View3dArgs) -> Result<(), Box<dyn std::error::Error>> {
    let path = crate::cli::compute_path(crate::compute::BackendChoice::Auto);
    let gpu = path
        .gpu()
        .ok_or_else(|| format!("the 3D view benchmark needs a GPU: {path}"))?;
    table(&args.sizes.sizes, gpu)
}

fn table(sizes: &[usize], gpu: &GpuContext) -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "3D view on {} ({}): 1280 x 720 frames, times in ms",
        gpu.adapter.name, gpu.adapter.backend
    );
    println!(
        "{:>7} {:>8} {:>8} {:>10} {:>9} {:>7} {:>9} {:>8} {:>7}",
        "terrain", "prepare", "gpu prep", "camera", "triangles", "chunks", "select", "frame", "fps"
    );
    pollster::block_on(crate::view3d::gpu_maps::warm(gpu))?;
    let cell = 10_000.0 / 1024.0;
    for &n in sizes {
        let field = fbm::diamond_square(n, n, 0.55, 7)?;
        // Heights of a few hundred metres, as the generator makes.
        let field = crate::heightfield::Heightfield::from_vec(
            n,
            n,
            field.data().iter().map(|v| v * 200.0).collect(),
        )?;
        let mut renderer = Renderer::new(&gpu.device);
        let start = Instant::now();
        let maps = TerrainMaps::new(&field, cell, renderer.max_texture_side());
        let prepare = start.elapsed().as_secs_f64() * 1e3;
        let start = Instant::now();
        let on_gpu = pollster::block_on(crate::view3d::gpu_maps::prepare(
            gpu,
            &field,
            None,
            cell,
            renderer.max_texture_side(),
            &crate::jobs::JobCtx::detached(),
        ))?;
        let gpu_prepare = start.elapsed().as_secs_f64() * 1e3;
        drop(on_gpu);
        let (w, h) = maps.extent();
        let mid = 0.5 * (maps.zmin + maps.zmax) * 2.0;
        renderer.set_terrain(&gpu.device, &gpu.queue, maps, None);
        let settings = View3dSettings::default();
        for (label, distance, pitch) in [
            ("3 widths", 3.0, 35.0f32),
            ("overview", 1.6, 35.0),
            ("0.2 width", 0.2, 25.0),
            ("ground", 0.02, 12.0),
        ] {
            let mut camera = Camera::overview(w, h, mid);
            camera.distance = distance * w;
            camera.pitch = pitch.to_radians();
            // Warm up (pipelines, first upload), then time.
            let mut stats = renderer
                .render(&gpu.device, &gpu.queue, FRAME, &camera, &settings)
                .ok_or("no terrain to draw")?;
            pollster::block_on(wait_for_submitted_work(gpu))?;
            let (mut select, mut total) = (0.0, 0.0);
            for _ in 0..FRAMES {
                let t = Instant::now();
                stats = renderer
                    .render(&gpu.device, &gpu.queue, FRAME, &camera, &settings)
                    .ok_or("no terrain to draw")?;
                select += t.elapsed().as_secs_f64() * 1e3;
                pollster::block_on(wait_for_submitted_work(gpu))?;
                total += t.elapsed().as_secs_f64() * 1e3;
            }
            let (select, frame) = (select / FRAMES as f64, total / FRAMES as f64);
            println!(
                "{:>7} {:>8.0} {:>8.0} {:>10} {:>9} {:>7} {:>9.2} {:>8.2} {:>7.1}",
                format!("{n}^2"),
                prepare,
                gpu_prepare,
                label,
                stats.triangles,
                stats.chunks,
                select,
                frame,
                1e3 / frame
            );
        }
    }
    println!(
        "select = choosing chunks and recording the frame on the CPU; frame = until the GPU is \
         done. Target (3D view issue): 60 fps (16.7 ms) on a desktop GPU at 4096^2; on lavapipe \
         (a CPU rasteriser) the frame column is the CPU fallback's cost."
    );
    Ok(())
}
