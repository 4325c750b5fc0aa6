//! Shared helpers for the integration tests.

pub mod app;

use strahler::gpu::GpuContext;

/// A headless GPU for tests. Without an adapter the test fails, unless the run asked to skip
/// GPU tests (`strahler::gpu::skip`): then it is recorded as skipped and this gives `None`.
pub fn gpu() -> Option<GpuContext> {
    match pollster::block_on(GpuContext::headless()) {
        Ok(ctx) => Some(ctx),
        Err(err) => {
            strahler::gpu::skip::no_adapter(&err);
            None
        }
    }
}

/// `field` plus `offset` in a storage buffer of `ctx`, as a GPU stage hands its terrain on
/// (`STORAGE | COPY_SRC`).
#[allow(dead_code)] // Only the tests of the GPU copies use it.
pub fn gpu_copy(
    ctx: &GpuContext,
    field: &strahler::heightfield::Heightfield,
    offset: f32,
) -> strahler::gpu::GpuField {
    use wgpu::util::DeviceExt;
    let data: Vec<f32> = field.data().iter().map(|z| z + offset).collect();
    let buffer = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test terrain"),
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
    strahler::gpu::GpuField::new(ctx, buffer, field.width(), field.height())
}

/// With `STRAHLER_SHOTS=<folder>`, writes a picture (tightly packed RGBA rows) there as
/// `<name>.png`, to look at; otherwise does nothing.
#[allow(dead_code)] // Only the 3D view's tests take pictures.
pub fn save_shot(name: &str, rgba: &[u8], size: [u32; 2]) {
    let Some(dir) = std::env::var_os("STRAHLER_SHOTS") else {
        return;
    };
    let path = std::path::Path::new(&dir).join(format!("{name}.png"));
    let file = std::fs::File::create(&path).expect("the shots folder is writable");
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size[0], size[1]);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .and_then(|mut writer| writer.write_image_data(rgba))
        .expect("the picture is written");
}
