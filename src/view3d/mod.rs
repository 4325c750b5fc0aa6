//! The 3D view: a chunked quadtree LoD terrain renderer with elevation-banded texturing.
//!
//! Seeds 003 (Sec. 3.3: quadtree LoD mesh, four textures mixed by an elevation mask, a snow
//! scene) and 004 (chunk pyramid, eq. 7 triangle-density refinement, multifractal detail of
//! eqs. 4-6 synthesised on the GPU inside close chunks).
//!
//! - [`camera`]: orbit and fly cameras (pure math).
//! - [`lod`]: the chunk quadtree and eq. 7 selection (pure, CPU).
//! - [`maps`]: the textures the shader reads, prepared on the CPU from the heightfield.
//! - [`gpu_maps`]: the same textures made on a hardware GPU that computes.
//! - [`mesh`]: the grid (with its skirt) every chunk is drawn with.
//! - [`subdivision`]: seed 004's smooth subdivision (eqs. 2-3) and its limit, the bicubic
//!   B-spline the vertex stage evaluates (CPU reference).
//! - [`renderer`]: wgpu pipelines drawing the chunks into an offscreen colour + depth target,
//!   on WebGPU, WebGL2 (vertex buffers and textures only, no storage buffers) and natively.
//! - [`target`]: that target, and reading it back.
//!
//! Nothing here depends on egui; `app::view3d` shows the target and turns input into camera
//! moves.

pub mod camera;
pub mod gpu_maps;
pub mod lod;
pub mod maps;
pub mod mesh;
pub mod renderer;
pub mod subdivision;
pub mod target;

pub use camera::{Camera, CameraMode};
pub use maps::TerrainMaps;
pub use renderer::{FrameStats, Renderer};

/// What the user sets in the 3D view's panel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View3dSettings {
    /// Sun direction: compass azimuth and elevation above the horizon (degrees).
    pub sun_azimuth: f32,
    pub sun_elevation: f32,
    /// World z = height x exaggeration.
    pub exaggeration: f32,
    /// Seed 003's snow scene (its Fig. 22): snow above `snow_line` (fraction of the height
    /// range) on slopes it can lie on.
    pub snow: bool,
    pub snow_line: f32,
    /// A water plane at `water_level` metres.
    pub water_plane: bool,
    pub water_level: f32,
    /// Draw the river network as water.
    pub rivers: bool,
    /// Seed 004's multifractal detail in chunks finer than the heightfield.
    pub detail: bool,
    /// Largest detail displacement, in metres per cell of the field.
    pub detail_amplitude: f32,
    /// Target size of a mesh quad on screen (pixels): smaller is finer (eq. 7's tau).
    pub pixels_per_quad: f32,
    /// Skirts hide the cracks between chunks of different levels (off only to see them).
    pub skirts: bool,
}

impl Default for View3dSettings {
    fn default() -> Self {
        Self {
            sun_azimuth: 135.0,
            sun_elevation: 40.0,
            exaggeration: 2.0,
            snow: false,
            snow_line: 0.7,
            water_plane: false,
            water_level: 0.0,
            rivers: true,
            detail: true,
            detail_amplitude: 0.15,
            pixels_per_quad: 6.0,
            skirts: true,
        }
    }
}

impl View3dSettings {
    /// Unit vector toward the sun (world: x east, y south, z up).
    pub fn sun_direction(&self) -> glam::Vec3 {
        let (az, el) = (
            self.sun_azimuth.to_radians(),
            self.sun_elevation.clamp(1.0, 90.0).to_radians(),
        );
        glam::Vec3::new(az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()).normalize()
    }
}
