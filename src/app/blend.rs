//! The DEM panel and the blend stage of the app (seed paper 000, Sec. VI, Algorithm 1).
//!
//! The user uploads a real DEM (button, drop, or `window.strahler.loadDem`), sees its size,
//! range, cell size and CRS, fills its voids if it has any, drags a rectangle on its preview
//! to select the reference block R, and places it on the map. With the Block tool (B) a
//! placed block is moved by dragging it and resized by dragging its corner handle; each
//! release re-solves. Turns, mirror and height scale are set per block. Blocks live in the
//! scene (`blend`), so they re-solve after a reload.
//!
//! The stage runs after the detail stage on its output (`detailed`); only block edits re-run
//! it, never the hydrology or the detail.

use std::sync::Arc;

use super::StrahlerApp;
use super::automation::{BlendStatus, DemStatus};
use super::map_view::{BlockDrag, Tool};
use super::panels::{DemAction, DemInfo, DemView};
use crate::blend::BlendBlock;
use crate::dem::format::{self, Format, ImportOptions};
use crate::dem::{Dem, DemError, ReadLimits};
use crate::diffusion::{self, DiffusionError, Method, MultigridParams};
use crate::heightfield::Heightfield;
use crate::jobs::JobHandle;
use crate::pipeline::Output;
use crate::scene::{Edit, Scene};

/// The uploaded DEM.
pub struct LoadedDem {
    pub name: String,
    pub dem: Dem,
    /// The file's bytes, kept to re-read a PNG/RAW with another height range.
    bytes: Arc<Vec<u8>>,
    preview: Option<egui::TextureHandle>,
    /// The lowest and highest heights, and the no-data cells (counted once, not per frame).
    range: (f32, f32),
    voids: usize,
}

/// How a block drag changes the block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grab {
    Move,
    Resize,
}

/// Everything the DEM panel and the blend stage keep.
pub struct BlendState {
    pub dem: Option<LoadedDem>,
    /// Height range for PNG and RAW files that carry none (the DEM panel's, once applied).
    pub z_range: (f32, f32),
    /// The reference window on the DEM: row, col, height, width.
    pub selection: [usize; 4],
    /// The block selected in the list or on the map (an index into the scene's `blend`).
    pub selected: Option<usize>,
    grab: Option<(usize, Grab)>,
    pub fill_job: Option<JobHandle<Result<Heightfield, DiffusionError>>>,
    /// Extracting the DEM's features (seed 003) into a scene.
    pub features_job: Option<JobHandle<Result<Scene, String>>>,
    pub summary: Option<String>,
    /// The DEM panel's network comparison.
    pub networks: super::networks::Comparison,
}

impl Default for BlendState {
    fn default() -> Self {
        Self {
            dem: None,
            z_range: super::panels::DEFAULT_Z_RANGE,
            selection: [0, 0, 0, 0],
            selected: None,
            grab: None,
            fill_job: None,
            features_job: None,
            summary: None,
            networks: Default::default(),
        }
    }
}

/// Heights of `field` in the window `[row, col, height, width]`.
fn crop(field: &Heightfield, [row, col, h, w]: [usize; 4]) -> Option<Heightfield> {
    let fits = row.checked_add(h).is_some_and(|r| r <= field.height())
        && col.checked_add(w).is_some_and(|c| c <= field.width());
    if h == 0 || w == 0 || !fits {
        return None;
    }
    let data = (row..row + h)
        .flat_map(|y| field.data()[y * field.width() + col..][..w].iter().copied())
        .collect();
    Heightfield::from_vec(w, h, data).ok()
}

impl StrahlerApp {
    /// Reads an uploaded file as the DEM. A PNG or RAW file without a height range uses the
    /// panel's range (and says so).
    pub(super) fn load_dem(&mut self, ctx: &egui::Context, name: &str, bytes: Vec<u8>) {
        let bytes = Arc::new(bytes);
        let options = ImportOptions {
            limits: ReadLimits::default(),
            z_range: None,
            flip_y: false,
        };
        let mut read = format::read(name, &bytes, &options);
        let needs_range = matches!(
            (&read, Format::from_name(name)),
            (Err(DemError::Unsupported(_)), Some(Format::Png))
                | (Err(DemError::Malformed { .. }), Some(Format::R16))
        );
        if needs_range {
            read = format::read(
                name,
                &bytes,
                &ImportOptions {
                    z_range: Some(self.blend.z_range),
                    ..options
                },
            );
            if read.is_ok() {
                self.messages.notice = Some(format!(
                    "{name} does not say its height range: read as {} to {} m (change it in the \
                     DEM panel)",
                    self.blend.z_range.0, self.blend.z_range.1
                ));
            }
        }
        match read {
            Ok(dem) => {
                super::stored_dem::keep(name, &dem, &self.automation);
                self.set_dem(ctx, name, dem, bytes);
            }
            Err(err) => self.set_error_at(super::Place::Dem, format!("{name}: {err}")),
        }
    }

    /// The DEM an earlier visit uploaded, as the browser kept it (`stored_dem`), unless a DEM
    /// was uploaded since the page opened.
    pub(super) fn restore_dem(&mut self, ctx: &egui::Context, name: &str, bytes: Vec<u8>) {
        if self.blend.dem.is_some() {
            return;
        }
        match super::stored_dem::read(&bytes) {
            Ok(dem) => {
                self.set_dem(ctx, name, dem, Arc::new(bytes));
                let said = format!("the DEM {name}");
                // One notice for what one load brought back (the scene too, usually).
                self.messages.notice = Some(match self.messages.notice.take() {
                    Some(scene) if scene.starts_with("Restored") => format!("{scene}, and {said}"),
                    _ => format!("Restored {said} kept in this browser"),
                });
            }
            Err(err) => self.set_error_at(
                super::Place::Dem,
                format!("{name} (kept in this browser): {err}"),
            ),
        }
    }

    fn set_dem(&mut self, ctx: &egui::Context, name: &str, dem: Dem, bytes: Arc<Vec<u8>>) {
        let (w, h) = (dem.field.width(), dem.field.height());
        let side = w.min(h).min(256);
        self.blend.selection = [(h - side) / 2, (w - side) / 2, side, side];
        let cell = dem.georef.cell_size_m(h).map_or(1.0, |c| c.0 as f32);
        let image = super::relief::shaded_relief(&dem.field, cell.max(1e-6));
        let preview = Some(ctx.load_texture("dem preview", image, egui::TextureOptions::LINEAR));
        let (zmin, zmax) = dem.field.finite_range().unwrap_or((0.0, 0.0));
        let status = DemStatus {
            name: name.to_owned(),
            width: w,
            height: h,
            zmin,
            zmax,
            void_cells: dem.void_cells(),
            checksum: dem.field.checksum(),
            cell_size: dem.georef.cell_size_m(h).map(|c| c.0),
            crs: dem.georef.crs_label(),
        };
        self.automation.update(|s| s.dem = Some(status));
        self.blend.dem = Some(LoadedDem {
            name: name.to_owned(),
            range: (zmin, zmax),
            voids: dem.void_cells(),
            dem,
            bytes,
            preview,
        });
        self.messages.error = None;
    }

    /// Fills the DEM's voids by harmonic diffusion (the diffusion stage's solver), as a job.
    pub(super) fn fill_dem_voids(&mut self, ctx: &egui::Context) {
        if self.blend.dem.as_ref().is_none_or(|l| l.voids == 0) {
            return;
        }
        let Some(backend) = self.backend() else {
            return;
        };
        let Some(loaded) = &self.blend.dem else {
            return;
        };
        let problem = diffusion::void_problem(&loaded.dem.field);
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "fill voids",
            move |job| async move {
                let method = Method::Multigrid(MultigridParams::default());
                diffusion::fill(&backend, &problem, method, &job)
                    .await
                    .map(|f| f.field)
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.blend.fill_job = Some(handle),
            Err(err) => self.set_error_at(super::Place::Dem, err.to_string()),
        }
    }

    /// The selected window of the DEM becomes a block in the middle of the map, one DEM cell
    /// per terrain cell (shrunk to half the map if larger).
    pub(super) fn place_selection(&mut self) {
        let window = self.blend.selection;
        let transform = crate::blend::Transform::default();
        self.place_block(
            window,
            None,
            transform,
            crate::blend::poisson::DEFAULT_FEATHER,
        );
    }

    /// Adds a block from the DEM window `[row, col, height, width]` at `rect` (map units;
    /// `None` = centred at one DEM cell per terrain cell), turned, mirrored and scaled by
    /// `transform`, its change fading in over `feather` of its shorter side.
    pub(super) fn place_block(
        &mut self,
        window: [usize; 4],
        rect: Option<[f64; 4]>,
        transform: crate::blend::Transform,
        feather: f32,
    ) {
        let crate::blend::Transform {
            quarter_turns,
            mirror,
            z_scale,
        } = transform;
        let Some(loaded) = &self.blend.dem else {
            self.set_error_at(
                super::Place::Dem,
                "Upload a DEM first (DEM panel: Upload DEM, or drop a file).".into(),
            );
            return;
        };
        let Some(reference) = crop(&loaded.dem.field, window) else {
            self.set_error_at(
                super::Place::Dem,
                format!(
                    "The window {window:?} (row, col, height, width) does not fit the {} x {} DEM",
                    loaded.dem.field.height(),
                    loaded.dem.field.width()
                ),
            );
            return;
        };
        let [row, col, h, w] = window;
        let name = format!("{} [{row},{col} {h}x{w}]", loaded.name);
        let n = self
            .output()
            .map_or(self.session.scene().size, |o| o.field.width())
            .max(2);
        let rect = rect.unwrap_or_else(|| {
            let (tw, th) = if quarter_turns % 2 == 1 {
                (h, w)
            } else {
                (w, h)
            };
            let span = |cells: usize| (cells.saturating_sub(1) as f64 / (n - 1) as f64).min(0.5);
            let (sx, sy) = (span(tw), span(th));
            [
                0.5 - sx / 2.0,
                0.5 - sy / 2.0,
                0.5 + sx / 2.0,
                0.5 + sy / 2.0,
            ]
        });
        match BlendBlock::new(&name, &reference, rect) {
            Ok(mut block) => {
                block.quarter_turns = quarter_turns;
                block.mirror = mirror;
                block.z_scale = z_scale;
                block.feather = feather;
                if let Err(err) = self.session.apply(Edit::AddBlock(block)) {
                    self.set_error_at(super::Place::Dem, format!("Block {err}"));
                    return;
                }
                self.blend.selected = Some(self.session.scene().blend.len() - 1);
            }
            Err(err) => self.set_error_at(super::Place::Dem, format!("Block: {err}")),
        }
    }

    /// Puts a finished picture on the map.
    pub(super) fn show_picture(&mut self, ctx: &egui::Context, picture: super::picture::Picture) {
        self.canvas.overlay.contours = picture.contours;
        self.canvas
            .map
            .set_field(ctx, picture.field, picture.relief);
    }

    /// Publishes the blend stage of a finished run (or its absence).
    pub(super) fn show_blend_status(&mut self, output: &Output) {
        let Some(b) = &output.blend else {
            self.blend.summary = None;
            self.automation.update(|s| s.blend = None);
            return;
        };
        let converged = b.solves.iter().all(|s| s.converged);
        let rects = self
            .session
            .scene()
            .blend
            .iter()
            .map(|block| {
                let r = block.rect_on(b.field.width(), b.field.height());
                [r.row, r.col, r.height, r.width]
            })
            .collect();
        self.blend.summary = Some(format!(
            "{} block{} blended on the {} in {:.0} ms{}",
            b.solves.len(),
            if b.solves.len() == 1 { "" } else { "s" },
            b.backend.to_uppercase(),
            b.millis,
            if converged { "" } else { " (NOT converged)" }
        ));
        self.automation.update(|s| {
            s.blend = Some(BlendStatus {
                blocks: b.solves.len(),
                backend: b.backend.to_owned(),
                millis: b.millis,
                converged,
                rects,
            })
        });
    }

    /// Extracts the uploaded DEM's ridge lines, valley lines and peaks (seed 003, Sec. 3.1)
    /// as a job; the result replaces the scene's rivers and sketch (see [`Self::take_features`]).
    pub(super) fn extract_features(&mut self, ctx: &egui::Context) {
        let Some(loaded) = &self.blend.dem else {
            self.set_error_at(
                super::Place::Dem,
                "Upload a DEM first (DEM panel: Upload DEM, or drop a file).".into(),
            );
            return;
        };
        let field = loaded.dem.field.clone();
        let (w, h) = (field.width(), field.height());
        let cell = loaded.dem.georef.cell_size_m(h).map_or(30.0, |c| c.0);
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "features",
            move |job| async move {
                let params = crate::features::FeatureParams::default();
                let mut steps = crate::features::Extraction::new(field.data(), w, h, &params)
                    .map_err(|e| e.to_string())?;
                loop {
                    let message = format!("extracting features: {}", steps.stage_name());
                    job.tick(steps.progress(), &message)
                        .await
                        .map_err(|e| e.to_string())?;
                    if steps.step() {
                        break;
                    }
                }
                Scene::from_features(&steps.finish(), w, h, cell).map_err(|e| e.to_string())
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.blend.features_job = Some(handle),
            Err(err) => self.set_error_at(super::Place::Dem, err.to_string()),
        }
    }

    /// Extracted features become the document: the sketch of ridges, valleys and peaks at
    /// the DEM's size and cell size, without rivers, ready to edit and regenerate (undo
    /// brings the previous scene back).
    pub(super) fn take_features(&mut self) {
        let Some(result) = self
            .blend
            .features_job
            .as_ref()
            .and_then(JobHandle::try_take)
        else {
            return;
        };
        self.blend.features_job = None;
        match result {
            Ok(scene) => {
                let s = &scene.sketch;
                self.messages.notice = Some(format!(
                    "Extracted {} ridges, {} valleys and {} peaks: edit them and regenerate",
                    s.ridges.len(),
                    s.valleys.len(),
                    s.peaks.len()
                ));
                self.load_scene(&scene);
            }
            Err(err) if err == "cancelled" => {}
            Err(err) => {
                self.set_error_at(super::Place::Dem, format!("Extract features failed: {err}"))
            }
        }
    }

    /// A finished void fill replaces the DEM's heights.
    pub(super) fn take_filled_dem(&mut self, ctx: &egui::Context) {
        let Some(result) = self.blend.fill_job.as_ref().and_then(JobHandle::try_take) else {
            return;
        };
        self.blend.fill_job = None;
        match result {
            Ok(field) => {
                if let Some(loaded) = self.blend.dem.take() {
                    let voids = loaded.voids;
                    let dem = Dem {
                        field,
                        georef: loaded.dem.georef,
                    };
                    // The same DEM with its voids filled: the chosen window stays.
                    super::stored_dem::keep(&loaded.name, &dem, &self.automation);
                    let window = self.blend.selection;
                    self.set_dem(ctx, &loaded.name, dem, loaded.bytes);
                    self.blend.selection = window;
                    self.messages.notice = Some(format!("Filled {voids} no-data cells"));
                }
            }
            Err(DiffusionError::Cancelled(_)) => {}
            Err(err) => self.set_error_at(super::Place::Dem, format!("Fill voids failed: {err}")),
        }
    }

    /// Moves or resizes blocks with the Block tool; a release re-solves.
    pub(super) fn drag_block(&mut self, drag: BlockDrag) {
        if self.blend.grab.is_none() {
            // Pick the topmost block under the drag's start; its corner handle resizes.
            let handle = 12.0 / 600.0;
            let hit = self
                .session
                .scene()
                .blend
                .iter()
                .enumerate()
                .rev()
                .find_map(|(i, b)| {
                    let [x0, y0, x1, y1] = b.rect.map(|v| v as f32);
                    let p = drag.from;
                    let near_corner = (p.x - x1).abs() < handle && (p.y - y1).abs() < handle;
                    let inside = (x0..=x1).contains(&p.x) && (y0..=y1).contains(&p.y);
                    if near_corner {
                        Some((i, Grab::Resize))
                    } else {
                        inside.then_some((i, Grab::Move))
                    }
                });
            self.blend.grab = hit;
            if let Some((i, _)) = hit {
                self.blend.selected = Some(i);
            }
        }
        if let Some((i, grab)) = self.blend.grab
            && let Some(mut block) = self.session.scene().blend.get(i).cloned()
        {
            let (dx, dy) = (f64::from(drag.delta.x), f64::from(drag.delta.y));
            let [x0, y0, x1, y1] = block.rect;
            block.rect = match grab {
                Grab::Move => {
                    let dx = dx.clamp(-x0, 1.0 - x1);
                    let dy = dy.clamp(-y0, 1.0 - y1);
                    [x0 + dx, y0 + dy, x1 + dx, y1 + dy]
                }
                Grab::Resize => {
                    let min = 4.0 / self.session.scene().size.max(8) as f64;
                    [
                        x0,
                        y0,
                        (x1 + dx).clamp(x0 + min, 1.0),
                        (y1 + dy).clamp(y0 + min, 1.0),
                    ]
                }
            };
            // Applied as the pointer moves; the run and the undo step wait for the release.
            self.edit(Edit::SetBlock { index: i, block });
        }
        if drag.finished {
            self.blend.grab = None;
        }
    }
}

impl StrahlerApp {
    /// What the DEM panel asked for ([`DemPanel`](super::panels::DemPanel)).
    pub(super) fn dem_action(&mut self, ctx: &egui::Context, action: DemAction) {
        match action {
            DemAction::Upload => upload(self),
            DemAction::Remove => {
                self.blend.dem = None;
                self.automation.update(|s| s.dem = None);
            }
            DemAction::Open(path) => self.open_dem(ctx, &path),
            DemAction::Reread(z_range) => {
                self.blend.z_range = z_range;
                if let Some(loaded) = self.blend.dem.take() {
                    let bytes = loaded.bytes.as_ref().clone();
                    self.load_dem(ctx, &loaded.name, bytes);
                }
            }
            DemAction::FillVoids => self.fill_dem_voids(ctx),
            DemAction::ExtractFeatures => self.extract_features(ctx),
            DemAction::CompareNetworks => self.compare_networks(ctx),
            DemAction::Window(window) => self.blend.selection = window,
            DemAction::Place => self.place_selection(),
            DemAction::Select(block) => self.blend.selected = block,
        }
    }

    /// Reads a DEM from a path typed on a native build, with the command line's checks: a
    /// regular file, its size bounded by its header (a pipe or a 3 GB file is refused before
    /// it is read).
    fn open_dem(&mut self, ctx: &egui::Context, path: &std::path::Path) {
        match crate::dem::format::read_file(path, ReadLimits::default()) {
            Ok(bytes) => {
                let name = path.to_string_lossy().into_owned();
                self.load_dem(ctx, &name, bytes);
            }
            Err(err) => self.set_error_at(
                super::Place::Dem,
                format!("cannot read {}: {err}", path.display()),
            ),
        }
    }
}

/// What the DEM panel reads: the DEM and its jobs, the window, the scene's blocks, the tool,
/// the section's error and the blend stage's summary.
pub(super) fn dem_view<'a>(
    blend: &'a BlendState,
    session: &'a super::session::Session,
    tool: Tool,
    messages: &'a super::Messages,
) -> DemView<'a> {
    let dem = blend.dem.as_ref().map(|loaded| DemInfo {
        name: &loaded.name,
        width: loaded.dem.field.width(),
        height: loaded.dem.field.height(),
        range: loaded.range,
        voids: loaded.voids,
        cell_size: loaded.dem.georef.cell_size(),
        crs: loaded.dem.georef.crs_label(),
        needs_range: matches!(
            Format::from_name(&loaded.name),
            Some(Format::Png | Format::R16)
        ),
        preview: loaded.preview.as_ref().map(egui::TextureHandle::id),
        window: blend.selection,
    });
    DemView {
        scene: session.scene(),
        dem,
        fill: blend.fill_job.as_ref().map(|j| (j.progress(), j.message())),
        features: (blend.features_job.as_ref()).map(|j| (j.progress(), j.message())),
        networks: blend.networks.view(session.output().is_some()),
        tool,
        selected: blend.selected,
        error: (messages.error_at == super::Place::Dem)
            .then_some(messages.error.as_deref())
            .flatten(),
        summary: blend.summary.as_deref(),
    }
}

/// Opens the file picker (web) whose file arrives as a `LoadDem` command (button or U).
pub(super) fn upload(app: &mut StrahlerApp) {
    #[cfg(target_arch = "wasm32")]
    {
        let accept = ".tif,.tiff,.hgt,.asc,.png,.r16,.raw";
        let check = super::files::check_elevation_file;
        let load = |name, bytes| super::Command::LoadDem { name, bytes };
        let place = super::Place::Dem;
        if let Err(err) = super::files::pick_into(&app.automation, accept, check, place, load) {
            app.set_error_at(place, err);
        }
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        app.messages.notice =
            Some("Type the DEM's path below and press Open, or drop the file".into());
    }
}
