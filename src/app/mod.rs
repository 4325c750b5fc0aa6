//! The eframe application: map in the centre, pipeline controls on the left, status below.
//!
//! The same code runs in a native window and in the browser. Heavy work runs as
//! [`crate::jobs`] jobs; the frame loop only polls their progress and takes their results.

mod arrived;
mod automation;
mod blend;
mod canvas;
mod detail;
mod export;
mod files;
mod frame;
mod history;
mod jobs;
mod layers;
mod map_view;
mod networks;
pub mod panels;
mod picture;
mod relief;
mod select;
mod session;
mod side_panel;
mod status_bar;
mod stored_dem;
mod view3d;

use std::sync::Arc;

pub use automation::{Automation, Command, JobStatus, Status};
pub use canvas::{Place, RunSummaries};
pub use layers::{Layers, section as layers_section};
pub use map_view::{Hover, MapView, Overlay, Tool};
pub use relief::shaded_relief;
pub use session::{COARSE_SIZE, OnMap, PREVIEW_SIZE, Pass, RunSettings, Session, SolverSettings};
pub use view3d::{CameraRequest, MapsChoice, View3d, View3dStatus, ViewKind};

use glam::DVec2;

use canvas::{Canvas, ComputeCheck, Messages};

use crate::compute::{ComputePath, CpuReason};
use crate::gpu::{GpuContext, device_descriptor};
use crate::pipeline::Output;
use crate::river::Stroke;
use crate::scene::{Edit, RiverStroke, Scene};

/// The river the first screen starts with: from the middle of the south edge, northwards.
pub fn default_stroke() -> Stroke {
    Stroke {
        estuary: DVec2::new(0.5, 1.0),
        toward: DVec2::new(0.5, 0.35),
        phi: 3,
        max_depth: crate::scene::default_depth(),
    }
}

/// The first screen's document: the default scene with the default river.
pub fn default_scene() -> Scene {
    Scene {
        rivers: vec![RiverStroke::from(default_stroke())],
        ..Scene::default()
    }
}

/// eframe's wgpu setup for Strahler: the adapter's full limits, so compute on large fields
/// works on the device egui draws with. On the web eframe tries WebGPU first and falls back
/// to WebGL2, which has no compute shaders: the app then computes on the CPU.
pub fn wgpu_options() -> egui_wgpu::WgpuConfiguration {
    let mut create = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    create.device_descriptor = Arc::new(device_descriptor);
    egui_wgpu::WgpuConfiguration {
        wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(create),
        ..Default::default()
    }
}

/// How soon a script's command or a finished job repaints: at once, but as one frame. egui
/// answers an immediate request (`request_repaint()`) with two frames, and where the page is
/// composited in software (headless Chromium here) each frame holds its thread over 100 ms,
/// which an edit's coarse pass waited behind; the frame that shows a result asks for any
/// frame after it that it needs.
pub(crate) const ONE_FRAME: std::time::Duration = std::time::Duration::from_millis(1);

/// The application state.
pub struct StrahlerApp {
    path: ComputePath,
    automation: Automation,
    /// The document (the scene) and its history, the pipeline, its job and its last output.
    /// The UI and `window.strahler` change the scene with edits; a run follows each change.
    session: Session,
    /// The central map: its view, overlays, tool, selection and mask.
    canvas: Canvas,
    /// What the side panel says about the last run, and its messages.
    summaries: RunSummaries,
    messages: Messages,
    check: ComputeCheck,
    /// The uploaded DEM, the placed blocks, the blend stage and the network comparison.
    blend: blend::BlendState,
    /// The export dialog and the exports being made.
    export: export::Exports,
    /// The side panel's sections, each with its own state.
    panels: panels::Panels,
    /// Which view the central area shows, and the 3D view.
    view: ViewKind,
    view3d: view3d::View3d,
}

impl StrahlerApp {
    /// Builds the app from eframe's creation context and starts generating from one default
    /// river, so the first screen shows terrain.
    pub fn new(cc: &eframe::CreationContext<'_>, automation: Automation) -> Self {
        let (path, adapter, caps) = match &cc.wgpu_render_state {
            Some(state) => {
                let gpu = GpuContext::from_device(&state.adapter, &state.device, &state.queue);
                let (adapter, caps) = (gpu.adapter.clone(), gpu.caps.clone());
                (ComputePath::from_context(gpu), Some(adapter), Some(caps))
            }
            None => (
                ComputePath::Cpu {
                    reason: CpuReason::NoAdapter("the window was created without wgpu".into()),
                },
                None,
                None,
            ),
        };
        log::info!("compute path: {path}");
        automation.set_compute_path(&path, adapter, caps);
        let repaint = cc.egui_ctx.clone();
        automation.set_repaint(move || repaint.request_repaint_after(ONE_FRAME));
        let mut app = Self {
            path,
            automation,
            session: Session::new(default_scene()),
            canvas: Canvas::default(),
            summaries: RunSummaries::default(),
            messages: Messages::default(),
            check: ComputeCheck::default(),
            blend: Default::default(),
            export: Default::default(),
            panels: Default::default(),
            view: ViewKind::Map,
            view3d: Default::default(),
        };
        // A scene autosaved by an earlier visit comes back (web only), as the history's
        // start.
        match history::restore() {
            Some(Ok((scene, undo))) => {
                app.session = Session::restored(scene, undo);
                app.scene_replaced();
                app.messages.notice = Some("Restored the scene autosaved in this browser".into());
            }
            Some(Err(err)) => {
                app.messages.notice = Some(format!("The autosaved scene was not restored: {err}"))
            }
            None => {}
        }
        // So does the DEM it had uploaded (web only; read in the background).
        stored_dem::restore(&app.automation);
        let (undo, redo) = app.session.history_depths();
        app.automation.update(|s| {
            s.undo = undo;
            s.redo = redo;
        });
        app.fit_mask(app.session.scene().size);
        app.start_warming_kernels(&cc.egui_ctx);
        app.poll_session(&cc.egui_ctx);
        app
    }

    pub fn compute_path(&self) -> &ComputePath {
        &self.path
    }

    pub fn automation(&self) -> &Automation {
        &self.automation
    }

    /// The terrain on the map, if any.
    pub fn terrain(&self) -> Option<&crate::heightfield::Heightfield> {
        self.canvas.map.field()
    }

    /// What the map shows of the runs (the pass and its size) and the run under way.
    pub fn on_map(&self) -> Option<OnMap> {
        self.session.on_map()
    }

    /// The erosion stage's map overlays, when the terrain has them: whether drainage area and
    /// erosion depth are shown.
    pub fn erosion_overlays(&self) -> Option<[bool; 2]> {
        self.canvas.map.has_erosion_layers().then_some([
            self.canvas.overlay.show_drainage,
            self.canvas.overlay.show_erosion_depth,
        ])
    }

    /// The DEM panel's network comparison table, once computed (label; DEM, its largest
    /// basin, generated).
    pub fn network_comparison(&self) -> Option<&[networks::Row]> {
        self.blend.networks.rows()
    }

    /// The diffusion solver and backend.
    pub fn settings(&self) -> &SolverSettings {
        &self.session.settings().solver
    }

    /// The diffusion solver and backend (tests and automation change them like the user
    /// would); a change re-runs the pipeline.
    pub fn settings_mut(&mut self) -> &mut SolverSettings {
        &mut self.session.settings_mut().solver
    }

    /// The user's river strokes.
    pub fn strokes(&self) -> Vec<Stroke> {
        self.session.scene().strokes()
    }

    /// The document, as saved and autosaved.
    pub fn scene(&self) -> Scene {
        self.session.scene().clone()
    }

    /// The last finished run on the map (its stages, layers and report).
    pub fn output(&self) -> Option<&Output> {
        self.session.output()
    }

    /// Applies an edit to the document (the next frame re-runs what it touched), or shows
    /// why it was refused. Every change to the scene, from the UI or a script, comes here.
    pub fn edit(&mut self, edit: Edit) {
        let replaces = matches!(edit, Edit::Replace(_));
        match self.session.apply(edit) {
            Ok(()) if replaces => self.scene_replaced(),
            Ok(()) => {}
            Err(err) => self.set_error(format!("Not changed: {err}")),
        }
    }

    /// Does what a panel asked.
    fn act(&mut self, ctx: &egui::Context, action: panels::Action) {
        use panels::Action;
        match action {
            Action::Edit(edit) => self.edit(edit),
            Action::Settings(settings) => *self.session.settings_mut() = settings,
            Action::Tool(tool) => self.canvas.tool = tool,
            Action::Generate => self.start_generate(ctx),
            Action::GenerateFullSize => self.generate_full_size(ctx),
            Action::Cancel => self.session.cancel(),
            Action::CompareBackends => self.start_selftest(ctx),
            Action::Error(message) => self.set_error(message),
            Action::DismissError => self.messages.error = None,
            Action::Mask(action) => self.mask_action(ctx, action),
            Action::Dem(action) => self.dem_action(ctx, action),
            Action::Document(action) => self.document_action(action),
            Action::Export { request, layers } => self.download(ctx, request, layers),
            Action::SaveWorldPlan { size, tile, fill } => self.save_world_plan(size, tile, fill),
            Action::SaveWorldPreview { size, tile } => self.save_world_preview(ctx, size, tile),
        }
    }

    /// Replaces the document (a validated scene) and regenerates.
    pub fn load_scene(&mut self, scene: &Scene) {
        self.edit(Edit::Replace(Box::new(scene.clone())));
    }

    /// Back one step.
    pub fn undo(&mut self) {
        self.step_history(true);
    }

    /// Forward one step.
    pub fn redo(&mut self) {
        self.step_history(false);
    }

    fn step_history(&mut self, back: bool) {
        if !self.session.step_history(back) {
            return;
        }
        let (undo, redo) = self.session.history_depths();
        self.automation.update(|s| {
            s.undo = undo;
            s.redo = redo;
        });
        self.scene_replaced();
        self.messages.notice = Some(if back { "Undone" } else { "Redone" }.to_owned());
    }

    /// After the whole document changed (opened, restored, undone): the decoded mask and
    /// the selections follow it.
    fn scene_replaced(&mut self) {
        let scene = self.session.scene();
        let (size, mask) = (scene.size, scene.mask(self.canvas.mask_kind));
        match mask {
            Ok(Some(mask)) => self.canvas.mask = mask,
            Ok(None) => {
                if let Ok(clear) = crate::wavelet::Mask::new(size, size) {
                    self.canvas.mask = clear;
                }
            }
            Err(err) => self.set_error(err.to_string()),
        }
        self.fit_mask(size);
        self.canvas.mask_overlay_stale = true;
        self.blend.selected = None;
        self.canvas.selected = None;
    }

    /// Replaces the document by a scene file's contents (refused with the bad field named,
    /// keeping the current scene).
    pub fn open_scene(&mut self, name: &str, bytes: &[u8]) {
        let scene = std::str::from_utf8(bytes)
            .map_err(|_| "not a text file".to_owned())
            .and_then(|text| Scene::from_json(text).map_err(|e| e.to_string()));
        match scene {
            Ok(scene) => {
                self.load_scene(&scene);
                self.messages.notice = Some(format!("Opened {name}"));
            }
            Err(err) => self.set_error(format!("{name}: {err}")),
        }
    }

    /// The sketched ridges, valleys and peaks.
    pub fn sketch(&self) -> &crate::scene::SketchSettings {
        &self.session.scene().sketch
    }

    /// Adds a river stroke (map units, estuary first) and regenerates.
    pub fn add_stroke(&mut self, stroke: Stroke) {
        self.edit(Edit::AddRiver(RiverStroke::from(stroke)));
    }

    /// The mask brush (size, hardness, grey value, eraser).
    pub fn brush_mut(&mut self) -> &mut crate::wavelet::Brush {
        &mut self.panels.mask.brush
    }

    pub fn tool(&self) -> Tool {
        self.canvas.tool
    }

    pub fn set_tool(&mut self, tool: Tool) {
        self.canvas.tool = tool;
    }

    /// The view in the central area.
    pub fn view(&self) -> ViewKind {
        self.view
    }

    pub fn set_view(&mut self, view: ViewKind) {
        self.view = view;
        self.automation.update(|s| s.view = view.key().into());
    }

    /// The 3D view's settings (tests and scripts change them like the user would).
    pub fn view3d_settings_mut(&mut self) -> &mut crate::view3d::View3dSettings {
        &mut self.view3d.settings
    }

    /// The 3D view's last frame and camera, once it has drawn one.
    pub fn view3d_status(&self) -> Option<View3dStatus> {
        self.view3d.status()
    }

    /// Whether a job is running or a regeneration is pending.
    pub fn busy(&self) -> bool {
        self.session.busy()
            || self.check.job.is_some()
            || self.blend.fill_job.is_some()
            || self.blend.features_job.is_some()
            || self.blend.networks.busy()
            || !self.export.running.is_empty()
    }
}
