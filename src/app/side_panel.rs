//! The left panel, in the order of the work: the document, the main choices (Start), the
//! drawing tools, the run, the map's layers and each stage's section; under Advanced
//! (folded) the paper's parameters, the diffusion's settings and the compute check.

use egui::RichText;

use super::StrahlerApp;

pub(super) fn show(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    egui::Panel::left("pipeline")
        .resizable(true)
        .default_size(290.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.add_space(6.0);
                ui.heading("Strahler");
                ui.label(RichText::new("Hydrology-based terrain sandbox").weak());
                document_row(ui, app);
                messages(ui, app);
                ui.separator();
                sections(ui, app);
                ui.separator();
                if ui
                    .button("Export heightmap... (E)")
                    .on_hover_text("PNG 16-bit, GeoTIFF, RAW R16, ESRI ASCII, SRTM .hgt or OBJ")
                    .clicked()
                {
                    app.export.dialog.open = true;
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

/// The last error and the passing notice, in one place under the document's buttons, each
/// with a button to dismiss it.
fn messages(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    if let Some(err) = app.messages.error.clone() {
        ui.horizontal_wrapped(|ui| {
            ui.colored_label(ui.visuals().error_fg_color, err);
            if ui.small_button("Dismiss").clicked() {
                app.messages.error = None;
            }
        });
    }
    if let Some(text) = app.messages.notice.clone() {
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new(text).weak());
            if ui.small_button("Dismiss").clicked() {
                app.messages.notice = None;
            }
        });
    }
}

/// Undo, redo, save and open: the document.
fn document_row(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.horizontal_wrapped(|ui| {
        if ui
            .add_enabled(app.session.can_undo(), egui::Button::new("Undo"))
            .on_hover_text("Ctrl+Z")
            .clicked()
        {
            app.undo();
        }
        if ui
            .add_enabled(app.session.can_redo(), egui::Button::new("Redo"))
            .on_hover_text("Ctrl+Shift+Z or Ctrl+Y")
            .clicked()
        {
            app.redo();
        }
        if ui
            .button("Save scene")
            .on_hover_text("The whole document as JSON (rivers, sketch, parameters, mask, blocks)")
            .clicked()
        {
            let json = app.scene().to_json();
            let name = format!(
                "{}.json",
                super::files::free_stem("strahler-scene", &[".json"])
            );
            match super::files::save(&name, "application/json", json.as_bytes()) {
                Ok(said) => app.messages.notice = Some(format!("Scene {said}")),
                Err(err) => app.set_error(err),
            }
        }
        #[cfg(target_arch = "wasm32")]
        if ui
            .button("Open scene...")
            .on_hover_text("A scene saved before; or drop the .json file on the map")
            .clicked()
        {
            let automation = app.automation.clone();
            let check = super::files::check_scene_file;
            if let Err(err) = super::files::pick_file(".json", check, move |name, read| {
                automation.push(match read {
                    Ok(bytes) => super::Command::OpenScene { name, bytes },
                    Err(message) => super::Command::FileRefused {
                        name,
                        message,
                        place: super::Place::Top,
                    },
                });
            }) {
                app.set_error(err);
            }
        }
    });
}
