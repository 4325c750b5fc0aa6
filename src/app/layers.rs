//! Map layers the user toggles: shaded relief, contour lines, rivers by Strahler order,
//! ridges, the skeleton's constraint and enriched cells, the detail mask, DEM blocks.

use egui::{Color32, ColorImage, Pos2, pos2};

use crate::heightfield::Heightfield;
use crate::skeleton::CellKind;

/// Which layers are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layers {
    pub relief: bool,
    pub contours: bool,
    pub rivers: bool,
    pub ridges: bool,
    pub constraints: bool,
    pub mask: bool,
    pub blocks: bool,
    /// The erosion stage's drainage area (log scale) and erosion depth.
    pub drainage: bool,
    pub erosion_depth: bool,
    /// Rivers are drawn from this Strahler order up (creeks would hide the relief).
    pub min_river_order: u32,
}

impl Default for Layers {
    fn default() -> Self {
        Self {
            relief: true,
            contours: false,
            rivers: true,
            ridges: false,
            constraints: false,
            mask: true,
            blocks: true,
            drainage: false,
            erosion_depth: false,
            min_river_order: 3,
        }
    }
}

/// Contours are traced on at most this many cells per side (the terrain is sampled), which
/// bounds the cost (O(side^2)) and the number of segments drawn.
const CONTOUR_SIDE: usize = 512;

/// A "nice" contour interval (1, 2 or 5 times a power of ten) giving about 20 levels.
pub fn contour_interval(range: f32) -> f32 {
    let raw = (range / 20.0).max(1e-6);
    let power = 10f32.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&step| step >= raw)
        .unwrap_or(10.0 * power)
}

/// Contour segments (map units) of `field` every `interval` metres, by marching squares on a
/// grid of at most [`CONTOUR_SIDE`] cells per side. O(cells sampled).
pub fn contours(field: &Heightfield, interval: f32) -> Vec<(Pos2, Pos2)> {
    let (w, h) = (field.width(), field.height());
    if w < 2 || h < 2 || interval.is_nan() || interval <= 0.0 {
        return Vec::new();
    }
    let (sw, sh) = (w.min(CONTOUR_SIDE), h.min(CONTOUR_SIDE));
    let sample = |i: usize, j: usize| {
        let x = i * (w - 1) / (sw - 1);
        let y = j * (h - 1) / (sh - 1);
        field.data()[y * w + x]
    };
    let grid: Vec<f32> = (0..sh)
        .flat_map(|j| (0..sw).map(move |i| (i, j)))
        .map(|(i, j)| sample(i, j))
        .collect();
    let at = |i: usize, j: usize| grid[j * sw + i];
    let to_map = |x: f32, y: f32| pos2(x / (sw - 1) as f32, y / (sh - 1) as f32);
    let mut out = Vec::new();
    for j in 0..sh - 1 {
        for i in 0..sw - 1 {
            let c = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            if c.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let lo = c.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = c.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let mut level = (lo / interval).ceil() * interval;
            while level <= hi {
                // Corners (x, y) in order around the square; edge k joins corner k and k + 1.
                let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
                let mut crossings = Vec::with_capacity(4);
                for k in 0..4 {
                    let (a, b) = (c[k], c[(k + 1) % 4]);
                    if (a < level) != (b < level) {
                        let t = (level - a) / (b - a);
                        let (p, q) = (corners[k], corners[(k + 1) % 4]);
                        crossings.push(to_map(
                            i as f32 + p.0 + t * (q.0 - p.0),
                            j as f32 + p.1 + t * (q.1 - p.1),
                        ));
                    }
                }
                for pair in crossings.chunks_exact(2) {
                    out.push((pair[0], pair[1]));
                }
                level += interval;
            }
        }
    }
    out
}

/// The skeleton's cells as an overlay: rivers blue, ridges red, sketched valleys cyan,
/// enriched points orange; other cells transparent.
pub fn constraints_image(kinds: &[CellKind], width: usize, height: usize) -> ColorImage {
    let pixels = kinds
        .iter()
        .map(|k| match k {
            CellKind::Free => Color32::TRANSPARENT,
            CellKind::River | CellKind::Grown => Color32::from_rgb(30, 90, 255),
            CellKind::Ridge => Color32::from_rgb(220, 40, 30),
            CellKind::Valley => Color32::from_rgb(30, 200, 210),
            CellKind::Enriched => Color32::from_rgb(255, 150, 20),
            CellKind::Floor => Color32::from_rgb(120, 170, 255),
        })
        .collect();
    ColorImage::new([width, height], pixels)
}

/// The erosion stage's layers as map overlays: drainage area in blue, opaque where water
/// gathers (log scale: the channel network stands out down to the smallest gullies), and
/// erosion depth in red, opaque where the cut is deepest. O(cells).
pub fn erosion_images(eroded: &crate::erosion::Eroded, before: &Heightfield) -> [ColorImage; 2] {
    let size = [eroded.field.width(), eroded.field.height()];
    let drainage = crate::erosion::drainage_grey(eroded)
        .into_iter()
        .map(|g| {
            let t = f32::from(g.saturating_sub(1)) / 254.0;
            Color32::from_rgba_unmultiplied(20, 90, 230, (235.0 * t * t).round() as u8)
        })
        .collect();
    let depth = crate::erosion::depth_grey(eroded, before)
        .into_iter()
        .map(|g| Color32::from_rgba_unmultiplied(210, 40, 20, (f32::from(g) * 0.85) as u8))
        .collect();
    [
        ColorImage::new(size, drainage),
        ColorImage::new(size, depth),
    ]
}

/// The Layers row of the side panel; `eroded` offers the erosion stage's layers.
pub fn section(ui: &mut egui::Ui, layers: &mut Layers, eroded: bool) {
    ui.horizontal_wrapped(|ui| {
        ui.label("Layers:");
        ui.checkbox(&mut layers.relief, "relief");
        ui.checkbox(&mut layers.contours, "contours");
        ui.checkbox(&mut layers.rivers, "rivers");
        if layers.rivers {
            let label = ui.label("from order").on_hover_text(
                "Rivers of lower Strahler order are not drawn (1 draws every creek)",
            );
            ui.add(egui::DragValue::new(&mut layers.min_river_order).range(1..=12))
                .labelled_by(label.id);
        }
        ui.checkbox(&mut layers.ridges, "ridges");
        ui.checkbox(&mut layers.constraints, "constraints")
            .on_hover_text("Skeleton cells: rivers, ridges, valleys, and MD/MDI enriched points");
        ui.checkbox(&mut layers.mask, "mask");
        ui.checkbox(&mut layers.blocks, "DEM blocks");
        if eroded {
            ui.checkbox(&mut layers.drainage, "drainage area")
                .on_hover_text(
                    "Where water gathers (log scale of the upstream area), from the erosion stage",
                );
            ui.checkbox(&mut layers.erosion_depth, "erosion depth")
                .on_hover_text("How deep erosion cut into the designed terrain");
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_are_nice_and_a_cone_gives_closed_rings() {
        assert_eq!(contour_interval(1000.0), 50.0);
        assert_eq!(contour_interval(90.0), 5.0);
        let n = 41;
        let cone: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 20.0, (i / n) as f32 - 20.0);
                100.0 - (x * x + y * y).sqrt()
            })
            .collect();
        let field = Heightfield::from_vec(n, n, cone).unwrap();
        let segments = contours(&field, 5.0);
        assert!(!segments.is_empty());
        // Every segment of the 90 m ring lies 10 cells from the centre.
        for (a, b) in &segments {
            for p in [a, b] {
                let r = ((p.x - 0.5).powi(2) + (p.y - 0.5).powi(2)).sqrt() * 40.0;
                let level = 100.0 - r;
                let nearest = (level / 5.0).round() * 5.0;
                assert!(
                    (level - nearest).abs() < 0.6,
                    "point at {r} cells, level {level}"
                );
            }
        }
    }
}
