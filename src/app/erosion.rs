//! The Erosion section: stream-power erosion with uplift and hillslope processes (the
//! scene's `erosion`), its presets and parameters in physical units, the before/after toggle
//! and the drainage-area and erosion-depth layers.

use egui::{ComboBox, DragValue, RichText};

use super::StrahlerApp;
use crate::erosion::{ErosionSettings, PRESETS};
use crate::scene::Edit;

/// The Erosion section of the side panel. Edits go to the scene; the side panel notices the
/// change and re-runs the pipeline (the cache keeps the hydrology).
pub(super) fn section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Erosion").strong()).on_hover_text(
        "Fluvial erosion by the stream-power law dh/dt = U - K A^m S^n with hillslope \
         diffusion (Braun and Willett 2013). The drawn rivers are the base level: they keep \
         their heights and the land around them is carved into valleys and ridges.",
    );
    let current = app.session.scene().erosion.clone();
    let mut on = current.is_some();
    ui.horizontal(|ui| {
        ui.checkbox(&mut on, "Erode the terrain");
        if current.is_some() {
            ui.toggle_value(&mut app.canvas.show_before_erosion, "Show before")
                .on_hover_text("Show the terrain before erosion (the design) on the map");
        }
    });
    if on != current.is_some() {
        app.edit(Edit::SetErosion(on.then(ErosionSettings::default)));
        return;
    }
    let Some(before) = current else {
        return;
    };
    let mut edited = before.clone();
    let e = &mut edited;
    egui::Grid::new("erosion settings")
        .num_columns(2)
        .show(ui, |ui| {
            let label = ui.label("Preset");
            ComboBox::from_id_salt("erosion preset")
                .selected_text(e.preset.clone())
                .show_ui(ui, |ui| {
                    for name in PRESETS {
                        if ui.selectable_label(e.preset == *name, *name).clicked()
                            && let Some(p) = ErosionSettings::preset(name)
                        {
                            *e = p;
                        }
                    }
                })
                .response
                .labelled_by(label.id);
            ui.end_row();
            let row = |ui: &mut egui::Ui, name: &str, tip: &str, value: &mut f64, range: std::ops::RangeInclusive<f64>, speed: f64| {
                let label = ui.label(name).on_hover_text(tip);
                ui.add(DragValue::new(value).range(range).speed(speed))
                    .labelled_by(label.id);
                ui.end_row();
            };
            row(ui, "Uplift (m/kyr)", "Rock uplift U in metres per thousand years where the design stands highest above its rivers; 15% of it beside the rivers, levelling off towards the highest ground.", &mut e.uplift_m_per_kyr, 0.0..=100.0, 0.05);
            row(ui, "Erodibility K", "K of the stream-power law, in m^(1-2m) per year: how fast water cuts rock. Larger K carves deeper valleys.", &mut e.erodibility, 0.0..=1.0, 1e-6);
            row(ui, "m", "Drainage-area exponent m (m/n is the concavity of river profiles, 0.3 to 0.7 in real rivers).", &mut e.m, 0.1..=1.0, 0.01);
            row(ui, "n", "Slope exponent n (1 for most bedrock rivers).", &mut e.n, 0.5..=2.0, 0.01);
            row(ui, "Diffusivity (m²/yr)", "Hillslope diffusivity kappa: soil creep that rounds ridges and fills hollows.", &mut e.diffusivity, 0.0..=10.0, 0.01);
            row(ui, "Years", "Simulated time.", &mut e.years, 0.0..=1.0e8, 1000.0);
            row(ui, "Rock contrast", "Rock hardness: how many times faster the softest rock erodes than the hardest (1 = uniform rock). Soft rock is dissected finely, hard rock stands in broader massifs.", &mut e.rock_contrast, 1.0..=100.0, 0.1);
            row(ui, "Rock patches (m)", "The size of the patches of harder and softer rock, in metres.", &mut e.rock_patch_m, 10.0..=1.0e6, 10.0);
            let label = ui.label("Steps").on_hover_text("Time steps (the implicit scheme is stable at any step; more steps follow the evolution more closely).");
            ui.add(DragValue::new(&mut e.steps).range(1..=1000)).labelled_by(label.id);
            ui.end_row();
            let label = ui.label("River banks").on_hover_text("Cells on each side of a river kept at their designed height with it.");
            ui.add(DragValue::new(&mut e.river_band).range(0..=16).suffix(" cells")).labelled_by(label.id);
            ui.end_row();
            let mut talus = e.talus_deg.is_some();
            let label = ui
                .label("Talus angle")
                .on_hover_text("Thermal erosion: scree slides where slopes exceed this angle, and (on the CPU) what stands steeper after each step fails, as landslides do.");
            ui.horizontal(|ui| {
                ui.checkbox(&mut talus, "scree");
                let mut deg = e.talus_deg.unwrap_or(35.0);
                ui.add_enabled(
                    talus,
                    DragValue::new(&mut deg).range(10.0..=60.0).suffix("°"),
                )
                .labelled_by(label.id);
                e.talus_deg = talus.then_some(deg);
            });
            ui.end_row();
        });
    if *e != before
        && e.preset == before.preset
        && ErosionSettings::preset(&e.preset).as_ref() != Some(e)
    {
        e.preset = "custom".into();
    }
    if edited != before {
        app.edit(Edit::SetErosion(Some(edited)));
    }
    if let Some(report) = app.output().and_then(|o| o.report.erosion.as_ref()) {
        ui.label(format!(
            "Eroded in {:.0} ms: mean {:.1} m, up to {:.0} m lowered; {:.1}% of river cells drain along the river",
            report.millis,
            report.mean_depth_m,
            report.max_depth_m,
            report.drainage.river_fraction * 100.0
        ));
    }
}

/// The Realism section: the measures `strahler analyze` gives a real DEM, for the terrain on
/// the map (when turned on, each run measures it: about 0.1 s at 512 x 512).
pub(super) fn realism_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Realism").strong()).on_hover_text(
        "Slope distribution, harmonic cells, geomorphons, drainage density, the wavelet \
         spectral slope and bump, the grid-direction index, straight channel runs, flats and \
         the hypsometric integral: compare them with `strahler analyze DEM --compare REAL`.",
    );
    let mut measure = app.session.settings().measure_realism;
    ui.checkbox(&mut measure, "Measure each terrain");
    if measure != app.session.settings().measure_realism {
        // The next run (every stage from the cache) measures, or stops measuring.
        app.session.settings_mut().measure_realism = measure;
    }
    if !measure {
        return;
    }
    match app.output().and_then(|o| o.report.realism.as_ref()) {
        Some(report) => {
            for line in report.lines() {
                ui.label(line);
            }
        }
        None => {
            ui.label(RichText::new("Measured with the next terrain").weak());
        }
    }
}

/// The Style section: detail from a real terrain's spectrum added into the terrain's own
/// levels where it is smoother (`crate::wavelet::style`): a bundled style, or one measured on
/// the DEM uploaded in the DEM panel.
pub(super) fn style_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    use crate::scene::StyleSettings;
    use crate::wavelet::style::STYLES;
    ui.label(RichText::new("Style from real terrain").strong())
        .on_hover_text(
            "Adds detail where the terrain is smoother than a real DEM's wavelet spectrum \
             (seed paper 001's gamma per band), kept off the rivers and the painted mask.",
        );
    let mut style = app.session.scene().style.clone();
    let current = style.as_ref().map_or("none".to_owned(), |s| s.name.clone());
    let mut chosen: Option<Option<StyleSettings>> = None;
    let label = ui.label("Style");
    ComboBox::from_id_salt("style")
        .selected_text(current.clone())
        .show_ui(ui, |ui| {
            if ui.selectable_label(current == "none", "none").clicked() {
                chosen = Some(None);
            }
            for (name, source, _) in STYLES {
                if ui
                    .selectable_label(current == *name, *name)
                    .on_hover_text(*source)
                    .clicked()
                {
                    chosen = Some(StyleSettings::bundled(name));
                }
            }
        })
        .response
        .labelled_by(label.id);
    if let Some(chosen) = chosen {
        app.edit(Edit::SetStyle(chosen));
        return;
    }
    if let Some(loaded) = &app.blend.dem
        && ui
            .button("Style from the uploaded DEM")
            .on_hover_text(
                "Measure the spectrum of the DEM in the DEM panel (fill its voids first)",
            )
            .clicked()
    {
        match crate::wavelet::style::measure(&loaded.dem.field) {
            Ok(gamma) => {
                let measured = StyleSettings {
                    name: format!("from {}", loaded.name),
                    gamma,
                    strength: 1.0,
                };
                app.edit(Edit::SetStyle(Some(measured)));
                return;
            }
            Err(err) => app.set_error(format!("Style: {err}")),
        }
    }
    let before = style.clone();
    if let Some(style) = style.as_mut() {
        let label = ui
            .label("Strength")
            .on_hover_text("Fraction of the missing detail variance added (0 to 2).");
        ui.add(egui::Slider::new(&mut style.strength, 0.0..=2.0))
            .labelled_by(label.id);
        ui.label(
            RichText::new(format!(
                "gamma H {:.2}, V {:.2}, D {:.2}",
                style.gamma[0], style.gamma[1], style.gamma[2]
            ))
            .weak(),
        );
    }
    if style != before {
        app.edit(Edit::SetStyle(style));
    }
}
