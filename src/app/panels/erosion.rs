//! The Erosion section: stream-power erosion with uplift and hillslope processes (the
//! scene's `erosion`): on or off, its parameters in physical units (folded; the preset is
//! the Start section's terrain type), the before/after toggle and the last run's report.

use egui::{DragValue, RichText};

use super::Action;
use crate::erosion::{Border, ErosionReport, ErosionSettings, Relief};
use crate::scene::{Edit, Scene};

/// The Erosion section; it owns the before/after toggle.
#[derive(Default)]
pub struct ErosionPanel {
    /// Show the terrain before erosion (the design) on the map.
    pub show_before: bool,
}

impl ErosionPanel {
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        report: Option<&ErosionReport>,
    ) -> Vec<Action> {
        ui.label(RichText::new("Erosion").strong()).on_hover_text(
            "Fluvial erosion by the stream-power law dh/dt = U - K A^m S^n with hillslope \
             diffusion (Braun and Willett 2013). The drawn rivers are the base level: they keep \
             their heights and the land around them is carved into valleys and ridges.",
        );
        let current = &scene.erosion;
        let mut on = current.is_some();
        ui.horizontal(|ui| {
            ui.checkbox(&mut on, "Erode the terrain");
            if current.is_some() {
                ui.toggle_value(&mut self.show_before, "Show before")
                    .on_hover_text("Show the terrain before erosion (the design) on the map");
            }
        });
        if on != current.is_some() {
            return vec![Action::Edit(Edit::SetErosion(
                on.then(ErosionSettings::default),
            ))];
        }
        let Some(before) = current else {
            return Vec::new();
        };
        let mut edited = before.clone();
        egui::CollapsingHeader::new(format!("Parameters ({})", before.preset))
            .id_salt("erosion parameters")
            .show(ui, |ui| settings(ui, &mut edited));
        if edited != *before
            && edited.preset == before.preset
            && ErosionSettings::preset(&edited.preset).as_ref() != Some(&edited)
        {
            edited.preset = "custom".into();
        }
        if let Some(report) = report {
            ui.label(format!(
                "Eroded in {:.0} ms{}: {}, up to {:.0} m lowered; {:.1}% of river cells drain \
                 along the river{}",
                report.millis,
                if report.in_worker {
                    " (in a Web Worker)"
                } else {
                    ""
                },
                net_change(report.mean_depth_m),
                report.max_depth_m,
                report.drainage.river_fraction * 100.0,
                report.drainage.branches_note()
            ));
        }
        if edited == *before {
            return Vec::new();
        }
        vec![Action::Edit(Edit::SetErosion(Some(edited)))]
    }
}

/// The land's mean change in words: uplift can outpace incision, raising the land on
/// average while the rivers cut their valleys.
fn net_change(mean_lowered_m: f64) -> String {
    if mean_lowered_m < 0.0 {
        format!("the land rose {:.1} m on average", -mean_lowered_m)
    } else {
        format!("the land fell {mean_lowered_m:.1} m on average")
    }
}

/// The parameters, on a copy of the scene's settings (the preset is the Start section's
/// terrain type).
fn settings(ui: &mut egui::Ui, e: &mut ErosionSettings) {
    egui::Grid::new("erosion settings")
        .num_columns(2)
        .show(ui, |ui| {
            let row = |ui: &mut egui::Ui, name: &str, tip: &str, value: &mut f64, range: std::ops::RangeInclusive<f64>, speed: f64| {
                let label = ui.label(name).on_hover_text(tip);
                ui.add(DragValue::new(value).range(range).speed(speed))
                    .labelled_by(label.id);
                ui.end_row();
            };
            let label = ui.label("Relief from").on_hover_text("Physics: the rock rises evenly and the stream-power law sets the heights of the branches the rivers grew (their courses kept), so the relief follows uplift against erodibility. Design: every river stays at its drawn heights and the uplift follows the design. A sketch of peaks or ridges always holds the design's heights.");
            ui.horizontal(|ui| {
                for relief in [Relief::Physics, Relief::Design] {
                    ui.selectable_value(&mut e.relief, relief, relief.name());
                }
            })
            .response
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Border").on_hover_text("Open: the map is a window on a larger land; where the rivers do not reach a stretch of the edge, a stream leaves the map there, so the high ground stands on the divides inside the map. Closed: every drop reaches the drawn rivers (an island, a basin), the edge is a divide and the land farthest from the rivers, often the corners, stands highest.");
            ui.horizontal(|ui| {
                for border in [Border::Open, Border::Closed] {
                    ui.selectable_value(&mut e.border, border, border.name());
                }
            })
            .response
            .labelled_by(label.id);
            ui.end_row();
            row(ui, "Uplift (m/kyr)", "Rock uplift U in metres per thousand years: everywhere alike with the relief from the physics; from the design, where the design stands highest above its rivers, 15% of it beside the rivers, levelling off towards the highest ground.", &mut e.uplift_m_per_kyr, 0.0..=100.0, 0.05);
            row(ui, "Uplift contrast", "Ranges and basins: how many times faster the rock rises in the fastest-rising ranges than in the slowest basins (1 = alike everywhere). The ranges stand high and rugged, the basins low and gentle; the drawn rivers run in basins unless the sketch draws peaks or ridges.", &mut e.uplift_contrast, 1.0..=100.0, 0.1);
            row(ui, "Ranges (m)", "The size of the ranges and basins: the wavelength of the largest, in metres. A map much smaller lies within one range or one basin.", &mut e.uplift_scale_m, 100.0..=1.0e7, 100.0);
            row(ui, "Erodibility K", "K of the stream-power law, in m^(1-2m) per year: how fast water cuts rock. Larger K carves deeper valleys.", &mut e.erodibility, 0.0..=1.0, 1e-6);
            row(ui, "m", "Drainage-area exponent m (m/n is the concavity of river profiles, 0.3 to 0.7 in real rivers).", &mut e.m, 0.1..=1.0, 0.01);
            row(ui, "n", "Slope exponent n (1 for most bedrock rivers).", &mut e.n, 0.5..=2.0, 0.01);
            row(ui, "Diffusivity (m²/yr)", "Hillslope diffusivity kappa: soil creep that rounds ridges and fills hollows.", &mut e.diffusivity, 0.0..=10.0, 0.01);
            row(ui, "Years", "Simulated time.", &mut e.years, 0.0..=1.0e8, 1000.0);
            row(ui, "Rock contrast", "Rock hardness: how many times faster the softest rock erodes than the hardest (1 = uniform rock). Soft rock is dissected finely, hard rock stands in broader massifs.", &mut e.rock_contrast, 1.0..=100.0, 0.1);
            row(ui, "Rock patches (m)", "The size of the patches of harder and softer rock, in metres.", &mut e.rock_patch_m, 10.0..=1.0e6, 10.0);
            row(ui, "Rock beds (m)", "Layered rock: the thickness of one hard bed and the soft bed above it, in metres (0 = no beds). Rivers cutting through the beds leave cliffs at the hard beds and benches at the soft ones: mesas, buttes, stepped canyon walls.", &mut e.strata_m, 0.0..=10_000.0, 1.0);
            row(ui, "Bed contrast", "How many times faster the soft beds erode than the hard ones (1 = no beds).", &mut e.strata_contrast, 1.0..=100.0, 0.1);
            row(ui, "Strength spread", "How much the rock's strength varies under the talus angle: each cell's steepest slope is the talus slope times a factor between 1 - spread and 1 (0 = one angle everywhere, whose failed flanks are planes; more gives chutes and ribs).", &mut e.strength_spread, 0.0..=0.9, 0.01);
            row(ui, "Soft rock strength", "How steep the soft rock of the rock patches stands: its threshold slope is this share of the hard rock's (1 = as steep). Soft units wear to gentle country, hard ones stand as steep massifs.", &mut e.soft_rock_strength, 0.1..=1.0, 0.01);
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
}
