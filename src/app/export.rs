//! The app's side of exports: what the export dialog (`panels::ExportDialog`) is told of
//! the terrain, and the export jobs it and scripts start (`crate::export` through
//! `pipeline::ExportSource`). A job reports its progress in the status bar, file by file
//! and within each (every pass over the cells ticks), and keeps the page answering. In the
//! browser a heightmap and its sidecar download as they are and more files as one zip, made
//! in the job too; natively each is saved in the working directory under a stem no file
//! there has yet.

use std::sync::{Arc, Weak};

use super::StrahlerApp;
use super::panels::{ExportDialog, ExportInfo};
use crate::export::{File, Request};
use crate::heightfield::Heightfield;
use crate::jobs::JobHandle;
use crate::pipeline::LayerPng;

/// The export dialog and the exports being made.
#[derive(Default)]
pub(super) struct Exports {
    pub dialog: ExportDialog,
    pub running: Vec<Exporting>,
    /// The height range of the terrain the dialog last showed (held weakly, so an old
    /// terrain is not kept alive), so an open dialog does not scan every cell each frame.
    range: Option<(Weak<Heightfield>, (f32, f32))>,
}

/// An export job and where its files go.
pub(super) struct Exporting {
    pub job: JobHandle<Result<Vec<File>, String>>,
    to: Destination,
}

enum Destination {
    /// Saved (natively) or downloaded (in the browser), with the layers asked for; `files`:
    /// how many the request writes (a zip holds them in the browser).
    Save {
        stem: String,
        layers: Vec<LayerPng>,
        files: usize,
    },
    /// Kept for the script whose command had this number.
    Script(u64),
}

impl StrahlerApp {
    /// What the export dialog shows of the terrain on the map, once there is one.
    pub(super) fn export_info(&mut self) -> Option<ExportInfo> {
        let output = self.session.output()?;
        let range = match &self.export.range {
            Some((field, range)) if Weak::ptr_eq(field, &Arc::downgrade(&output.field)) => *range,
            _ => {
                let range = output.field.finite_range().unwrap_or((0.0, 0.0));
                self.export.range = Some((Arc::downgrade(&output.field), range));
                range
            }
        };
        let output = self.session.output()?;
        let scene = self.session.scene();
        Some(ExportInfo {
            native: output.field.width(),
            cell_m: output.cell_m,
            range,
            preview_of: self.showing_preview().then_some(scene.size),
            vertical_scale: scene.vertical_scale as f32,
            textures: scene.textures,
        })
    }

    /// Shows the export dialog when open (with nothing to export, says so instead).
    pub(super) fn export_window(&mut self, ctx: &egui::Context) {
        if !self.export.dialog.open {
            return;
        }
        let Some(info) = self.export_info() else {
            self.export.dialog.open = false;
            self.set_error("Nothing to export yet: draw a river first.".into());
            return;
        };
        for action in self.export.dialog.show(ctx, &info) {
            self.act(ctx, action);
        }
    }

    /// Saves the plan of a world of the scene in tiles (`strahler build plan.json` builds
    /// it on one machine or a batch engine).
    pub(super) fn save_world_plan(&mut self, size: usize, tile: usize, fill: bool) {
        let scene = self.session.scene().clone();
        let saved = crate::world::Plan::new(&scene, size, tile, None)
            .map_err(|e| e.to_string())
            .and_then(|plan| {
                let plan = if fill { plan.with_fill() } else { plan };
                let stem = super::files::free_stem("strahler-world-plan", &[".json"]);
                let name = format!("{stem}.json");
                super::files::save(&name, "application/json", plan.to_json().as_bytes())
                    .map(|said| (said, name))
            });
        match saved {
            Ok((said, name)) => {
                self.messages.notice = Some(format!(
                    "World plan {said}: build it with `strahler build {name} --out world`"
                ))
            }
            Err(problem) => self.set_error(format!("The world plan: {problem}")),
        }
    }

    /// Builds the preview of a world of the scene in tiles (its global build, the bytes
    /// `strahler build`'s first task writes as `preview.tif`) in an export job, and saves it.
    pub(super) fn save_world_preview(&mut self, ctx: &egui::Context, size: usize, tile: usize) {
        let scene = self.session.scene().clone();
        let plan = match crate::world::Plan::new(&scene, size, tile, None) {
            Ok(plan) => plan,
            Err(problem) => return self.set_error(format!("The world preview: {problem}")),
        };
        let stem = super::files::free_stem("strahler-world-preview", &[".tif"]);
        let name = format!("{stem}.tif");
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "world preview",
            move |job| async move {
                let global = crate::world::task::build_global(&plan, &job)
                    .await
                    .map_err(|e| e.to_string())?;
                Ok(vec![File {
                    name,
                    mime: "image/tiff",
                    bytes: global.preview,
                }])
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(job) => self.export.running.push(Exporting {
                job,
                to: Destination::Save {
                    stem,
                    layers: Vec::new(),
                    files: 1,
                },
            }),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    /// Starts exporting `request` for the dialog (and the skeleton's layers with `layers`).
    pub(super) fn download(&mut self, ctx: &egui::Context, mut request: Request, layers: bool) {
        let suffixes: Vec<String> = request
            .names()
            .iter()
            .map(|n| n[request.stem.len()..].to_owned())
            .chain(std::iter::once(".zip".to_owned()))
            .collect();
        let suffixes: Vec<&str> = suffixes.iter().map(String::as_str).collect();
        request.stem = super::files::free_stem(&request.stem, &suffixes);
        let layers = match (layers, self.session.output()) {
            (true, Some(output)) => match output.layer_pngs() {
                Ok(layers) => layers,
                Err(err) => return self.set_error(format!("Export failed: {err}")),
            },
            _ => Vec::new(),
        };
        let stem = request.stem.clone();
        let files = request.names().len();
        self.start_export(
            ctx,
            request,
            Destination::Save {
                stem,
                layers,
                files,
            },
        );
    }

    /// Starts exporting `request` for the script command `number` (`exportHeightmap`).
    pub(super) fn export_for_script(&mut self, ctx: &egui::Context, request: Request, number: u64) {
        self.start_export(ctx, request, Destination::Script(number));
    }

    fn start_export(&mut self, ctx: &egui::Context, request: Request, to: Destination) {
        let Some(output) = self.session.output() else {
            let message = "there is no terrain yet".to_owned();
            match to {
                Destination::Script(number) => self.automation.set_export(number, Err(message)),
                Destination::Save { .. } => {
                    self.set_error("Nothing to export yet: draw a river first.".into())
                }
            }
            return;
        };
        let source = output.export_source(self.session.scene());
        let bundle = to.bundles(&request.names());
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "export",
            move |job| async move {
                if !bundle {
                    return source.files(&request, &job).await;
                }
                let files = source.files(&request, &job.part(0.0, 0.8)).await?;
                let zip = crate::export::bundle::zip_in(&files, &job.part(0.8, 1.0)).await?;
                Ok(vec![File {
                    name: format!("{}.zip", request.stem),
                    mime: "application/zip",
                    bytes: zip,
                }])
            },
            move || repaint.request_repaint(),
        );
        match (spawned, to) {
            (Ok(job), to) => self.export.running.push(Exporting { job, to }),
            (Err(err), Destination::Script(number)) => {
                self.automation.set_export(number, Err(err.to_string()))
            }
            (Err(err), Destination::Save { .. }) => self.set_error(err.to_string()),
        }
    }

    /// Takes finished exports: saves them, or hands them to their script.
    pub(super) fn take_exports(&mut self) {
        let mut k = 0;
        while k < self.export.running.len() {
            let Some(result) = self.export.running[k].job.try_take() else {
                k += 1;
                continue;
            };
            let done = self.export.running.remove(k);
            match done.to {
                Destination::Script(number) => {
                    // Moved, not copied: a 4033^2 export with maps is tens of megabytes.
                    let bytes = result.and_then(|files| match <[File; 1]>::try_from(files) {
                        Ok([file]) => Ok(file.bytes),
                        Err(files) => Err(format!(
                            "{} files where one (or its zip) was due",
                            files.len()
                        )),
                    });
                    self.automation.set_export(number, bytes);
                }
                Destination::Save {
                    stem,
                    layers,
                    files: count,
                } => {
                    let saved = result.and_then(|files| save_all(&files, &stem, &layers, count));
                    match saved {
                        Ok(said) => self.messages.notice = Some(format!("Heightmap {said}")),
                        Err(err) if err == "cancelled" => {}
                        Err(err) => self.set_error(format!("Export failed: {err}")),
                    }
                }
            }
        }
    }
}

/// Saves `files` and `layers`: a heightmap (and its sidecar) as they are, the zip of
/// `count` files the job made in the browser, or several files one by one natively.
fn save_all(
    files: &[File],
    stem: &str,
    layers: &[LayerPng],
    count: usize,
) -> Result<String, String> {
    let mut said = match files {
        [file] if count > 1 => {
            let said = super::files::save(&file.name, file.mime, &file.bytes)?;
            format!("{said} ({count} files)")
        }
        [file] => super::files::save(&file.name, file.mime, &file.bytes)?,
        [map, sidecar] if sidecar.name.ends_with(".json") => {
            let said = super::files::save(&map.name, map.mime, &map.bytes)?;
            super::files::save(&sidecar.name, sidecar.mime, &sidecar.bytes)?;
            format!("{said} and its .json")
        }
        _ => save_several(files, stem)?,
    };
    for (name, png) in layers {
        let stem = name.trim_end_matches(".png");
        let stem = super::files::free_stem(&format!("strahler-{stem}"), &[".png"]);
        super::files::save(&format!("{stem}.png"), "image/png", png)?;
    }
    if !layers.is_empty() {
        said.push_str(" with the layers");
    }
    Ok(said)
}

impl Destination {
    /// Whether the job hands over the files named `names` as one zip: for a script, any
    /// export of more than one file; in the browser, more than a heightmap and its sidecar.
    fn bundles(&self, names: &[String]) -> bool {
        match self {
            Destination::Script(_) => names.len() > 1,
            Destination::Save { .. } => cfg!(target_arch = "wasm32") && !alone(names),
        }
    }
}

/// A heightmap alone, or with its sidecar JSON.
fn alone(names: &[String]) -> bool {
    match names {
        [_] => true,
        [_, sidecar] => sidecar.ends_with(".json"),
        _ => false,
    }
}

/// Several files saved one by one (natively; the browser gets them zipped by the job).
fn save_several(files: &[File], _stem: &str) -> Result<String, String> {
    for file in files {
        super::files::save(&file.name, file.mime, &file.bytes)?;
    }
    Ok(format!(
        "saved {} and {} more files",
        files[0].name,
        files.len() - 1
    ))
}
