//! The Start section, first in the side panel: the main choices of a new terrain. The
//! terrain type (an erosion preset, or the design alone), the grid size, the map's width,
//! the preview and the seed.

use egui::{ComboBox, DragValue, RichText};

use super::Action;
use crate::app::session::{PREVIEW_SIZE, RunSettings};
use crate::erosion::{ErosionSettings, PRESETS};
use crate::scene::{Edit, Location, Scene};

/// Grid sizes offered (square, cells per side).
pub const SIZES: [usize; 6] = [128, 256, 512, 1024, 2048, 4096];

/// The terrain type of a scene without erosion.
pub const DESIGN_ONLY: &str = "design only (no erosion)";

/// The Start section (it keeps no state of its own).
#[derive(Default)]
pub struct StartPanel;

/// The section's part of the scene, edited as a copy.
#[derive(Clone, PartialEq)]
struct Choices {
    /// The erosion preset's name, or [`DESIGN_ONLY`].
    terrain_type: String,
    size: usize,
    cell_size: f64,
    seed: u64,
    preview: bool,
    location: Option<Location>,
}

impl StartPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, scene: &Scene, run: &RunSettings) -> Vec<Action> {
        ui.label(RichText::new("Start").strong()).on_hover_text(
            "The main choices: what kind of land, how many cells, how wide. Then draw rivers \
             on the map; every edit regenerates the terrain.",
        );
        let before = Choices {
            terrain_type: scene
                .erosion
                .as_ref()
                .map_or(DESIGN_ONLY.to_owned(), |e| e.preset.clone()),
            size: scene.size,
            cell_size: scene.cell_size,
            seed: scene.seed,
            preview: run.preview,
            location: scene.location,
        };
        let mut after = before.clone();
        choices(ui, &mut after);
        actions(run, scene, &before, after)
    }
}

/// What changed, as actions: a terrain type sets the erosion, and the drawn rivers' slope
/// where it asks for one ([`crate::erosion::river_slope`]: a coastal plain's rivers fall
/// gently).
fn actions(run: &RunSettings, scene: &Scene, before: &Choices, after: Choices) -> Vec<Action> {
    let mut actions = Vec::new();
    if after.terrain_type != before.terrain_type {
        let erosion = ErosionSettings::preset(&after.terrain_type);
        actions.push(Action::Edit(Edit::SetErosion(erosion)));
        if let Some(slope) = crate::erosion::river_slope(&after.terrain_type)
            && slope != scene.params.river_slope
        {
            let params = crate::scene::Params {
                river_slope: slope,
                ..scene.params
            };
            actions.push(Action::Edit(Edit::SetParams(params)));
        }
    }
    if (after.size, after.cell_size) != (before.size, before.cell_size) {
        actions.push(Action::Edit(Edit::SetGrid {
            size: after.size,
            cell_size: after.cell_size,
        }));
    }
    if after.seed != before.seed {
        actions.push(Action::Edit(Edit::SetSeed(after.seed)));
    }
    if after.location != before.location {
        actions.push(Action::Edit(Edit::SetLocation(after.location)));
    }
    if after.preview != before.preview {
        actions.push(Action::Settings(RunSettings {
            preview: after.preview,
            ..run.clone()
        }));
    }
    actions
}

/// The section's widgets on a copy of its fields.
fn choices(ui: &mut egui::Ui, c: &mut Choices) {
    let width = c.cell_size * c.size as f64;
    egui::Grid::new("start choices")
        .num_columns(2)
        .show(ui, |ui| {
            let label = ui.label("Terrain type").on_hover_text(
                "How the land is worn: an erosion preset (stream-power erosion with hillslope \
                 processes, tuned for a map about 10 km wide), or the design alone. The \
                 Erosion section has each preset's parameters.",
            );
            ComboBox::from_id_salt("terrain type")
                .selected_text(c.terrain_type.clone())
                .show_ui(ui, |ui| {
                    for name in PRESETS.iter().copied().chain([DESIGN_ONLY]) {
                        let what = crate::erosion::describe(name)
                            .unwrap_or("No erosion: the design as drawn.");
                        ui.selectable_value(&mut c.terrain_type, name.to_owned(), name)
                            .on_hover_text(what);
                    }
                })
                .response
                .labelled_by(label.id);
            ui.end_row();

            let label = ui
                .label("Grid size")
                .on_hover_text("Cells per side of the square terrain (and of its heightmap).");
            ComboBox::from_id_salt("grid size")
                .selected_text(format!("{0} x {0}", c.size))
                .show_ui(ui, |ui| {
                    for size in SIZES {
                        ui.selectable_value(&mut c.size, size, format!("{size} x {size}"));
                    }
                })
                .response
                .labelled_by(label.id);
            // The map keeps its width in metres when its cell count changes.
            c.cell_size = width / c.size as f64;
            ui.end_row();

            let label = ui.label("Map width").on_hover_text(
                "Width of the square map in kilometres (sets the cell size: the width over \
                 the grid size). Relief and valley spacing follow it.",
            );
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
                c.cell_size = km * 1000.0 / c.size as f64;
            }
            ui.end_row();

            ui.label("Preview").on_hover_text(format!(
                "Edits of a map larger than {0} x {0} regenerate at {0} x {0}; Generate full \
                 size makes the real one.",
                PREVIEW_SIZE
            ));
            ui.checkbox(&mut c.preview, format!("edit at {}", PREVIEW_SIZE));
            ui.end_row();

            let label = ui
                .label("Seed")
                .on_hover_text("The same scene and seed make the same terrain, bit for bit.");
            ui.horizontal(|ui| {
                ui.add(DragValue::new(&mut c.seed)).labelled_by(label.id);
                if ui.button("New seed").clicked() {
                    c.seed = c
                        .seed
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1)
                        >> 16;
                }
            });
            ui.end_row();

            location(ui, &mut c.location);
            ui.end_row();
        });
}

/// The map's place on Earth (its centre), or none.
fn location(ui: &mut egui::Ui, location: &mut Option<Location>) {
    ui.label("Location").on_hover_text(
        "The map's centre on Earth, latitude and longitude in degrees (WGS84). Exports are \
         then georeferenced in its UTM zone and the rivers' GeoJSON is in longitude and \
         latitude; the terrain does not change.",
    );
    ui.horizontal(|ui| {
        let mut on = location.is_some();
        ui.checkbox(&mut on, "on Earth");
        let mut place = location.unwrap_or(Location {
            lat: 45.9,
            lon: 6.9,
        });
        if on {
            let lats = crate::dem::utm::LATITUDES;
            ui.add(
                DragValue::new(&mut place.lat)
                    .range(*lats.start()..=*lats.end())
                    .speed(0.01)
                    .suffix("° N"),
            );
            ui.add(
                DragValue::new(&mut place.lon)
                    .range(-180.0..=180.0)
                    .speed(0.01)
                    .suffix("° E"),
            );
        }
        *location = on.then_some(place);
    });
}
