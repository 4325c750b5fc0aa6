//! Draws the selected chunks into an offscreen colour + depth target with wgpu.
//!
//! One shared grid mesh (`n x n` vertices plus a skirt ring) is instanced once per chunk;
//! the per-chunk data (origin, stride, skirt depth) is an instance vertex buffer and the
//! heights come from a texture, so the same code runs on WebGPU, on WebGL2 (no storage
//! buffers) and natively. The colour target is `Rgba8Unorm` holding gamma-encoded colour,
//! which is what egui's renderer expects of a native texture.
//!
//! Per frame: an O(chunks) instance upload, one draw call for the terrain and one for the
//! water plane.

use glam::Mat4;
use serde::Serialize;
use wgpu::util::DeviceExt;

use super::lod::{self, LodParams, Selection, ViewPoint};
use super::maps::Rasters;
use super::mesh::grid_mesh;
use super::target::{COLOR_FORMAT, DEPTH_FORMAT, Target};
use super::{Camera, TerrainMaps, View3dSettings};
use crate::gpu::{GpuContext, GpuError};

/// The B-spline evaluation (seed 004's subdivision limit) the terrain shader calls; tests
/// wrap it in a compute shader to check it against [`super::subdivision::evaluate`].
pub const BSPLINE_WGSL: &str = include_str!("../../shaders/bspline.wgsl");

const SHADER: &str = concat!(
    include_str!("../../shaders/bspline.wgsl"),
    include_str!("../../shaders/terrain3d.wgsl")
);

/// Background (the shader's sky colour, gamma-encoded).
pub const CLEAR: [f64; 3] = [0.7681, 0.8469, 0.9301];

/// What one frame drew (`status().view3d` reports it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameStats {
    pub triangles: usize,
    pub chunks: usize,
    /// Finest chunk level drawn (negative: synthetic detail below the field's cells).
    pub finest_level: i32,
    pub width: u32,
    pub height: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    sun: [f32; 4],
    map: [f32; 4],
    heights: [f32; 4],
    flags: [f32; 4],
    detail: [f32; 4],
}

struct TerrainTextures {
    bind_group: wgpu::BindGroup,
    maps: TerrainMaps,
}

/// GPU resources of the 3D view.
pub struct Renderer {
    terrain_pipeline: wgpu::RenderPipeline,
    water_pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    grid_vertices: wgpu::Buffer,
    grid_indices: wgpu::Buffer,
    index_count: u32,
    instances: wgpu::Buffer,
    instance_capacity: usize,
    globals: wgpu::Buffer,
    terrain: Option<TerrainTextures>,
    target: Option<Target>,
    /// Largest texture side of the device.
    max_texture_side: usize,
}

impl Renderer {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("terrain3d"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let texture_entry = |binding: u32, filterable: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("terrain3d"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                texture_entry(1, false),
                texture_entry(2, true),
                texture_entry(3, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                texture_entry(5, true),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("terrain3d"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let depth = |write: bool| wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let terrain_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("terrain3d terrain"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_terrain"),
                compilation_options: Default::default(),
                buffers: &[
                    Some(wgpu::VertexBufferLayout {
                        array_stride: 12,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                    }),
                    Some(wgpu::VertexBufferLayout {
                        array_stride: 16,
                        step_mode: wgpu::VertexStepMode::Instance,
                        attributes: &wgpu::vertex_attr_array![1 => Float32x4],
                    }),
                ],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_terrain"),
                compilation_options: Default::default(),
                targets: &[Some(COLOR_FORMAT.into())],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(depth(true)),
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        });
        let water_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("terrain3d water"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_water"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_water"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: COLOR_FORMAT,
                    blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(depth(false)),
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        });
        let (vertices, indices) = grid_mesh();
        let grid_vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("terrain3d grid"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let grid_indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("terrain3d grid indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let instance_capacity = 256;
        let instances = Self::instance_buffer(device, instance_capacity);
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("terrain3d globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("terrain3d linear"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self {
            terrain_pipeline,
            water_pipeline,
            layout,
            sampler,
            grid_vertices,
            grid_indices,
            index_count: indices.len() as u32,
            instances,
            instance_capacity,
            globals,
            terrain: None,
            target: None,
            max_texture_side: device.limits().max_texture_dimension_2d as usize,
        }
    }

    fn instance_buffer(device: &wgpu::Device, capacity: usize) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("terrain3d chunks"),
            size: (capacity * 16) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Largest texture side: fields larger than this are reduced for the view.
    pub fn max_texture_side(&self) -> usize {
        self.max_texture_side
    }

    /// The terrain being shown, if any.
    pub fn maps(&self) -> Option<&TerrainMaps> {
        self.terrain.as_ref().map(|t| &t.maps)
    }

    /// Uploads a terrain (prepared with at most [`Self::max_texture_side`] per side) and its
    /// water mask (`size` x `size`, see [`super::maps::water_mask`]; `None`: no rivers).
    pub fn set_terrain(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        maps: TerrainMaps,
        water: Option<(&[u8], usize)>,
    ) {
        let extent = |w: usize, h: usize| wgpu::Extent3d {
            width: w as u32,
            height: h as u32,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, w: usize, h: usize, bytes: &[u8], texel: usize| {
            device.create_texture_with_data(
                queue,
                &wgpu::TextureDescriptor {
                    label: Some(label),
                    size: extent(w, h),
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                &bytes[..w * h * texel],
            )
        };
        let (w, h) = (maps.width, maps.height);
        // Rasters made on the GPU are bound as they are; the CPU's go up now.
        let (heights, roughness, gradients) = match &maps.rasters {
            Rasters::Gpu(made) => (
                made.control.clone(),
                made.roughness.clone(),
                made.gradients.clone(),
            ),
            Rasters::Cpu {
                gradients,
                roughness,
            } => (
                texture(
                    "terrain3d control points",
                    wgpu::TextureFormat::R32Float,
                    w,
                    h,
                    bytemuck::cast_slice(&maps.control),
                    4,
                ),
                texture(
                    "terrain3d roughness",
                    wgpu::TextureFormat::R8Unorm,
                    w,
                    h,
                    roughness,
                    1,
                ),
                texture(
                    "terrain3d gradients",
                    wgpu::TextureFormat::Rg16Float,
                    w,
                    h,
                    bytemuck::cast_slice(gradients),
                    4,
                ),
            ),
        };
        let (mask, side) = match water {
            Some((mask, side)) if side > 0 && mask.len() >= side * side => {
                super::maps::reduce_mask(mask, side, self.max_texture_side)
            }
            _ => (vec![0u8], 1),
        };
        let water = texture(
            "terrain3d water",
            wgpu::TextureFormat::R8Unorm,
            side,
            side,
            &mask,
            1,
        );
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("terrain3d"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.globals.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&view(&heights)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view(&gradients)),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&view(&water)),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&view(&roughness)),
                },
            ],
        });
        self.terrain = Some(TerrainTextures { bind_group, maps });
    }

    /// The colour target of the last frame (for egui or a readback).
    pub fn color_view(&self) -> Option<&wgpu::TextureView> {
        self.target.as_ref().map(|t| &t.color_view)
    }

    /// Makes the target `size` pixels (within the device's limit); true when it was
    /// (re)created, so a texture registered elsewhere must be updated.
    pub fn ensure_target(&mut self, device: &wgpu::Device, size: [u32; 2]) -> bool {
        let side = self.max_texture_side as u32;
        let size = [size[0].clamp(1, side), size[1].clamp(1, side)];
        if self.target.as_ref().is_some_and(|t| t.size == size) {
            return false;
        }
        self.target = Some(Target::new(device, size));
        true
    }

    /// Selects the chunks for `camera` (eq. 7) and draws them, and the water plane, into the
    /// target of `size` pixels. Nothing is drawn (and `None` returned) without a terrain.
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        size: [u32; 2],
        camera: &Camera,
        settings: &View3dSettings,
    ) -> Option<FrameStats> {
        self.ensure_target(device, size);
        let terrain = self.terrain.as_ref()?;
        let target = self.target.as_ref()?;
        let maps = &terrain.maps;
        let [tw, th] = target.size;
        let aspect = tw as f32 / th as f32;
        let (near, far) = clip_planes(camera, maps, settings.exaggeration);
        let view_proj = camera.view_proj(aspect, near, far);
        let detail_amplitude = if settings.detail {
            settings.detail_amplitude.max(0.0) * maps.cell
        } else {
            0.0
        };
        let selection = self.select(camera, settings, view_proj, th as f32, detail_amplitude);
        let chunks: Vec<[f32; 4]> = selection
            .chunks
            .iter()
            .map(|c| [c.origin[0], c.origin[1], c.stride(), c.skirt()])
            .collect();
        if chunks.len() > self.instance_capacity {
            self.instance_capacity = chunks.len().next_power_of_two();
            self.instances = Self::instance_buffer(device, self.instance_capacity);
        }
        if !chunks.is_empty() {
            queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&chunks));
        }
        let eye = camera.eye();
        let (extent_x, extent_y) = maps.extent();
        let sun = settings.sun_direction();
        let globals = Globals {
            view_proj: view_proj.to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 4.0 * extent_x.max(extent_y)],
            sun: [sun.x, sun.y, sun.z, 0.28],
            map: [
                maps.width as f32,
                maps.height as f32,
                maps.cell,
                settings.exaggeration,
            ],
            heights: [
                maps.zmin,
                maps.zmax,
                settings.water_level,
                if settings.snow {
                    settings.snow_line
                } else {
                    -1.0
                },
            ],
            flags: [
                f32::from(u8::from(settings.rivers)),
                f32::from(u8::from(settings.water_plane)),
                detail_amplitude,
                f32::from(u8::from(settings.skirts)),
            ],
            detail: [2f32.powf(-maps.hurst), maps.hurst, 0.0, 0.0],
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("terrain3d"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("terrain3d"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target.color_view,
                    resolve_target: None,
                    depth_slice: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: CLEAR[0],
                            g: CLEAR[1],
                            b: CLEAR[2],
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &target.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &terrain.bind_group, &[]);
            if !chunks.is_empty() {
                pass.set_pipeline(&self.terrain_pipeline);
                pass.set_vertex_buffer(0, self.grid_vertices.slice(..));
                pass.set_vertex_buffer(1, self.instances.slice(..));
                pass.set_index_buffer(self.grid_indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.index_count, 0, 0..chunks.len() as u32);
            }
            if settings.water_plane {
                pass.set_pipeline(&self.water_pipeline);
                pass.draw(0..6, 0..1);
            }
        }
        queue.submit([encoder.finish()]);
        Some(FrameStats {
            triangles: selection.triangles(),
            chunks: selection.chunks.len(),
            finest_level: selection.finest_level().unwrap_or(0),
            width: tw,
            height: th,
        })
    }

    /// The chunks [`Self::render`] would draw for `camera` in a target `height_px` tall.
    fn select(
        &self,
        camera: &Camera,
        settings: &View3dSettings,
        view_proj: Mat4,
        height_px: f32,
        detail_amplitude: f32,
    ) -> Selection {
        let Some(terrain) = &self.terrain else {
            return Selection::default();
        };
        let maps = &terrain.maps;
        let view = ViewPoint {
            eye: camera.eye(),
            view_proj: Some(view_proj),
            cell: maps.cell,
            exaggeration: settings.exaggeration,
        };
        let params = LodParams {
            tau: lod::tau_for_viewport(height_px, super::camera::FOV_Y, settings.pixels_per_quad),
            detail_levels: if settings.detail { 2 } else { 0 },
            detail_amplitude,
            // 2.4 million triangles at most.
            max_chunks: 1024,
        };
        lod::select(&maps.tree, &view, &params)
    }

    /// Reads the colour target back (tightly packed RGBA rows): tests and screenshots.
    pub async fn read_color(&self, ctx: &GpuContext) -> Result<(Vec<u8>, [u32; 2]), GpuError> {
        let target = self
            .target
            .as_ref()
            .ok_or_else(|| GpuError::Readback("nothing rendered yet".into()))?;
        target.read_color(ctx).await
    }
}

/// Near and far planes around the terrain: near shrinks as the eye nears the ground (so
/// close-ups are not clipped), far reaches past the whole map.
pub fn clip_planes(camera: &Camera, maps: &TerrainMaps, exaggeration: f32) -> (f32, f32) {
    let eye = camera.eye();
    let ground = maps.ground(eye.x, eye.y) * exaggeration;
    let clearance = (eye.z - ground).abs().max(1.0);
    let near = (0.2 * clearance).clamp(0.5, 200.0);
    let (ex, ey) = maps.extent();
    let relief = (maps.zmax - maps.zmin) * exaggeration;
    let far = eye.truncate().length() + 3.0 * ex.max(ey) + eye.z.abs() + relief;
    (near, far.max(near * 10.0))
}
