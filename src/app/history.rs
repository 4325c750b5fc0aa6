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

/// Browser storage key of the autosaved undo steps (a JSON array of scene files, oldest
/// first).
#[cfg(target_arch = "wasm32")]
pub const UNDO_KEY: &str = "strahler.undo.v1";

/// The most bytes of undo steps autosaved: the newest steps that fit (browsers give a page
/// about 5 MB of storage, and the scene needs its share).
const UNDO_BUDGET: usize = 2 << 20;

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
    /// Starts the history at `scene` (the session's first document), with `undo` steps
    /// before it (oldest first; restored from an earlier visit).
    pub fn start(&mut self, scene: Scene, mut undo: Vec<Scene>) {
        if undo.len() > DEPTH {
            undo.drain(..undo.len() - DEPTH);
        }
        *self = Self {
            current: Some(scene),
            undo,
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
        // The undo steps beside it, as many of the newest as fit; a browser that refuses
        // them still keeps the scene.
        store_undo(&self.undo);
        // Keep working either way; a failure is said once, not every two seconds.
        self.autosaved = Some(json);
        stored
            .err()
            .map(|err| format!("Autosave failed: {err}. Use Save scene."))
    }
}

/// The autosaved scene and its undo steps (oldest first), if the browser has them (always
/// `None` natively).
pub fn restore() -> Option<Result<(Scene, Vec<Scene>), String>> {
    #[cfg(target_arch = "wasm32")]
    {
        let storage = web_sys::window()?.local_storage().ok()??;
        let text = storage.get_item(AUTOSAVE_KEY).ok()??;
        let undo = storage
            .get_item(UNDO_KEY)
            .ok()
            .flatten()
            .map(|text| undo_steps(&text))
            .unwrap_or_default();
        Some(
            Scene::from_json(&text)
                .map(|scene| (scene, undo))
                .map_err(|e| e.to_string()),
        )
    }
    #[cfg(not(target_arch = "wasm32"))]
    None
}

/// The newest of `undo` (oldest first) whose scene files fit `budget` bytes together, as a
/// JSON array of those files, oldest first.
#[cfg_attr(not(target_arch = "wasm32"), allow(dead_code))]
fn undo_json(undo: &[Scene], budget: usize) -> String {
    let mut kept = Vec::new();
    let mut bytes = 2;
    for scene in undo.iter().rev() {
        let json = serde_json::to_string(scene).unwrap_or_default();
        if bytes + json.len() + 1 > budget {
            break;
        }
        bytes += json.len() + 1;
        kept.push(json);
    }
    kept.reverse();
    format!("[{}]", kept.join(","))
}

/// The undo steps of [`undo_json`]'s text; steps that do not read as scenes (a file from an
/// older build) are dropped, with the ones before them, so undo never jumps.
#[cfg_attr(not(target_arch = "wasm32"), allow(dead_code))]
fn undo_steps(text: &str) -> Vec<Scene> {
    let Ok(values) = serde_json::from_str::<Vec<serde_json::Value>>(text) else {
        return Vec::new();
    };
    let mut steps = Vec::new();
    for value in values {
        match Scene::from_json(&value.to_string()) {
            Ok(scene) => steps.push(scene),
            Err(_) => steps.clear(),
        }
    }
    steps
}

/// Writes the undo steps to browser storage (web only): the newest that fit, halving the
/// budget while the browser refuses them, none at last.
fn store_undo(undo: &[Scene]) {
    #[cfg(target_arch = "wasm32")]
    {
        let Some(storage) = web_sys::window().and_then(|w| w.local_storage().ok().flatten()) else {
            return;
        };
        let mut budget = UNDO_BUDGET;
        while storage
            .set_item(UNDO_KEY, &undo_json(undo, budget))
            .is_err()
        {
            if budget < 1024 {
                let _ = storage.remove_item(UNDO_KEY);
                return;
            }
            budget /= 2;
        }
    }
    #[cfg(not(target_arch = "wasm32"))]
    let _ = (undo, UNDO_BUDGET);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(seed: u64) -> Scene {
        Scene {
            seed,
            ..Scene::default()
        }
    }

    /// The autosaved undo steps read back as they were, the newest kept when they do not all
    /// fit, and a step that no longer reads drops the older ones.
    #[test]
    fn undo_steps_round_trip_within_their_budget() {
        let undo: Vec<Scene> = (1..=5).map(scene).collect();
        assert_eq!(undo_steps(&undo_json(&undo, UNDO_BUDGET)), undo);
        let one = serde_json::to_string(&undo[0]).unwrap().len();
        let two_fit = undo_steps(&undo_json(&undo, 2 * one + 8));
        assert_eq!(two_fit, undo[3..].to_vec(), "the two newest");
        assert!(undo_steps(&undo_json(&undo, 10)).is_empty());
        let text = undo_json(&undo, UNDO_BUDGET).replacen("\"version\":1", "\"version\":99", 2);
        assert_eq!(
            undo_steps(&text),
            undo[2..].to_vec(),
            "the steps after the unreadable"
        );
        assert!(undo_steps("not json").is_empty());
    }

    #[test]
    fn a_restored_history_undoes_to_its_steps() {
        let mut history = History::default();
        history.start(scene(9), vec![scene(7), scene(8)]);
        assert_eq!(history.depths(), (2, 0));
        assert_eq!(history.step(true), Some(scene(8)));
        assert_eq!(history.step(true), Some(scene(7)));
        assert_eq!(history.step(true), None);
    }
}
