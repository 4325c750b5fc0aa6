//! The design's parameters (under Advanced): the hydrology paper's branching angle, river
//! slope, the courses' wander and meanders, ridge slope, noise and enrichment (with its symbols in tooltips). The grid, the
//! seed and the terrain type are in the Start section ([`super::StartPanel`]).

use egui::{DragValue, RichText};

use super::Action;
use crate::scene::{Edit, Params, Scene};

/// The design's parameters (it keeps no state of its own).
#[derive(Default)]
pub struct TerrainPanel;

impl TerrainPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, scene: &Scene) -> Vec<Action> {
        ui.label(RichText::new("Design").strong()).on_hover_text(
            "The hydrology paper's parameters (seed paper 000): how the river networks branch, \
             how steep rivers and ridges are, and the noise and enrichment of the skeleton.",
        );
        let mut params = scene.params;
        edit_params(ui, &mut params);
        if params == scene.params {
            return Vec::new();
        }
        vec![Action::Edit(Edit::SetParams(params))]
    }
}

/// The parameters' widgets on a copy of the scene's.
fn edit_params(ui: &mut egui::Ui, params: &mut Params) {
    egui::Grid::new("design parameters")
        .num_columns(2)
        .show(ui, |ui| {
            let label = ui
                .label("θ (°)")
                .on_hover_text("Branching angle theta: exterior links turn theta or 2 theta.");
            ui.add(
                DragValue::new(&mut params.theta)
                    .range(5.0..=60.0)
                    .speed(0.5),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("River slope")
                .on_hover_text("Metres of height per metre of channel (Sec. IV-C).");
            ui.add(
                DragValue::new(&mut params.river_slope)
                    .range(0.0..=0.2)
                    .speed(0.001),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("Wander").on_hover_text(
                "How far each drawn river's course bends away from the straight stroke: the \
                 standard deviation of its sideways offset, in stroke lengths (0: straight). \
                 The estuary and the stroke's end stay where drawn.",
            );
            ui.add(
                DragValue::new(&mut params.wander)
                    .range(0.0..=crate::river::course::MAX_WANDER)
                    .speed(0.002),
            )
            .labelled_by(label.id);
            ui.end_row();
            meander_rows(ui, &mut params.meanders);
            let label = ui.label("α").on_hover_text(
                "alpha of eq. 4: ridge metres per metre of distance to the nearest river node.",
            );
            ui.add(
                DragValue::new(&mut params.alpha)
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
                DragValue::new(&mut params.noise.amplitude)
                    .range(0.0..=500.0)
                    .speed(1.0),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("Octaves")
                .on_hover_text("Octaves of the fractal noise of eq. 5 (1 to 16).");
            ui.add(DragValue::new(&mut params.noise.octaves).range(1..=16))
                .labelled_by(label.id);
            ui.end_row();
            let label = ui
                .label("Roughness")
                .on_hover_text("Amplitude ratio between successive octaves of eq. 5's noise.");
            ui.add(
                DragValue::new(&mut params.noise.roughness)
                    .range(0.0..=1.0)
                    .speed(0.01),
            )
            .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("MD/MDI passes").on_hover_text(
                "Midpoint displacement and its inverse (Sec. V-B): each pass widens rivers and \
                 ridges by a cell of flank. 0 turns enrichment off.",
            );
            ui.add(DragValue::new(&mut params.enrich.passes).range(0..=16))
                .labelled_by(label.id);
            ui.end_row();
            let label = ui.label("L (cells)").on_hover_text(
                "Distance limit L. From the skeleton: no point is added farther than L cells \
                 from the rivers and ridges. Between points (the paper as written): no point \
                 is interpolated from points more than L cells apart; on 3 x 3 squares that \
                 limits nothing from L = 3, and the passes alone bound the flanks.",
            );
            ui.horizontal(|ui| {
                ui.add(DragValue::new(&mut params.enrich.distance_limit).range(1..=64))
                    .labelled_by(label.id);
                use crate::skeleton::enrich::DistanceRule;
                let rule = &mut params.enrich.distance_rule;
                ui.selectable_value(rule, DistanceRule::Skeleton, "from skeleton");
                ui.selectable_value(rule, DistanceRule::Points, "between points");
            });
            ui.end_row();
        });
}

/// The meanders' two rows of the design grid: the largest angle and the wavelength.
fn meander_rows(ui: &mut egui::Ui, meanders: &mut crate::river::hydraulic::Meanders) {
    use crate::river::hydraulic::{MAX_ANGLE_DEG, WAVELENGTH_WIDTHS};
    let label = ui.label("Meanders (°)").on_hover_text(
        "Loops of the drawn rivers' channels on their floodplains: the largest angle between \
         the channel and its valley (0: none; 40 gently sinuous, 70 about 1.5 times the \
         valley's length, 90 twice). Loops show where the map has at least 12 cells a \
         wavelength: the lower reaches, and more of them on larger maps.",
    );
    ui.add(
        DragValue::new(&mut meanders.angle_deg)
            .range(0.0..=MAX_ANGLE_DEG)
            .speed(0.5),
    )
    .labelled_by(label.id);
    ui.end_row();
    let label = ui.label("λ (widths)").on_hover_text(
        "The meanders' wavelength: one loop's length along the valley, in channel widths \
         (real rivers 10 to 14). Channel widths follow the drainage area, so loops grow \
         downstream.",
    );
    ui.add(
        DragValue::new(&mut meanders.wavelength_widths)
            .range(WAVELENGTH_WIDTHS)
            .speed(0.1),
    )
    .labelled_by(label.id);
    ui.end_row();
}
