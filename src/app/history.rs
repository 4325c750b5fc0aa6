//! The document's history: undo and redo of every edit, and autosave to browser storage.
//!
//! The session commits the scene here after each edit once the gesture that made it is
//! over (a slider drag or a brush stroke is one step). Each step keeps the sections of the
//! scene file the edit changed, as they were ([`Patch`]): adding a river keeps the rivers,
//! painting a mask that mask, never the whole scene. Undoing applies the step and keeps its
//! inverse for redo, so both are exact whatever the edit was. O(scene size) per committed
//! edit (the scene is compared section by section); at most [`DEPTH`] steps are kept.

use serde_json::{Map, Value};

use crate::scene::{Patch, Scene};

/// Undo steps kept.
pub const DEPTH: usize = 100;

/// Browser storage key of the autosaved scene.
#[cfg(target_arch = "wasm32")]
pub const AUTOSAVE_KEY: &str = "strahler.autosave.v1";

/// Browser storage key of the autosaved undo steps (a JSON array of [`Patch`]es, oldest
/// first).
#[cfg(target_arch = "wasm32")]
pub const UNDO_KEY: &str = "strahler.undo.v2";

/// Where builds before the steps were patches kept whole scenes (removed when the new steps
/// are stored: they could fill the storage).
#[cfg(target_arch = "wasm32")]
const OLD_UNDO_KEY: &str = "strahler.undo.v1";

/// The most bytes of undo steps autosaved: the newest steps that fit (browsers give a page
/// about 5 MB of storage, and the scene needs its share).
const UNDO_BUDGET: usize = 2 << 20;

/// Seconds between autosaves (when something changed).
const AUTOSAVE_SECONDS: f64 = 2.0;

/// The committed scene and its file's sections (what the next step is compared with).
struct Current {
    scene: Scene,
    sections: Map<String, Value>,
}

impl Current {
    fn new(scene: Scene) -> Self {
        let sections = scene.sections();
        Self { scene, sections }
    }
}

#[derive(Default)]
pub struct History {
    current: Option<Current>,
    /// Each takes the current scene one step back (the newest last).
    undo: Vec<Patch>,
    /// Each takes it one step forward again.
    redo: Vec<Patch>,
    last_autosave: Option<web_time::Instant>,
    autosaved: Option<String>,
    /// The document changed since the last autosave.
    unsaved: bool,
}

impl History {
    /// Starts the history at `scene` (the session's first document), with `undo` steps
    /// before it (oldest first; restored from an earlier visit).
    pub fn start(&mut self, scene: Scene, mut undo: Vec<Patch>) {
        if undo.len() > DEPTH {
            undo.drain(..undo.len() - DEPTH);
        }
        *self = Self {
            current: Some(Current::new(scene)),
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
        if self.current.as_ref().map(|c| &c.scene) == Some(scene) {
            return None;
        }
        let next = Current::new(scene.clone());
        if let Some(previous) = self.current.take() {
            self.undo
                .push(Patch::between_sections(&next.sections, &previous.sections));
            if self.undo.len() > DEPTH {
                self.undo.remove(0);
            }
        }
        self.current = Some(next);
        self.redo.clear();
        self.unsaved = true;
        Some(self.depths())
    }

    /// Back (`back`) or forward one step: the scene that becomes current, if there is one.
    /// A step that no longer applies (saved by a build whose scene format differs) is
    /// dropped with every step beyond it, so the history never jumps.
    pub fn step(&mut self, back: bool) -> Option<Scene> {
        let (from, to) = if back {
            (&mut self.undo, &mut self.redo)
        } else {
            (&mut self.redo, &mut self.undo)
        };
        let patch = from.pop()?;
        let current = self.current.as_ref()?;
        let Ok((scene, inverse)) = patch.apply(&current.scene) else {
            from.clear();
            return None;
        };
        to.push(inverse);
        self.current = Some(Current::new(scene.clone()));
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
        let json = self.current.as_ref()?.scene.to_json();
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
pub fn restore() -> Option<Result<(Scene, Vec<Patch>), String>> {
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

/// The newest of `undo` (oldest first) that fit `budget` bytes together, as a JSON array,
/// oldest first.
#[cfg_attr(not(target_arch = "wasm32"), allow(dead_code))]
fn undo_json(undo: &[Patch], budget: usize) -> String {
    let mut kept = Vec::new();
    let mut bytes = 2;
    for step in undo.iter().rev() {
        let json = serde_json::to_string(step).unwrap_or_default();
        if bytes + json.len() + 1 > budget {
            break;
        }
        bytes += json.len() + 1;
        kept.push(json);
    }
    kept.reverse();
    format!("[{}]", kept.join(","))
}

/// The undo steps of [`undo_json`]'s text; steps that do not read as patches are dropped,
/// with the ones before them, so undo never jumps (a step that reads but no longer applies
/// is dropped when undone, [`History::step`]).
#[cfg_attr(not(target_arch = "wasm32"), allow(dead_code))]
fn undo_steps(text: &str) -> Vec<Patch> {
    let Ok(values) = serde_json::from_str::<Vec<Value>>(text) else {
        return Vec::new();
    };
    let mut steps = Vec::new();
    for value in values {
        match serde_json::from_value::<Patch>(value) {
            Ok(step) => steps.push(step),
            Err(_) => steps.clear(),
        }
    }
    steps
}

/// Writes the undo steps to browser storage (web only): the newest that fit, halving the
/// budget while the browser refuses them, none at last.
fn store_undo(undo: &[Patch]) {
    #[cfg(target_arch = "wasm32")]
    {
        let Some(storage) = web_sys::window().and_then(|w| w.local_storage().ok().flatten()) else {
            return;
        };
        let _ = storage.remove_item(OLD_UNDO_KEY);
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
    use crate::scene::{Edit, LineKind, RiverStroke, SketchLine};

    fn scene(seed: u64) -> Scene {
        Scene {
            seed,
            ..Scene::default()
        }
    }

    /// The step from scene `a` back to scene `b`.
    fn step(from: u64, to: u64) -> Patch {
        Patch::between(&scene(from), &scene(to))
    }

    /// The autosaved undo steps read back as they were, the newest kept when they do not all
    /// fit, and a step that no longer reads drops the older ones.
    #[test]
    fn undo_steps_round_trip_within_their_budget() {
        let undo: Vec<Patch> = (1..=5).map(|k| step(k + 1, k)).collect();
        assert_eq!(undo_steps(&undo_json(&undo, UNDO_BUDGET)), undo);
        let one = serde_json::to_string(&undo[0]).unwrap().len();
        let two_fit = undo_steps(&undo_json(&undo, 2 * one + 8));
        assert_eq!(two_fit, undo[3..].to_vec(), "the two newest");
        assert!(undo_steps(&undo_json(&undo, 10)).is_empty());
        let text = undo_json(&undo, UNDO_BUDGET).replacen("\"set\"", "\"sett\"", 2);
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
        history.start(scene(9), vec![step(8, 7), step(9, 8)]);
        assert_eq!(history.depths(), (2, 0));
        assert_eq!(history.step(true), Some(scene(8)));
        assert_eq!(history.step(true), Some(scene(7)));
        assert_eq!(history.step(true), None);
        assert_eq!(history.step(false), Some(scene(8)));
        assert_eq!(history.step(false), Some(scene(9)));
        assert_eq!(history.step(false), None);
    }

    /// Edits of every kind undo and redo to exactly the scenes they made, each step keeping
    /// only the sections its edit changed; a new edit after undoing drops the redo steps.
    #[test]
    fn edits_undo_and_redo_exactly_and_keep_only_their_sections() {
        let mut scenes = vec![Scene::default()];
        let mut history = History::default();
        history.start(scenes[0].clone(), Vec::new());
        let line = SketchLine {
            points: vec![[0.2, 0.2], [0.6, 0.3]],
            height: Some(700.0),
            heights: None,
        };
        let edits = [
            Edit::SetSeed(42),
            Edit::AddLine {
                kind: LineKind::Ridge,
                line,
            },
            Edit::SetErosion(None),
            Edit::AddRiver(RiverStroke {
                estuary: [0.5, 1.0],
                toward: [0.5, 0.4],
                phi: 3,
                depth: 4,
            }),
        ];
        for edit in edits {
            let mut next = scenes.last().unwrap().clone();
            next.apply(edit).unwrap();
            assert!(history.commit(&next).is_some());
            assert_eq!(history.commit(&next), None, "the same scene is no new step");
            scenes.push(next);
        }
        let kept: Vec<Vec<&str>> = history
            .undo
            .iter()
            .map(|p| p.sections().collect())
            .collect();
        assert_eq!(kept, [["seed"], ["sketch"], ["erosion"], ["rivers"]]);
        for expected in scenes.iter().rev().skip(1) {
            assert_eq!(history.step(true).as_ref(), Some(expected));
        }
        assert_eq!(history.step(true), None);
        for expected in scenes.iter().skip(1) {
            assert_eq!(history.step(false).as_ref(), Some(expected));
        }
        // Two back, then a new edit: the redo steps are gone, the new one undoes.
        history.step(true);
        history.step(true);
        let mut other = scenes[2].clone();
        other.apply(Edit::SetSeed(7)).unwrap();
        assert_eq!(history.commit(&other), Some((3, 0)));
        assert_eq!(history.step(true).as_ref(), Some(&scenes[2]));
    }

    /// A restored step that reads but no longer applies (another build's format) is dropped
    /// with the steps before it, and the scene stays.
    #[test]
    fn a_step_that_no_longer_applies_ends_the_history_there() {
        let mut broken = Patch::default();
        broken
            .set
            .insert("size".into(), serde_json::Value::from("huge"));
        let mut history = History::default();
        history.start(scene(9), vec![step(8, 7), broken]);
        assert_eq!(history.step(true), None);
        assert_eq!(history.depths(), (0, 0));
        assert!(!history.can_undo());
    }
}
