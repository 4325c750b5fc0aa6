//! The Style section: detail from a real terrain's spectrum added into the terrain's own
//! levels where it is smoother (`crate::wavelet::style`): a bundled style, or one measured on
//! the DEM uploaded in the DEM panel.

use egui::{ComboBox, RichText};

use super::Action;
use crate::heightfield::Heightfield;
use crate::scene::{Edit, Scene, StyleSettings};
use crate::wavelet::style::STYLES;

/// The Style section (it keeps no state of its own).
#[derive(Default)]
pub struct StylePanel;

impl StylePanel {
    /// `dem`: the uploaded DEM's name and heights, to measure a style on.
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        dem: Option<(&str, &Heightfield)>,
    ) -> Vec<Action> {
        ui.label(RichText::new("Style from real terrain").strong())
            .on_hover_text(
                "Adds detail where the terrain is smoother than a real DEM's wavelet spectrum \
                 (seed paper 001's gamma per band), kept off the rivers and the painted mask.",
            );
        let mut style = scene.style.clone();
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
            return vec![Action::Edit(Edit::SetStyle(chosen))];
        }
        if let Some((name, field)) = dem
            && ui
                .button("Style from the uploaded DEM")
                .on_hover_text(
                    "Measure the spectrum of the DEM in the DEM panel (fill its voids first)",
                )
                .clicked()
        {
            return vec![match crate::wavelet::style::measure(field) {
                Ok(gamma) => Action::Edit(Edit::SetStyle(Some(StyleSettings {
                    name: format!("from {name}"),
                    gamma,
                    strength: 1.0,
                }))),
                Err(err) => Action::Error(format!("Style: {err}")),
            }];
        }
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
        if style == scene.style {
            return Vec::new();
        }
        vec![Action::Edit(Edit::SetStyle(style))]
    }
}
