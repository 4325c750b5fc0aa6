//! The document's row at the top of the side panel: undo, redo, save and open, the last
//! error and the passing notice under them, and the Export button further down. It reads
//! what the session can do and returns [`DocumentAction`]s.

use egui::RichText;

use super::Action;

/// What the document's buttons ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DocumentAction {
    Undo,
    Redo,
    /// Save the scene as JSON (a download in the browser).
    Save,
    /// Pick a scene file to open (the browser's file picker).
    Open,
    /// Forget the notice shown.
    DismissNotice,
    /// Open the export dialog.
    Export,
}

/// What the document's row shows.
#[derive(Clone, Copy, Debug, Default)]
pub struct DocumentView<'a> {
    pub can_undo: bool,
    pub can_redo: bool,
    /// Whether this build can pick a file to open (the browser's picker; natively a scene
    /// is opened by dropping it on the map or from the command line).
    pub can_open: bool,
    pub error: Option<&'a str>,
    pub notice: Option<&'a str>,
}

/// The document's row; it keeps no state of its own.
#[derive(Default)]
pub struct DocumentPanel;

impl DocumentPanel {
    /// The buttons, then the error and the notice, each with its Dismiss button.
    pub fn show(&mut self, ui: &mut egui::Ui, view: &DocumentView<'_>) -> Vec<Action> {
        let mut asked = Vec::new();
        ui.horizontal_wrapped(|ui| {
            let buttons = [
                (view.can_undo, "Undo", "Ctrl+Z", DocumentAction::Undo),
                (
                    view.can_redo,
                    "Redo",
                    "Ctrl+Shift+Z or Ctrl+Y",
                    DocumentAction::Redo,
                ),
                (
                    true,
                    "Save scene",
                    "The whole document as JSON (rivers, sketch, parameters, mask, blocks)",
                    DocumentAction::Save,
                ),
            ];
            for (enabled, label, hint, action) in buttons {
                if ui
                    .add_enabled(enabled, egui::Button::new(label))
                    .on_hover_text(hint)
                    .clicked()
                {
                    asked.push(action);
                }
            }
            if view.can_open
                && ui
                    .button("Open scene...")
                    .on_hover_text("A scene saved before; or drop the .json file on the map")
                    .clicked()
            {
                asked.push(DocumentAction::Open);
            }
        });
        let mut actions: Vec<Action> = asked.into_iter().map(Action::Document).collect();
        actions.extend(super::error_row(ui, view.error));
        if let Some(text) = view.notice {
            ui.horizontal_wrapped(|ui| {
                ui.label(RichText::new(text).weak());
                if ui.small_button("Dismiss").clicked() {
                    actions.push(Action::Document(DocumentAction::DismissNotice));
                }
            });
        }
        actions
    }

    /// The button that opens the export dialog.
    pub fn export_button(&mut self, ui: &mut egui::Ui) -> Option<Action> {
        ui.button("Export heightmap... (E)")
            .on_hover_text("PNG 16-bit, GeoTIFF, RAW R16, ESRI ASCII, SRTM .hgt or OBJ")
            .clicked()
            .then_some(Action::Document(DocumentAction::Export))
    }
}
