//! The bottom bar: the active compute path in plain words, job progress, cursor readout.

use egui::RichText;

use super::StrahlerApp;
use crate::compute::ComputePath;

pub(super) fn show(ui: &mut egui::Ui, app: &StrahlerApp) {
    egui::Panel::bottom("status").show(ui, |ui| {
        ui.horizontal(|ui| {
            let path = app.compute_path();
            let label = ui.label(RichText::new(path.to_string()).strong());
            label.on_hover_ui(|ui| compute_details(ui, path));
            if let Some(job) = app
                .session
                .job()
                .map(|j| (j.name(), j.progress(), j.message(), j.time_left()))
                .or_else(|| {
                    let j = app.check.job.as_ref()?;
                    Some((j.name(), j.progress(), j.message(), j.time_left()))
                })
                .or_else(|| {
                    let j = &app.export.running.first()?.job;
                    Some((j.name(), j.progress(), j.message(), j.time_left()))
                })
            {
                let (name, progress, message, left) = job;
                ui.separator();
                // A still bar, not a spinner: a spinner repaints every frame, which on the
                // CPU path takes time from the job itself. The bar only moves forward
                // (`jobs`), with the stage and about how long is left.
                ui.add(egui::ProgressBar::new(progress).desired_width(60.0));
                let left = left.map_or(String::new(), |d| {
                    format!(", about {} left", crate::jobs::time_words(d))
                });
                ui.label(format!("{name} {:.0}%: {message}{left}", progress * 100.0));
            }
            ui.separator();
            let tool = match app.canvas.tool {
                super::Tool::Pan => "Tool: pan (P)",
                super::Tool::River => "Tool: draw river (R) - press at the estuary, drag upstream",
                super::Tool::Ridge => "Tool: sketch ridge (D) - drag along the crest",
                super::Tool::Valley => "Tool: sketch valley (V) - drag from its mouth upwards",
                super::Tool::Peak => "Tool: sketch peak (K) - click",
                super::Tool::Mask => "Tool: paint mask (M) - drag; white keeps the detail smooth",
                super::Tool::Select => {
                    "Tool: select (S) - click an item, drag to move it, Delete removes it"
                }
                super::Tool::Block => {
                    "Tool: move blocks (B) - drag a block; drag its corner to resize"
                }
            };
            ui.label(tool);
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.label(RichText::new(format!("v{}", crate::VERSION)).weak());
                if let Some(hover) = app.canvas.hover {
                    ui.separator();
                    let height = hover
                        .height
                        .map(|h| format!("{h:.1} m"))
                        .unwrap_or_else(|| "-".to_owned());
                    ui.monospace(format!(
                        "x {:.4}  y {:.4}  {height}",
                        hover.map.x, hover.map.y
                    ));
                }
            });
        });
    });
}

fn compute_details(ui: &mut egui::Ui, path: &ComputePath) {
    match path {
        ComputePath::Gpu { context } => {
            let a = &context.adapter;
            let c = &context.caps;
            ui.label(format!(
                "Adapter: {} ({}, {})",
                a.name, a.backend, a.device_type
            ));
            ui.label(format!(
                "Largest storage buffer: {} MiB",
                c.max_storage_bytes() >> 20
            ));
            ui.label(format!(
                "Largest square field in one binding: {0} x {0} (the diffusion solvers tile \
                 larger ones)",
                c.max_square_field()
            ));
            if context.is_software() {
                ui.label(
                    "A software rasteriser: with Compute on auto, erosion and the wavelet \
                     statistics run on the CPU, which is faster here (choose GPU to run every \
                     stage on it).",
                );
            }
        }
        ComputePath::Cpu { reason } => {
            ui.label(format!("Computing on the CPU because {reason}."));
            ui.label("Everything works; large terrains take longer.");
        }
    }
}
