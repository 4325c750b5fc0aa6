//! The document's history: undo and redo of every edit, and autosave to browser storage.
//!
//! The session commits the scene here after each edit once the gesture that made it is
//! over (a slider drag or a brush stroke is one step). Undo and redo swap whole scenes,
//! which keeps them exact whatever the edit was. O(scene size) per committed edit; at most
//! [`DEPTH`] steps are kept.

use crate::scene::Scene;

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
    last_autosave: Option<web_time::Instant>,
    autosaved: Option<String>,
    /// The document changed since the last autosave.
    unsaved: bool,
}

impl History {
    /// Starts the history at `scene` (the session's first document).
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

    /// Records `scene` as a new step when it differs from the current one (clearing the redo
    /// steps). Returns the new depths when it did.
    pub fn commit(&mut self, scene: &Scene) -> Option<(usize, usize)> {
        if self.current.as_ref() == Some(scene) {
            return None;
        }
        if let Some(previous) = self.current.replace(scene.clone()) {
            self.undo.push(previous);
            if self.undo.len() > DEPTH {
                self.undo.remove(0);
            }
        }
        self.redo.clear();
        self.unsaved = true;
        Some(self.depths())
    }

    /// Back (`back`) or forward one step: the scene that becomes current, if there is one.
    pub fn step(&mut self, back: bool) -> Option<Scene> {
        let (from, to) = if back {
            (&mut self.undo, &mut self.redo)
        } else {
            (&mut self.redo, &mut self.undo)
        };
        let scene = from.pop()?;
        if let Some(current) = self.current.replace(scene.clone()) {
            to.push(current);
        }
        self.unsaved = true;
        Some(scene)
    }

    /// Writes the scene to browser storage when it changed (web only), at most every
    /// [`AUTOSAVE_SECONDS`] and within that time of any change however it was made (mouse,
    /// keyboard or `window.strahler`): a change not yet due calls `wake` with the time until
    /// it is, so an idle page still saves it. `Some` says why saving failed.
    pub fn autosave(&mut self, wake: impl FnOnce(std::time::Duration)) -> Option<String> {
        if !self.unsaved {
            return None;
        }
        let since = self
            .last_autosave
            .map_or(f64::INFINITY, |t| t.elapsed().as_secs_f64());
        if since < AUTOSAVE_SECONDS {
            let wait = (AUTOSAVE_SECONDS - since).max(0.05);
            wake(std::time::Duration::from_secs_f64(wait));
            return None;
        }
        self.unsaved = false;
        self.last_autosave = Some(web_time::Instant::now());
        let json = self.current.as_ref()?.to_json();
        if self.autosaved.as_ref() == Some(&json) {
            return None;
        }
        let stored = store(&json);
        // Keep working either way; a failure is said once, not every two seconds.
        self.autosaved = Some(json);
        stored
            .err()
            .map(|err| format!("Autosave failed: {err}. Use Save scene."))
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
