//! The central 2D map: the current terrain as shaded relief, with pan and zoom.
//!
//! Map coordinates are resolution-independent map units: (0, 0) is the north-west corner
//! and (1, 1) the south-east one, whatever the raster size (the scene format uses the same
//! units). The view keeps a centre in map units and a zoom in screen points per map unit.

use egui::{
    Color32, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, TextureOptions, Vec2, pos2,
};

use crate::heightfield::Heightfield;

/// Zoom limits relative to "the map fits the panel".
const MIN_ZOOM: f32 = 0.25;
const MAX_ZOOM: f32 = 64.0;

/// What a primary-button drag on the map does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tool {
    /// Drag to pan (any button pans in every tool except the primary one in River).
    #[default]
    Pan,
    /// Press at the estuary and drag upstream: a new river stroke.
    River,
    /// Drag a sketched ridge line.
    Ridge,
    /// Drag a sketched valley line, from its mouth upwards.
    Valley,
    /// Click a sketched peak.
    Peak,
    /// Paint the energy-reduction mask (drag; the brush is set in the Detail section).
    Mask,
    /// Move a blended DEM block (drag it) or resize it (drag its corner handle).
    Block,
    /// Select a river, sketch line or peak (click), move it (drag), delete it (Delete).
    Select,
}

impl Tool {
    /// Tools whose primary drag draws a line.
    fn draws_lines(self) -> bool {
        matches!(self, Tool::River | Tool::Ridge | Tool::Valley)
    }
}

/// Lines drawn over the terrain, in map units.
#[derive(Clone, Debug, Default)]
pub struct Overlay {
    /// River links with their Strahler order.
    pub rivers: Vec<(Pos2, Pos2, u32)>,
    pub ridges: Vec<(Pos2, Pos2)>,
    /// The user's strokes: each river's course from its estuary to its flow point (the
    /// stroke bent as the terrain draws its trunk).
    pub strokes: Vec<Vec<Pos2>>,
    /// Sketched ridge and valley segments, and peaks.
    pub sketch_ridges: Vec<(Pos2, Pos2)>,
    pub sketch_valleys: Vec<(Pos2, Pos2)>,
    pub peaks: Vec<Pos2>,
    pub show_rivers: bool,
    /// Rivers below this Strahler order are not drawn.
    pub min_river_order: u32,
    pub show_ridges: bool,
    pub show_mask: bool,
    pub show_relief: bool,
    pub show_constraints: bool,
    pub show_blocks: bool,
    /// The erosion stage's drainage area and erosion depth layers.
    pub show_drainage: bool,
    pub show_erosion_depth: bool,
    /// Contour segments (map units), drawn when `show_contours`.
    pub contours: Vec<(Pos2, Pos2)>,
    pub show_contours: bool,
    /// Brush radius in map units, drawn around the pointer with the mask tool.
    pub brush_radius: Option<f32>,
    /// Blended DEM blocks (map units) and whether each is the selected one.
    pub blocks: Vec<(Rect, bool)>,
    /// The selected vector item's points, highlighted.
    pub selected: Vec<Pos2>,
    /// While no terrain is shown: the running build's progress (0 to 1) and what it is
    /// doing, said in its place (a reload computes the restored scene before any picture).
    pub building: Option<(f32, String)>,
}

/// A drag with the block tool, in map units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockDrag {
    /// Where the drag started.
    pub from: Pos2,
    /// Movement this frame.
    pub delta: Vec2,
    /// The drag ended this frame.
    pub finished: bool,
}

/// What happened on the map this frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MapResponse {
    pub hover: Option<Hover>,
    /// A line finished this frame with the active line tool (start, end), clamped to the map.
    pub new_stroke: Option<(Pos2, Pos2)>,
    /// A click with the peak tool, in map units.
    pub clicked: Option<Pos2>,
    /// A piece of mask brush stroke painted this frame (from, to), in map units.
    pub paint: Option<(Pos2, Pos2)>,
    /// The mask brush stroke ended this frame.
    pub paint_finished: bool,
    /// A drag with the block or select tool.
    pub block_drag: Option<BlockDrag>,
    /// A click with the select tool, in map units.
    pub select_click: Option<Pos2>,
    /// About 10 screen points in map units: how near a click must be to pick an item.
    pub pick_tolerance: f32,
}

/// What the pointer is over.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hover {
    /// Map units, (0, 0) north-west.
    pub map: Pos2,
    /// Height under the pointer in metres, if it is over the terrain.
    pub height: Option<f32>,
}

/// Pan/zoom state and the terrain texture.
#[derive(Default)]
pub struct MapView {
    center: Option<Pos2>,
    /// Relative zoom: 1 = the map fits the panel.
    zoom: f32,
    texture: Option<TextureHandle>,
    field: Option<std::sync::Arc<Heightfield>>,
    /// Start of the river stroke being drawn.
    stroke_start: Option<Pos2>,
    /// Where the pointer last went down on the map (screen), for clicks.
    press_at: Option<Pos2>,
    /// Last point of the mask brush stroke being painted (map units).
    last_paint: Option<Pos2>,
    /// Start of the block drag in progress (map units).
    block_from: Option<Pos2>,
    mask_texture: Option<TextureHandle>,
    constraints_texture: Option<TextureHandle>,
    /// Drainage area and erosion depth ([`MapView::set_erosion_layers`]).
    erosion_textures: Option<[TextureHandle; 2]>,
    /// Counts [`Self::set_field`] calls, so other views know when the terrain changed.
    version: u64,
}

impl MapView {
    /// Shows `field` from now on, keeping the current view.
    pub fn set_field(
        &mut self,
        ctx: &egui::Context,
        field: std::sync::Arc<Heightfield>,
        image: egui::ColorImage,
    ) {
        match &mut self.texture {
            Some(texture) => texture.set(image, TextureOptions::LINEAR),
            None => {
                self.texture = Some(ctx.load_texture("terrain", image, TextureOptions::LINEAR));
            }
        }
        self.field = Some(field);
        self.version += 1;
    }

    pub fn field(&self) -> Option<&Heightfield> {
        self.field.as_deref()
    }

    /// Changes whenever the terrain shown changes.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Shows `mask` (magenta, opacity by value) over the terrain; `None` removes it.
    pub fn set_mask(&mut self, ctx: &egui::Context, mask: Option<&crate::wavelet::Mask>) {
        let Some(mask) = mask else {
            self.mask_texture = None;
            return;
        };
        let rgba: Vec<u8> = mask
            .values()
            .iter()
            .flat_map(|v| [230, 40, 200, (v * 150.0).round() as u8])
            .collect();
        let image = egui::ColorImage::from_rgba_unmultiplied([mask.width(), mask.height()], &rgba);
        match &mut self.mask_texture {
            Some(texture) => texture.set(image, TextureOptions::LINEAR),
            None => {
                self.mask_texture = Some(ctx.load_texture("mask", image, TextureOptions::LINEAR));
            }
        }
    }

    /// The skeleton's cells as an overlay image.
    pub fn set_constraints(&mut self, ctx: &egui::Context, image: egui::ColorImage) {
        match &mut self.constraints_texture {
            Some(texture) => texture.set(image, TextureOptions::NEAREST),
            None => {
                self.constraints_texture =
                    Some(ctx.load_texture("constraints", image, TextureOptions::NEAREST));
            }
        }
    }

    /// The erosion stage's drainage-area and erosion-depth images (`None`: no erosion ran).
    pub fn set_erosion_layers(
        &mut self,
        ctx: &egui::Context,
        images: Option<[egui::ColorImage; 2]>,
    ) {
        self.erosion_textures = images.map(|[drainage, depth]| {
            [("drainage area", drainage), ("erosion depth", depth)]
                .map(|(name, image)| ctx.load_texture(name, image, TextureOptions::LINEAR))
        });
    }

    /// Whether the map has the erosion stage's layers to show.
    pub fn has_erosion_layers(&self) -> bool {
        self.erosion_textures.is_some()
    }

    /// Back to the whole map, centred.
    pub fn reset(&mut self) {
        self.center = None;
        self.zoom = 1.0;
    }

    /// Draws the map and its overlay into the remaining space and handles the tools: pan
    /// (drag; with the river tool, drag with the secondary or middle button), zoom (scroll or
    /// pinch, about the pointer; double-click resets) and river strokes.
    pub fn show(&mut self, ui: &mut egui::Ui, tool: Tool, overlay: &Overlay) -> MapResponse {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        if self.zoom <= 0.0 {
            self.zoom = 1.0;
        }
        let fit = fit_scale(rect.size());
        let at = Placement {
            rect,
            center: *self.center.get_or_insert(pos2(0.5, 0.5)),
            scale: fit * self.zoom,
        };
        let out = self.interact(ui, &response, tool, at, fit);
        let painter = ui.painter_at(rect);
        self.draw_terrain(ui, &painter, at, overlay);
        draw_vectors(&painter, at, overlay);
        self.draw_pointer(&painter, &response, at, tool, overlay);
        out
    }

    /// What the pointer did this frame (strokes, clicks, paint, drags), and the pan and zoom
    /// it asked for (drawn from the next frame).
    fn interact(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        tool: Tool,
        at: Placement,
        fit: f32,
    ) -> MapResponse {
        let lines = tool.draws_lines();
        let painting = tool == Tool::Mask;
        let blocks = matches!(tool, Tool::Block | Tool::Select);
        let drawing =
            (lines || painting || blocks) && response.dragged_by(egui::PointerButton::Primary);
        let mut block_drag = None;
        if blocks {
            if response.drag_started_by(egui::PointerButton::Primary) {
                // Where the button went down, not where the drag was recognised.
                let origin = ui.input(|i| i.pointer.press_origin());
                self.block_from = origin
                    .or(response.interact_pointer_pos())
                    .map(|p| at.to_map(p));
            }
            if let Some(from) = self.block_from {
                let finished = response.drag_stopped();
                block_drag = Some(BlockDrag {
                    from,
                    delta: response.drag_delta() / at.scale,
                    finished,
                });
                if finished {
                    self.block_from = None;
                }
            }
        }
        let mut paint = None;
        let mut paint_finished = false;
        if painting {
            let primary_down = ui.input(|i| i.pointer.primary_down());
            if primary_down && (response.is_pointer_button_down_on() || self.last_paint.is_some()) {
                if let Some(p) = response.interact_pointer_pos().map(|p| at.to_map(p)) {
                    paint = Some((self.last_paint.unwrap_or(p), p));
                    self.last_paint = Some(p);
                }
            } else if self.last_paint.take().is_some() {
                paint_finished = true;
            }
        }
        let mut new_stroke = None;
        if response.is_pointer_button_down_on()
            && let Some(p) = response.interact_pointer_pos()
        {
            self.press_at = Some(p);
        }
        let select_click = (tool == Tool::Select && response.clicked())
            .then(|| self.press_at.map(|p| at.to_map(p)))
            .flatten();
        let clicked = (tool == Tool::Peak && response.clicked())
            .then(|| self.press_at.map(|p| at.to_map(p)))
            .flatten()
            .filter(|p| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y));
        if lines && response.drag_started_by(egui::PointerButton::Primary) {
            // Where the button went down, not where the drag was recognised (a few pixels
            // on): the estuary lands under the press.
            let origin = ui.input(|i| i.pointer.press_origin());
            self.stroke_start = origin
                .or(response.interact_pointer_pos())
                .map(|p| at.to_map(p));
        }
        if lines && response.drag_stopped_by(egui::PointerButton::Primary) {
            let end = response.interact_pointer_pos().map(|p| at.to_map(p));
            if let (Some(a), Some(b)) = (self.stroke_start.take(), end) {
                let clamp = |p: Pos2| pos2(p.x.clamp(0.0, 1.0), p.y.clamp(0.0, 1.0));
                if a.distance(b) > 0.02 {
                    new_stroke = Some((clamp(a), clamp(b)));
                }
            }
        }
        if response.dragged() && !drawing && self.stroke_start.is_none() {
            self.center = Some(at.center - response.drag_delta() / at.scale);
        }
        if response.double_clicked() {
            self.reset();
        }
        if let Some(pointer) = response.hover_pos() {
            let (scroll, pinch) = ui.input(|i| (i.smooth_scroll_delta().y, i.zoom_delta()));
            let factor = pinch * (scroll / 200.0).exp();
            if factor != 1.0 {
                let before = at.to_map(pointer);
                self.zoom = (self.zoom * factor).clamp(MIN_ZOOM, MAX_ZOOM);
                let new_scale = fit * self.zoom;
                // Keep the map point under the pointer fixed.
                self.center = Some(before - (pointer - at.rect.center()) / new_scale);
            }
        }

        MapResponse {
            hover: response.hover_pos().map(|pointer| {
                let map = at.to_map(pointer);
                Hover {
                    map,
                    height: self.height_at(map),
                }
            }),
            new_stroke,
            clicked,
            paint,
            paint_finished,
            block_drag,
            select_click,
            pick_tolerance: 10.0 / at.scale,
        }
    }

    /// The terrain's picture and its raster overlays (constraints, erosion layers, contours,
    /// mask), and the map's frame.
    fn draw_terrain(
        &self,
        ui: &mut egui::Ui,
        painter: &egui::Painter,
        at: Placement,
        overlay: &Overlay,
    ) {
        painter.rect_filled(at.rect, 0.0, ui.visuals().extreme_bg_color);
        let map_rect =
            Rect::from_min_max(at.to_screen(pos2(0.0, 0.0)), at.to_screen(pos2(1.0, 1.0)));
        match &self.texture {
            Some(texture) => {
                let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
                if overlay.show_relief {
                    painter.image(texture.id(), map_rect, uv, Color32::WHITE);
                } else {
                    painter.rect_filled(map_rect, 0.0, Color32::from_gray(235));
                }
                if let (true, Some(points)) = (overlay.show_constraints, &self.constraints_texture)
                {
                    painter.image(points.id(), map_rect, uv, Color32::WHITE);
                }
                if let Some([drainage, depth]) = &self.erosion_textures {
                    if overlay.show_erosion_depth {
                        painter.image(depth.id(), map_rect, uv, Color32::WHITE);
                    }
                    if overlay.show_drainage {
                        painter.image(drainage.id(), map_rect, uv, Color32::WHITE);
                    }
                }
                if overlay.show_contours {
                    let line = Stroke::new(0.8, Color32::from_rgba_unmultiplied(60, 40, 20, 170));
                    for (a, b) in &overlay.contours {
                        painter.line_segment([at.to_screen(*a), at.to_screen(*b)], line);
                    }
                }
                if let (true, Some(mask)) = (overlay.show_mask, &self.mask_texture) {
                    painter.image(mask.id(), map_rect, uv, Color32::WHITE);
                }
            }
            None => {
                let text = match &overlay.building {
                    Some((progress, doing)) => format!(
                        "Building the terrain: {:.0}%\n{doing}",
                        100.0 * progress.clamp(0.0, 1.0)
                    ),
                    None => "No terrain yet".to_owned(),
                };
                // A label (not painted text), so the words are read out and tests find
                // them; it senses nothing, so strokes drawn across it reach the map.
                let label =
                    egui::Label::new(egui::RichText::new(text).size(16.0).weak()).selectable(false);
                ui.put(
                    Rect::from_center_size(at.rect.center(), egui::vec2(420.0, 60.0)),
                    label,
                );
            }
        }
        painter.rect_stroke(
            map_rect,
            0.0,
            Stroke::new(1.0, ui.visuals().widgets.noninteractive.bg_stroke.color),
            StrokeKind::Outside,
        );
    }

    /// The stroke being drawn and the brush under the pointer.
    fn draw_pointer(
        &self,
        painter: &egui::Painter,
        response: &egui::Response,
        at: Placement,
        tool: Tool,
        overlay: &Overlay,
    ) {
        let stroke_style = Stroke::new(2.0, Color32::from_rgb(255, 200, 40));
        if let (Some(a), Some(pointer)) = (self.stroke_start, response.interact_pointer_pos()) {
            arrow(painter, &[at.to_screen(a), pointer], stroke_style);
        }
        if let (true, Some(radius), Some(pointer)) = (
            tool == Tool::Mask,
            overlay.brush_radius,
            response.hover_pos(),
        ) {
            let ring = Stroke::new(1.5, Color32::from_rgb(230, 40, 200));
            painter.circle_stroke(pointer, radius * at.scale, ring);
        }
    }

    /// Height at a map position (nearest cell), `None` outside the map or without terrain.
    fn height_at(&self, map: Pos2) -> Option<f32> {
        let field = self.field.as_deref()?;
        if !(0.0..=1.0).contains(&map.x) || !(0.0..=1.0).contains(&map.y) {
            return None;
        }
        let cell = |u: f32, n: usize| ((u * n as f32) as usize).min(n - 1);
        field
            .get(cell(map.x, field.width()), cell(map.y, field.height()))
            .filter(|h| h.is_finite())
    }
}

/// A river's course from the estuary (its first point, a dot) to the flow point (its last,
/// with a small fixed-size head pointing along the course's last piece).
fn arrow(painter: &egui::Painter, course: &[Pos2], stroke: Stroke) {
    let (Some(&a), Some(&b)) = (course.first(), course.last()) else {
        return;
    };
    painter.add(egui::Shape::line(course.to_vec(), stroke));
    let before = course.iter().rev().nth(1).copied().unwrap_or(a);
    let dir = (b - before).normalized();
    if dir.is_finite() {
        let back = -dir * 10.0;
        let side = egui::vec2(-dir.y, dir.x) * 5.0;
        painter.line_segment([b, b + back + side], stroke);
        painter.line_segment([b, b + back - side], stroke);
    }
    painter.circle_filled(a, 3.5, stroke.color);
}

/// Screen points per map unit at zoom 1 for a panel of `size`: the map fits with a margin.
pub fn fit_scale(size: Vec2) -> f32 {
    size.x.min(size.y).max(1.0) * 0.95
}

#[cfg(test)]
mod tests {
    use super::*;
    use egui::vec2;

    #[test]
    fn fit_uses_the_shorter_side() {
        assert_eq!(fit_scale(vec2(800.0, 400.0)), 380.0);
    }
}

/// Where the map sits on the screen this frame: its rectangle, the map point at its centre
/// and screen points per map unit.
#[derive(Clone, Copy)]
struct Placement {
    rect: Rect,
    center: Pos2,
    scale: f32,
}

impl Placement {
    fn to_screen(self, map: Pos2) -> Pos2 {
        self.rect.center() + (map - self.center) * self.scale
    }

    fn to_map(self, screen: Pos2) -> Pos2 {
        self.center + (screen - self.rect.center()) / self.scale
    }
}

/// The vector overlays: ridges, rivers by order, the sketch, blocks, the selection and the
/// drawn strokes.
fn draw_vectors(painter: &egui::Painter, at: Placement, overlay: &Overlay) {
    if overlay.show_ridges {
        let ridge = Stroke::new(1.0, Color32::from_rgb(200, 60, 50));
        for (a, b) in &overlay.ridges {
            painter.line_segment([at.to_screen(*a), at.to_screen(*b)], ridge);
        }
    }
    if overlay.show_rivers {
        // Thin lines that widen with the order, so the relief leads.
        for (a, b, order) in overlay
            .rivers
            .iter()
            .filter(|r| r.2 >= overlay.min_river_order)
        {
            let width = 0.5 + 0.35 * (*order + 1 - overlay.min_river_order) as f32;
            let stroke = Stroke::new(width, Color32::from_rgb(40, 110, 220));
            painter.line_segment([at.to_screen(*a), at.to_screen(*b)], stroke);
        }
    }
    let sketch_ridge = Stroke::new(2.5, Color32::from_rgb(150, 70, 30));
    for (a, b) in &overlay.sketch_ridges {
        painter.line_segment([at.to_screen(*a), at.to_screen(*b)], sketch_ridge);
    }
    let sketch_valley = Stroke::new(2.5, Color32::from_rgb(30, 190, 200));
    for (a, b) in &overlay.sketch_valleys {
        painter.line_segment([at.to_screen(*a), at.to_screen(*b)], sketch_valley);
    }
    for p in &overlay.peaks {
        let c = at.to_screen(*p);
        let tri = vec![
            c + egui::vec2(0.0, -7.0),
            c + egui::vec2(6.0, 5.0),
            c + egui::vec2(-6.0, 5.0),
        ];
        painter.add(egui::Shape::convex_polygon(
            tri,
            Color32::from_rgb(120, 60, 20),
            Stroke::new(1.0, Color32::WHITE),
        ));
    }
    let blocks: &[(Rect, bool)] = if overlay.show_blocks {
        &overlay.blocks
    } else {
        &[]
    };
    for (block, selected) in blocks {
        let r = Rect::from_min_max(at.to_screen(block.min), at.to_screen(block.max));
        let color = if *selected {
            Color32::from_rgb(255, 235, 60)
        } else {
            Color32::from_rgb(190, 170, 60)
        };
        painter.rect_stroke(r, 0.0, Stroke::new(2.0, color), StrokeKind::Middle);
        if *selected {
            // The resize handle at the south-east corner.
            painter.rect_filled(Rect::from_center_size(r.max, Vec2::splat(10.0)), 1.0, color);
        }
    }
    if !overlay.selected.is_empty() {
        let halo = Stroke::new(5.0, Color32::from_rgba_unmultiplied(255, 255, 255, 200));
        let screen: Vec<Pos2> = overlay.selected.iter().map(|p| at.to_screen(*p)).collect();
        if let [only] = screen.as_slice() {
            painter.circle_stroke(*only, 9.0, halo);
        } else {
            painter.add(egui::Shape::line(screen, halo));
        }
    }
    let stroke_style = Stroke::new(2.0, Color32::from_rgb(255, 200, 40));
    for course in &overlay.strokes {
        let screen: Vec<Pos2> = course.iter().map(|p| at.to_screen(*p)).collect();
        arrow(painter, &screen, stroke_style);
    }
}
