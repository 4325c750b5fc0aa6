//! The vertex stage's B-spline (seed 004's subdivision limit, `shaders/bspline.wgsl`, the
//! very text the terrain shader is built from) against the CPU reference
//! (`strahler::view3d::subdivision::evaluate`), through a small compute wrapper on lavapipe.

mod common;

use strahler::gpu::read_f32_buffer;
use strahler::view3d::renderer::BSPLINE_WGSL;
use strahler::view3d::subdivision;
use wgpu::util::DeviceExt;

const WRAPPER: &str = r#"
@group(0) @binding(0) var height_tex: texture_2d<f32>;
@group(0) @binding(1) var<storage, read> points: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> heights: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i < arrayLength(&heights)) {
        heights[i] = bspline_height(points[i]);
    }
}
"#;

fn hash(i: u32) -> f32 {
    let mut v = i.wrapping_mul(2_654_435_761);
    v ^= v >> 15;
    v = v.wrapping_mul(2_246_822_519);
    v ^= v >> 13;
    (v & 0xffff) as f32 / 65535.0
}

/// Heights the shader's `bspline_height` gives at `points` over `control` (`w x h`).
fn shader_heights(
    ctx: &strahler::gpu::GpuContext,
    control: &[f32],
    w: usize,
    h: usize,
    points: &[[f32; 2]],
) -> Vec<f32> {
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("bspline test"),
        source: wgpu::ShaderSource::Wgsl(format!("{BSPLINE_WGSL}\n{WRAPPER}").into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("bspline test"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let texture = device.create_texture_with_data(
        &ctx.queue,
        &wgpu::TextureDescriptor {
            label: Some("control points"),
            size: wgpu::Extent3d {
                width: w as u32,
                height: h as u32,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(control),
    );
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("points"),
        contents: bytemuck::cast_slice(points),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("heights"),
        size: (points.len() * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let view = texture.create_view(&Default::default());
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("bspline test"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(points.len().div_ceil(64) as u32, 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    pollster::block_on(read_f32_buffer(ctx, &output, points.len())).unwrap()
}

#[test]
fn the_shaders_b_spline_matches_the_cpu_reference() {
    let Some(ctx) = common::gpu() else { return };
    for (w, h) in [(23usize, 17usize), (2, 5), (1, 3)] {
        // Heights of a few hundred metres, as a terrain's, through the interpolating control
        // points the view uploads.
        let samples: Vec<f32> = (0..w * h).map(|i| 300.0 + 200.0 * hash(i as u32)).collect();
        let control = subdivision::interpolating(&samples, w, h);
        // Random points, the samples themselves, quarter cells (level -2 vertices) and points
        // outside the map (clamped).
        let mut points: Vec<[f32; 2]> = (0..400)
            .map(|k| {
                [
                    hash(7 * k + 1) * (w as f32 + 1.0) - 0.5,
                    hash(7 * k + 2) * (h as f32 + 1.0) - 0.5,
                ]
            })
            .collect();
        points.extend((0..w * h).map(|i| [(i % w) as f32, (i / w) as f32]));
        points.extend((0..4 * w).map(|k| [k as f32 * 0.25, 0.25 * (k % (4 * h)) as f32]));
        let gpu = shader_heights(&ctx, &control, w, h, &points);
        for (p, g) in points.iter().zip(&gpu) {
            let cpu = subdivision::evaluate(&control, w, h, p[0], p[1]);
            assert!(
                (g - cpu).abs() <= 1e-3,
                "{w}x{h} at {p:?}: shader {g}, CPU {cpu}"
            );
        }
        // At the samples the drawn surface is the field itself.
        for (i, s) in samples.iter().enumerate() {
            let g = gpu[400 + i];
            assert!((g - s).abs() <= 2e-3, "{w}x{h} sample {i}: {g} vs {s}");
        }
    }
}
