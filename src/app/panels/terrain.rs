//! The Terrain section: grid size, map width, preview, seed and the hydrology paper's
//! parameters (with its symbols in tooltips).

use egui::{ComboBox, DragValue, RichText};

use super::Action;
use crate::app::session::{PREVIEW_SIZE, RunSettings};
use crate::scene::{Edit, Params, Scene};

/// Grid sizes offered (square, cells per side).
pub const SIZES: [usize; 6] = [128, 256, 512, 1024, 2048, 4096];

/// The Terrain section (it keeps no state of its own).
#[derive(Default)]
pub struct TerrainPanel;

/// The section's part of the scene, edited as a copy.
#[derive(Clone, Copy, PartialEq)]
struct Grid {
    size: usize,
    cell_size: f64,
    seed: u64,
    params: Params,
}

impl TerrainPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, scene: &Scene, run: &RunSettings) -> Vec<Action> {
        ui.label(RichText::new("Terrain").strong());
        let before = Grid {
            size: scene.size,
            cell_size: scene.cell_size,
            seed: scene.seed,
            params: scene.params,
        };
        let mut preview = run.preview;
        let scene = edit_grid(ui, before, &mut preview);
        let mut actions = Vec::new();
        if preview != run.preview {
            actions.push(Action::Settings(RunSettings {
                preview,
                ..run.clone()
            }));
        }
        if (scene.size, scene.cell_size) != (before.size, before.cell_size) {
            actions.push(Action::Edit(Edit::SetGrid {
                size: scene.size,
                cell_size: scene.cell_size,
            }));
        }
        if scene.seed != before.seed {
            actions.push(Action::Edit(Edit::SetSeed(scene.seed)));
        }
        if scene.params != before.params {
            actions.push(Action::Edit(Edit::SetParams(scene.params)));
        }
        actions
    }
}

/// The grid's widgets on a copy of the section's fields.
fn edit_grid(ui: &mut egui::Ui, before: Grid, preview: &mut bool) -> Grid {
    let mut scene = before;
    let width = before.cell_size * before.size as f64;
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
                PREVIEW_SIZE
            ));
            ui.checkbox(preview, format!("edit at {}", PREVIEW_SIZE));
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
    scene
}
