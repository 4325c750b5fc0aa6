//! The frame: keys, the side panel, the view switch, and the central area (the map with its
//! overlays and tools, or the 3D view).

use egui::pos2;

use super::map_view::Tool;
use super::{StrahlerApp, ViewKind, blend, side_panel, status_bar};
use crate::scene::{Edit, LineKind, RiverStroke};

impl StrahlerApp {
    /// Shows the terrain before or after erosion, as the Erosion section's toggle asks.
    fn switch_before_after(&mut self, ctx: &egui::Context) {
        let want = self.panels.erosion.show_before && self.session.scene().erosion.is_some();
        if want == self.canvas.showing_before {
            return;
        }
        let picture = match &self.canvas.pictures {
            Some((_, Some(before))) if want => before.clone(),
            Some((after, _)) if !want => after.clone(),
            _ => return,
        };
        self.canvas.showing_before = want;
        self.show_picture(ctx, picture);
    }

    /// The bar above the central area that switches between the map and the 3D view.
    fn view_switch(&mut self, ui: &mut egui::Ui) {
        egui::Panel::top("views").show(ui, |ui| {
            ui.horizontal(|ui| {
                let mut view = self.view;
                ui.selectable_value(&mut view, ViewKind::Map, "2D map (2)");
                ui.selectable_value(&mut view, ViewKind::ThreeD, "3D view (3)");
                if view != self.view {
                    self.set_view(view);
                }
            });
        });
    }
}

impl eframe::App for StrahlerApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.poll_jobs(&ctx);
        let frame_cpu_ms = frame.info().cpu_usage.map(|s| s * 1e3);
        self.automation.update(|s| s.frame_cpu_ms = frame_cpu_ms);
        self.keys(&ctx);
        status_bar::show(ui, self);
        side_panel::show(ui, self);
        self.switch_before_after(&ctx);
        self.view_switch(ui);
        self.export_window(&ctx);
        if self.view == ViewKind::ThreeD {
            self.view3d_area(ui, frame);
            return;
        }
        for file in ctx.input(|i| i.raw.dropped_files.clone()) {
            self.start_import(&ctx, file);
        }
        self.sync_overlay();
        self.map_area(ui, &ctx);
    }
}

impl StrahlerApp {
    /// The keys: 2 and 3 switch views; on the map, the tools' letters, U (upload), E
    /// (export), Delete (the selected item); everywhere, undo and redo.
    fn keys(&mut self, ctx: &egui::Context) {
        if !ctx.egui_wants_keyboard_input() {
            let (map, three_d) = ctx.input(|i| {
                (
                    i.key_pressed(egui::Key::Num2),
                    i.key_pressed(egui::Key::Num3),
                )
            });
            if map {
                self.set_view(ViewKind::Map);
            }
            if three_d {
                self.set_view(ViewKind::ThreeD);
            }
        }
        // The map's tool keys; the 3D view uses letters to fly.
        if !ctx.egui_wants_keyboard_input() && self.view == ViewKind::Map {
            ctx.input(|i| {
                if i.key_pressed(egui::Key::R) {
                    self.canvas.tool = Tool::River;
                }
                if i.key_pressed(egui::Key::P) {
                    self.canvas.tool = Tool::Pan;
                }
                if i.key_pressed(egui::Key::D) {
                    self.canvas.tool = Tool::Ridge;
                }
                if i.key_pressed(egui::Key::V) {
                    self.canvas.tool = Tool::Valley;
                }
                if i.key_pressed(egui::Key::K) {
                    self.canvas.tool = Tool::Peak;
                }
                if i.key_pressed(egui::Key::M) {
                    self.canvas.tool = Tool::Mask;
                }
                if i.key_pressed(egui::Key::B) {
                    self.canvas.tool = Tool::Block;
                }
                if i.key_pressed(egui::Key::S) {
                    self.canvas.tool = Tool::Select;
                }
            });
            if ctx.input(|i| i.key_pressed(egui::Key::U)) {
                blend::upload(self);
            }
            if ctx.input(|i| i.key_pressed(egui::Key::E)) {
                self.export.dialog.open = true;
            }
        }
        if !ctx.egui_wants_keyboard_input() {
            if self.canvas.selected.is_some()
                && ctx.input(|i| {
                    i.key_pressed(egui::Key::Delete) || i.key_pressed(egui::Key::Backspace)
                })
            {
                self.delete_selected();
            }
            let (undo, redo) = ctx.input_mut(|i| {
                let redo = i.consume_key(
                    egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
                    egui::Key::Z,
                ) || i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y);
                (i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z), redo)
            });
            if undo {
                self.undo();
            }
            if redo {
                self.redo();
            }
        }
    }

    /// The 3D view and its settings.
    fn view3d_area(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        egui::Panel::right("view3d settings").show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.view3d.settings_ui(ui));
        });
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let field = self
                .canvas
                .map
                .field()
                .map(|f| (f, self.canvas.map.version()));
            let rivers = self.session.output().map(|o| {
                let s = &o.hydrology.skeleton;
                (s.courses.as_slice(), s.size)
            });
            let cell = self.session.output().map_or(1.0, |o| o.cell_m as f32);
            // The 3D view's rasters on the GPU it draws with, where that pays (or where
            // a script asked).
            let gpu = self.view3d.maps().pick(self.path.gpu());
            // The terrain on the GPU too, if the pipeline left it there.
            let on_gpu = self
                .session
                .output()
                .filter(|o| {
                    self.canvas
                        .map
                        .field()
                        .is_some_and(|f| std::ptr::eq(f, &*o.field))
                })
                .and_then(|o| o.gpu.as_ref());
            self.view3d
                .show(ui, frame, field, on_gpu, rivers, cell, gpu);
        });
        let status = self.view3d.status();
        self.automation.update(|s| s.view3d = status);
    }

    /// The overlays as the layers, the tool and the scene ask.
    fn sync_overlay(&mut self) {
        let l = self.canvas.layers;
        self.canvas.overlay.show_rivers = l.rivers;
        self.canvas.overlay.min_river_order = l.min_river_order;
        self.canvas.overlay.show_ridges = l.ridges;
        self.canvas.overlay.show_mask = l.mask || self.canvas.tool == Tool::Mask;
        self.canvas.overlay.show_relief = l.relief;
        self.canvas.overlay.show_contours = l.contours;
        self.canvas.overlay.show_constraints = l.constraints;
        self.canvas.overlay.show_drainage = l.drainage;
        self.canvas.overlay.show_erosion_depth = l.erosion_depth;
        self.canvas.overlay.show_blocks = l.blocks || self.canvas.tool == Tool::Block;
        self.canvas.overlay.building = self.session.job().map(|j| (j.progress(), j.message()));
        self.canvas.overlay.brush_radius =
            Some(self.panels.mask.brush.radius / self.canvas.mask.width().max(2) as f32);
        self.canvas.courses.refresh(self.session.scene());
        self.canvas.overlay.selected = if self.canvas.tool == Tool::Select {
            self.selected_points()
        } else {
            Vec::new()
        };
        self.canvas.overlay.blocks = self
            .session
            .scene()
            .blend
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let [x0, y0, x1, y1] = b.rect.map(|v| v as f32);
                (
                    egui::Rect::from_min_max(pos2(x0, y0), pos2(x1, y1)),
                    self.blend.selected == Some(i),
                )
            })
            .collect();
        let p = |v: &[f64; 2]| pos2(v[0] as f32, v[1] as f32);
        self.canvas.overlay.strokes = self
            .canvas
            .courses
            .of(self.session.scene())
            .iter()
            .map(|course| {
                course
                    .iter()
                    .map(|c| pos2(c.x as f32, c.y as f32))
                    .collect()
            })
            .collect();
        let segments = |lines: &[crate::scene::SketchLine]| {
            lines
                .iter()
                .flat_map(|l| {
                    l.points
                        .windows(2)
                        .map(|w| (p(&w[0]), p(&w[1])))
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        };
        let sketch = &self.session.scene().sketch;
        self.canvas.overlay.sketch_ridges = segments(&sketch.ridges);
        self.canvas.overlay.sketch_valleys = segments(&sketch.valleys);
        self.canvas.overlay.peaks = sketch.peaks.iter().map(|k| p(&k.at)).collect();
    }

    /// The map, and what the pointer did on it: strokes, clicks, paint, drags, selections.
    fn map_area(&mut self, ui: &mut egui::Ui, ctx: &egui::Context) {
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let response = self
                .canvas
                .map
                .show(ui, self.canvas.tool, &self.canvas.overlay);
            self.canvas.hover = response.hover;
            if let Some((a, b)) = response.paint {
                self.paint_mask(ctx, a, b);
            }
            if response.paint_finished {
                self.finish_mask_stroke(ctx);
            }
            if let Some(drag) = response.block_drag {
                if self.canvas.tool == Tool::Select {
                    self.drag_item(drag, response.pick_tolerance);
                } else {
                    self.drag_block(drag);
                }
            }
            if let Some(at) = response.select_click {
                self.select_at(at, response.pick_tolerance);
            }
            let d = |q: egui::Pos2| [f64::from(q.x), f64::from(q.y)];
            if let Some((a, b)) = response.new_stroke {
                use crate::scene::SketchLine;
                let line = SketchLine {
                    points: vec![d(a), d(b)],
                    height: None,
                    heights: None,
                };
                let edit = match self.canvas.tool {
                    Tool::Ridge => Edit::AddLine {
                        kind: LineKind::Ridge,
                        line,
                    },
                    Tool::Valley => Edit::AddLine {
                        kind: LineKind::Valley,
                        line,
                    },
                    _ => {
                        let last = self
                            .session
                            .scene()
                            .rivers
                            .last()
                            .copied()
                            .unwrap_or_else(|| super::default_stroke().into());
                        Edit::AddRiver(RiverStroke {
                            estuary: d(a),
                            toward: d(b),
                            ..last
                        })
                    }
                };
                self.edit(edit);
            }
            if let Some(at) = response.clicked {
                self.edit(Edit::AddPeak(crate::scene::SketchPeak {
                    at: d(at),
                    height: None,
                }));
            }
        });
    }
}
