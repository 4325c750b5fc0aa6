//! State the app publishes for scripts: `window.strahler` on the web, tests natively.
//!
//! The app writes it each time something worth reporting changes; readers take a snapshot.
//! It holds no egui types so the web binding can live outside the frame loop.

use std::sync::{Arc, Mutex, PoisonError};

use serde::Serialize;

use crate::compute::ComputePath;
use crate::diffusion::selftest::RunSummary;
use crate::gpu::{AdapterSummary, Capabilities};
use crate::scene::Scene;

/// What `window.strahler.status()` returns (serialised as camelCase JSON).
#[derive(Clone, Debug, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Status {
    pub version: String,
    /// False until the app has started (the wasm may still be loading).
    pub ready: bool,
    /// "webgpu", "vulkan", "metal", "dx12", "gl" or "cpu".
    pub compute: String,
    /// The status bar's words, e.g. "GPU: WebGPU" or "CPU (this browser has no WebGPU)".
    pub compute_path: String,
    /// Where the page's heavy stages run: "the erosion runs in a Web Worker", or why not;
    /// `None` natively.
    pub worker: Option<String>,
    /// The threads the Web Worker's stages run on (its pool's, 1 without one: the page not
    /// cross-origin isolated, or `?threads=1`), once it started; `None` before and natively.
    pub threads: Option<u32>,
    /// The adapter eframe draws with (a WebGL adapter on the CPU fallback).
    pub adapter: Option<AdapterSummary>,
    pub capabilities: Option<Capabilities>,
    /// Name and progress of the running job, if any.
    pub job: Option<JobStatus>,
    /// The last finished diffusion run shown on the map.
    pub last_run: Option<RunSummary>,
    /// The last error shown to the user.
    pub last_error: Option<String>,
    /// The wavelet levels of detail on the map, if any.
    pub detail: Option<DetailStatus>,
    /// The uploaded real DEM, if any.
    pub dem: Option<DemStatus>,
    /// The blended blocks on the map, if any.
    pub blend: Option<BlendStatus>,
    /// The terrain on the map (after detail and blending).
    pub terrain: Option<TerrainStatus>,
    /// The realism measures of the terrain on the map (grid-direction index, flats,
    /// hypsometry, slopes, spectral slope and bump...), when the Realism section measures
    /// each terrain; `generate({realism: true})` returns them for any run.
    pub realism: Option<crate::realism::RealismReport>,
    /// Undo and redo steps available.
    pub undo: usize,
    pub redo: usize,
    /// The view in the central area: "2d" (map) or "3d".
    pub view: String,
    /// The 3D view's last frame (triangles, chunks) and camera, once it has drawn one.
    pub view3d: Option<super::View3dStatus>,
    /// Milliseconds of CPU the app's last frame took (its update and painting, not the
    /// browser's compositing), as eframe measures it.
    pub frame_cpu_ms: Option<f32>,
    /// Bytes of the page's WebAssembly memory (it only grows, so after a run this is the
    /// peak the app needed); `None` natively.
    pub memory_bytes: Option<f64>,
}

/// The uploaded DEM, as the DEM panel shows it.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct DemStatus {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub zmin: f32,
    pub zmax: f32,
    pub void_cells: usize,
    /// FNV-1a of the heights' bits (the same after a reload restores the DEM).
    pub checksum: String,
    /// Cell size in the CRS's units, when the file says.
    pub cell_size: Option<f64>,
    pub crs: Option<String>,
}

/// The last blend stage run.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct BlendStatus {
    pub blocks: usize,
    pub backend: String,
    pub millis: f64,
    pub converged: bool,
    /// Each block's cells on the terrain: `[row, col, height, width]`.
    pub rects: Vec<[usize; 4]>,
}

/// The terrain on the map.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TerrainStatus {
    pub width: usize,
    pub height: usize,
    pub zmin: f32,
    pub zmax: f32,
    /// "coarse" (an edit's first, small pass, while its own size is computed), "preview"
    /// (smaller than the scene, Preview on) or "full".
    pub pass: super::session::Pass,
}

/// The levels of detail on the map, as scripts see them.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct DetailStatus {
    pub levels: u32,
    pub width: usize,
    pub height: usize,
    pub backend: String,
    pub millis: f64,
    /// RMS of the synthetic detail where the mask is clear, and where it is fully white.
    pub rms_unmasked: f64,
    pub rms_masked: Option<f64>,
    /// Mask samples painted (value > 0).
    pub mask_cells: usize,
}

/// A running job, as scripts see it.
#[derive(Clone, Debug, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct JobStatus {
    pub name: String,
    /// The job's one bar, 0..1; it only moves forward.
    pub progress: f32,
    pub message: String,
    /// About how long the job still needs, at its rate so far (null until it can tell).
    pub seconds_left: Option<f64>,
}

/// What a script asks the app to do; applied at the start of the next frame.
#[derive(Clone, Debug)]
pub enum Command {
    /// A change to the scene, as the UI makes it.
    Edit(crate::scene::Edit),
    /// Replace the detail mask by one derived from the rivers.
    MaskFromRivers,
    /// Paint the detail mask from one map point to another with a brush.
    /// Paints a segment of the mask of a kind (the brush's kind switches to it).
    PaintMask(
        crate::scene::MaskKind,
        glam::DVec2,
        glam::DVec2,
        crate::wavelet::Brush,
    ),
    /// A file's bytes for the DEM panel (upload button, drop, or script).
    LoadDem {
        name: String,
        bytes: Vec<u8>,
    },
    /// The DEM an earlier visit uploaded, as the browser kept it (a float32 GeoTIFF; see
    /// `stored_dem`).
    RestoreDem {
        name: String,
        bytes: Vec<u8>,
    },
    /// A PNG's bytes for the detail mask (import button).
    ImportMask {
        name: String,
        bytes: Vec<u8>,
    },
    /// Fill the uploaded DEM's voids by harmonic diffusion.
    FillVoids,
    /// Extract the uploaded DEM's ridges, valleys and peaks (seed 003) as the scene's sketch.
    ExtractFeatures,
    /// Place a block of the uploaded DEM: its window `[row, col, height, width]` on the
    /// DEM, and where it goes on the map (`[x0, y0, x1, y1]`, map units).
    PlaceBlock {
        window: [usize; 4],
        rect: [f64; 4],
        quarter_turns: u8,
        mirror: bool,
        z_scale: f32,
        /// The share of the block's shorter side its change fades in over.
        feather: f32,
    },
    Undo,
    Redo,
    /// Show the map or the 3D view.
    SetView(super::ViewKind),
    /// Move the 3D camera (and show the 3D view).
    SetCamera(super::CameraRequest),
    /// Where the 3D view's rasters are made (and show the 3D view).
    View3dMaps(super::MapsChoice),
    /// Where the terrain is computed (the Advanced section's "Compute on"): a change
    /// recomputes it.
    Compute(crate::compute::BackendChoice),
    /// An engine export of the terrain on the map (`exportHeightmap` with a preset, tiles,
    /// maps or rivers): its one file, or its files as a zip, kept for the script
    /// ([`Automation::take_export`]).
    Export(Box<crate::export::Request>),
    /// A scene file's bytes (open button or drop).
    OpenScene {
        name: String,
        bytes: Vec<u8>,
    },
    /// A chosen file refused before it was read (empty, or larger than its format allows).
    FileRefused {
        name: String,
        message: String,
        /// The section that asked for the file, where the error is shown.
        place: super::Place,
    },
}

type Repaint = Arc<dyn Fn() + Send + Sync>;

/// Refusals kept for scripts that do not await their promises.
const MAX_REFUSALS: usize = 64;

/// Shared between the app and its automation bindings.
#[derive(Clone, Default)]
pub struct Automation {
    inner: Arc<Mutex<Shared>>,
}

#[derive(Default)]
struct Shared {
    status: Status,
    path: Option<ComputePath>,
    scene: Option<Scene>,
    /// The terrain on the map and its cell size in metres, for `exportHeightmap`.
    terrain: Option<(Arc<crate::heightfield::Heightfield>, f64)>,
    commands: Vec<Command>,
    /// Finished exports by the number of their command.
    exports: Vec<(u64, Result<Vec<u8>, String>)>,
    /// The app's message for each command it refused as it applied it, by number, until the
    /// script's promise takes it (the newest [`MAX_REFUSALS`]).
    refused: std::collections::VecDeque<(u64, String)>,
    /// Commands queued so far, and how many of them the app has applied (and published the
    /// scene after): a script's mutation resolves once `applied` reaches its number.
    queued: u64,
    applied: u64,
    repaint: Option<Repaint>,
}

impl Automation {
    pub fn status(&self) -> Status {
        let shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        Status {
            version: crate::VERSION.to_owned(),
            ..shared.status.clone()
        }
    }

    /// The compute path once the app has started.
    pub fn compute_path(&self) -> Option<ComputePath> {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .path
            .clone()
    }

    pub(crate) fn set_compute_path(
        &self,
        path: &ComputePath,
        adapter: Option<AdapterSummary>,
        caps: Option<Capabilities>,
    ) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        shared.path = Some(path.clone());
        shared.status.ready = true;
        shared.status.compute = path.key();
        shared.status.compute_path = path.to_string();
        shared.status.adapter = adapter;
        shared.status.capabilities = caps;
    }

    /// The scene as the app last published it (`None` before the app started).
    pub fn scene(&self) -> Option<Scene> {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .scene
            .clone()
    }

    /// Queues a command for the app and wakes its frame loop. Returns the command's number:
    /// it has been applied once [`Automation::applied`] reaches it.
    pub fn push(&self, command: Command) -> u64 {
        let (number, repaint) = {
            let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
            shared.commands.push(command);
            shared.queued += 1;
            (shared.queued, shared.repaint.clone())
        };
        if let Some(repaint) = repaint {
            repaint();
        }
        number
    }

    /// How many commands have been queued.
    pub fn queued(&self) -> u64 {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .queued
    }

    /// How many queued commands the app has applied.
    pub fn applied(&self) -> u64 {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .applied
    }

    /// The queued commands, and the number of the last of them.
    pub(crate) fn take_commands(&self) -> (Vec<Command>, u64) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        (std::mem::take(&mut shared.commands), shared.queued)
    }

    /// The export made for command `number`.
    pub(crate) fn set_export(&self, number: u64, result: Result<Vec<u8>, String>) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        shared.exports.push((number, result));
    }

    /// Takes the export made for command `number`, once it is.
    pub fn take_export(&self, number: u64) -> Option<Result<Vec<u8>, String>> {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        let at = shared.exports.iter().position(|(n, _)| *n == number)?;
        Some(shared.exports.remove(at).1)
    }

    /// The app refused command `number` with `message` (shown in the app too).
    pub(crate) fn refuse(&self, number: u64, message: String) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        if shared.refused.len() == MAX_REFUSALS {
            shared.refused.pop_front();
        }
        shared.refused.push_back((number, message));
    }

    /// Takes the app's message if it refused command `number` (once it is applied).
    pub fn take_refusal(&self, number: u64) -> Option<String> {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        let at = shared.refused.iter().position(|(n, _)| *n == number)?;
        shared.refused.remove(at).map(|(_, message)| message)
    }

    /// The app applied every command up to `number` and published the scene.
    pub(crate) fn mark_applied(&self, number: u64) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        shared.applied = shared.applied.max(number);
    }

    /// The terrain on the map and its cell size in metres.
    pub fn terrain(&self) -> Option<(Arc<crate::heightfield::Heightfield>, f64)> {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .terrain
            .clone()
    }

    pub(crate) fn set_terrain(
        &self,
        field: Arc<crate::heightfield::Heightfield>,
        cell: f64,
        pass: super::session::Pass,
    ) {
        let (zmin, zmax) = field.finite_range().unwrap_or((0.0, 0.0));
        let status = TerrainStatus {
            width: field.width(),
            height: field.height(),
            zmin,
            zmax,
            pass,
        };
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        shared.terrain = Some((field, cell));
        shared.status.terrain = Some(status);
    }

    pub(crate) fn set_scene(&self, scene: Scene) {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .scene = Some(scene);
    }

    pub(crate) fn set_repaint(&self, repaint: impl Fn() + Send + Sync + 'static) {
        self.inner
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .repaint = Some(Arc::new(repaint));
    }

    pub(crate) fn update(&self, edit: impl FnOnce(&mut Status)) {
        let mut shared = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        edit(&mut shared.status);
    }
}
