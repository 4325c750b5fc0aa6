//! The Generate section (Generate / full size / Cancel, the job's bar and the last run's
//! numbers) and, under Advanced, the diffusion's settings: the solver and the backend (run
//! settings) and the post-filters (the scene's).

use egui::{ComboBox, DragValue, ProgressBar, RichText};

use super::Action;
use crate::app::canvas::RunSummaries;
use crate::app::session::{PREVIEW_SIZE, RunSettings};
use crate::compute::BackendChoice;
use crate::scene::{Edit, Scene};

/// The Generate section and the diffusion's settings (it keeps no state of its own).
#[derive(Default)]
pub struct SolverPanel;

/// What the section reports: the running job's progress and message, and the last run's
/// summaries.
pub struct Report<'a> {
    pub job: Option<(f32, String)>,
    pub summaries: &'a RunSummaries,
}

impl SolverPanel {
    /// The run: Generate, Generate full size, Cancel, the job's bar and the last run's
    /// numbers (the main flow, always in view).
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        run: &RunSettings,
        report: &Report<'_>,
    ) -> Vec<Action> {
        ui.label(RichText::new("Generate").strong()).on_hover_text(
            "Every edit regenerates the terrain by itself; Generate runs it again as it is.",
        );
        let mut actions = Vec::new();
        ui.horizontal_wrapped(|ui| {
            if ui.button("Generate terrain").clicked() {
                actions.push(Action::Generate);
            }
            let size = scene.size;
            if run.preview
                && size > PREVIEW_SIZE
                && ui
                    .button(format!("Generate full size ({size} x {size})"))
                    .clicked()
            {
                actions.push(Action::GenerateFullSize);
            }
            // Always there, so that nothing below moves when a job starts or ends.
            if ui
                .add_enabled(report.job.is_some(), egui::Button::new("Cancel"))
                .clicked()
            {
                actions.push(Action::Cancel);
            }
        });
        let (progress, message) = match &report.job {
            Some((progress, message)) => (*progress, message.as_str()),
            None => (0.0, "idle: an edit regenerates"),
        };
        ui.add(ProgressBar::new(progress).text(message));
        last_run(ui, report.summaries);
        actions
    }

    /// The diffusion's settings (advanced): the solver and the backend (run settings) and
    /// the post-filters (the scene's).
    pub fn show_settings(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        run: &RunSettings,
    ) -> Vec<Action> {
        ui.label(RichText::new("Diffusion").strong()).on_hover_text(
            "Laplace diffusion (seed paper 000, eqs. 6-7): every free cell relaxes to the mean \
             of its four neighbours while the skeleton's cells keep their heights.",
        );
        let mut actions = Vec::new();
        let mut solver = run.solver.clone();
        let mut post = scene.params.post;
        settings(ui, &mut solver, &mut post);
        if solver != run.solver {
            actions.push(Action::Settings(RunSettings {
                solver,
                ..run.clone()
            }));
        }
        if post != scene.params.post {
            let mut params = scene.params;
            params.post = post;
            actions.push(Action::Edit(Edit::SetParams(params)));
        }
        actions
    }
}

/// The solver's and the post-filters' widgets.
fn settings(
    ui: &mut egui::Ui,
    solver: &mut crate::app::SolverSettings,
    post: &mut crate::diffusion::PostFilter,
) {
    egui::Grid::new("fill settings")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("Solver").on_hover_text(
                "Multigrid solves eq. 7 to convergence in a few cycles. Jacobi runs the paper's \
                 fixed number of sweeps (5500), far from converged on large grids.",
            );
            ui.horizontal(|ui| {
                ui.selectable_value(&mut solver.multigrid, true, "multigrid");
                ui.selectable_value(&mut solver.multigrid, false, "Jacobi");
            });
            ui.end_row();

            if solver.multigrid {
                let label = ui.label("Tolerance").on_hover_text(
                    "Stop when one more Jacobi sweep would move no cell by more than this \
                     fraction of the height range (and the estimated error is small too).",
                );
                ui.add(
                    DragValue::new(&mut solver.tolerance)
                        .range(1e-8..=1e-2)
                        .speed(1e-7)
                        .custom_formatter(|v, _| format!("{v:.0e}")),
                )
                .labelled_by(label.id);
            } else {
                let label = ui
                    .label("Sweeps")
                    .on_hover_text("Jacobi iterations of eq. 7 (the paper runs 5500).");
                ui.add(
                    DragValue::new(&mut solver.sweeps)
                        .range(0..=100_000)
                        .speed(20),
                )
                .labelled_by(label.id);
            }
            ui.end_row();

            let label = ui.label("Smoothing").on_hover_text(
                "Gaussian smoothing of the filled terrain, sigma in cells (0 = off). Rivers and \
                 a margin around them are never touched, so they drain as designed.",
            );
            ui.add(
                DragValue::new(&mut post.smooth_sigma)
                    .range(0.0..=crate::diffusion::post::MAX_SIGMA)
                    .speed(0.05)
                    .suffix(" cells"),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Added fBm").on_hover_text(
                "Fractal Perlin noise added to the filled terrain (amplitude in metres; 0 = off), \
                 faded out near the rivers.",
            );
            ui.add(
                DragValue::new(&mut post.fbm_amplitude)
                    .range(0.0..=500.0)
                    .speed(0.2)
                    .suffix(" m"),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Compute on");
            ComboBox::from_id_salt("backend")
                .selected_text(solver.backend.label())
                .show_ui(ui, |ui| {
                    for choice in BackendChoice::ALL {
                        ui.selectable_value(&mut solver.backend, choice, choice.label());
                    }
                })
                .response
                .labelled_by(label.id);
            ui.end_row();
        });
}

/// The last run's numbers.
fn last_run(ui: &mut egui::Ui, summaries: &RunSummaries) {
    if let Some((size, run)) = &summaries.last_run {
        ui.label(format!(
            "Last terrain: {size} x {size}, {} on the {} in {:.0} ms",
            if run.method == "jacobi" {
                "Jacobi"
            } else {
                run.method
            },
            run.backend.to_uppercase(),
            run.millis
        ));
        let how = if run.method == "multigrid" {
            format!("{} cycles", run.cycles)
        } else {
            format!("{} sweeps", run.sweeps)
        };
        let state = if run.converged {
            "converged"
        } else {
            "NOT converged"
        };
        // `+ 0.0` turns a height rounded to -0 into 0.
        ui.label(format!(
            "{how}, residual {:.1e} of the range ({state}); heights {:.0} to {:.0} m",
            run.relative_residual,
            run.min.round() + 0.0,
            run.max.round() + 0.0
        ));
    }
    if let Some(text) = &summaries.terrain {
        ui.label(text);
    }
}
