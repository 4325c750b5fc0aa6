//! The Detail section's settings: wavelet levels of detail (seed paper 001) on top of the
//! terrain: new levels, scope and window. (The mask tools beside them paint the map.)

use egui::{ComboBox, RichText, Slider};

use super::Action;
use crate::scene::{Edit, Scene};
use crate::wavelet::synthesis;

/// The Detail section's settings (it keeps no state of its own).
#[derive(Default)]
pub struct DetailPanel;

impl DetailPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, scene: &Scene) -> Vec<Action> {
        ui.label(RichText::new("Detail (wavelet LoD)").strong())
            .on_hover_text(
                "New levels of detail from the terrain's own wavelet statistics (seed paper \
                 001): each level doubles the resolution with Gaussian detail whose variance \
                 continues the fitted line of log2 variance per level. The mask removes that \
                 detail where it is white.",
            );
        let size = scene.size;
        let mut detail = scene.detail.clone();
        egui::Grid::new("detail settings")
            .num_columns(2)
            .show(ui, |ui| {
                ui.label("New levels");
                let out = synthesis::output_len(size, detail.levels);
                ui.add(Slider::new(&mut detail.levels, 0..=3).text(format!("-> {out} x {out}")));
                ui.end_row();
                let label = ui.label("Scope").on_hover_text(
                    "Global (GSA): one line per band for the whole map. Local (LSA): a line per \
                     location from a window of coefficients, so rough and smooth areas keep their \
                     character; calibrated so each level's energy follows the global line. Local \
                     (paper): eq. 8 exactly as written, each location's raw fit.",
                );
                ComboBox::from_id_salt("detail scope")
                    .selected_text(detail.scope.clone())
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut detail.scope, "global".to_owned(), "global");
                        ui.selectable_value(&mut detail.scope, "local".to_owned(), "local");
                        ui.selectable_value(
                            &mut detail.scope,
                            "local-paper".to_owned(),
                            "local (paper)",
                        );
                    })
                    .response
                    .labelled_by(label.id);
                ui.end_row();
                if detail.scope.starts_with("local") {
                    let label = ui.label("Window");
                    let mut half = (detail.window / 2) as u32;
                    ui.add(Slider::new(&mut half, 0..=8).custom_formatter(|v, _| {
                        let w = 2 * v as usize + 1;
                        format!("{w} x {w}")
                    }))
                    .labelled_by(label.id);
                    detail.window = 2 * half as usize + 1;
                    ui.end_row();
                }
            });
        if detail == scene.detail {
            return Vec::new();
        }
        vec![Action::Edit(Edit::SetDetail(detail))]
    }
}
