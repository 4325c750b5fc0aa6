//! The export dialog: the terrain for a game engine or a GIS. Pick an engine (or a plain
//! file), its size and format, tiles, texture maps and the river network; the dialog shows
//! the files it will write and the numbers to type into the engine before anything is
//! written. Folded below: the plan of a world in tiles larger than the map, for
//! `strahler build`. In the browser a heightmap and its sidecar download as they are, more files as
//! one zip; natively they are saved in the working directory.

use egui::{ComboBox, DragValue, RichText};

use super::Action;
use crate::dem::format::{Format, SIZE_PRESETS};
use crate::export::{Engine, MapKind, NormalConvention, Request};
use crate::scene::{Edit, TextureRules};

/// What the dialog knows of the terrain it exports.
#[derive(Clone, Copy, Debug)]
pub struct ExportInfo {
    /// Vertices a side of the terrain on the map.
    pub native: usize,
    pub cell_m: f64,
    /// Its height range (metres).
    pub range: (f32, f32),
    /// The full size, when the map shows a smaller preview.
    pub preview_of: Option<usize>,
    /// The scene's vertical scale (applies to every export).
    pub vertical_scale: f32,
    pub textures: TextureRules,
}

/// The dialog's own state, kept between openings.
pub struct ExportDialog {
    pub open: bool,
    pub engine: Option<Engine>,
    pub format: Format,
    /// `None` = the terrain's own size (or the engine's default).
    pub size: Option<usize>,
    pub flip_y: bool,
    pub z_scale: f32,
    /// `(columns, rows)`; `(1, 1)` = one file.
    pub tiles: (usize, usize),
    pub maps: Vec<MapKind>,
    pub normals: NormalConvention,
    pub rivers: bool,
    /// Also the skeleton's layers (rivers, ridges, constraints) as PNGs.
    pub layers: bool,
    /// A world in tiles of the scene: its cells a side and its tiles'.
    pub world: (usize, usize),
    /// Whether that world's depressions are filled (`strahler build --fill-depressions`).
    pub world_fill: bool,
}

impl Default for ExportDialog {
    fn default() -> Self {
        Self {
            open: false,
            engine: None,
            format: Format::Png,
            size: None,
            flip_y: false,
            z_scale: 1.0,
            tiles: (1, 1),
            maps: Vec::new(),
            normals: NormalConvention::OpenGl,
            rivers: false,
            layers: false,
            world: (16_384, 2048),
            world_fill: false,
        }
    }
}

impl ExportDialog {
    /// The request the dialog's choices make.
    pub fn request(&self, info: &ExportInfo) -> Request {
        let mut request = match self.engine {
            Some(engine) => Request::for_engine(engine, info.native),
            None => Request::heightmap(self.format),
        };
        request.format = self.format;
        if self.size.is_some() {
            request.size = self.size;
        }
        request.flip_y = self.flip_y;
        request.z_scale = self.z_scale * info.vertical_scale;
        request.tiles = (self.tiles != (1, 1)).then_some(self.tiles);
        request.maps = self.maps.clone();
        request.normals = self.normals;
        request.rivers = self.rivers;
        request
    }

    /// Picks `engine` (or a plain file) and its defaults.
    pub fn choose(&mut self, engine: Option<Engine>) {
        self.engine = engine;
        if let Some(e) = engine {
            self.format = e.formats()[0];
            self.size = None;
            self.flip_y = e.flip_y();
            self.normals = if e == Engine::Unreal {
                NormalConvention::DirectX
            } else {
                NormalConvention::OpenGl
            };
        }
    }

    /// Shows the dialog when open; Escape closes it, Enter downloads.
    pub fn show(&mut self, ctx: &egui::Context, info: &ExportInfo) -> Vec<Action> {
        if self.open && ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, egui::Key::Escape)) {
            self.open = false;
        }
        let mut open = self.open;
        let mut actions = Vec::new();
        egui::Window::new("Export")
            .open(&mut open)
            .collapsible(false)
            .resizable(false)
            .show(ctx, |ui| actions = self.contents(ui, info));
        self.open = open && self.open;
        actions
    }

    fn contents(&mut self, ui: &mut egui::Ui, info: &ExportInfo) -> Vec<Action> {
        let mut actions = Vec::new();
        egui::Grid::new("export settings")
            .num_columns(2)
            .show(ui, |ui| {
                self.target_rows(ui, info);
                self.extra_rows(ui);
            });
        if let Some(full) = info.preview_of {
            ui.label(
                RichText::new(format!(
                    "The map shows a {0} x {0} preview: generate the full size first \
                     (Generate section) to export from {full} x {full}.",
                    info.native
                ))
                .weak(),
            );
        }
        if self.maps.contains(&MapKind::Splat) {
            actions.extend(splat_rows(ui, &info.textures));
        }
        ui.separator();
        let request = self.request(info);
        let plan = crate::export::plan(&request, info.native, info.cell_m, info.range);
        match &plan {
            Ok(plan) => summary(ui, plan),
            Err(problem) => {
                ui.colored_label(ui.visuals().error_fg_color, problem);
            }
        }
        if self.format == Format::Obj && plan.as_ref().is_ok_and(|p| p.size > 2049) {
            ui.label(
                RichText::new("OBJ meshes are limited to 2049 x 2049: pick a smaller size").weak(),
            );
        }
        let clicked = ui
            .add_enabled(plan.is_ok(), egui::Button::new("Download (Enter)"))
            .clicked();
        // Enter downloads too, so the dialog works from the keyboard (E, then Enter).
        if plan.is_ok() && (clicked || ui.input(|i| i.key_pressed(egui::Key::Enter))) {
            actions.push(Action::Export {
                request,
                layers: self.layers,
            });
        }
        actions.extend(self.world_rows(ui));
        actions
    }

    /// Larger than the map: the plan of a world in tiles, for `strahler build`.
    fn world_rows(&mut self, ui: &mut egui::Ui) -> Vec<Action> {
        let mut actions = Vec::new();
        egui::CollapsingHeader::new("A world in tiles")
            .default_open(false)
            .show(ui, |ui| {
                ui.label(
                    RichText::new(
                        "Larger than one piece (up to 65536 x 65536): the scene built at a \
                         global size with levels of detail above it, in tiles, on your machine \
                         or a batch engine, by `strahler build` from this plan.",
                    )
                    .weak(),
                );
                let (size, tile) = &mut self.world;
                ui.horizontal(|ui| {
                    let label = ui.label("Cells a side");
                    ui.add(DragValue::new(size).range(1024..=65_536).speed(64))
                        .labelled_by(label.id);
                    let label = ui.label("Tile");
                    ComboBox::from_id_salt("world tile")
                        .selected_text(tile.to_string())
                        .show_ui(ui, |ui| {
                            for side in [1008, 1024, 2016, 2048, 4032, 4096] {
                                ui.selectable_value(tile, side, side.to_string());
                            }
                        })
                        .response
                        .labelled_by(label.id);
                });
                ui.checkbox(&mut self.world_fill, "Fill the depressions")
                    .on_hover_text(
                        "Flat lakes where water would stand, so that every cell drains to the \
                         world's edge (GIS tools' \"fill sinks\"), exactly, tile by tile: \
                         three more stages of tasks.",
                    );
                let fill = self.world_fill;
                let scene = crate::scene::Scene::default();
                match crate::world::Plan::new(&scene, *size, *tile, None) {
                    Ok(plan) => {
                        let plan = if fill { plan.with_fill() } else { plan };
                        ui.label(format!(
                            "{} tasks: the global build at {}^2, then {} x {} tiles with {} \
                             levels of detail{}",
                            plan.tasks(),
                            plan.world,
                            plan.tiles_per_side(),
                            plan.tiles_per_side(),
                            plan.levels,
                            match (plan.refine, plan.fill) {
                                (true, true) => {
                                    ", the erosion refined tile by tile, the depressions filled"
                                }
                                (true, false) => ", the erosion refined tile by tile",
                                (false, true) => ", the depressions filled",
                                (false, false) => "",
                            }
                        ));
                        ui.horizontal(|ui| {
                            if ui.button("Save the world plan").clicked() {
                                actions.push(Action::SaveWorldPlan {
                                    size: *size,
                                    tile: *tile,
                                    fill,
                                });
                            }
                            let preview = ui.button("Save the preview").on_hover_text(format!(
                                "The whole world at low resolution ({}^2, GeoTIFF): the \
                                 build's first task, the same bytes as its preview.tif",
                                plan.world
                            ));
                            if preview.clicked() {
                                actions.push(Action::SaveWorldPreview {
                                    size: *size,
                                    tile: *tile,
                                });
                            }
                        });
                    }
                    Err(problem) => {
                        ui.colored_label(ui.visuals().error_fg_color, problem.to_string());
                    }
                }
            });
        actions
    }

    /// Engine, format, size, flip and height scale.
    fn target_rows(&mut self, ui: &mut egui::Ui, info: &ExportInfo) {
        let label = ui.label("For");
        let name = |e: Option<Engine>| e.map_or("a plain file", Engine::label);
        let mut engine = self.engine;
        ComboBox::from_id_salt("export engine")
            .selected_text(name(engine))
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut engine, None, name(None));
                for e in Engine::ALL {
                    ui.selectable_value(&mut engine, Some(e), e.label());
                }
            })
            .response
            .labelled_by(label.id);
        if engine != self.engine {
            self.choose(engine);
        }
        ui.end_row();
        let label = ui.label("Format");
        let formats: Vec<Format> = match self.engine {
            Some(e) => e.formats().to_vec(),
            None => Format::EXPORTS.to_vec(),
        };
        ComboBox::from_id_salt("export format")
            .selected_text(self.format.label())
            .show_ui(ui, |ui| {
                for f in formats {
                    ui.selectable_value(&mut self.format, f, f.label());
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
        let label = ui.label("Size");
        let native = info.native;
        let default = self.engine.map_or(native, |e| e.default_size(native));
        let text = |s: Option<usize>| match s {
            None if self.engine.is_some() => format!("{default} x {default}"),
            None => format!("as on the map ({native} x {native})"),
            Some(n) => format!("{n} x {n}"),
        };
        let sizes: Vec<usize> = match self.engine {
            Some(e) => e.sizes().to_vec(),
            None => SIZE_PRESETS.to_vec(),
        };
        ComboBox::from_id_salt("export size")
            .selected_text(text(self.size))
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut self.size, None, text(None));
                for n in sizes {
                    ui.selectable_value(&mut self.size, Some(n), text(Some(n)));
                }
            })
            .response
            .labelled_by(label.id);
        ui.end_row();
        let label = ui
            .label("Flip Y")
            .on_hover_text("Rows bottom-up, as Unity reads RAW files (PNG, RAW R16 and R32)");
        ui.add_enabled(
            matches!(self.format, Format::Png | Format::R16 | Format::R32),
            egui::Checkbox::without_text(&mut self.flip_y),
        )
        .labelled_by(label.id);
        ui.end_row();
        let label = ui.label("Height scale");
        ui.add(
            DragValue::new(&mut self.z_scale)
                .range(0.001..=1000.0)
                .speed(0.01),
        )
        .labelled_by(label.id);
        ui.end_row();
    }

    /// Tiles, maps, rivers and layers.
    fn extra_rows(&mut self, ui: &mut egui::Ui) {
        ui.label("Tiles").on_hover_text(
            "Columns x rows of tiles that share their edge vertices, one height range for all, \
             named _x0_y0 (Unreal World Partition)",
        );
        ui.horizontal(|ui| {
            ui.add(
                DragValue::new(&mut self.tiles.0)
                    .range(1..=16)
                    .suffix(" across"),
            );
            ui.add(
                DragValue::new(&mut self.tiles.1)
                    .range(1..=16)
                    .suffix(" down"),
            );
        });
        ui.end_row();
        ui.label("Maps");
        ui.vertical(|ui| {
            for map in MapKind::ALL {
                let mut on = self.maps.contains(&map);
                if ui
                    .checkbox(&mut on, map.key())
                    .on_hover_text(map.describe())
                    .changed()
                {
                    self.maps.retain(|m| *m != map);
                    if on {
                        self.maps.push(map);
                    }
                }
            }
            if self.maps.contains(&MapKind::Normal) {
                ui.horizontal(|ui| {
                    ui.radio_value(&mut self.normals, NormalConvention::OpenGl, "OpenGL");
                    ui.radio_value(&mut self.normals, NormalConvention::DirectX, "DirectX");
                });
            }
        });
        ui.end_row();
        ui.label("Rivers").on_hover_text(
            "The river network (Strahler order, width, drainage area) and ridges as GeoJSON",
        );
        ui.checkbox(&mut self.rivers, "GeoJSON");
        ui.end_row();
        ui.label("Layers").on_hover_text(
            "Also rivers.png (Strahler order), ridges.png and constraints.png, 8-bit, at the \
             generated terrain's size",
        );
        ui.checkbox(&mut self.layers, "PNGs");
        ui.end_row();
    }
}

/// The splat map's thresholds (the scene's `textures`).
fn splat_rows(ui: &mut egui::Ui, rules: &TextureRules) -> Vec<Action> {
    let mut r = *rules;
    ui.label(RichText::new("Splat map: rock, grass, sediment, snow").strong());
    egui::Grid::new("splat rules")
        .num_columns(2)
        .show(ui, |ui| {
            let label = ui.label("Rock above");
            ui.add(
                DragValue::new(&mut r.rock_slope_deg)
                    .range(1.0..=89.0)
                    .suffix(" deg"),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Snow above");
            ui.add(
                DragValue::new(&mut r.snow_above)
                    .range(0.0..=1.0)
                    .speed(0.01),
            )
            .on_hover_text("Fraction of the height range")
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Sediment from");
            ui.add(
                DragValue::new(&mut r.sediment_area_m2)
                    .range(1.0..=1e12)
                    .speed(1e4)
                    .suffix(" m2"),
            )
            .on_hover_text("Drainage area above which the ground is sediment")
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Softness");
            ui.add(DragValue::new(&mut r.softness).range(0.0..=1.0).speed(0.01))
                .labelled_by(label.id);
            ui.end_row();
        });
    if r != *rules {
        vec![Action::Edit(Edit::SetTextures(r))]
    } else {
        Vec::new()
    }
}

/// The files a plan writes and the numbers to type into the engine.
fn summary(ui: &mut egui::Ui, plan: &crate::export::Plan) {
    ui.label(format!(
        "{0} x {0} vertices, {1:.0} m across; {2} file(s):",
        plan.size,
        plan.extent_m,
        plan.names.len()
    ));
    let shown = 6;
    let mut list = plan
        .names
        .iter()
        .take(shown)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if plan.names.len() > shown {
        list.push_str(&format!(" and {} more", plan.names.len() - shown));
    }
    ui.label(RichText::new(list).monospace().small());
    if let Some(numbers) = &plan.numbers {
        ui.label(RichText::new("To type into the engine").strong());
        egui::Grid::new("engine numbers")
            .num_columns(2)
            .show(ui, |ui| {
                for (key, value) in &numbers.settings {
                    ui.label(key);
                    ui.label(RichText::new(value).monospace());
                    ui.end_row();
                }
            });
    }
}
