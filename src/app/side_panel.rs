//! The left panel, in the order of the work: the document, the main choices (Start), the
//! drawing tools, the run, the map's layers and each stage's section; under Advanced
//! (folded) the paper's parameters, the diffusion's settings and the compute check.

use egui::RichText;

use super::StrahlerApp;
use super::panels::{DocumentAction, DocumentView};

pub(super) fn show(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    egui::Panel::left("pipeline")
        .resizable(true)
        .default_size(290.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.add_space(6.0);
                ui.heading("Strahler");
                ui.label(RichText::new("Hydrology-based terrain sandbox").weak());
                document(ui, app);
                ui.separator();
                sections(ui, app);
                ui.separator();
                if let Some(action) = app.panels.document.export_button(ui) {
                    app.act(&ui.ctx().clone(), action);
                }
                ui.separator();
                advanced(ui, app);
            });
        });
}

/// The sections in the order of the work: the main choices and the drawing tools first,
/// then what the map shows, the run, and each stage after the design (erosion, style,
/// detail and its mask, real terrain). Each panel is given what it reads; their actions are
/// applied once they are all drawn.
fn sections(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    let scene = app.session.scene();
    let run = app.session.settings();
    let output = app.session.output();
    let panels = &mut app.panels;
    let mut actions = panels.start.show(ui, scene, run);
    ui.separator();
    actions.extend(panels.rivers.show(ui, scene, app.canvas.tool));
    ui.separator();
    let report = super::panels::SolverReport {
        job: app.session.job().map(|j| (j.progress(), j.message())),
        summaries: &app.summaries,
    };
    actions.extend(panels.solver.show(ui, scene, run, &report));
    ui.separator();
    let eroded = app.canvas.map.has_erosion_layers();
    super::layers::section(ui, &mut app.canvas.layers, eroded);
    ui.separator();
    let erosion = output.and_then(|o| o.report.erosion.as_ref());
    actions.extend(panels.erosion.show(ui, scene, erosion));
    ui.separator();
    let dem = app
        .blend
        .dem
        .as_ref()
        .map(|l| (l.name.as_str(), &l.dem.field));
    actions.extend(panels.style.show(ui, scene, dem));
    ui.separator();
    actions.extend(panels.detail.show(ui, scene));
    let mask = super::detail::mask_view(&app.canvas, &app.messages, &app.summaries);
    actions.extend(panels.mask.show(ui, &mask));
    let ctx = ui.ctx().clone();
    for action in actions {
        app.act(&ctx, action);
    }
    ui.separator();
    let dem = super::blend::dem_view(&app.blend, &app.session, app.canvas.tool, &app.messages);
    let mut actions = app.panels.dem.show(ui, &dem);
    ui.separator();
    let run = app.session.settings();
    let realism = app.session.output().and_then(|o| o.report.realism.as_ref());
    actions.extend(app.panels.realism.show(ui, run, realism));
    for action in actions {
        app.act(&ctx, action);
    }
}

/// Folded at first: the design's parameters (the paper's), the diffusion's settings and
/// the compute check.
fn advanced(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    egui::CollapsingHeader::new(RichText::new("Advanced").strong())
        .id_salt("advanced")
        .show(ui, |ui| {
            let scene = app.session.scene();
            let run = app.session.settings();
            let mut actions = app.panels.terrain.show(ui, scene);
            ui.separator();
            actions.extend(app.panels.solver.show_settings(ui, scene, run));
            ui.separator();
            let report = super::panels::CheckReport {
                running: app.check.job.is_some(),
                result: app.check.result.as_ref(),
            };
            actions.extend(app.panels.check.show(ui, &report));
            let ctx = ui.ctx().clone();
            for action in actions {
                app.act(&ctx, action);
            }
        });
}

/// The document's row (undo, redo, save, open) with the last error and the passing notice
/// under it.
fn document(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    let view = DocumentView {
        can_undo: app.session.can_undo(),
        can_redo: app.session.can_redo(),
        can_open: cfg!(target_arch = "wasm32"),
        error: app.messages.error.as_deref(),
        notice: app.messages.notice.as_deref(),
    };
    let actions = app.panels.document.show(ui, &view);
    let ctx = ui.ctx().clone();
    for action in actions {
        app.act(&ctx, action);
    }
}

impl StrahlerApp {
    /// Carries out what the document's row asked for.
    pub(super) fn document_action(&mut self, action: DocumentAction) {
        match action {
            DocumentAction::Undo => self.undo(),
            DocumentAction::Redo => self.redo(),
            DocumentAction::Save => self.save_scene(),
            DocumentAction::Open => self.pick_scene(),
            DocumentAction::DismissNotice => self.messages.notice = None,
            DocumentAction::Export => self.export.dialog.open = true,
        }
    }

    /// Saves the scene as JSON: a download in the browser, a file in the working directory
    /// natively.
    fn save_scene(&mut self) {
        let json = self.scene().to_json();
        let name = format!(
            "{}.json",
            super::files::free_stem("strahler-scene", &[".json"])
        );
        match super::files::save(&name, "application/json", json.as_bytes()) {
            Ok(said) => self.messages.notice = Some(format!("Scene {said}")),
            Err(err) => self.set_error(err),
        }
    }

    /// The browser's file picker for a scene; the file arrives as `Command::OpenScene`.
    #[cfg(target_arch = "wasm32")]
    fn pick_scene(&mut self) {
        let check = super::files::check_scene_file;
        let open = |name, bytes| super::Command::OpenScene { name, bytes };
        let place = super::Place::Top;
        if let Err(err) = super::files::pick_into(&self.automation, ".json", check, place, open) {
            self.set_error(err);
        }
    }

    /// Natively a scene is opened by dropping it on the map (or `strahler generate`).
    #[cfg(not(target_arch = "wasm32"))]
    fn pick_scene(&mut self) {}
}
