//! Strahler: hydrology-based terrain synthesis that runs in the browser and on the desktop.
//!
//! The crate is one library with two front ends: the eframe app (`app`, native window and
//! wasm page) and the native command line (`cli`). The numerical stages never depend on
//! egui; each heavy kernel has a CPU reference implementation and a WGSL one (`shaders/`),
//! and [`compute::Backend`] picks between them.
//!
//! Module map:
//! - [`heightfield`]: the raster type every stage reads and writes.
//! - [`gpu`]: device context (from eframe's render state or headless), capabilities, readback.
//! - [`compute`]: the CPU/GPU backend choice and the human-readable compute path.
//! - [`diffusion`]: Laplace diffusion with fixed cells (seed paper 000, eqs. 6-7): multigrid
//!   and the paper's Jacobi baseline, on CPU and GPU.
//! - [`dem`]: real elevation rasters in and out (GeoTIFF, SRTM .hgt, ESRI ASCII, PNG).
//! - [`blend`]: Poisson blending of real DEM blocks into the terrain (seed paper 000, Sec. VI).
//! - [`river`]: Tokunaga river networks grown by an L-system (seed paper 000, Sec. IV).
//! - [`scene`]: the user's document (versioned JSON) from which everything is rebuilt.
//! - [`wavelet`]: wavelet levels of detail with energy-reduction masks (seed paper 001).
//! - [`view3d`]: the 3D view's chunked quadtree LoD renderer (seed papers 003 and 004).
//! - [`jobs`]: background work with progress and cancellation that never blocks the UI.
//! - [`app`]: the eframe application.

pub mod app;
pub mod blend;
pub mod compute;
pub mod dem;
pub mod diffusion;
pub mod erosion;
pub mod export;
pub mod features;
pub mod gpu;
pub mod heightfield;
pub mod jobs;
pub mod noise;
pub mod parallel;
pub mod pipeline;
pub mod radix_heap;
pub mod realism;
pub mod ridge;
pub mod river;
pub mod scene;
pub mod skeleton;
pub mod terrain;
pub mod view3d;
pub mod wavelet;
pub mod world;

#[cfg(not(target_arch = "wasm32"))]
pub mod cli;

#[cfg(target_arch = "wasm32")]
pub mod web;

/// The version reported by `strahler info`, the status bar and `window.strahler.status()`.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
