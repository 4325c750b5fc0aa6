//! The eframe application: map in the centre, pipeline controls on the left, status below.
//!
//! The same code runs in a native window and in the browser. Heavy work runs as
//! [`crate::jobs`] jobs; the frame loop only polls their progress and takes their results.

mod arrived;
mod automation;
mod blend;
mod detail;
mod erosion;
mod export;
mod files;
mod history;
mod layers;
mod map_view;
mod networks;
mod picture;
mod relief;
mod select;
mod session;
mod side_panel;
mod status_bar;
mod view3d;

use std::sync::Arc;

pub use automation::{Automation, Command, JobStatus, Status};
pub use map_view::{Hover, MapView, Overlay, Tool};
pub use session::{PREVIEW_SIZE, RunSettings, Session};
pub use side_panel::SolverSettings;
pub use view3d::{CameraRequest, MapsChoice, View3d, View3dStatus, ViewKind};

use egui::pos2;
use glam::DVec2;

use crate::compute::{ComputePath, CpuReason};
use crate::diffusion::DiffusionError;
use crate::diffusion::selftest::{RunSummary, SelfTest};
use crate::gpu::{GpuContext, device_descriptor};
use crate::jobs::JobHandle;
use crate::pipeline::Output;
use crate::river::Stroke;
use crate::scene::{Edit, LineKind, RiverStroke, Scene};

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

/// The application state.
pub struct StrahlerApp {
    path: ComputePath,
    automation: Automation,
    map: MapView,
    /// The document (the scene) and its history, the pipeline, its job and its last output.
    /// The UI and `window.strahler` change the scene with edits; a run follows each change.
    session: Session,
    tool: Tool,
    overlay: Overlay,
    terrain_summary: Option<String>,
    selftest_job: Option<JobHandle<Result<SelfTest, DiffusionError>>>,
    /// Builds the GPU kernels at start (see [`crate::pipeline::warm_kernels`]); `None` once
    /// done, or on the CPU path.
    kernels_job: Option<JobHandle<Result<(), crate::pipeline::WarmError>>>,
    last_run: Option<(usize, RunSummary)>,
    selftest: Option<Result<SelfTest, String>>,
    error: Option<String>,
    /// A passing message (a file saved, a mask imported).
    notice: Option<String>,
    hover: Option<Hover>,
    /// The energy-reduction mask, decoded, at the scene's size (the scene keeps it as PNG).
    mask: crate::wavelet::Mask,
    brush: crate::wavelet::Brush,
    /// Which map layers are drawn.
    layers: layers::Layers,
    /// The vector item the Select tool picked, and whether it is being dragged.
    selected: Option<select::Item>,
    moving: bool,
    detail_summary: Option<String>,
    /// The Erosion section's before/after toggle, and the pictures it switches between
    /// (after erosion, before it).
    show_before_erosion: bool,
    pictures: Option<(picture::Picture, Option<picture::Picture>)>,
    showing_before: bool,
    /// The mask changed outside the frame loop (a loaded scene): redraw its overlay.
    mask_overlay_stale: bool,
    /// A dropped file being read (the browser reads files asynchronously).
    import_job: Option<JobHandle<detail::Dropped>>,
    /// The uploaded DEM, the placed blocks and the blend stage.
    blend: blend::BlendState,
    /// The DEM panel's network comparison.
    networks: networks::Comparison,
    export: export::ExportDialog,
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
        automation.set_repaint(move || repaint.request_repaint());
        let mut app = Self {
            path,
            automation,
            map: MapView::default(),
            session: Session::new(default_scene()),
            tool: Tool::default(),
            overlay: Overlay::default(),
            terrain_summary: None,
            selftest_job: None,
            kernels_job: None,
            last_run: None,
            selftest: None,
            error: None,
            notice: None,
            hover: None,
            mask: crate::wavelet::Mask::new(512, 512).expect("a 512 x 512 mask is within limits"),
            brush: Default::default(),
            layers: Default::default(),
            selected: None,
            moving: false,
            detail_summary: None,
            show_before_erosion: false,
            pictures: None,
            showing_before: false,
            mask_overlay_stale: false,
            import_job: None,
            blend: Default::default(),
            networks: Default::default(),
            export: Default::default(),
            view: ViewKind::Map,
            view3d: Default::default(),
        };
        // A scene autosaved by an earlier visit comes back (web only), as the history's
        // start.
        match history::restore() {
            Some(Ok(scene)) => {
                app.session = Session::new(scene);
                app.scene_replaced();
                app.notice = Some("Restored the scene autosaved in this browser".into());
            }
            Some(Err(err)) => {
                app.notice = Some(format!("The autosaved scene was not restored: {err}"))
            }
            None => {}
        }
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
        self.map.field()
    }

    /// The erosion stage's map overlays, when the terrain has them: whether drainage area and
    /// erosion depth are shown.
    pub fn erosion_overlays(&self) -> Option<[bool; 2]> {
        self.map
            .has_erosion_layers()
            .then_some([self.overlay.show_drainage, self.overlay.show_erosion_depth])
    }

    /// The DEM panel's network comparison table, once computed (label; DEM, its largest
    /// basin, generated).
    pub fn network_comparison(&self) -> Option<&[networks::Row]> {
        self.networks.rows()
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
        self.notice = Some(if back { "Undone" } else { "Redone" }.to_owned());
    }

    /// After the whole document changed (opened, restored, undone): the decoded mask and
    /// the selections follow it.
    fn scene_replaced(&mut self) {
        let scene = self.session.scene();
        let (size, mask) = (scene.size, scene.detail.mask());
        match mask {
            Ok(Some(mask)) => self.mask = mask,
            Ok(None) => {
                if let Ok(clear) = crate::wavelet::Mask::new(size, size) {
                    self.mask = clear;
                }
            }
            Err(err) => self.set_error(err.to_string()),
        }
        self.fit_mask(size);
        self.mask_overlay_stale = true;
        self.blend.selected = None;
        self.selected = None;
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
                self.notice = Some(format!("Opened {name}"));
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
        &mut self.brush
    }

    pub fn tool(&self) -> Tool {
        self.tool
    }

    pub fn set_tool(&mut self, tool: Tool) {
        self.tool = tool;
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
            || self.selftest_job.is_some()
            || self.blend.fill_job.is_some()
            || self.blend.features_job.is_some()
            || self.networks.busy()
    }

    /// Runs the pipeline on the scene again, even if nothing changed (the Generate button).
    pub fn start_generate(&mut self, ctx: &egui::Context) {
        self.session.regenerate();
        self.poll_session(ctx);
    }

    /// Generates the terrain at the full grid size (with Preview on, edits use a smaller one).
    pub fn generate_full_size(&mut self, ctx: &egui::Context) {
        self.session.generate_full_size();
        self.poll_session(ctx);
    }

    /// Takes the session's finished run and starts the next one when the document changed;
    /// records the history and autosaves once no gesture is in progress.
    fn poll_session(&mut self, ctx: &egui::Context) {
        let gesture = ctx.input(|i| i.pointer.any_down());
        if let Some((undo, redo)) = self.session.commit(gesture) {
            self.automation.update(|s| {
                s.undo = undo;
                s.redo = redo;
            });
        }
        let repaint = ctx.clone();
        let events = self
            .session
            .poll(&self.path, gesture, move || repaint.request_repaint());
        for event in events {
            match event {
                session::Event::Started => self.automation.set_scene(self.scene()),
                session::Event::Finished(shown) => self.show_output(ctx, *shown),
                session::Event::Failed(message) => self.set_error(message),
            }
        }
        let wake = ctx.clone();
        if let Some(notice) = self
            .session
            .autosave(move |after| wake.request_repaint_after(after))
        {
            self.notice = Some(notice);
        }
    }

    /// Whether the map shows a preview smaller than the chosen grid size.
    pub fn showing_preview(&self) -> bool {
        self.output()
            .is_some_and(|o| o.hydrology.terrain.width() < self.session.scene().size)
    }

    /// Builds the GPU stages' kernels in the background, beside the first terrain, so the
    /// first edit finds them ready (in the browser, pipeline creation would otherwise fall in
    /// that edit's job).
    fn start_warming_kernels(&mut self, ctx: &egui::Context) {
        let Some(gpu) = self.path.gpu().cloned() else {
            return;
        };
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "GPU kernels",
            move |job| async move {
                crate::pipeline::warm_kernels(&gpu, &job).await?;
                // The 3D view's kernels too, wherever it may make its maps on the GPU: built
                // (and so checked by the browser's compiler) at start, a few milliseconds.
                crate::view3d::gpu_maps::warm(&gpu).await?;
                Ok(())
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.kernels_job = Some(handle),
            Err(err) => log::warn!("the GPU kernels will be built on first use: {err}"),
        }
    }

    /// Whether the GPU kernels are built (or there is no GPU path to build them for).
    pub fn kernels_ready(&self) -> bool {
        self.kernels_job.is_none()
    }

    /// Runs the CPU/GPU self-test in the background.
    pub fn start_selftest(&mut self, ctx: &egui::Context) {
        let path = self.path.clone();
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "self-test",
            move |job| async move { crate::diffusion::selftest::run(&path, &job).await },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.selftest_job = Some(handle),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    /// The backend the Diffusion section asks for, or `None` after telling the user why
    /// there is none (the GPU was requested but does not compute).
    fn backend(&mut self) -> Option<crate::compute::Backend> {
        match self.settings().backend.resolve(&self.path) {
            Ok(backend) => Some(backend),
            Err(err) => {
                self.set_error(err.to_string());
                None
            }
        }
    }

    fn set_error(&mut self, message: String) {
        log::warn!("{message}");
        self.automation
            .update(|s| s.last_error = Some(message.clone()));
        self.error = Some(message);
    }

    /// Puts a finished run on the map with its overlays and publishes its summaries.
    fn show_output(&mut self, ctx: &egui::Context, shown: arrived::Shown) {
        let arrived::Shown {
            constraints,
            summary,
            picture,
            before,
            erosion_layers,
        } = shown;
        let Some(output) = self.session.output().cloned() else {
            return;
        };
        let g = &output.hydrology;
        let size = g.terrain.width();
        let r = &output.report.terrain;
        self.terrain_summary = Some(format!(
            "{} river nodes, Strahler order {}, {} ridges; {:.1}% of river cells drain along \
             the river, {} pits",
            r.rivers.nodes,
            r.rivers.max_order,
            r.ridges.edges,
            r.drainage.river_fraction * 100.0,
            r.drainage.pit_cells
        ));
        let p = |v: DVec2| pos2(v.x as f32, v.y as f32);
        self.overlay.rivers = g
            .rivers
            .iter()
            .flat_map(|river| {
                let order = crate::river::stats::strahler_orders(&river.network);
                river
                    .network
                    .link_pairs()
                    .map(|(a, b)| {
                        (
                            p(river.network.nodes[a]),
                            p(river.network.nodes[b]),
                            order[b],
                        )
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        self.overlay.ridges = g
            .ridges
            .iter()
            .map(|r| (p(DVec2::from(r.a)), p(DVec2::from(r.b))))
            .collect();
        self.map.set_constraints(ctx, constraints);
        self.map.set_erosion_layers(ctx, erosion_layers);
        // The mask stays at the full size, whatever size this run had (the detail stage
        // resamples it), so a preview never blurs what the user painted.
        self.fit_mask(self.session.scene().size);
        self.map.set_mask(ctx, Some(&self.mask));
        self.show_detail_status(&output);
        self.show_blend_status(&output);
        self.automation
            .set_terrain(output.field.clone(), output.cell_m);
        let realism = output.report.realism.clone();
        self.automation.update(|s| s.realism = realism);
        self.showing_before = self.show_before_erosion && before.is_some();
        let shown = if self.showing_before {
            before.clone()
        } else {
            None
        };
        self.show_picture(ctx, shown.unwrap_or_else(|| picture.clone()));
        self.pictures = Some((picture, before));
        self.automation
            .update(|s| s.last_run = Some(summary.clone()));
        self.last_run = Some((size, summary));
        self.error = None;
    }

    /// Takes finished results and publishes job progress. Called once per frame.
    fn poll_jobs(&mut self, ctx: &egui::Context) {
        let (commands, applied) = self.automation.take_commands();
        let scripted = !commands.is_empty();
        for command in commands {
            match command {
                Command::Edit(edit) => self.edit(edit),
                Command::MaskFromRivers => self.mask_from_rivers(ctx),
                Command::PaintMask(a, b, brush) => {
                    self.mask.paint_segment(a, b, &brush);
                    self.set_mask(ctx, self.mask.clone());
                }
                Command::LoadDem { name, bytes } => self.load_dem(ctx, &name, bytes),
                Command::ImportMask { name, bytes } => self.import_mask(ctx, &name, &bytes),
                Command::FillVoids => self.fill_dem_voids(ctx),
                Command::ExtractFeatures => self.extract_features(ctx),
                Command::PlaceBlock {
                    window,
                    rect,
                    quarter_turns,
                    mirror,
                    z_scale,
                } => self.place_block(window, Some(rect), quarter_turns, mirror, z_scale),
                Command::OpenScene { name, bytes } => self.open_scene(&name, &bytes),
                Command::FileRefused { name, message } => {
                    self.set_error(format!("{name}: {message}"))
                }
                Command::Undo => self.undo(),
                Command::Redo => self.redo(),
                Command::SetView(view) => self.set_view(view),
                Command::View3dMaps(maps) => {
                    self.set_view(ViewKind::ThreeD);
                    self.view3d.set_maps(maps);
                }
                Command::SetCamera(request) => {
                    self.set_view(ViewKind::ThreeD);
                    self.view3d.request_camera(request);
                }
            }
        }
        if scripted {
            // Scripts see their edits in `scene()` once their promise resolves.
            self.automation.set_scene(self.scene());
        }
        self.automation.mark_applied(applied);
        self.poll_session(ctx);
        if self.mask_overlay_stale {
            self.mask_overlay_stale = false;
            self.map.set_mask(ctx, Some(&self.mask));
        }
        if let Some((name, target, bytes)) = self.import_job.as_ref().and_then(JobHandle::try_take)
        {
            self.import_job = None;
            match bytes {
                Ok(bytes) if target == detail::ImportTarget::Mask => {
                    self.import_mask(ctx, &name, &bytes)
                }
                Ok(bytes) if target == detail::ImportTarget::Scene => {
                    self.open_scene(&name, &bytes)
                }
                Ok(bytes) => self.load_dem(ctx, &name, bytes),
                Err(err) => self.set_error(format!("{name}: {err}")),
            }
        }
        self.take_filled_dem(ctx);
        self.take_features();
        self.take_networks();
        if let Some(result) = self.kernels_job.as_ref().and_then(JobHandle::try_take) {
            self.kernels_job = None;
            if let Err(err) = result {
                log::warn!("{err}; each stage builds its kernels when it first runs");
            }
        }
        if let Some(result) = self.selftest_job.as_ref().and_then(JobHandle::try_take) {
            self.selftest_job = None;
            self.selftest = Some(result.map_err(|err| err.to_string()));
        }
        // The first running job, in pipeline order, is the one scripts see.
        let job = job_status(&self.session.job())
            .or_else(|| job_status(&self.blend.fill_job.as_ref()))
            .or_else(|| job_status(&self.blend.features_job.as_ref()))
            .or_else(|| job_status(&self.selftest_job.as_ref()));
        self.automation.update(|s| s.job = job);
        if self.busy() {
            // Keep the progress bar moving; results trigger a repaint when they land. In the
            // browser jobs share the main thread with painting, and a frame can cost 250 ms
            // where the page is composited in software (headless Chromium here), so the bar
            // moves at 2 Hz there and leaves the job its time; natively jobs have threads.
            let every = if cfg!(target_arch = "wasm32") {
                500
            } else {
                100
            };
            ctx.request_repaint_after(std::time::Duration::from_millis(every));
        }
    }
}

/// A running job's name, progress and message.
fn job_status<T>(job: &Option<&JobHandle<T>>) -> Option<JobStatus> {
    job.map(|j| JobStatus {
        name: j.name().to_owned(),
        progress: j.progress(),
        message: j.message(),
    })
}

impl StrahlerApp {
    /// Shows the terrain before or after erosion, as the Erosion section's toggle asks.
    fn switch_before_after(&mut self, ctx: &egui::Context) {
        let want = self.show_before_erosion && self.session.scene().erosion.is_some();
        if want == self.showing_before {
            return;
        }
        let picture = match &self.pictures {
            Some((_, Some(before))) if want => before.clone(),
            Some((after, _)) if !want => after.clone(),
            _ => return,
        };
        self.showing_before = want;
        self.show_picture(ctx, picture);
    }

    /// The bar above the central area that switches between the map and the 3D view.
    fn view_switch(&mut self, ui: &mut egui::Ui) {
        egui::Panel::top("views").show(ui, |ui| {
            ui.horizontal(|ui| {
                let mut view = self.view;
                ui.selectable_value(&mut view, ViewKind::Map, "2D map (2)");
                ui.selectable_value(&mut view, ViewKind::ThreeD, "3D view (3)");
                if view != self.view {
                    self.set_view(view);
                }
            });
        });
    }
}

impl eframe::App for StrahlerApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.poll_jobs(&ctx);
        let frame_cpu_ms = frame.info().cpu_usage.map(|s| s * 1e3);
        self.automation.update(|s| s.frame_cpu_ms = frame_cpu_ms);
        if !ctx.egui_wants_keyboard_input() {
            let (map, three_d) = ctx.input(|i| {
                (
                    i.key_pressed(egui::Key::Num2),
                    i.key_pressed(egui::Key::Num3),
                )
            });
            if map {
                self.set_view(ViewKind::Map);
            }
            if three_d {
                self.set_view(ViewKind::ThreeD);
            }
        }
        // The map's tool keys; the 3D view uses letters to fly.
        if !ctx.egui_wants_keyboard_input() && self.view == ViewKind::Map {
            ctx.input(|i| {
                if i.key_pressed(egui::Key::R) {
                    self.tool = Tool::River;
                }
                if i.key_pressed(egui::Key::P) {
                    self.tool = Tool::Pan;
                }
                if i.key_pressed(egui::Key::D) {
                    self.tool = Tool::Ridge;
                }
                if i.key_pressed(egui::Key::V) {
                    self.tool = Tool::Valley;
                }
                if i.key_pressed(egui::Key::K) {
                    self.tool = Tool::Peak;
                }
                if i.key_pressed(egui::Key::M) {
                    self.tool = Tool::Mask;
                }
                if i.key_pressed(egui::Key::B) {
                    self.tool = Tool::Block;
                }
                if i.key_pressed(egui::Key::S) {
                    self.tool = Tool::Select;
                }
            });
            if ctx.input(|i| i.key_pressed(egui::Key::U)) {
                blend::upload(self);
            }
            if ctx.input(|i| i.key_pressed(egui::Key::E)) {
                self.export.open = true;
            }
        }
        if !ctx.egui_wants_keyboard_input() {
            if self.selected.is_some()
                && ctx.input(|i| {
                    i.key_pressed(egui::Key::Delete) || i.key_pressed(egui::Key::Backspace)
                })
            {
                self.delete_selected();
            }
            let (undo, redo) = ctx.input_mut(|i| {
                let redo = i.consume_key(
                    egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
                    egui::Key::Z,
                ) || i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y);
                (i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z), redo)
            });
            if undo {
                self.undo();
            }
            if redo {
                self.redo();
            }
        }
        status_bar::show(ui, self);
        side_panel::show(ui, self);
        self.switch_before_after(&ctx);
        self.view_switch(ui);
        export::window(&ctx, self);
        if self.view == ViewKind::ThreeD {
            egui::Panel::right("view3d settings").show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.view3d.settings_ui(ui));
            });
            egui::CentralPanel::no_frame().show(ui, |ui| {
                let field = self.map.field().map(|f| (f, self.map.version()));
                let rivers = self.session.output().map(|o| {
                    let s = &o.hydrology.skeleton;
                    (s.river_order.as_slice(), s.size)
                });
                let cell = self.session.output().map_or(1.0, |o| o.cell_m as f32);
                // The 3D view's rasters on the GPU it draws with, where that pays (or where
                // a script asked).
                let gpu = self.view3d.maps().pick(self.path.gpu());
                // The terrain on the GPU too, if the pipeline left it there.
                let on_gpu = self
                    .session
                    .output()
                    .filter(|o| self.map.field().is_some_and(|f| std::ptr::eq(f, &*o.field)))
                    .and_then(|o| o.gpu.as_ref());
                self.view3d
                    .show(ui, frame, field, on_gpu, rivers, cell, gpu);
            });
            let status = self.view3d.status();
            self.automation.update(|s| s.view3d = status);
            return;
        }
        let l = self.layers;
        self.overlay.show_rivers = l.rivers;
        self.overlay.min_river_order = l.min_river_order;
        self.overlay.show_ridges = l.ridges;
        self.overlay.show_mask = l.mask || self.tool == Tool::Mask;
        self.overlay.show_relief = l.relief;
        self.overlay.show_contours = l.contours;
        self.overlay.show_constraints = l.constraints;
        self.overlay.show_drainage = l.drainage;
        self.overlay.show_erosion_depth = l.erosion_depth;
        self.overlay.show_blocks = l.blocks || self.tool == Tool::Block;
        self.overlay.brush_radius = Some(self.brush.radius / self.mask.width().max(2) as f32);
        self.overlay.selected = if self.tool == Tool::Select {
            self.selected_points()
        } else {
            Vec::new()
        };
        self.overlay.blocks = self
            .session
            .scene()
            .blend
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let [x0, y0, x1, y1] = b.rect.map(|v| v as f32);
                (
                    egui::Rect::from_min_max(pos2(x0, y0), pos2(x1, y1)),
                    self.blend.selected == Some(i),
                )
            })
            .collect();
        for file in ctx.input(|i| i.raw.dropped_files.clone()) {
            self.start_import(&ctx, file);
        }
        let p = |v: &[f64; 2]| pos2(v[0] as f32, v[1] as f32);
        self.overlay.strokes = self
            .session
            .scene()
            .rivers
            .iter()
            .map(|s| (p(&s.estuary), p(&s.toward)))
            .collect();
        let segments = |lines: &[crate::scene::SketchLine]| {
            lines
                .iter()
                .flat_map(|l| {
                    l.points
                        .windows(2)
                        .map(|w| (p(&w[0]), p(&w[1])))
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        };
        let sketch = &self.session.scene().sketch;
        self.overlay.sketch_ridges = segments(&sketch.ridges);
        self.overlay.sketch_valleys = segments(&sketch.valleys);
        self.overlay.peaks = sketch.peaks.iter().map(|k| p(&k.at)).collect();
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let response = self.map.show(ui, self.tool, &self.overlay);
            self.hover = response.hover;
            if let Some((a, b)) = response.paint {
                self.paint_mask(&ctx, a, b);
            }
            if response.paint_finished {
                self.finish_mask_stroke(&ctx);
            }
            if let Some(drag) = response.block_drag {
                if self.tool == Tool::Select {
                    self.drag_item(drag, response.pick_tolerance);
                } else {
                    self.drag_block(drag);
                }
            }
            if let Some(at) = response.select_click {
                self.select_at(at, response.pick_tolerance);
            }
            let d = |q: egui::Pos2| [f64::from(q.x), f64::from(q.y)];
            if let Some((a, b)) = response.new_stroke {
                use crate::scene::SketchLine;
                let line = SketchLine {
                    points: vec![d(a), d(b)],
                    height: None,
                    heights: None,
                };
                let edit = match self.tool {
                    Tool::Ridge => Edit::AddLine {
                        kind: LineKind::Ridge,
                        line,
                    },
                    Tool::Valley => Edit::AddLine {
                        kind: LineKind::Valley,
                        line,
                    },
                    _ => {
                        let last = self
                            .session
                            .scene()
                            .rivers
                            .last()
                            .copied()
                            .unwrap_or_else(|| default_stroke().into());
                        Edit::AddRiver(RiverStroke {
                            estuary: d(a),
                            toward: d(b),
                            ..last
                        })
                    }
                };
                self.edit(edit);
            }
            if let Some(at) = response.clicked {
                self.edit(Edit::AddPeak(crate::scene::SketchPeak {
                    at: d(at),
                    height: None,
                }));
            }
        });
    }
}
