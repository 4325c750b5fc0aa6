//! The Rivers section: the drawing tools, each river's phi and depth, and the sketch's counts.

use egui::{DragValue, RichText};

use super::Action;
use crate::app::map_view::Tool;
use crate::scene::{Edit, Scene};

/// The Rivers section (it keeps no state of its own).
#[derive(Default)]
pub struct RiversPanel;

impl RiversPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, scene: &Scene, tool: Tool) -> Vec<Action> {
        let mut actions = Vec::new();
        ui.label(RichText::new("Rivers").strong()).on_hover_text(
            "Each stroke grows a Tokunaga river network (seed paper 000, Sec. IV): press at \
             the estuary and drag upstream in the flow direction.",
        );
        let mut picked = tool;
        ui.horizontal_wrapped(|ui| {
            ui.selectable_value(&mut picked, Tool::Pan, "Pan (P)");
            ui.selectable_value(&mut picked, Tool::River, "Draw river (R)");
            ui.selectable_value(&mut picked, Tool::Select, "Select (S)")
                .on_hover_text(
                    "Click a river, sketch line or peak; drag to move it; Delete removes it",
                );
        });
        ui.horizontal_wrapped(|ui| {
            ui.label("Sketch:").on_hover_text(
                "Sketched features (seed paper 003) become extra constraints: ridges (drag), \
                 valleys (drag from the mouth upwards) and peaks (click). Heights follow eq. 4.",
            );
            ui.selectable_value(&mut picked, Tool::Ridge, "Ridge (D)");
            ui.selectable_value(&mut picked, Tool::Valley, "Valley (V)");
            ui.selectable_value(&mut picked, Tool::Peak, "Peak (K)");
        });
        if picked != tool {
            actions.push(Action::Tool(picked));
        }
        for (index, drawn) in scene.rivers.iter().enumerate() {
            let mut stroke = *drawn;
            ui.horizontal(|ui| {
                ui.label(format!("#{}", index + 1));
                let label = ui.label("φ").on_hover_text(
                    "Generator index phi (1 to 6): higher grows more feather-like networks \
                     (Table 1).",
                );
                ui.add(DragValue::new(&mut stroke.phi).range(1..=6))
                    .labelled_by(label.id);
                let label = ui
                    .label("depth")
                    .on_hover_text("MaxDepth of eq. 3 (1 to 16).");
                ui.add(DragValue::new(&mut stroke.depth).range(1..=16))
                    .labelled_by(label.id);
                if ui
                    .small_button("x")
                    .on_hover_text("Delete this river")
                    .clicked()
                {
                    actions.push(Action::Edit(Edit::RemoveRiver(index)));
                }
            });
            if stroke != *drawn {
                actions.push(Action::Edit(Edit::SetRiver { index, stroke }));
            }
        }
        if scene.rivers.is_empty() {
            ui.label(RichText::new("No river yet: choose Draw river and drag on the map.").weak());
        } else if ui.button("Delete all rivers").clicked() {
            actions.push(Action::Edit(Edit::ClearRivers));
        }
        let sketch = &scene.sketch;
        let counts = (
            sketch.ridges.len(),
            sketch.valleys.len(),
            sketch.peaks.len(),
        );
        if counts != (0, 0, 0) {
            ui.horizontal(|ui| {
                ui.label(format!(
                    "Sketch: {} ridges, {} valleys, {} peaks",
                    counts.0, counts.1, counts.2
                ));
                if ui.button("Delete sketch").clicked() {
                    actions.push(Action::Edit(Edit::ClearSketch));
                }
            });
        }
        actions
    }
}
