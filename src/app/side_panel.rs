//! The left panel: pipeline controls. For now the diffusion stage and the compute check;
//! each later stage (rivers, ridges, detail, blending) adds its section here.

use egui::{ComboBox, DragValue, ProgressBar, RichText};

use super::StrahlerApp;
use crate::compute::BackendChoice;
use crate::diffusion::{Method, MultigridParams};

/// Grid sizes offered for the fill (square, cells per side).
pub const SIZES: [usize; 6] = [128, 256, 512, 1024, 2048, 4096];

/// The diffusion controls' values.
#[derive(Clone, Debug, PartialEq)]
pub struct FillSettings {
    pub size: usize,
    /// Multigrid (converged) or the paper's fixed count of Jacobi sweeps.
    pub multigrid: bool,
    /// Residual tolerance of multigrid, as a fraction of the height range.
    pub tolerance: f32,
    /// Sweeps of the Jacobi method.
    pub sweeps: u32,
    pub backend: BackendChoice,
}

impl Default for FillSettings {
    fn default() -> Self {
        Self {
            size: 512,
            multigrid: true,
            tolerance: MultigridParams::default().tolerance,
            sweeps: 5500,
            backend: BackendChoice::Auto,
        }
    }
}

impl FillSettings {
    pub fn method(&self) -> Method {
        if self.multigrid {
            Method::Multigrid(MultigridParams {
                tolerance: self.tolerance,
                ..Default::default()
            })
        } else {
            Method::Jacobi {
                sweeps: self.sweeps,
            }
        }
    }
}

pub(super) fn show(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    egui::Panel::left("pipeline")
        .resizable(true)
        .default_size(270.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.add_space(6.0);
                ui.heading("Strahler");
                ui.label(RichText::new("Hydrology-based terrain sandbox").weak());
                ui.separator();
                diffusion_section(ui, app);
                ui.separator();
                selftest_section(ui, app);
            });
        });
}

fn diffusion_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Diffusion").strong()).on_hover_text(
        "Laplace diffusion (seed paper 000, eqs. 6-7): every free cell relaxes to the mean \
         of its four neighbours while the fixed cells (valley and summits) keep their heights.",
    );
    let ctx = ui.ctx().clone();
    egui::Grid::new("fill settings")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("Grid size");
            ComboBox::from_id_salt("grid size")
                .selected_text(format!("{0} x {0}", app.settings.size))
                .show_ui(ui, |ui| {
                    for size in SIZES {
                        ui.selectable_value(
                            &mut app.settings.size,
                            size,
                            format!("{size} x {size}"),
                        );
                    }
                });
            ui.end_row();

            ui.label("Solver").on_hover_text(
                "Multigrid solves eq. 7 to convergence in a few cycles. Jacobi runs the paper's \
                 fixed number of sweeps (5500), far from converged on large grids.",
            );
            ui.horizontal(|ui| {
                ui.selectable_value(&mut app.settings.multigrid, true, "multigrid");
                ui.selectable_value(&mut app.settings.multigrid, false, "Jacobi");
            });
            ui.end_row();

            if app.settings.multigrid {
                ui.label("Tolerance").on_hover_text(
                    "Stop when one more Jacobi sweep would move no cell by more than this \
                     fraction of the height range (and the estimated error is small too).",
                );
                ui.add(
                    DragValue::new(&mut app.settings.tolerance)
                        .range(1e-8..=1e-2)
                        .speed(1e-7)
                        .custom_formatter(|v, _| format!("{v:.0e}")),
                );
            } else {
                ui.label("Sweeps")
                    .on_hover_text("Jacobi iterations of eq. 7 (the paper runs 5500).");
                ui.add(
                    DragValue::new(&mut app.settings.sweeps)
                        .range(0..=100_000)
                        .speed(20),
                );
            }
            ui.end_row();

            ui.label("Compute on");
            ComboBox::from_id_salt("backend")
                .selected_text(app.settings.backend.label())
                .show_ui(ui, |ui| {
                    for choice in BackendChoice::ALL {
                        ui.selectable_value(&mut app.settings.backend, choice, choice.label());
                    }
                });
            ui.end_row();
        });

    ui.horizontal(|ui| {
        if ui.button("Fill terrain").clicked() {
            app.start_fill(&ctx);
        }
        if let Some(job) = &app.fill_job
            && ui.button("Cancel").clicked()
        {
            job.cancel();
        }
    });
    if let Some(job) = &app.fill_job {
        ui.add(ProgressBar::new(job.progress()).text(job.message()));
    }
    if let Some((size, run)) = &app.last_run {
        ui.label(format!(
            "Last fill: {size} x {size}, {} on the {} in {:.0} ms",
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
        ui.label(format!(
            "{how}, residual {:.1e} of the range ({state}); heights {:.0} to {:.0} m",
            run.relative_residual, run.min, run.max
        ));
    }
    if let Some(err) = &app.error {
        ui.colored_label(ui.visuals().error_fg_color, err);
    }
}

fn selftest_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Compute check").strong())
        .on_hover_text(
            "Runs the same diffusion on the CPU and on the GPU and compares the results.",
        );
    let ctx = ui.ctx().clone();
    ui.add_enabled_ui(app.selftest_job.is_none(), |ui| {
        if ui.button("Compare CPU and GPU").clicked() {
            app.start_selftest(&ctx);
        }
    });
    match &app.selftest {
        None => {}
        Some(Err(err)) => {
            ui.colored_label(ui.visuals().error_fg_color, format!("Check failed: {err}"));
        }
        Some(Ok(test)) => {
            ui.label(format!(
                "CPU: {:.0} ms, checksum {}",
                test.cpu.millis, test.cpu.checksum
            ));
            match (&test.gpu, test.relative_diff) {
                (Some(gpu), Some(rel)) => {
                    ui.label(format!("GPU: {:.0} ms", gpu.millis));
                    let verdict = if rel <= 1e-5 { "agree" } else { "DIFFER" };
                    ui.label(format!(
                        "CPU and GPU {verdict}: max difference {:.2e} of the height range",
                        rel
                    ));
                }
                _ => {
                    ui.label("No GPU compute on this path: CPU only.");
                }
            }
        }
    }
}
