//! The compute check (under Advanced): runs the same diffusion problems on the CPU and on
//! the GPU and says whether they agree.

use egui::RichText;

use super::Action;
use crate::diffusion::selftest::SelfTest;

/// Largest difference, as a fraction of the height range, at which the two backends agree
/// (the Jacobi results are bit-identical; multigrid agrees to about 1e-6).
pub const AGREEMENT: f32 = 1e-5;

/// The compute check (it keeps no state of its own: the app runs the check).
#[derive(Default)]
pub struct CheckPanel;

/// What the section shows: whether a check runs, and the last one's result.
pub struct CheckReport<'a> {
    pub running: bool,
    pub result: Option<&'a Result<SelfTest, String>>,
}

impl CheckPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, report: &CheckReport<'_>) -> Vec<Action> {
        ui.label(RichText::new("Compute check").strong())
            .on_hover_text(
                "Runs the same diffusion problem on the CPU and on the GPU and compares the \
                 results.",
            );
        let mut actions = Vec::new();
        ui.add_enabled_ui(!report.running, |ui| {
            if ui.button("Compare CPU and GPU").clicked() {
                actions.push(Action::CompareBackends);
            }
        });
        match report.result {
            None => {}
            Some(Err(err)) => {
                ui.colored_label(ui.visuals().error_fg_color, format!("Check failed: {err}"));
            }
            Some(Ok(test)) => result(ui, test),
        }
        actions
    }
}

/// The last check's numbers and verdict.
fn result(ui: &mut egui::Ui, test: &SelfTest) {
    ui.label(format!(
        "CPU: {:.0} ms, checksum {}",
        test.cpu.millis, test.cpu.checksum
    ));
    match (&test.gpu, test.relative_diff) {
        (Some(gpu), Some(rel)) => {
            ui.label(format!("GPU: {:.0} ms", gpu.millis));
            let verdict = if rel <= AGREEMENT { "agree" } else { "DIFFER" };
            ui.label(format!(
                "CPU and GPU {verdict}: max difference {rel:.2e} of the height range"
            ));
        }
        _ => {
            ui.label("No GPU compute on this path: CPU only.");
        }
    }
}
