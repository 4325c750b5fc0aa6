//! The left panel: the river tool and strokes, the terrain parameters (with the paper's
//! symbols in tooltips), the diffusion solver, and the compute check.

use egui::{ComboBox, DragValue, ProgressBar, RichText};

use super::StrahlerApp;
use super::map_view::Tool;
use crate::compute::BackendChoice;
use crate::diffusion::{Method, MultigridParams};
use crate::scene::Edit;

/// Grid sizes offered (square, cells per side).
pub const SIZES: [usize; 6] = [128, 256, 512, 1024, 2048, 4096];

/// How the diffusion stage solves and on what: run options, not part of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverSettings {
    /// Multigrid (converged) or the paper's fixed count of Jacobi sweeps.
    pub multigrid: bool,
    /// Residual tolerance of multigrid, as a fraction of the height range.
    pub tolerance: f32,
    /// Sweeps of the Jacobi method.
    pub sweeps: u32,
    pub backend: BackendChoice,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            multigrid: true,
            tolerance: MultigridParams::default().tolerance,
            sweeps: 5500,
            backend: BackendChoice::Auto,
        }
    }
}

impl SolverSettings {
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
        .default_size(290.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.add_space(6.0);
                ui.heading("Strahler");
                ui.label(RichText::new("Hydrology-based terrain sandbox").weak());
                document_row(ui, app);
                let eroded = app.canvas.map.has_erosion_layers();
                super::layers::section(ui, &mut app.canvas.layers, eroded);
                ui.separator();
                rivers_section(ui, app);
                ui.separator();
                terrain_section(ui, app);
                ui.separator();
                diffusion_section(ui, app);
                ui.separator();
                super::erosion::section(ui, app);
                ui.separator();
                super::erosion::style_section(ui, app);
                ui.separator();
                super::erosion::realism_section(ui, app);
                ui.separator();
                super::detail::section(ui, app);
                ui.separator();
                super::blend::section(ui, app);
                ui.separator();
                if ui
                    .button("Export heightmap... (E)")
                    .on_hover_text("PNG 16-bit, GeoTIFF, RAW R16, ESRI ASCII, SRTM .hgt or OBJ")
                    .clicked()
                {
                    app.export.open = true;
                }
                ui.separator();
                selftest_section(ui, app);
            });
        });
}

/// Undo, redo, save and open: the document.
fn document_row(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.horizontal_wrapped(|ui| {
        if ui
            .add_enabled(app.session.can_undo(), egui::Button::new("Undo"))
            .on_hover_text("Ctrl+Z")
            .clicked()
        {
            app.undo();
        }
        if ui
            .add_enabled(app.session.can_redo(), egui::Button::new("Redo"))
            .on_hover_text("Ctrl+Shift+Z or Ctrl+Y")
            .clicked()
        {
            app.redo();
        }
        if ui
            .button("Save scene")
            .on_hover_text("The whole document as JSON (rivers, sketch, parameters, mask, blocks)")
            .clicked()
        {
            let json = app.scene().to_json();
            let name = format!(
                "{}.json",
                super::files::free_stem("strahler-scene", &[".json"])
            );
            match super::files::save(&name, "application/json", json.as_bytes()) {
                Ok(said) => app.messages.notice = Some(format!("Scene {said}")),
                Err(err) => app.set_error(err),
            }
        }
        #[cfg(target_arch = "wasm32")]
        if ui
            .button("Open scene...")
            .on_hover_text("A scene saved before; or drop the .json file on the map")
            .clicked()
        {
            let automation = app.automation.clone();
            let check = super::files::check_scene_file;
            if let Err(err) = super::files::pick_file(".json", check, move |name, read| {
                automation.push(match read {
                    Ok(bytes) => super::Command::OpenScene { name, bytes },
                    Err(message) => super::Command::FileRefused { name, message },
                });
            }) {
                app.set_error(err);
            }
        }
    });
}

fn rivers_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Rivers").strong()).on_hover_text(
        "Each stroke grows a Tokunaga river network (seed paper 000, Sec. IV): press at the \
         estuary and drag upstream in the flow direction.",
    );
    ui.horizontal_wrapped(|ui| {
        ui.selectable_value(&mut app.canvas.tool, Tool::Pan, "Pan (P)");
        ui.selectable_value(&mut app.canvas.tool, Tool::River, "Draw river (R)");
        ui.selectable_value(&mut app.canvas.tool, Tool::Select, "Select (S)")
            .on_hover_text(
                "Click a river, sketch line or peak; drag to move it; Delete removes it",
            );
    });
    ui.horizontal_wrapped(|ui| {
        ui.label("Sketch:").on_hover_text(
            "Sketched features (seed paper 003) become extra constraints: ridges (drag), \
             valleys (drag from the mouth upwards) and peaks (click). Heights follow eq. 4.",
        );
        ui.selectable_value(&mut app.canvas.tool, Tool::Ridge, "Ridge (D)");
        ui.selectable_value(&mut app.canvas.tool, Tool::Valley, "Valley (V)");
        ui.selectable_value(&mut app.canvas.tool, Tool::Peak, "Peak (K)");
    });
    let mut edits = Vec::new();
    let scene = app.session.scene();
    for (index, drawn) in scene.rivers.iter().enumerate() {
        let mut stroke = *drawn;
        ui.horizontal(|ui| {
            ui.label(format!("#{}", index + 1));
            let label = ui.label("φ").on_hover_text(
                "Generator index phi (1 to 6): higher grows more feather-like networks (Table 1).",
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
                edits.push(Edit::RemoveRiver(index));
            }
        });
        if stroke != *drawn {
            edits.push(Edit::SetRiver { index, stroke });
        }
    }
    if scene.rivers.is_empty() {
        ui.label(RichText::new("No river yet: choose Draw river and drag on the map.").weak());
    } else if ui.button("Delete all rivers").clicked() {
        edits.push(Edit::ClearRivers);
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
                edits.push(Edit::ClearSketch);
            }
        });
    }
    for edit in edits {
        app.edit(edit);
    }
}

fn terrain_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Terrain").strong());
    let current = app.session.scene();
    let width = current.map_width();
    let mut scene = Grid {
        size: current.size,
        cell_size: current.cell_size,
        seed: current.seed,
        params: current.params,
    };
    let before = scene;
    let mut preview = app.session.settings().preview;
    egui::Grid::new("terrain settings")
        .num_columns(2)
        .show(ui, |ui| {
            let label = ui.label("Grid size");
            ComboBox::from_id_salt("grid size")
                .selected_text(format!("{0} x {0}", scene.size))
                .show_ui(ui, |ui| {
                    for size in SIZES {
                        ui.selectable_value(&mut scene.size, size, format!("{size} x {size}"));
                    }
                })
                .response
                .labelled_by(label.id);
            // The map keeps its width in metres when its cell count changes.
            scene.cell_size = width / scene.size as f64;
            ui.end_row();
            let label = ui
                .label("Map width")
                .on_hover_text("Width of the square map in metres (sets the cell size).");
            let mut km = width / 1000.0;
            if ui
                .add(
                    DragValue::new(&mut km)
                        .range(0.1..=1000.0)
                        .speed(0.1)
                        .suffix(" km"),
                )
                .labelled_by(label.id)
                .changed()
            {
                scene.cell_size = km * 1000.0 / scene.size as f64;
            }
            ui.end_row();
            ui.label("Preview").on_hover_text(format!(
                "Edits of a map larger than {0} x {0} regenerate at {0} x {0}; Generate full \
                 size makes the real one.",
                super::PREVIEW_SIZE
            ));
            ui.checkbox(&mut preview, format!("edit at {}", super::PREVIEW_SIZE));
            ui.end_row();
            let label = ui.label("Seed");
            ui.horizontal(|ui| {
                ui.add(DragValue::new(&mut scene.seed))
                    .labelled_by(label.id);
                if ui.button("New seed").clicked() {
                    scene.seed = scene
                        .seed
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1)
                        >> 16;
                }
            });
            ui.end_row();
            let label = ui
                .label("θ (°)")
                .on_hover_text("Branching angle theta: exterior links turn theta or 2 theta.");
            ui.add(
                DragValue::new(&mut scene.params.theta)
                    .range(5.0..=60.0)
                    .speed(0.5),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("River slope")
                .on_hover_text("Metres of height per metre of channel (Sec. IV-C).");
            ui.add(
                DragValue::new(&mut scene.params.river_slope)
                    .range(0.0..=0.2)
                    .speed(0.001),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("α").on_hover_text(
                "alpha of eq. 4: ridge metres per metre of distance to the nearest river node.",
            );
            ui.add(
                DragValue::new(&mut scene.params.alpha)
                    .range(0.0..=1.0)
                    .speed(0.005),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Noise (m)").on_hover_text(
                "Amplitude of the fractal Perlin noise F(P) of eq. 5 on ridges. Downwards it \
                     takes at most half of a ridge's height above its rivers (alpha * d of \
                     eq. 4), so low ridges between close rivers stay above them.",
            );
            ui.add(
                DragValue::new(&mut scene.params.noise.amplitude)
                    .range(0.0..=500.0)
                    .speed(1.0),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("Octaves")
                .on_hover_text("Octaves of the fractal noise of eq. 5 (1 to 16).");
            ui.add(DragValue::new(&mut scene.params.noise.octaves).range(1..=16))
                .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("Roughness")
                .on_hover_text("Amplitude ratio between successive octaves of eq. 5's noise.");
            ui.add(
                DragValue::new(&mut scene.params.noise.roughness)
                    .range(0.0..=1.0)
                    .speed(0.01),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("MD/MDI passes").on_hover_text(
                "Midpoint displacement and its inverse (Sec. V-B): each pass widens rivers and \
                 ridges by a cell of flank. 0 turns enrichment off.",
            );
            ui.add(DragValue::new(&mut scene.params.enrich.passes).range(0..=16))
                .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("L (cells)").on_hover_text(
                "Distance limit L. From the skeleton: no point is added farther than L cells \
                 from the rivers and ridges. Between points (the paper as written): no point \
                 is interpolated from points more than L cells apart; on 3 x 3 squares that \
                 limits nothing from L = 3, and the passes alone bound the flanks.",
            );
            ui.horizontal(|ui| {
                ui.add(DragValue::new(&mut scene.params.enrich.distance_limit).range(1..=64))
                    .labelled_by(label.id);
                use crate::skeleton::enrich::DistanceRule;
                let rule = &mut scene.params.enrich.distance_rule;
                ui.selectable_value(rule, DistanceRule::Skeleton, "from skeleton");
                ui.selectable_value(rule, DistanceRule::Points, "between points");
            });
            ui.end_row();
        });
    if preview != app.session.settings().preview {
        app.session.settings_mut().preview = preview;
    }
    if (scene.size, scene.cell_size) != (before.size, before.cell_size) {
        app.edit(Edit::SetGrid {
            size: scene.size,
            cell_size: scene.cell_size,
        });
    }
    if scene.seed != before.seed {
        app.edit(Edit::SetSeed(scene.seed));
    }
    if scene.params != before.params {
        app.edit(Edit::SetParams(scene.params));
    }
}

/// The Terrain section's part of the scene, edited as a copy.
#[derive(Clone, Copy)]
struct Grid {
    size: usize,
    cell_size: f64,
    seed: u64,
    params: crate::scene::Params,
}

fn diffusion_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Diffusion").strong()).on_hover_text(
        "Laplace diffusion (seed paper 000, eqs. 6-7): every free cell relaxes to the mean \
         of its four neighbours while the skeleton's cells keep their heights.",
    );
    let ctx = ui.ctx().clone();
    let mut solver = app.settings().clone();
    let mut post = app.session.scene().params.post;
    let before = (solver.clone(), post);
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

    if solver != before.0 {
        *app.settings_mut() = solver;
    }
    if post != before.1 {
        let mut params = app.session.scene().params;
        params.post = post;
        app.edit(Edit::SetParams(params));
    }
    ui.horizontal(|ui| {
        if ui.button("Generate terrain").clicked() {
            app.start_generate(&ctx);
        }
        let size = app.session.scene().size;
        if app.session.settings().preview
            && size > super::PREVIEW_SIZE
            && ui
                .button(format!("Generate full size ({size} x {size})"))
                .clicked()
        {
            app.generate_full_size(&ctx);
        }
        if let Some(job) = app.session.job()
            && ui.button("Cancel").clicked()
        {
            job.cancel();
        }
    });
    if let Some(job) = app.session.job() {
        ui.add(ProgressBar::new(job.progress()).text(job.message()));
    }
    if let Some((size, run)) = &app.summaries.last_run {
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
        ui.label(format!(
            "{how}, residual {:.1e} of the range ({state}); heights {:.0} to {:.0} m",
            run.relative_residual, run.min, run.max
        ));
    }
    if let Some(text) = &app.summaries.terrain {
        ui.label(text);
    }
    if let Some(err) = &app.messages.error {
        ui.colored_label(ui.visuals().error_fg_color, err);
    }
}

fn selftest_section(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    ui.label(RichText::new("Compute check").strong())
        .on_hover_text(
            "Runs the same diffusion problem on the CPU and on the GPU and compares the results.",
        );
    let ctx = ui.ctx().clone();
    ui.add_enabled_ui(app.check.job.is_none(), |ui| {
        if ui.button("Compare CPU and GPU").clicked() {
            app.start_selftest(&ctx);
        }
    });
    match &app.check.result {
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
                        "CPU and GPU {verdict}: max difference {rel:.2e} of the height range"
                    ));
                }
                _ => {
                    ui.label("No GPU compute on this path: CPU only.");
                }
            }
        }
    }
}
