//! The Detail section and stage of the app: wavelet levels of detail (seed paper 001) on top
//! of the generated terrain, and the energy-reduction mask the user paints, derives from the
//! rivers, imports and exports.
//!
//! The settings and the mask live in the scene; a change of either re-runs the pipeline,
//! whose stage cache recomputes only detail and what follows, never the hydrology.

use super::StrahlerApp;
use super::automation::DetailStatus;
use super::canvas::ImportTarget;
use super::map_view::Tool;
use super::panels::{MaskAction, MaskView};
use crate::pipeline::Output;
use crate::scene::{Edit, MaskKind};
use crate::wavelet::Mask;

impl StrahlerApp {
    /// The mask, resampled to the `size x size` terrain when the size changed.
    pub(super) fn fit_mask(&mut self, size: usize) {
        if self.canvas.mask.width() != size || self.canvas.mask.height() != size {
            let values = self.canvas.mask.resampled(size, size);
            if let Ok(mask) = Mask::from_values(size, size, values) {
                self.canvas.mask = mask;
            }
        }
    }

    /// The energy-reduction mask (terrain-sized).
    pub fn mask(&self) -> &Mask {
        &self.canvas.mask
    }

    /// Replaces the mask (e.g. imported), resampled to the terrain, and re-runs the detail.
    pub fn set_mask(&mut self, ctx: &egui::Context, mask: Mask) {
        self.canvas.mask = mask;
        self.fit_mask(self.session.scene().size);
        self.mask_changed(ctx);
    }

    /// After any mask edit: refresh the overlay, store the mask in the scene (the pipeline
    /// re-runs the stage that reads it and what follows; the cache keeps the stages before).
    fn mask_changed(&mut self, ctx: &egui::Context) {
        self.canvas.map.set_mask(ctx, Some(&self.canvas.mask));
        let kind = self.canvas.mask_kind;
        self.edit(Edit::SetMask(kind, Some(self.canvas.mask.clone())));
    }

    /// Paints `kind` from now on: its mask comes from the scene (clear when it has none).
    pub fn choose_mask(&mut self, kind: MaskKind) {
        if kind == self.canvas.mask_kind {
            return;
        }
        self.canvas.mask_kind = kind;
        self.scene_replaced();
    }

    /// Which mask the brush paints.
    pub fn mask_kind(&self) -> MaskKind {
        self.canvas.mask_kind
    }

    /// Paints one piece of a brush stroke (map units).
    pub(super) fn paint_mask(&mut self, ctx: &egui::Context, a: egui::Pos2, b: egui::Pos2) {
        let d = |p: egui::Pos2| glam::DVec2::new(f64::from(p.x), f64::from(p.y));
        self.canvas
            .mask
            .paint_segment(d(a), d(b), &self.panels.mask.brush);
        self.canvas.map.set_mask(ctx, Some(&self.canvas.mask));
    }

    /// The brush stroke ended: the new mask takes effect.
    pub(super) fn finish_mask_stroke(&mut self, ctx: &egui::Context) {
        self.mask_changed(ctx);
        let scene = self.session.scene();
        if self.canvas.mask_kind != MaskKind::Detail {
            if scene.erosion.is_none() {
                self.messages.notice = Some(
                    "Uplift and hard rock shape the land through erosion: turn on a terrain \
                     type (Start) to see them"
                        .into(),
                );
            }
        } else if scene.detail.levels == 0 && scene.style.is_none() {
            // Nothing on the map changes yet: say what the mask is for.
            self.messages.notice = Some(
                "The mask calms the synthetic detail where it is white: add new levels in \
                 Detail (or a Style) to see it"
                    .into(),
            );
        }
    }

    /// Publishes the detail stage of a finished run (or its absence).
    pub(super) fn show_detail_status(&mut self, output: &Output) {
        let Some(d) = &output.detail else {
            self.automation.update(|s| s.detail = None);
            self.summaries.detail = None;
            return;
        };
        let status = DetailStatus {
            levels: self.session.scene().detail.levels,
            width: d.field.width(),
            height: d.field.height(),
            backend: d.backend.to_owned(),
            millis: d.millis,
            rms_unmasked: d.rms.unmasked,
            rms_masked: d.rms.masked,
            mask_cells: self
                .canvas
                .mask
                .values()
                .iter()
                .filter(|&&v| v > 0.0)
                .count(),
        };
        self.summaries.detail = Some(format!(
            "Detail: {} x {} on the {} in {:.0} ms; RMS {:.2} m{}",
            status.width,
            status.height,
            d.backend.to_uppercase(),
            d.millis,
            d.rms.unmasked,
            d.rms
                .masked
                .map(|m| format!(", {m:.2} m under the mask"))
                .unwrap_or_default()
        ));
        self.automation.update(|s| s.detail = Some(status));
    }

    /// The river networks as a starting mask (rivers stay smooth).
    pub(super) fn mask_from_rivers(&mut self, ctx: &egui::Context) {
        let Some(output) = self.session.output() else {
            self.set_error_at(
                super::Place::Mask,
                "Generate a terrain first: the mask follows its rivers.".into(),
            );
            return;
        };
        let grown = &output.hydrology.rivers;
        let orders: Vec<Vec<u32>> = grown
            .iter()
            .map(|r| crate::river::stats::strahler_orders(&r.network))
            .collect();
        let rivers: Vec<_> = grown
            .iter()
            .zip(&orders)
            .map(|(r, o)| (&r.network, o.as_slice()))
            .collect();
        let n = self.session.scene().size;
        let radius = (n as f32 / 256.0).max(1.0);
        let mask = Mask::from_rivers(n, n, &rivers, radius);
        match mask {
            Ok(mask) => self.set_mask(ctx, mask),
            Err(err) => self.set_error_at(super::Place::Mask, err.to_string()),
        }
    }

    /// Reads a file dropped on the window (asynchronously: browsers only read files so).
    pub(super) fn start_import(&mut self, ctx: &egui::Context, file: egui::DroppedFileHandle) {
        let name = file
            .path()
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "the dropped file".to_owned());
        let is_png = name.to_ascii_lowercase().ends_with(".png");
        let target = if self.canvas.tool == Tool::Mask && is_png {
            ImportTarget::Mask
        } else if name.to_ascii_lowercase().ends_with(".json") {
            ImportTarget::Scene
        } else {
            ImportTarget::Dem
        };
        if target == ImportTarget::Dem && crate::dem::format::Format::from_name(&name).is_none() {
            self.set_error(format!(
                "{name}: drop an elevation file (.tif, .hgt, .asc, .png, .r16) to upload it as \
                 a DEM, or a greyscale PNG with the mask tool active to import a mask"
            ));
            return;
        }
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "import",
            move |_job| async move {
                #[cfg(target_arch = "wasm32")]
                let bytes = file.bytes_async().await;
                #[cfg(not(target_arch = "wasm32"))]
                let bytes = read_dropped(file.path(), target);
                (name, target, bytes)
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.canvas.import_job = Some(handle),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    /// A PNG dropped on the window becomes the mask.
    pub(super) fn import_mask(&mut self, ctx: &egui::Context, name: &str, bytes: &[u8]) {
        match Mask::from_png(bytes, crate::dem::ReadLimits::default()) {
            Ok(mask) => {
                self.set_mask(ctx, mask);
                self.canvas.layers.mask = true;
                self.messages.notice = Some(format!("Mask imported from {name}"));
            }
            Err(err) => self.set_error_at(super::Place::Mask, format!("{name}: {err}")),
        }
    }
}

impl StrahlerApp {
    /// What the mask tools asked for ([`MaskPanel`](super::panels::MaskPanel)).
    pub(super) fn mask_action(&mut self, ctx: &egui::Context, action: MaskAction) {
        match action {
            MaskAction::Paint(kind) => self.choose_mask(kind),
            MaskAction::Show(on) => self.canvas.layers.mask = on,
            MaskAction::FromRivers => {
                self.mask_from_rivers(ctx);
                self.canvas.layers.mask = true;
            }
            MaskAction::Clear => {
                let size = self.session.scene().size;
                match Mask::new(size, size) {
                    Ok(mask) => self.set_mask(ctx, mask),
                    Err(err) => self.set_error_at(super::Place::Mask, err.to_string()),
                }
            }
            MaskAction::Export => self.export_mask(),
            MaskAction::Import => self.pick_mask_file(),
        }
    }

    /// Saves the mask being painted as a PNG (downloads it in the page).
    fn export_mask(&mut self) {
        let saved = self
            .canvas
            .mask
            .to_png()
            .map_err(|e| e.to_string())
            .and_then(|png| {
                let stem = super::files::free_stem("strahler-mask", &[".png"]);
                super::files::save(&format!("{stem}.png"), "image/png", &png)
            });
        match saved {
            Ok(where_to) => self.messages.notice = Some(format!("Mask {where_to}")),
            Err(err) => self.set_error_at(super::Place::Mask, err),
        }
    }

    /// Opens the page's file picker for a mask PNG; what is read arrives as a command.
    fn pick_mask_file(&mut self) {
        #[cfg(target_arch = "wasm32")]
        {
            let check = super::files::check_elevation_file;
            let import = |name, bytes| super::Command::ImportMask { name, bytes };
            let place = super::Place::Mask;
            if let Err(err) =
                super::files::pick_into(&self.automation, ".png", check, place, import)
            {
                self.set_error_at(place, err);
            }
        }
        #[cfg(not(target_arch = "wasm32"))]
        {
            self.messages.notice =
                Some("Drop a PNG on the map with the mask tool active to import it".into());
        }
    }
}

/// What the mask tools read from the map, the messages and the last run.
pub(super) fn mask_view<'a>(
    canvas: &super::Canvas,
    messages: &'a super::Messages,
    summaries: &'a super::RunSummaries,
) -> MaskView<'a> {
    MaskView {
        tool: canvas.tool,
        shown: canvas.layers.mask,
        kind: canvas.mask_kind,
        error: (messages.error_at == super::Place::Mask)
            .then_some(messages.error.as_deref())
            .flatten(),
        summary: summaries.detail.as_deref(),
    }
}

/// A file dropped on the native window, read with the command line's checks: a regular file
/// (a dropped pipe would block the app), its length within what its kind may take.
#[cfg(not(target_arch = "wasm32"))]
fn read_dropped(path: &std::path::Path, target: ImportTarget) -> Result<Vec<u8>, String> {
    let read = match target {
        ImportTarget::Scene => {
            crate::dem::read_bounded(path, crate::scene::MAX_SCENE_BYTES, "a scene file may take")
        }
        ImportTarget::Mask | ImportTarget::Dem => {
            crate::dem::format::read_file(path, crate::dem::ReadLimits::default())
        }
    };
    read.map_err(|e| e.to_string())
}
