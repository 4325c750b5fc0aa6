//! The 3D view in the app: the [`crate::view3d`] renderer's offscreen target shown as an egui
//! image, mouse, keyboard and touch turned into camera moves, and its settings panel.
//!
//! Orbit mode: drag turns around the target, right-drag (or Shift+drag, or two fingers)
//! pans, scroll or pinch zooms. Fly mode (F): drag looks around, W/A/S/D or the arrows move,
//! Q/E go down/up, Shift goes faster, scroll moves along the look direction. Home resets the
//! view, 1 toggles snow (as in seed 003's editor).

use egui::{Color32, Key, Sense, Ui, vec2};
use serde::Serialize;

use crate::view3d::{Camera, CameraMode, FrameStats, Renderer, TerrainMaps, View3dSettings};

/// Which view the central area shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewKind {
    #[default]
    Map,
    ThreeD,
}

impl ViewKind {
    pub fn key(self) -> &'static str {
        match self {
            Self::Map => "2d",
            Self::ThreeD => "3d",
        }
    }
}

/// What `status().view3d` reports: the last frame and the camera.
#[derive(Clone, Debug, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct View3dStatus {
    pub triangles: usize,
    pub chunks: usize,
    pub finest_level: i32,
    pub width: u32,
    pub height: u32,
    /// "orbit" or "fly".
    pub mode: String,
    /// Eye to target in map widths (orbit mode).
    pub distance: f32,
    /// Degrees.
    pub yaw: f32,
    pub pitch: f32,
    /// Where the terrain's rasters were made: "gpu" or "cpu".
    pub maps: String,
    /// Whether the GPU-made rasters read the terrain from the pipeline's GPU copy (no
    /// upload).
    pub from_gpu_copy: bool,
}

/// Where the 3D view's rasters are made: `Auto` picks the GPU where it pays
/// ([`crate::view3d::gpu_maps::pays_on`]: a hardware GPU in the page), `Gpu` on any GPU that
/// computes, `Cpu` always on the CPU (scripts choose, `setView('3d', {maps})`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapsChoice {
    #[default]
    Auto,
    Gpu,
    Cpu,
}

impl MapsChoice {
    /// The GPU to make the rasters on, of `gpu` (the app's computing GPU, if any).
    pub fn pick(
        self,
        gpu: Option<&std::sync::Arc<crate::gpu::GpuContext>>,
    ) -> Option<&std::sync::Arc<crate::gpu::GpuContext>> {
        match self {
            MapsChoice::Auto => gpu.filter(|g| crate::view3d::gpu_maps::pays_on(g)),
            MapsChoice::Gpu => gpu,
            MapsChoice::Cpu => None,
        }
    }
}

/// A camera request from a script: distance in map widths, angles in degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraRequest {
    pub distance: Option<f32>,
    pub yaw: Option<f32>,
    pub pitch: Option<f32>,
}

/// Closest and farthest orbit, in map widths.
const MIN_DISTANCE: f32 = 0.002;
const MAX_DISTANCE: f32 = 6.0;

/// State of the 3D view.
#[derive(Default)]
pub struct View3d {
    pub camera: Option<Camera>,
    pub settings: View3dSettings,
    renderer: Option<Renderer>,
    texture: Option<egui::TextureId>,
    /// The terrain uploaded to the renderer: its map version and whether a GPU was asked
    /// to make its rasters.
    uploaded: Option<Made>,
    /// Map width in metres of the uploaded terrain.
    map_width: f32,
    pub stats: Option<FrameStats>,
    /// A camera request from a script, applied once a terrain is shown.
    pending: Option<CameraRequest>,
    /// The terrain being prepared for upload.
    preparing: Option<(Made, PrepareJob)>,
    /// Where the rasters are made.
    maps: MapsChoice,
}

/// A terrain's map version, and whether its rasters were asked of a GPU.
type Made = (u64, bool);
type Prepared = (TerrainMaps, Option<(Vec<u8>, usize)>);
type PrepareJob = crate::jobs::JobHandle<Result<Prepared, crate::jobs::Cancelled>>;

impl View3d {
    pub fn with_settings(settings: View3dSettings) -> Self {
        Self {
            settings,
            ..Default::default()
        }
    }

    /// Where the rasters are made from now on. Where that moves them (CPU to GPU or back),
    /// the terrain is prepared again; the old rasters stay drawn until the new ones are in.
    pub fn set_maps(&mut self, maps: MapsChoice) {
        self.maps = maps;
    }

    pub fn maps(&self) -> MapsChoice {
        self.maps
    }

    /// Applies a script's camera request (now, or once the first terrain is shown).
    pub fn request_camera(&mut self, request: CameraRequest) {
        match &mut self.camera {
            Some(camera) => apply(camera, request, self.map_width),
            None => self.pending = Some(request),
        }
    }

    /// Back to the overview.
    pub fn reset_camera(&mut self) {
        if let Some(maps) = self.renderer.as_ref().and_then(Renderer::maps) {
            self.camera = Some(overview(maps, self.settings.exaggeration));
        }
    }

    /// What scripts see.
    pub fn status(&self) -> Option<View3dStatus> {
        let (stats, camera) = (self.stats?, self.camera?);
        let (maps, from_gpu_copy) = match &self.renderer.as_ref()?.maps()?.rasters {
            crate::view3d::maps::Rasters::Gpu(r) => ("gpu", r.from_gpu_copy),
            crate::view3d::maps::Rasters::Cpu { .. } => ("cpu", false),
        };
        Some(View3dStatus {
            triangles: stats.triangles,
            chunks: stats.chunks,
            finest_level: stats.finest_level,
            width: stats.width,
            height: stats.height,
            mode: match camera.mode {
                CameraMode::Orbit => "orbit",
                CameraMode::Fly => "fly",
            }
            .into(),
            distance: camera.distance / self.map_width.max(1.0),
            yaw: camera.yaw.to_degrees(),
            pitch: camera.pitch.to_degrees(),
            maps: maps.into(),
            from_gpu_copy,
        })
    }

    /// Draws the view into the rest of `ui`: uploads a changed terrain, moves the camera from
    /// input and renders a frame. `rivers` is the rivers' courses on the skeleton's square grid
    /// of that side;
    /// `cell` the field's cell size in metres. With `gpu` (the device the view draws with)
    /// the rasters are made there, else on the CPU; `on_gpu` is the field already on a GPU,
    /// if the pipeline left it there (read there instead of uploaded).
    #[allow(clippy::too_many_arguments)]
    pub fn show(
        &mut self,
        ui: &mut Ui,
        frame: &eframe::Frame,
        field: Option<(&crate::heightfield::Heightfield, u64)>,
        on_gpu: Option<&crate::gpu::GpuField>,
        rivers: Option<(&[crate::skeleton::RiverPiece], usize)>,
        cell: f32,
        gpu: Option<&std::sync::Arc<crate::gpu::GpuContext>>,
    ) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let message = |ui: &mut Ui, text: &str| {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(16.0),
                ui.visuals().text_color(),
            );
        };
        let Some(state) = frame.wgpu_render_state() else {
            message(
                ui,
                "The 3D view needs a GPU renderer (WebGPU, WebGL2, Vulkan, Metal or DX12).",
            );
            return;
        };
        let Some((field, version)) = field else {
            message(ui, "Generating terrain...");
            return;
        };
        let renderer = self
            .renderer
            .get_or_insert_with(|| Renderer::new(&state.device));
        let made = (version, gpu.is_some());
        let wanted = self.uploaded != Some(made);
        if wanted && self.preparing.as_ref().map(|(m, _)| *m) != Some(made) {
            // O(cells), off the UI thread; a newer terrain cancels the older preparation.
            let max_side = renderer.max_texture_side();
            let field = field.clone();
            let rivers = rivers.map(|(courses, side)| (courses.to_vec(), side));
            let repaint = ui.ctx().clone();
            let gpu = gpu.cloned();
            let on_gpu = on_gpu.filter(|_| gpu.is_some()).cloned();
            let spawned = crate::jobs::spawn(
                "3D view",
                move |job| async move {
                    let gpu = gpu.as_deref().map(|g| (g, on_gpu.as_ref()));
                    let maps = prepare_maps(gpu, &field, cell, max_side, &job).await?;
                    // The skeleton's cells may be coarser than the field's (detail levels).
                    let water = rivers.map(|(courses, side)| {
                        let river_cell = cell * field.width() as f32 / side.max(1) as f32;
                        (
                            crate::view3d::maps::water_mask(&courses, side, river_cell),
                            side,
                        )
                    });
                    Ok((maps, water))
                },
                move || repaint.request_repaint(),
            );
            match spawned {
                Ok(handle) => self.preparing = Some((made, handle)),
                Err(err) => log::error!("{err}"),
            }
        }
        if let Some((prepared, handle)) = &self.preparing
            && let Some(result) = handle.try_take()
        {
            if let Ok((maps, water)) = result {
                self.map_width = maps.extent().0;
                let water = water.as_ref().map(|(mask, side)| (mask.as_slice(), *side));
                renderer.set_terrain(&state.device, &state.queue, maps, water);
                self.uploaded = Some(*prepared);
            }
            self.preparing = None;
            if self.camera.is_none() {
                self.reset_camera();
            }
        }
        if self.uploaded.is_none() {
            let progress = self.preparing.as_ref().map_or(0.0, |(_, h)| h.progress());
            message(
                ui,
                &format!("Preparing the 3D view... {:.0}%", 100.0 * progress),
            );
            return;
        }
        let (Some(mut camera), Some(maps)) =
            (self.camera, self.renderer.as_ref().and_then(Renderer::maps))
        else {
            return;
        };
        let moving = steer(ui, &response, &mut camera, maps, &mut self.settings);
        if let Some(request) = self.pending.take() {
            apply(&mut camera, request, self.map_width);
        }
        // Never under the ground.
        let eye = camera.eye();
        let ground = maps.ground(eye.x, eye.y) * self.settings.exaggeration;
        camera.keep_above(ground, 2.0);
        self.camera = Some(camera);
        let camera_now = camera;
        let ppp = ui.ctx().pixels_per_point();
        let size = [
            (rect.width() * ppp).round().max(1.0) as u32,
            (rect.height() * ppp).round().max(1.0) as u32,
        ];
        let Some(renderer) = self.renderer.as_mut() else {
            return;
        };
        let recreated = renderer.ensure_target(&state.device, size);
        self.stats = renderer.render(
            &state.device,
            &state.queue,
            size,
            &camera_now,
            &self.settings,
        );
        self.paint_frame(ui, state, rect, &camera_now, recreated);
        if moving {
            ui.ctx().request_repaint();
        }
    }

    /// Shows the rendered frame (registering its texture with egui once, again when the
    /// target was recreated) and the frame's numbers with the controls.
    fn paint_frame(
        &mut self,
        ui: &Ui,
        state: &egui_wgpu::RenderState,
        rect: egui::Rect,
        camera: &Camera,
        recreated: bool,
    ) {
        if let Some(view) = self.renderer.as_ref().and_then(Renderer::color_view) {
            let mut egui_renderer = state.renderer.write();
            match self.texture {
                Some(id) if recreated => egui_renderer.update_egui_texture_from_wgpu_texture(
                    &state.device,
                    view,
                    wgpu::FilterMode::Linear,
                    id,
                ),
                Some(_) => {}
                None => {
                    self.texture = Some(egui_renderer.register_native_texture(
                        &state.device,
                        view,
                        wgpu::FilterMode::Linear,
                    ));
                }
            }
        }
        if let Some(id) = self.texture {
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            ui.painter().image(id, rect, uv, Color32::WHITE);
        }
        if let Some(stats) = self.stats {
            let text = format!(
                "{} triangles in {} chunks (finest level {})  |  {}",
                stats.triangles,
                stats.chunks,
                stats.finest_level,
                match camera.mode {
                    CameraMode::Orbit =>
                        "drag: turn, right-drag: pan, scroll: zoom, F: fly, Home: reset",
                    CameraMode::Fly => "drag: look, WASD/QE: move, Shift: fast, F: orbit",
                }
            );
            ui.painter().text(
                rect.left_bottom() + vec2(8.0, -8.0),
                egui::Align2::LEFT_BOTTOM,
                text,
                egui::FontId::proportional(12.0),
                Color32::from_gray(20),
            );
        }
    }

    /// The settings panel (right side).
    pub fn settings_ui(&mut self, ui: &mut Ui) {
        ui.heading("3D view");
        let mut mode = self.camera.map(|c| c.mode).unwrap_or_default();
        ui.horizontal(|ui| {
            ui.label("Camera");
            ui.selectable_value(&mut mode, CameraMode::Orbit, "Orbit");
            ui.selectable_value(&mut mode, CameraMode::Fly, "Fly (F)");
        });
        if let Some(camera) = self.camera.as_mut() {
            let ahead = camera.distance;
            camera.set_mode(mode, ahead);
        }
        if ui.button("Reset view (Home)").clicked() {
            self.reset_camera();
        }
        ui.separator();
        let s = &mut self.settings;
        ui.add(egui::Slider::new(&mut s.sun_azimuth, 0.0..=360.0).text("Sun azimuth (deg)"));
        ui.add(egui::Slider::new(&mut s.sun_elevation, 2.0..=90.0).text("Sun elevation (deg)"));
        ui.add(
            egui::Slider::new(&mut s.exaggeration, 0.5..=10.0)
                .text("Vertical exaggeration")
                .logarithmic(true),
        );
        ui.checkbox(&mut s.rivers, "Rivers as water");
        ui.checkbox(&mut s.snow, "Snow (1)")
            .on_hover_text("Seed 003's snow scene: snow above the snow line where slopes hold it");
        ui.add_enabled(
            s.snow,
            egui::Slider::new(&mut s.snow_line, 0.0..=1.0).text("Snow line (of range)"),
        );
        ui.checkbox(&mut s.water_plane, "Water plane");
        let (lo, hi) = self
            .renderer
            .as_ref()
            .and_then(Renderer::maps)
            .map_or((0.0, 1000.0), |m| (m.zmin, m.zmax));
        ui.add_enabled(
            s.water_plane,
            egui::Slider::new(&mut s.water_level, lo..=hi).text("Water level (m)"),
        );
        ui.separator();
        ui.checkbox(&mut s.detail, "Procedural close-up detail")
            .on_hover_text(
                "Seed 004, eqs. 4-6: multifractal Perlin detail in chunks finer than the \
             heightfield, stronger on high, steep and rough ground",
            );
        ui.add_enabled(
            s.detail,
            egui::Slider::new(&mut s.detail_amplitude, 0.0..=1.0).text("Detail (m per m of cell)"),
        );
        ui.add(
            egui::Slider::new(&mut s.pixels_per_quad, 1.0..=32.0)
                .text("Mesh coarseness (px/quad)")
                .logarithmic(true),
        )
        .on_hover_text(
            "Seed 004, eq. 7: a chunk is refined while it shows fewer triangles per radian \
             than a quad every this many pixels",
        );
        ui.checkbox(&mut s.skirts, "Skirts between levels")
            .on_hover_text("Hide the cracks between chunks of different levels");
        if let Some(stats) = self.stats {
            ui.label(format!(
                "{} triangles, {} chunks, {} x {} px",
                stats.triangles, stats.chunks, stats.width, stats.height
            ));
        }
    }
}

/// The whole map from the south, looking at its mid height.
fn overview(maps: &TerrainMaps, exaggeration: f32) -> Camera {
    let (w, h) = maps.extent();
    Camera::overview(w, h, 0.5 * (maps.zmin + maps.zmax) * exaggeration)
}

/// Applies a script's camera request (distance in map widths, degrees); orbit mode.
fn apply(camera: &mut Camera, request: CameraRequest, map_width: f32) {
    camera.set_mode(CameraMode::Orbit, camera.distance);
    if let Some(d) = request.distance.filter(|d| d.is_finite() && *d > 0.0) {
        camera.distance = d.clamp(MIN_DISTANCE, MAX_DISTANCE) * map_width.max(1.0);
    }
    if let Some(yaw) = request.yaw.filter(|v| v.is_finite()) {
        camera.yaw = yaw.to_radians().rem_euclid(std::f32::consts::TAU);
    }
    if let Some(pitch) = request.pitch.filter(|v| v.is_finite()) {
        camera.rotate(0.0, pitch.to_radians() - camera.pitch);
    }
}

/// Moves `camera` from this frame's pointer, touch and keys. Returns whether it keeps moving
/// (keys held), so the view repaints.
fn steer(
    ui: &Ui,
    response: &egui::Response,
    camera: &mut Camera,
    maps: &TerrainMaps,
    settings: &mut View3dSettings,
) -> bool {
    let width = maps.extent().0.max(1.0);
    let eye = camera.eye();
    let clearance = (eye.z - maps.ground(eye.x, eye.y) * settings.exaggeration).max(5.0);
    let (keys_active, dt) = (
        !ui.ctx().egui_wants_keyboard_input(),
        ui.input(|i| i.stable_dt).min(0.1),
    );
    if keys_active {
        let (mode_toggle, reset, snow) = ui.input(|i| {
            (
                i.key_pressed(Key::F),
                i.key_pressed(Key::Home),
                i.key_pressed(Key::Num1),
            )
        });
        if mode_toggle {
            let next = match camera.mode {
                CameraMode::Orbit => CameraMode::Fly,
                CameraMode::Fly => CameraMode::Orbit,
            };
            camera.set_mode(next, clearance * 2.0);
        }
        if reset {
            *camera = overview(maps, settings.exaggeration);
        }
        if snow {
            settings.snow = !settings.snow;
        }
    }
    let drag = response.drag_delta();
    let pan = response.dragged_by(egui::PointerButton::Secondary)
        || (response.dragged_by(egui::PointerButton::Primary) && ui.input(|i| i.modifiers.shift));
    let (scroll, zoom, touch) =
        ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta(), i.multi_touch()));
    let hovered = response.hovered() || response.dragged();
    match camera.mode {
        CameraMode::Orbit => {
            let metres_per_px = camera.distance / ui.available_height().max(200.0);
            if let Some(touch) = touch.filter(|t| t.num_touches >= 2) {
                let t = touch.translation_delta;
                camera.translate(-t.x * metres_per_px, t.y * metres_per_px, 0.0);
            } else if pan {
                camera.translate(-drag.x * metres_per_px, drag.y * metres_per_px, 0.0);
            } else if response.dragged() {
                camera.rotate(drag.x * 0.006, drag.y * 0.006);
            }
            if hovered {
                let factor = (-scroll * 0.0015).exp() / zoom.max(1e-3);
                camera.zoom(factor, MIN_DISTANCE * width, MAX_DISTANCE * width);
            }
            false
        }
        CameraMode::Fly => {
            if response.dragged() {
                camera.rotate(drag.x * 0.004, -drag.y * 0.004);
            }
            let speed = clearance.clamp(20.0, width) * dt;
            if hovered && scroll != 0.0 {
                camera.advance(scroll * clearance * 0.004);
            }
            if !keys_active {
                return false;
            }
            let fast = if ui.input(|i| i.modifiers.shift) {
                4.0
            } else {
                1.0
            };
            let held = |keys: &[Key]| ui.input(|i| keys.iter().any(|k| i.key_down(*k)));
            let axis = |plus: &[Key], minus: &[Key]| {
                f32::from(u8::from(held(plus))) - f32::from(u8::from(held(minus)))
            };
            let ahead = axis(&[Key::W, Key::ArrowUp], &[Key::S, Key::ArrowDown]);
            let right = axis(&[Key::D, Key::ArrowRight], &[Key::A, Key::ArrowLeft]);
            let up = axis(&[Key::E], &[Key::Q]);
            camera.advance(ahead * speed * fast);
            camera.translate(right * speed * fast, 0.0, up * speed * fast);
            ahead != 0.0 || right != 0.0 || up != 0.0
        }
    }
}

/// The terrain's 3D maps on `gpu` where given (with the field on a GPU, if it is), else
/// (or when the GPU fails, which is logged) on the CPU.
async fn prepare_maps(
    gpu: Option<(&crate::gpu::GpuContext, Option<&crate::gpu::GpuField>)>,
    field: &crate::heightfield::Heightfield,
    cell: f32,
    max_side: usize,
    job: &crate::jobs::JobCtx,
) -> Result<TerrainMaps, crate::jobs::Cancelled> {
    if let Some((gpu, on_gpu)) = gpu {
        use crate::view3d::gpu_maps::{self, GpuMapsError};
        match gpu_maps::prepare(gpu, field, on_gpu, cell, max_side, job).await {
            Ok(maps) => return Ok(maps),
            Err(GpuMapsError::Cancelled(c)) => return Err(c),
            Err(GpuMapsError::Gpu(err)) => log::warn!("3D maps on the CPU: {err}"),
        }
    }
    TerrainMaps::prepare(field, cell, max_side, job).await
}
