//! The app's side of the export dialog (`panels::ExportDialog`): what it is told of the
//! terrain, and writing what it asks for. In the browser one file downloads as itself and
//! several as one zip; natively each is saved in the working directory under a stem no file
//! there has yet.

use super::StrahlerApp;
use super::panels::ExportInfo;
use crate::export::{File, Request};

impl StrahlerApp {
    /// What the export dialog shows of the terrain on the map, once there is one.
    pub(super) fn export_info(&self) -> Option<ExportInfo> {
        let output = self.session.output()?;
        let scene = self.session.scene();
        let native = output.field.width();
        Some(ExportInfo {
            native,
            cell_m: output.cell_m,
            range: output.field.finite_range().unwrap_or((0.0, 0.0)),
            preview_of: self.showing_preview().then_some(scene.size),
            vertical_scale: scene.vertical_scale as f32,
            textures: scene.textures,
        })
    }

    /// Shows the export dialog when open (with nothing to export, says so instead).
    pub(super) fn export_window(&mut self, ctx: &egui::Context) {
        if !self.export.open {
            return;
        }
        let Some(info) = self.export_info() else {
            self.export.open = false;
            self.set_error("Nothing to export yet: draw a river first.".into());
            return;
        };
        for action in self.export.show(ctx, &info) {
            self.act(ctx, action);
        }
    }

    /// Writes `request`'s files (and the skeleton's layers with `layers`).
    pub(super) fn download(&mut self, mut request: Request, layers: bool) {
        let Some(output) = self.session.output() else {
            self.set_error("Nothing to export yet: draw a river first.".into());
            return;
        };
        let splat = self.session.scene().textures.splat();
        let suffixes: Vec<String> = request
            .names()
            .iter()
            .map(|n| n[request.stem.len()..].to_owned())
            .chain(std::iter::once(".zip".to_owned()))
            .collect();
        let suffixes: Vec<&str> = suffixes.iter().map(String::as_str).collect();
        request.stem = super::files::free_stem(&request.stem, &suffixes);
        let result = output.export_files(&request, splat).and_then(|files| {
            let mut said = save_all(&files, &request.stem)?;
            if layers {
                for (name, png) in &output.layer_pngs()? {
                    let stem = name.trim_end_matches(".png");
                    let stem = super::files::free_stem(&format!("strahler-{stem}"), &[".png"]);
                    super::files::save(&format!("{stem}.png"), "image/png", png)?;
                }
                said.push_str(" with the layers");
            }
            Ok(said)
        });
        match result {
            Ok(said) => self.messages.notice = Some(format!("Heightmap {said}")),
            Err(err) => self.set_error(format!("Export failed: {err}")),
        }
    }
}

impl StrahlerApp {
    /// `request`'s one file, or its files as one zip (a script's export).
    pub(super) fn export_bytes(&self, request: &Request) -> Result<Vec<u8>, String> {
        let output = self.session.output().ok_or("there is no terrain yet")?;
        let files = output.export_files(request, self.session.scene().textures.splat())?;
        match files.as_slice() {
            [file] => Ok(file.bytes.clone()),
            _ => crate::export::bundle::zip(&files),
        }
    }
}

/// Saves `files`: one as itself; several as `stem.zip` in the browser, one by one natively.
fn save_all(files: &[File], stem: &str) -> Result<String, String> {
    if let [file] = files {
        return super::files::save(&file.name, file.mime, &file.bytes);
    }
    #[cfg(target_arch = "wasm32")]
    {
        let zip = crate::export::bundle::zip(files)?;
        let said = super::files::save(&format!("{stem}.zip"), "application/zip", &zip)?;
        Ok(format!("{said} ({} files)", files.len()))
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = stem;
        for file in files {
            super::files::save(&file.name, file.mime, &file.bytes)?;
        }
        Ok(format!(
            "saved {} and {} more files",
            files[0].name,
            files.len() - 1
        ))
    }
}
