//! The DEM panel: the uploaded real DEM (its facts, the height range of a PNG or RAW file,
//! void filling, feature extraction, the network comparison), the window of it to place as
//! a block (dragged on its preview), and the placed blocks (seed paper 000, Sec. VI).
//!
//! The panel owns what is typed or dragged here (the height range being typed, the path on
//! native builds, a drag on the preview, the question before an extraction replaces the
//! scene); the DEM, the window and the blocks are the app's and the scene's, read through a
//! [`DemView`] and changed by the [`Action`]s it returns.

use egui::{Color32, DragValue, ProgressBar, Rect, RichText, Sense, Stroke, StrokeKind, pos2};

use super::Action;
use crate::app::map_view::Tool;
use crate::scene::{Edit, Scene};

/// What the DEM panel asks of the app.
#[derive(Clone, Debug, PartialEq)]
pub enum DemAction {
    /// Open the file picker (the page) or say how to open a file (native).
    Upload,
    Remove,
    /// Read the file at this path (native builds).
    Open(std::path::PathBuf),
    /// Read the PNG or RAW file again with this height range (metres).
    Reread((f32, f32)),
    FillVoids,
    ExtractFeatures,
    CompareNetworks,
    /// The window of the DEM to place: row, col, height, width.
    Window([usize; 4]),
    /// Place the window as a block in the middle of the map.
    Place,
    /// Select a placed block (an index into the scene's blocks), or none.
    Select(Option<usize>),
}

/// What the panel shows of the uploaded DEM (facts measured once, when it was read).
pub struct DemInfo<'a> {
    pub name: &'a str,
    pub width: usize,
    pub height: usize,
    /// The lowest and highest heights, metres.
    pub range: (f32, f32),
    pub voids: usize,
    /// Metres (or degrees) per cell in x and y, if the file says.
    pub cell_size: Option<(f64, f64)>,
    pub crs: Option<String>,
    /// A PNG or RAW file: its heights depend on the range it is read with.
    pub needs_range: bool,
    /// The shaded relief drawn under the window.
    pub preview: Option<egui::TextureId>,
    /// The window to place: row, col, height, width.
    pub window: [usize; 4],
}

/// A job's progress and message.
pub type Progress = (f32, String);

/// The network comparison's state.
#[derive(Default)]
pub struct NetworksView<'a> {
    /// A terrain is on the map and no comparison runs.
    pub can_start: bool,
    pub progress: Option<Progress>,
    pub table: Option<NetworkTable<'a>>,
}

/// The last network comparison.
pub struct NetworkTable<'a> {
    /// The DEM's name.
    pub dem: &'a str,
    /// The channel initiation area used, m².
    pub channel_area_m2: f64,
    /// Each row: its label, and the values for the DEM, its largest basin and the generated
    /// networks.
    pub rows: &'a [(String, [String; 3])],
}

/// What the DEM panel reads.
pub struct DemView<'a> {
    pub scene: &'a Scene,
    pub dem: Option<DemInfo<'a>>,
    pub fill: Option<Progress>,
    pub features: Option<Progress>,
    pub networks: NetworksView<'a>,
    pub tool: Tool,
    /// The placed block selected on the map or in the list.
    pub selected: Option<usize>,
    /// The last error, when an action taken here caused it.
    pub error: Option<&'a str>,
    /// What the blend stage did in the last run.
    pub summary: Option<&'a str>,
}

/// The DEM panel's own state.
pub struct DemPanel {
    /// The height range typed for a PNG or RAW file (applied with Apply).
    pub z_range: (f32, f32),
    /// Where a drag on the preview started (row, col).
    select_from: Option<(usize, usize)>,
    /// Extract features was pressed over a scene with work in it: asking first.
    confirm_extract: bool,
    /// Native builds: the path typed into the Open field.
    pub path: String,
}

impl Default for DemPanel {
    fn default() -> Self {
        Self {
            z_range: DEFAULT_Z_RANGE,
            select_from: None,
            confirm_extract: false,
            path: String::new(),
        }
    }
}

/// The height range a PNG or RAW file without one is read with at first, metres.
pub const DEFAULT_Z_RANGE: (f32, f32) = (0.0, 1000.0);

impl DemPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, view: &DemView<'_>) -> Vec<Action> {
        let mut actions = Vec::new();
        ui.label(RichText::new("Real DEM and blending").strong())
            .on_hover_text(
                "Upload a real elevation file, select a block of it and place it on the map: \
                 the block is solved from the Poisson equation with the terrain on its border \
                 (seed paper 000, Sec. VI), so its landforms appear without a seam.",
            );
        ui.horizontal_wrapped(|ui| {
            if ui
                .button("Upload DEM... (U)")
                .on_hover_text("GeoTIFF, SRTM .hgt, ESRI .asc, PNG or RAW .r16; or drop the file")
                .clicked()
            {
                actions.push(DemAction::Upload);
            }
            if view.dem.is_some() && ui.button("Remove DEM").clicked() {
                actions.push(DemAction::Remove);
            }
        });
        let dismissed = super::error_row(ui, view.error);
        if !cfg!(target_arch = "wasm32") {
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.path).hint_text("path/to/dem.tif"));
                if ui.button("Open").clicked() {
                    actions.push(DemAction::Open(self.path.trim().into()));
                }
            });
        }
        if let Some(dem) = &view.dem {
            self.loaded(ui, view, dem, &mut actions);
        }
        let mut actions: Vec<Action> = actions.into_iter().map(Action::Dem).collect();
        actions.extend(dismissed);
        actions.extend(blocks(ui, view));
        actions
    }

    /// Everything about the uploaded DEM.
    fn loaded(
        &mut self,
        ui: &mut egui::Ui,
        view: &DemView<'_>,
        dem: &DemInfo<'_>,
        actions: &mut Vec<DemAction>,
    ) {
        facts(ui, dem);
        if dem.needs_range {
            ui.horizontal(|ui| {
                ui.label("Height range");
                let (a, b) = &mut self.z_range;
                ui.add(DragValue::new(a).suffix(" m"));
                ui.add(DragValue::new(b).suffix(" m"));
                if ui.button("Apply").clicked() {
                    actions.push(DemAction::Reread(self.z_range));
                }
            });
        }
        if dem.voids > 0
            && ui
                .button("Fill voids")
                .on_hover_text("Harmonic fill: the diffusion solver with every known cell fixed")
                .clicked()
        {
            actions.push(DemAction::FillVoids);
        }
        progress(ui, view.fill.as_ref());
        self.extraction(ui, view, dem, actions);
        progress(ui, view.features.as_ref());
        if networks(ui, &view.networks) {
            actions.push(DemAction::CompareNetworks);
        }
        if let Some(window) = self.preview(ui, dem)
            && window != dem.window
        {
            actions.push(DemAction::Window(window));
        }
        if ui
            .button("Place block on map")
            .on_hover_text("Then drag it with the Block tool (B); drag its corner to resize")
            .clicked()
        {
            actions.push(DemAction::Place);
        }
    }

    /// Extract features, asking first when the scene has work that it would replace.
    fn extraction(
        &mut self,
        ui: &mut egui::Ui,
        view: &DemView<'_>,
        dem: &DemInfo<'_>,
        actions: &mut Vec<DemAction>,
    ) {
        let pressed = ui
            .add_enabled(dem.voids == 0, egui::Button::new("Extract features"))
            .on_hover_text(
                "Ridge lines, valley lines and peaks of the DEM (seed paper 003) become the \
                 map's sketch, with the DEM's heights: edit them and regenerate. Fill the \
                 voids first.",
            )
            .clicked();
        let work = scene_work(view.scene);
        if pressed && work.is_empty() {
            actions.push(DemAction::ExtractFeatures);
        } else if pressed {
            self.confirm_extract = true;
        }
        if !self.confirm_extract {
            return;
        }
        ui.label(format!(
            "This replaces the scene's {work} with the DEM's features (Undo brings them back)."
        ));
        ui.horizontal(|ui| {
            if ui.button("Replace the scene").clicked() {
                actions.push(DemAction::ExtractFeatures);
                self.confirm_extract = false;
            }
            if ui.button("Keep the scene").clicked() {
                self.confirm_extract = false;
            }
        });
    }

    /// The DEM's shaded relief with the window on it (drag to select another) and the
    /// window's numbers; returns the window as drawn.
    fn preview(&mut self, ui: &mut egui::Ui, dem: &DemInfo<'_>) -> Option<[usize; 4]> {
        let texture = dem.preview?;
        let (w, h) = (dem.width.max(1), dem.height.max(1));
        let side = ui.available_width().min(260.0);
        let scale = side / w.max(h) as f32;
        let (rect, response) = ui.allocate_exact_size(
            egui::vec2(w as f32 * scale, h as f32 * scale),
            Sense::drag(),
        );
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, "DEM preview"));
        let painter = ui.painter_at(rect);
        let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
        painter.image(texture, rect, uv, Color32::WHITE);
        let cell = |p: egui::Pos2| {
            let v = (p - rect.min) / scale;
            (
                (v.y.max(0.0) as usize).min(h - 1),
                (v.x.max(0.0) as usize).min(w - 1),
            )
        };
        let mut window = dem.window;
        if response.drag_started()
            && let Some(p) = response.interact_pointer_pos()
        {
            self.select_from = Some(cell(p));
        }
        if let (Some((r0, c0)), Some(p)) = (self.select_from, response.interact_pointer_pos()) {
            let (r1, c1) = cell(p);
            window = [
                r0.min(r1),
                c0.min(c1),
                r0.abs_diff(r1) + 1,
                c0.abs_diff(c1) + 1,
            ];
        }
        if response.drag_stopped() {
            self.select_from = None;
        }
        let [row, col, sh, sw] = window;
        let drawn = Rect::from_min_size(
            rect.min + egui::vec2(col as f32, row as f32) * scale,
            egui::vec2(sw as f32, sh as f32) * scale,
        );
        painter.rect_stroke(
            drawn,
            0.0,
            Stroke::new(2.0, Color32::from_rgb(230, 40, 40)),
            StrokeKind::Middle,
        );
        ui.horizontal(|ui| {
            ui.label("Window")
                .on_hover_text("row, col, height, width on the DEM");
            let s = &mut window;
            let ranges = [0..=h - 1, 0..=w - 1, 3..=h, 3..=w];
            let names = [
                "Window row",
                "Window column",
                "Window height",
                "Window width",
            ];
            for ((value, range), name) in s.iter_mut().zip(ranges).zip(names) {
                let response = ui.add(DragValue::new(value).range(range));
                response
                    .widget_info(|| egui::WidgetInfo::labeled(egui::Role::SpinButton, true, name));
            }
            s[2] = s[2].min(h - s[0]);
            s[3] = s[3].min(w - s[1]);
        });
        Some(window)
    }
}

/// `v` with up to six decimals and no trailing zeros: "90", "0.000833".
fn short(v: f64) -> String {
    let text = format!("{v:.6}");
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// The DEM's file, size, heights, cell size, CRS and voids.
fn facts(ui: &mut egui::Ui, dem: &DemInfo<'_>) {
    egui::Grid::new("dem info").num_columns(2).show(ui, |ui| {
        let rows = [
            ("File", dem.name.to_owned()),
            ("Size", format!("{} x {} cells", dem.width, dem.height)),
            (
                "Heights",
                format!("{:.1} to {:.1} m", dem.range.0, dem.range.1),
            ),
            (
                "Cell size",
                dem.cell_size.map_or("unknown".into(), |(x, y)| {
                    format!("{} x {}", short(x), short(y))
                }),
            ),
            ("CRS", dem.crs.clone().unwrap_or("unknown".into())),
            ("No-data", format!("{} cells", dem.voids)),
        ];
        for (label, value) in rows {
            ui.label(label);
            ui.label(value);
            ui.end_row();
        }
    });
}

fn progress(ui: &mut egui::Ui, job: Option<&Progress>) {
    if let Some((fraction, message)) = job {
        ui.add(ProgressBar::new(*fraction).text(message.as_str()));
    }
}

/// The network comparison: the button, its progress and the table; returns whether the
/// button was pressed.
fn networks(ui: &mut egui::Ui, view: &NetworksView<'_>) -> bool {
    let clicked = ui
        .add_enabled(view.can_start, egui::Button::new("Compare river networks"))
        .on_hover_text(
            "The DEM's channel network (D8 flow accumulation, seed paper 000 Sec. VII) beside \
             the rivers of the terrain on the map: Strahler orders, bifurcation and length \
             ratios, Tokunaga T_k",
        )
        .clicked();
    progress(ui, view.progress.as_ref());
    if let Some(table) = &view.table {
        ui.label(
            RichText::new(format!(
                "{}: channels from {:.2} km² upstream",
                table.dem,
                table.channel_area_m2 / 1e6
            ))
            .weak(),
        );
        egui::Grid::new("network comparison")
            .num_columns(4)
            .striped(true)
            .show(ui, |ui| {
                for header in ["", "DEM", "largest basin", "generated"] {
                    ui.label(RichText::new(header).strong());
                }
                ui.end_row();
                for (label, cells) in table.rows {
                    ui.label(label);
                    for cell in cells {
                        ui.label(cell);
                    }
                    ui.end_row();
                }
            });
    }
    clicked
}

/// The placed blocks: the Block tool, select, turn, mirror, scale, remove.
fn blocks(ui: &mut egui::Ui, view: &DemView<'_>) -> Vec<Action> {
    let mut actions = Vec::new();
    if view.scene.blend.is_empty() {
        return actions;
    }
    let mut tool = view.tool;
    ui.horizontal_wrapped(|ui| {
        ui.selectable_value(&mut tool, Tool::Block, "Move blocks (B)");
    });
    if tool != view.tool {
        actions.push(Action::Tool(tool));
    }
    for (i, placed) in view.scene.blend.iter().enumerate() {
        let mut block = placed.clone();
        let mut changed = false;
        let selected = view.selected == Some(i);
        ui.horizontal(|ui| {
            if ui.selectable_label(selected, &block.name).clicked() {
                actions.push(Action::Dem(DemAction::Select(Some(i))));
            }
            if ui
                .small_button("x")
                .on_hover_text("Remove this block")
                .clicked()
            {
                actions.push(Action::Edit(Edit::RemoveBlock(i)));
                actions.push(Action::Dem(DemAction::Select(None)));
            }
        });
        if selected {
            ui.horizontal(|ui| {
                if ui.button("Rotate 90").clicked() {
                    block.quarter_turns = (block.quarter_turns + 1) % 4;
                    changed = true;
                }
                changed |= ui.checkbox(&mut block.mirror, "Mirror").changed();
                let label = ui.label("z x");
                changed |= ui
                    .add(
                        DragValue::new(&mut block.z_scale)
                            .range(-10.0..=10.0)
                            .speed(0.02),
                    )
                    .labelled_by(label.id)
                    .changed();
                let label = ui.label("Feather").on_hover_text(
                    "How far the block's change fades in from its edge, as a share of its \
                     shorter side (0: the paper's Poisson blend alone, its edge a crease)",
                );
                changed |= ui
                    .add(
                        DragValue::new(&mut block.feather)
                            .range(0.0..=crate::blend::poisson::MAX_FEATHER)
                            .speed(0.01),
                    )
                    .labelled_by(label.id)
                    .changed();
            });
        }
        if changed {
            actions.push(Action::Edit(Edit::SetBlock { index: i, block }));
        }
    }
    if let Some(text) = view.summary {
        ui.label(text);
    }
    actions
}

/// What an extraction would replace, in words ("2 rivers, 3 sketch items and 1 block"), or
/// nothing.
fn scene_work(scene: &Scene) -> String {
    let sketch = &scene.sketch;
    let items = sketch.ridges.len() + sketch.valleys.len() + sketch.peaks.len();
    let parts: Vec<String> = [
        (scene.rivers.len(), "river"),
        (items, "sketch item"),
        (scene.blend.len(), "block"),
    ]
    .into_iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, what)| format!("{n} {what}{}", if n == 1 { "" } else { "s" }))
    .collect();
    match parts.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}
