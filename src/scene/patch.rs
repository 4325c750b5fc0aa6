//! A change to a scene as the sections of its file it replaces: what the app's history keeps
//! for each undo and redo step, and what the autosave writes of them.
//!
//! A section is a top-level field of the scene file (`rivers`, `sketch`, `erosion`,
//! `detail`, ...), in the scene's own schema (`file.rs`). An edit touches one or two of
//! them, so a step holds those alone, not the whole scene (whose masks can be megabytes),
//! and a field added to the scene is a section here without a line of code.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use super::{Scene, SceneError};

/// The sections a change replaces, with the values it puts there, and those it removes
/// (back to their defaults).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Patch {
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub set: Map<String, Value>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unset: Vec<String>,
}

impl Patch {
    /// What turns `from` into `to`: the sections of `to` that differ from `from`'s. O(scene
    /// size).
    pub fn between(from: &Scene, to: &Scene) -> Self {
        Self::between_sections(&from.sections(), &to.sections())
    }

    /// [`Self::between`] of two scenes' [`Scene::sections`].
    pub fn between_sections(from: &Map<String, Value>, to: &Map<String, Value>) -> Self {
        let set = to
            .iter()
            .filter(|(key, value)| from.get(*key) != Some(*value))
            .map(|(key, value)| (key.clone(), value.clone()))
            .collect();
        let unset = from
            .keys()
            .filter(|k| !to.contains_key(*k))
            .cloned()
            .collect();
        Self { set, unset }
    }

    /// Whether it changes nothing.
    pub fn is_empty(&self) -> bool {
        self.set.is_empty() && self.unset.is_empty()
    }

    /// The names of the sections it changes.
    pub fn sections(&self) -> impl Iterator<Item = &str> {
        self.set.keys().chain(&self.unset).map(String::as_str)
    }

    /// `scene` with this change, and the patch that takes it back. The result is read in the
    /// scene file's schema, so a step saved by a build whose format differs is an error, not a
    /// wrong scene. It is not validated: the history goes back to any scene the session held,
    /// one an edit left out of range included (the run then names the problem). O(scene
    /// size).
    pub fn apply(&self, scene: &Scene) -> Result<(Scene, Patch), SceneError> {
        let mut map = scene.sections();
        let mut back = Patch::default();
        for key in self.sections() {
            match map.get(key) {
                Some(value) => {
                    back.set.insert(key.to_owned(), value.clone());
                }
                None => back.unset.push(key.to_owned()),
            }
        }
        for (key, value) in &self.set {
            map.insert(key.clone(), value.clone());
        }
        for key in &self.unset {
            map.remove(key);
        }
        let after: Scene = serde_path_to_error::deserialize(Value::Object(map))
            .map_err(|e| SceneError::Parse(format!("{}: {}", e.path(), e.inner())))?;
        Ok((after, back))
    }
}

impl Scene {
    /// The scene file's top-level fields (its sections), as JSON values.
    pub fn sections(&self) -> Map<String, Value> {
        match serde_json::to_value(self) {
            Ok(Value::Object(map)) => map,
            _ => Map::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Edit, RiverStroke};

    fn edited(scene: &Scene, edit: Edit) -> Scene {
        let mut next = scene.clone();
        next.apply(edit).unwrap();
        next
    }

    /// A patch holds the sections an edit touched, applies exactly, and its inverse takes
    /// the scene back exactly, an absent section (None) included.
    #[test]
    fn a_patch_holds_only_what_changed_and_undoes_exactly() {
        let start = Scene::default();
        let river = RiverStroke {
            estuary: [0.3, 1.0],
            toward: [0.4, 0.5],
            phi: 3,
            depth: 4,
        };
        let added = edited(&start, Edit::AddRiver(river));
        let patch = Patch::between(&start, &added);
        assert_eq!(patch.sections().collect::<Vec<_>>(), ["rivers"]);
        let (after, back) = patch.apply(&start).unwrap();
        assert_eq!(after, added);
        assert_eq!(back.apply(&after).unwrap().0, start);

        let bare = edited(&added, Edit::SetErosion(None));
        let patch = Patch::between(&added, &bare);
        assert_eq!(patch.sections().collect::<Vec<_>>(), ["erosion"]);
        let (after, back) = patch.apply(&added).unwrap();
        assert_eq!(after.erosion, None);
        assert_eq!(back.apply(&after).unwrap().0, added, "erosion comes back");
        assert!(Patch::between(&bare, &bare).is_empty());

        // Written and read as the autosave does.
        let text = serde_json::to_string(&back).unwrap();
        assert_eq!(serde_json::from_str::<Patch>(&text).unwrap(), back);
    }

    #[test]
    fn a_patch_that_no_longer_reads_is_an_error() {
        let mut patch = Patch::default();
        patch.set.insert("size".into(), Value::from("big"));
        let err = patch.apply(&Scene::default()).unwrap_err();
        assert!(err.to_string().contains("size"), "{err}");
        let mut patch = Patch::default();
        patch.set.insert("seeed".into(), Value::from(3));
        assert!(
            patch.apply(&Scene::default()).is_err(),
            "an unknown section"
        );
    }

    /// A step goes back to any scene the session held, one out of range included: the
    /// history must not end at it.
    #[test]
    fn a_patch_restores_a_scene_out_of_range() {
        let mut odd = Scene::default();
        odd.erosion.as_mut().unwrap().years = 0.0;
        assert!(odd.validate().is_err());
        let patch = Patch::between(&Scene::default(), &odd);
        let (after, back) = patch.apply(&Scene::default()).unwrap();
        assert_eq!(after, odd);
        assert_eq!(back.apply(&after).unwrap().0, Scene::default());
    }
}
