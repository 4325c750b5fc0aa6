//! The document's history: undo and redo of every edit, and autosave to browser storage.
//!
//! The scene (`StrahlerApp::scene`) is the document. After an edit (anything that makes the
//! terrain, detail or blend stage re-run: strokes, sketch items, parameters, mask strokes,
//! block moves, loaded scenes) the new scene is committed once the pointer is released, so
//! a slider drag or a brush stroke is one step. Undo and redo swap whole scenes, which keeps
//! them exact whatever the edit was. O(scene size) per committed edit; at most [`DEPTH`]
//! steps are kept.

use crate::scene::Scene;

use super::StrahlerApp;

/// Undo steps kept.
pub const DEPTH: usize = 100;

/// Browser storage key of the autosaved scene.
#[cfg(target_arch = "wasm32")]
pub const AUTOSAVE_KEY: &str = "strahler.autosave.v1";

/// Seconds between autosaves (when something changed).
const AUTOSAVE_SECONDS: f64 = 2.0;

#[derive(Default)]
pub struct History {
    current: Option<Scene>,
    undo: Vec<Scene>,
    redo: Vec<Scene>,
    /// An edit happened and is not committed yet.
    pending: bool,
    /// The next commit is the result of an undo or redo, not a new edit.
    restoring: bool,
    last_autosave: Option<web_time::Instant>,
    autosaved: Option<String>,
    /// The document changed since the last autosave.
    unsaved: bool,
}

impl History {
    /// Starts the history at `scene` (the app's first document).
    pub fn start(&mut self, scene: Scene) {
        *self = Self {
            current: Some(scene),
            ..Default::default()
        };
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    pub fn depths(&self) -> (usize, usize) {
        (self.undo.len(), self.redo.len())
    }
}

impl StrahlerApp {
    /// Called each frame after the commands: notes edits and commits them when the pointer
    /// is up; autosaves on the web.
    pub(super) fn track_history(&mut self, ctx: &egui::Context) {
        if self.dirty {
            self.history.pending = true;
        }
        let pointer_down = ctx.input(|i| i.pointer.any_down());
        if self.history.pending && !pointer_down {
            self.history.pending = false;
            let scene = self.scene();
            let h = &mut self.history;
            if h.restoring {
                h.restoring = false;
            } else if let Some(previous) = h.current.take().filter(|c| *c != scene) {
                h.undo.push(previous);
                if h.undo.len() > DEPTH {
                    h.undo.remove(0);
                }
                h.redo.clear();
            }
            h.current = Some(scene);
            h.unsaved = true;
            let (undo, redo) = h.depths();
            self.automation.update(|s| {
                s.undo = undo;
                s.redo = redo;
            });
        }
        self.autosave(ctx);
    }

    /// Back one step.
    pub fn undo(&mut self) {
        self.step_history(true);
    }

    /// Forward one step.
    pub fn redo(&mut self) {
        self.step_history(false);
    }

    fn step_history(&mut self, back: bool) {
        let h = &mut self.history;
        let (from, to) = if back {
            (&mut h.undo, &mut h.redo)
        } else {
            (&mut h.redo, &mut h.undo)
        };
        let Some(scene) = from.pop() else {
            return;
        };
        if let Some(current) = h.current.replace(scene.clone()) {
            to.push(current);
        }
        h.restoring = true;
        h.unsaved = true;
        let (undo, redo) = h.depths();
        self.automation.update(|s| {
            s.undo = undo;
            s.redo = redo;
        });
        self.load_scene(&scene);
        self.notice = Some(if back { "Undone" } else { "Redone" }.to_owned());
    }

    /// Writes the scene to browser storage when it changed (web only).
    /// Saves the document at most every [`AUTOSAVE_SECONDS`], within that time of any change
    /// however it was made (mouse, keyboard or `window.strahler`): a change that is not yet
    /// due asks for a frame when it will be, so an idle page still saves it.
    fn autosave(&mut self, ctx: &egui::Context) {
        if !self.history.unsaved {
            return;
        }
        let since = self
            .history
            .last_autosave
            .map_or(f64::INFINITY, |t| t.elapsed().as_secs_f64());
        if since < AUTOSAVE_SECONDS {
            let wait = (AUTOSAVE_SECONDS - since).max(0.05);
            ctx.request_repaint_after(std::time::Duration::from_secs_f64(wait));
            return;
        }
        self.history.unsaved = false;
        self.history.last_autosave = Some(web_time::Instant::now());
        let Some(scene) = &self.history.current else {
            return;
        };
        let json = scene.to_json();
        if self.history.autosaved.as_ref() == Some(&json) {
            return;
        }
        match store(&json) {
            Ok(()) => self.history.autosaved = Some(json),
            Err(err) => {
                // Keep working; say why the scene is not being kept.
                self.history.autosaved = Some(json);
                self.notice = Some(format!("Autosave failed: {err}. Use Save scene."));
            }
        }
    }
}

/// The autosaved scene, if the browser has one (always `None` natively).
pub fn restore() -> Option<Result<Scene, String>> {
    #[cfg(target_arch = "wasm32")]
    {
        let storage = web_sys::window()?.local_storage().ok()??;
        let text = storage.get_item(AUTOSAVE_KEY).ok()??;
        Some(Scene::from_json(&text).map_err(|e| e.to_string()))
    }
    #[cfg(not(target_arch = "wasm32"))]
    None
}

fn store(json: &str) -> Result<(), String> {
    #[cfg(target_arch = "wasm32")]
    {
        let storage = web_sys::window()
            .and_then(|w| w.local_storage().ok().flatten())
            .ok_or("this browser has no local storage")?;
        storage.set_item(AUTOSAVE_KEY, json).map_err(|_| {
            format!(
                "the scene ({} kB) does not fit the browser's storage",
                json.len() / 1024
            )
        })
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = json;
        Ok(())
    }
}
