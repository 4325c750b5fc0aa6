//! The bottom bar as a component: the compute path in plain words (its details on hover),
//! what the map shows (a coarse pass, a preview or the full size), the running job's one bar with its stage and the time left, the active tool's hint and
//! the height under the pointer. It reads a [`StatusInfo`] and asks for nothing.

use egui::RichText;

use crate::app::{Hover, Tool};
use crate::compute::ComputePath;

/// A running job as the bar shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct JobLine {
    pub name: String,
    /// The job's one bar, 0..1.
    pub progress: f32,
    pub message: String,
    pub left: Option<std::time::Duration>,
}

impl JobLine {
    /// "terrain 40%: eroding: step 3 of 20, about 12 s left".
    pub fn text(&self) -> String {
        let left = self.left.map_or(String::new(), |d| {
            format!(", about {} left", crate::jobs::time_words(d))
        });
        format!(
            "{} {:.0}%: {}{left}",
            self.name,
            self.progress * 100.0,
            self.message
        )
    }
}

/// What the bar shows this frame.
pub struct StatusInfo<'a> {
    pub path: &'a ComputePath,
    pub job: Option<JobLine>,
    /// The terrain on the map (which pass, which size) and the one coming.
    pub map: Option<crate::app::OnMap>,
    pub tool: Tool,
    pub hover: Option<Hover>,
    /// Where the page's heavy stages run (its Web Worker, or why not); `None` natively.
    pub worker: Option<String>,
}

/// The bottom bar (no state of its own).
#[derive(Default)]
pub struct StatusBar;

impl StatusBar {
    pub fn show(&mut self, ui: &mut egui::Ui, info: &StatusInfo<'_>) {
        ui.horizontal(|ui| {
            let label = ui.label(RichText::new(info.path.to_string()).strong());
            label.on_hover_ui(|ui| {
                compute_details(ui, info.path);
                if let Some(worker) = &info.worker {
                    ui.label(worker);
                }
            });
            if let Some(map) = &info.map {
                ui.separator();
                ui.label(map.words()).on_hover_text(
                    "An edit that changes the terrain shows a coarse one first, then the \
                     terrain at its own size; with Preview on, a map larger than the preview is \
                     generated at full size on demand (Generate section).",
                );
            }
            // The job's line: a still bar, not a spinner (a spinner repaints every frame,
            // which on the CPU path takes time from the job itself); it only moves forward
            // (`jobs`), with the stage and about how long is left. Its widgets are there in
            // every frame, hidden without a job: egui styles a widget it has not seen on its
            // second frame and asks for that frame at once, so a line appearing with each
            // new job cost an edit one more repaint before its coarse terrain could show
            // (120-210 ms each where the page is composited in software).
            let (shown, progress, text) = match &info.job {
                Some(job) => (true, job.progress, job.text()),
                None => (false, 0.0, String::new()),
            };
            ui.add_visible(shown, egui::Separator::default());
            ui.add_visible(shown, egui::ProgressBar::new(progress).desired_width(60.0));
            ui.add_visible(shown, egui::Label::new(text));
            ui.separator();
            ui.label(tool_hint(info.tool));
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.label(RichText::new(format!("v{}", crate::VERSION)).weak());
                if let Some(hover) = info.hover {
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
    }
}

/// What the active tool does, with its key.
pub fn tool_hint(tool: Tool) -> &'static str {
    match tool {
        Tool::Pan => "Tool: pan (P)",
        Tool::River => "Tool: draw river (R) - press at the estuary, drag upstream",
        Tool::Ridge => "Tool: sketch ridge (D) - drag along the crest",
        Tool::Valley => "Tool: sketch valley (V) - drag from its mouth upwards",
        Tool::Peak => "Tool: sketch peak (K) - click",
        Tool::Mask => "Tool: paint mask (M) - drag; white keeps the detail smooth",
        Tool::Select => "Tool: select (S) - click an item, drag to move it, Delete removes it",
        Tool::Block => "Tool: move blocks (B) - drag a block; drag its corner to resize",
    }
}

/// The compute path's details (on hover).
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
                    "A software rasteriser: with Compute on auto the terrain is computed on \
                     the CPU, which is faster here (choose GPU to run every stage on it).",
                );
            }
        }
        ComputePath::Cpu { reason } => {
            ui.label(format!("Computing on the CPU because {reason}."));
            ui.label("Everything works; large terrains take longer.");
        }
    }
}
