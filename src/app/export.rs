//! The export dialog: the terrain on the map in a format engines and GIS tools read, at a
//! size preset, with an optional Y flip and height scale. In the browser the file downloads;
//! natively it is saved in the working directory. PNG and RAW also get their sidecar JSON
//! (height range, cell size), since their samples are normalised.

use egui::{ComboBox, DragValue, RichText};

use super::StrahlerApp;
use crate::dem::format::{Format, SIZE_PRESETS};
use crate::pipeline::{HeightmapExport, encode_heightmap};

/// What the dialog remembers between openings.
pub struct ExportDialog {
    pub open: bool,
    pub format: Format,
    /// `None` = the terrain's own size.
    pub size: Option<usize>,
    pub flip_y: bool,
    pub z_scale: f32,
    /// Also download the skeleton's layers (rivers, ridges, constraints) as PNGs.
    pub layers: bool,
}

impl Default for ExportDialog {
    fn default() -> Self {
        Self {
            open: false,
            format: Format::Png,
            size: None,
            flip_y: false,
            z_scale: 1.0,
            layers: false,
        }
    }
}

/// Shows the dialog when open.
pub(super) fn window(ctx: &egui::Context, app: &mut StrahlerApp) {
    let mut open = app.export.open;
    // Escape closes the dialog, as users expect of one.
    if open && ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, egui::Key::Escape)) {
        app.export.open = false;
        return;
    }
    let preview = app.showing_preview();
    let mut save = false;
    egui::Window::new("Export heightmap")
        .open(&mut open)
        .collapsible(false)
        .resizable(false)
        .show(ctx, |ui| {
            let d = &mut app.export;
            let native = app.canvas.map.field().map(|f| f.width()).unwrap_or(0);
            egui::Grid::new("export settings")
                .num_columns(2)
                .show(ui, |ui| {
                    let label = ui.label("Format");
                    ComboBox::from_id_salt("export format")
                        .selected_text(d.format.label())
                        .show_ui(ui, |ui| {
                            for f in Format::EXPORTS {
                                ui.selectable_value(&mut d.format, f, f.label());
                            }
                        })
                        .response
                        .labelled_by(label.id);
                    ui.end_row();
                    ui.label("Size");
                    let label = |s: Option<usize>| match s {
                        None => format!("as on the map ({native} x {native})"),
                        Some(n) => format!("{n} x {n}"),
                    };
                    ComboBox::from_id_salt("export size")
                        .selected_text(label(d.size))
                        .show_ui(ui, |ui| {
                            ui.selectable_value(&mut d.size, None, label(None));
                            for n in SIZE_PRESETS {
                                ui.selectable_value(&mut d.size, Some(n), label(Some(n)));
                            }
                        });
                    ui.end_row();
                    ui.label("Flip Y")
                        .on_hover_text("Rows bottom-up, as Unity reads RAW files (PNG and RAW)");
                    ui.add_enabled(
                        matches!(d.format, Format::Png | Format::R16),
                        egui::Checkbox::without_text(&mut d.flip_y),
                    );
                    ui.end_row();
                    let label = ui.label("Height scale");
                    ui.add(
                        DragValue::new(&mut d.z_scale)
                            .range(0.001..=1000.0)
                            .speed(0.01),
                    )
                    .labelled_by(label.id);
                    ui.end_row();
                    ui.label("Layers").on_hover_text(
                        "Also rivers.png (Strahler order), ridges.png and constraints.png, \
                         8-bit, at the generated terrain's size",
                    );
                    ui.checkbox(&mut d.layers, "");
                    ui.end_row();
                });
            if preview {
                ui.label(
                    RichText::new(format!(
                        "The map shows a {native} x {native} preview: generate the full size \
                         first (Diffusion section) to export {0} x {0}.",
                        app.session.scene().size
                    ))
                    .weak(),
                );
            }
            if d.format == Format::Obj && d.size.unwrap_or(native) > 2049 {
                ui.label(
                    RichText::new("OBJ meshes are limited to 2049 x 2049: pick a smaller size")
                        .weak(),
                );
            }
            // Enter downloads too, so the dialog works from the keyboard (E, then Enter).
            save = ui.button("Download (Enter)").clicked()
                || ui.input(|i| i.key_pressed(egui::Key::Enter));
        });
    app.export.open = open;
    if save {
        export_now(app);
    }
}

fn export_now(app: &mut StrahlerApp) {
    let Some(output) = app.session.output() else {
        app.set_error("Nothing to export yet: draw a river first.".into());
        return;
    };
    let d = &app.export;
    let export = HeightmapExport {
        format: d.format,
        size: d.size,
        flip_y: d.flip_y,
        z_scale: d.z_scale * app.session.scene().vertical_scale as f32,
    };
    let result = encode_heightmap(&output.field, output.cell_m, &export).and_then(|out| {
        // A heightmap and its sidecar share a stem no file beside them has yet.
        let ext = format!(".{}", d.format.extension());
        let stem = super::files::free_stem("strahler-heightmap", &[&ext, ".json"]);
        let mut said = super::files::save(&format!("{stem}{ext}"), d.format.mime(), &out.bytes)?;
        if let Some(json) = &out.sidecar {
            super::files::save(&format!("{stem}.json"), "application/json", json.as_bytes())?;
            said.push_str(" and its .json");
        }
        if d.layers {
            for (name, png) in &output.layer_pngs()? {
                let stem = name.trim_end_matches(".png");
                let stem = super::files::free_stem(&format!("strahler-{stem}"), &[".png"]);
                super::files::save(&format!("{stem}.png"), "image/png", png)?;
            }
            said.push_str(" with the layers");
        }
        Ok(said)
    });
    match result {
        Ok(said) => app.messages.notice = Some(format!("Heightmap {said}")),
        Err(err) => app.set_error(format!("Export failed: {err}")),
    }
}
