//! The mask tools beside the Detail section: the brush that paints the map, what it paints
//! (calm detail, uplift, hard rock; each mask is kept in the scene), and the mask's buttons.
//! The panel owns the brush; painting itself happens on the map.

use egui::{DragValue, RichText, Slider};

use super::Action;
use crate::app::map_view::Tool;
use crate::erosion::{HARD_ROCK, UPLIFT_GAIN};
use crate::scene::MaskKind;
use crate::wavelet::Brush;

/// What the mask tools ask of the app (besides picking the tool).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaskAction {
    /// Paint this kind of mask from now on.
    Paint(MaskKind),
    /// Show or hide the mask on the map.
    Show(bool),
    /// Start from the river network.
    FromRivers,
    Clear,
    /// Save the mask being painted as a PNG.
    Export,
    /// Pick a PNG to paint with (the page's file picker).
    Import,
}

/// What the mask tools read from the app.
pub struct MaskView<'a> {
    pub tool: Tool,
    /// The mask layer is on.
    pub shown: bool,
    pub kind: MaskKind,
    /// The last error, when an action taken here caused it.
    pub error: Option<&'a str>,
    /// What the detail stage did in the last run.
    pub summary: Option<&'a str>,
}

/// The mask tools and their brush.
#[derive(Default)]
pub struct MaskPanel {
    pub brush: Brush,
}

impl MaskPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, view: &MaskView<'_>) -> Vec<Action> {
        let mut actions = Vec::new();
        let (mut tool, mut shown) = (view.tool, view.shown);
        ui.horizontal_wrapped(|ui| {
            ui.selectable_value(&mut tool, Tool::Mask, "Paint mask (M)");
            ui.checkbox(&mut shown, "show mask");
        });
        if tool != view.tool {
            actions.push(Action::Tool(tool));
        }
        if shown != view.shown {
            actions.push(Action::Mask(MaskAction::Show(shown)));
        }
        let kind = kind_menu(ui, view.kind);
        if kind != view.kind {
            actions.push(Action::Mask(MaskAction::Paint(kind)));
        }
        actions.extend(super::error_row(ui, view.error));
        if view.tool == Tool::Mask {
            self.brush_settings(ui, view.kind);
        }
        ui.horizontal_wrapped(|ui| {
            if ui
                .button("Mask from rivers")
                .on_hover_text("Start from the river network: wider for higher Strahler orders.")
                .clicked()
            {
                actions.push(Action::Mask(MaskAction::FromRivers));
            }
            if ui.button("Clear mask").clicked() {
                actions.push(Action::Mask(MaskAction::Clear));
            }
            if ui.button("Export mask PNG").clicked() {
                actions.push(Action::Mask(MaskAction::Export));
            }
        });
        ui.horizontal_wrapped(|ui| {
            if cfg!(target_arch = "wasm32") && ui.button("Import mask PNG...").clicked() {
                actions.push(Action::Mask(MaskAction::Import));
            }
            ui.label(RichText::new("or drop a PNG on the map with the mask tool active").weak());
        });
        if let Some(text) = view.summary {
            ui.label(text);
        }
        actions
    }

    fn brush_settings(&mut self, ui: &mut egui::Ui, kind: MaskKind) {
        let brush = &mut self.brush;
        egui::Grid::new("brush settings")
            .num_columns(2)
            .show(ui, |ui| {
                let label = ui.label("Brush size");
                ui.add(
                    DragValue::new(&mut brush.radius)
                        .range(1.0..=256.0)
                        .suffix(" cells"),
                )
                .labelled_by(label.id);
                ui.end_row();
                let label = ui.label("Hardness");
                ui.add(Slider::new(&mut brush.hardness, 0.0..=1.0))
                    .labelled_by(label.id);
                ui.end_row();
                let label = ui.label("Grey value").on_hover_text(white_means(kind));
                ui.add(Slider::new(&mut brush.value, 0.0..=1.0))
                    .labelled_by(label.id);
                ui.end_row();
                let label = ui.label("Eraser");
                ui.checkbox(&mut brush.eraser, "").labelled_by(label.id);
                ui.end_row();
            });
    }
}

/// The Paints menu: which mask the brush paints.
fn kind_menu(ui: &mut egui::Ui, current: MaskKind) -> MaskKind {
    let mut kind = current;
    ui.horizontal(|ui| {
        let label = ui.label("Paints").on_hover_text(format!(
            "What the mask does where it is white: calm the synthetic detail, raise the land \
             faster (ranges rise there, up to {} times the uplift), or make the rock harder \
             (up to {HARD_ROCK} times: it stands as massifs). Each is kept in the scene.",
            UPLIFT_GAIN + 1.0
        ));
        egui::ComboBox::from_id_salt("mask kind")
            .selected_text(kind_words(kind))
            .show_ui(ui, |ui| {
                for k in MaskKind::ALL {
                    ui.selectable_value(&mut kind, k, kind_words(k));
                }
            })
            .response
            .labelled_by(label.id);
    });
    kind
}

/// What a kind of mask does, as the Paints menu says it.
pub fn kind_words(kind: MaskKind) -> &'static str {
    match kind {
        MaskKind::Detail => "calm detail",
        MaskKind::Uplift => "uplift (ranges)",
        MaskKind::HardRock => "hard rock",
    }
}

/// What a grey value of 1 does on a mask of `kind`.
fn white_means(kind: MaskKind) -> String {
    match kind {
        MaskKind::Detail => "1 (white) removes all synthetic detail.".to_owned(),
        MaskKind::Uplift => format!(
            "1 (white) lifts the land {} times as fast.",
            UPLIFT_GAIN + 1.0
        ),
        MaskKind::HardRock => format!("1 (white) makes the rock {HARD_ROCK} times harder."),
    }
}
