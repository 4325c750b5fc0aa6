//! Every change to the document as one type: [`Edit`], applied by [`Scene::apply`].
//!
//! The app's panels and map tools return edits, and `window.strahler` sends the same ones, so
//! a change made with the mouse and one made by a script go through the same code and the
//! same checks; the session keeps undo, redo and autosave on the edits it applies. An edit
//! that cannot apply (an index past the end, a value out of range) is refused with the
//! message [`Scene::validate`] gives for it and leaves the scene as it was.

use thiserror::Error;

use super::validate::Part;
use super::{
    DetailSettings, Params, RiverStroke, Scene, SceneError, SketchLine, SketchPeak, StyleSettings,
    TextureRules,
};
use crate::blend::BlendBlock;
use crate::erosion::ErosionSettings;

/// Which list of sketched lines an edit is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    Ridge,
    Valley,
}

impl LineKind {
    fn field(self) -> &'static str {
        match self {
            Self::Ridge => "sketch.ridges",
            Self::Valley => "sketch.valleys",
        }
    }
}

/// One change to the scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    AddRiver(RiverStroke),
    SetRiver {
        index: usize,
        stroke: RiverStroke,
    },
    RemoveRiver(usize),
    ClearRivers,
    AddLine {
        kind: LineKind,
        line: SketchLine,
    },
    SetLine {
        kind: LineKind,
        index: usize,
        line: SketchLine,
    },
    RemoveLine {
        kind: LineKind,
        index: usize,
    },
    AddPeak(SketchPeak),
    SetPeak {
        index: usize,
        peak: SketchPeak,
    },
    RemovePeak(usize),
    ClearSketch,
    /// Cells per side and the cell size in metres.
    SetGrid {
        size: usize,
        cell_size: f64,
    },
    SetSeed(u64),
    /// Places the map's centre on Earth (or takes it off).
    SetLocation(Option<super::Location>),
    SetParams(Params),
    SetErosion(Option<ErosionSettings>),
    SetStyle(Option<StyleSettings>),
    /// The Detail section's settings; the mask stays as it is.
    SetDetail(DetailSettings),
    /// A painted mask: the detail's energy reduction, the uplift or the hard rock (`None` or
    /// a clear mask: none).
    SetMask(super::MaskKind, Option<crate::wavelet::Mask>),
    AddBlock(BlendBlock),
    SetBlock {
        index: usize,
        block: BlendBlock,
    },
    /// Moves or resizes a block to `[x0, y0, x1, y1]` in map units.
    SetBlockRect {
        index: usize,
        rect: [f64; 4],
    },
    RemoveBlock(usize),
    /// The exported splat map's rules.
    SetTextures(TextureRules),
    /// A whole new document (a scene opened or extracted, undo and redo).
    Replace(Box<Scene>),
}

/// Why an edit was refused.
#[derive(Debug, Error, PartialEq)]
pub enum EditError {
    #[error("there is no {what} {index} (the scene has {len})")]
    NoSuchItem {
        what: &'static str,
        index: usize,
        len: usize,
    },
    #[error("{field}: {problem}")]
    Invalid { field: String, problem: String },
}

/// `list[index]`, or the error naming `what` was missing.
fn item<'a, T>(
    list: &'a mut [T],
    index: usize,
    what: &'static str,
) -> Result<&'a mut T, EditError> {
    let len = list.len();
    list.get_mut(index)
        .ok_or(EditError::NoSuchItem { what, index, len })
}

impl From<SceneError> for EditError {
    fn from(error: SceneError) -> Self {
        match error {
            SceneError::Invalid { field, problem } => Self::Invalid { field, problem },
            SceneError::Parse(problem) => Self::Invalid {
                field: "scene".into(),
                problem,
            },
        }
    }
}

impl Edit {
    /// The part of `scene` this edit changes, whose checks the result must pass.
    fn part(&self, scene: &Scene) -> Part {
        match self {
            Self::AddRiver(_) | Self::SetRiver { .. } => Part::Rivers,
            Self::AddLine { .. }
            | Self::SetLine { .. }
            | Self::AddPeak(_)
            | Self::SetPeak { .. } => Part::Sketch,
            Self::SetGrid { .. } => Part::Map,
            Self::SetLocation(_) => Part::Location,
            Self::SetParams(_) => Part::Params,
            Self::SetErosion(_) => Part::Erosion,
            Self::SetStyle(_) => Part::Style,
            Self::SetDetail(_) => Part::Detail,
            Self::AddBlock(_) => Part::Block(scene.blend.len()),
            Self::SetBlock { index, .. } | Self::SetBlockRect { index, .. } => Part::Block(*index),
            Self::SetTextures(_) => Part::Textures,
            Self::RemoveRiver(_)
            | Self::ClearRivers
            | Self::RemoveLine { .. }
            | Self::RemovePeak(_)
            | Self::ClearSketch
            | Self::SetSeed(_)
            | Self::SetMask(..)
            | Self::RemoveBlock(_)
            | Self::Replace(_) => Part::Unchecked,
        }
    }
}

/// The scene's heavy parts: the blocks (their references as PNG) and the painted masks.
/// Only block and mask edits change them, so [`Saved`] keeps them out of its copy.
struct Heavy {
    blend: Vec<BlendBlock>,
    detail_mask: Option<String>,
    erosion_masks: super::ErosionMasks,
}

impl Heavy {
    fn take(scene: &mut Scene) -> Self {
        Self {
            blend: std::mem::take(&mut scene.blend),
            detail_mask: scene.detail.mask_png.take(),
            erosion_masks: std::mem::take(&mut scene.erosion_masks),
        }
    }

    fn put(self, scene: &mut Scene) {
        scene.blend = self.blend;
        scene.detail.mask_png = self.detail_mask;
        scene.erosion_masks = self.erosion_masks;
    }
}

/// The scene before a checked edit, to put back when the edit's checks fail: everything but
/// the heavy parts, and for a block edit the one block it changes. An edit sent as the
/// pointer moves copies a few numbers, not the blocks' references.
struct Saved {
    light: Scene,
    blocks: usize,
    block: Option<(usize, BlendBlock)>,
}

impl Saved {
    fn of(scene: &mut Scene, part: Part) -> Self {
        let heavy = Heavy::take(scene);
        let light = scene.clone();
        heavy.put(scene);
        let block = match part {
            Part::Block(i) => scene.blend.get(i).map(|b| (i, b.clone())),
            _ => None,
        };
        Self {
            light,
            blocks: scene.blend.len(),
            block,
        }
    }

    fn restore(self, scene: &mut Scene) {
        let heavy = Heavy::take(scene);
        *scene = self.light;
        heavy.put(scene);
        scene.blend.truncate(self.blocks);
        if let Some((i, block)) = self.block
            && let Some(slot) = scene.blend.get_mut(i)
        {
            *slot = block;
        }
    }
}

impl Scene {
    /// Applies `edit`, or refuses it with the scene unchanged: a missing item, or a value
    /// [`Scene::validate`] would refuse in the part the edit changes (with its message). A
    /// whole scene ([`Edit::Replace`]) is taken as it is: the history goes back to any scene
    /// the session held.
    pub fn apply(&mut self, edit: Edit) -> Result<(), EditError> {
        let part = edit.part(self);
        if part == Part::Unchecked {
            return self.change(edit);
        }
        let saved = Saved::of(self, part);
        let checked = self
            .change(edit)
            .and_then(|()| self.check_part(part).map_err(EditError::from));
        if checked.is_err() {
            saved.restore(self);
        }
        checked
    }

    /// Makes the change `edit` names, refusing only a missing item.
    fn change(&mut self, edit: Edit) -> Result<(), EditError> {
        match edit {
            Edit::AddRiver(stroke) => self.rivers.push(stroke),
            Edit::SetRiver { index, stroke } => *item(&mut self.rivers, index, "river")? = stroke,
            Edit::RemoveRiver(index) => {
                item(&mut self.rivers, index, "river")?;
                self.rivers.remove(index);
            }
            Edit::ClearRivers => self.rivers.clear(),
            Edit::AddLine { kind, line } => self.lines(kind).push(line),
            Edit::SetLine { kind, index, line } => {
                *item(self.lines(kind), index, kind.field())? = line;
            }
            Edit::RemoveLine { kind, index } => {
                item(self.lines(kind), index, kind.field())?;
                self.lines(kind).remove(index);
            }
            Edit::AddPeak(peak) => self.sketch.peaks.push(peak),
            Edit::SetPeak { index, peak } => *item(&mut self.sketch.peaks, index, "peak")? = peak,
            Edit::RemovePeak(index) => {
                item(&mut self.sketch.peaks, index, "peak")?;
                self.sketch.peaks.remove(index);
            }
            Edit::ClearSketch => self.sketch = Default::default(),
            Edit::SetGrid { size, cell_size } => (self.size, self.cell_size) = (size, cell_size),
            Edit::SetSeed(seed) => self.seed = seed,
            Edit::SetLocation(location) => self.location = location,
            Edit::SetParams(params) => self.params = params,
            Edit::SetErosion(erosion) => self.erosion = erosion,
            Edit::SetStyle(style) => self.style = style,
            Edit::SetDetail(detail) => {
                let mask = self.detail.mask_png.take();
                self.detail = DetailSettings {
                    mask_png: mask,
                    ..detail
                };
            }
            Edit::SetMask(kind, mask) => self.set_mask(kind, mask.as_ref()),
            Edit::AddBlock(block) => self.blend.push(block),
            Edit::SetBlock { index, block } => *item(&mut self.blend, index, "block")? = block,
            Edit::SetBlockRect { index, rect } => {
                item(&mut self.blend, index, "block")?.rect = rect
            }
            Edit::RemoveBlock(index) => {
                item(&mut self.blend, index, "block")?;
                self.blend.remove(index);
            }
            Edit::SetTextures(rules) => self.textures = rules,
            Edit::Replace(scene) => *self = *scene,
        }
        Ok(())
    }

    fn lines(&mut self, kind: LineKind) -> &mut Vec<SketchLine> {
        match kind {
            LineKind::Ridge => &mut self.sketch.ridges,
            LineKind::Valley => &mut self.sketch.valleys,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stroke(x: f64) -> RiverStroke {
        RiverStroke {
            estuary: [x, 1.0],
            toward: [x, 0.5],
            phi: 3,
            depth: 5,
        }
    }

    #[test]
    fn edits_change_what_they_name_and_refuse_missing_items() {
        let mut scene = Scene::default();
        scene.apply(Edit::AddRiver(stroke(0.2))).unwrap();
        scene.apply(Edit::AddRiver(stroke(0.8))).unwrap();
        scene
            .apply(Edit::SetRiver {
                index: 1,
                stroke: stroke(0.6),
            })
            .unwrap();
        assert_eq!(scene.rivers[1].estuary, [0.6, 1.0]);
        let before = scene.clone();
        let err = scene.apply(Edit::RemoveRiver(5)).unwrap_err();
        assert_eq!(err.to_string(), "there is no river 5 (the scene has 2)");
        assert_eq!(scene, before, "a refused edit changes nothing");
        scene.apply(Edit::RemoveRiver(0)).unwrap();
        assert_eq!(scene.rivers, vec![stroke(0.6)]);

        let line = SketchLine {
            points: vec![[0.1, 0.1], [0.9, 0.1]],
            height: None,
            heights: None,
        };
        scene
            .apply(Edit::AddLine {
                kind: LineKind::Valley,
                line: line.clone(),
            })
            .unwrap();
        assert_eq!(scene.sketch.valleys, vec![line]);
        assert!(scene.sketch.ridges.is_empty());
        let err = scene
            .apply(Edit::RemoveLine {
                kind: LineKind::Ridge,
                index: 0,
            })
            .unwrap_err();
        assert!(err.to_string().contains("sketch.ridges 0"), "{err}");
        scene.apply(Edit::ClearSketch).unwrap();
        assert!(scene.sketch.is_empty());
    }

    #[test]
    fn detail_settings_keep_the_mask_and_blocks_are_checked() {
        let mut scene = Scene::default();
        let mut mask = crate::wavelet::Mask::new(16, 16).unwrap();
        mask.paint_segment(
            glam::DVec2::new(0.5, 0.5),
            glam::DVec2::new(0.6, 0.5),
            &Default::default(),
        );
        scene
            .apply(Edit::SetMask(crate::scene::MaskKind::Detail, Some(mask)))
            .unwrap();
        assert!(scene.detail.mask_png.is_some());
        let detail = DetailSettings {
            levels: 2,
            ..Default::default()
        };
        scene.apply(Edit::SetDetail(detail)).unwrap();
        assert_eq!(scene.detail.levels, 2);
        assert!(scene.detail.mask_png.is_some(), "the mask stays");
        scene
            .apply(Edit::SetMask(crate::scene::MaskKind::Detail, None))
            .unwrap();
        assert!(scene.detail.mask_png.is_none());

        let reference = crate::heightfield::Heightfield::from_vec(4, 4, vec![1.0; 16]).unwrap();
        let mut block = BlendBlock::new("b", &reference, [0.1, 0.1, 0.4, 0.4]).unwrap();
        scene.apply(Edit::AddBlock(block.clone())).unwrap();
        block.rect = [0.5, 0.5, 0.2, 0.9];
        let err = scene
            .apply(Edit::SetBlock {
                index: 0,
                block: block.clone(),
            })
            .unwrap_err();
        assert!(err.to_string().starts_with("blend[0].rect"), "{err}");
        assert_eq!(scene.blend[0].rect, [0.1, 0.1, 0.4, 0.4]);
        let before = scene.clone();
        let err = scene.apply(Edit::AddBlock(block)).unwrap_err();
        assert!(err.to_string().starts_with("blend[1].rect"), "{err}");
        assert_eq!(scene, before, "a refused block is not added");
        let mut feathered = BlendBlock::new("b", &reference, [0.1, 0.1, 0.4, 0.4]).unwrap();
        feathered.feather = 0.9;
        let err = scene.apply(Edit::AddBlock(feathered)).unwrap_err();
        assert!(err.to_string().starts_with("blend[1].feather"), "{err}");
        assert_eq!(
            scene, before,
            "a block feathered past half its side is not added"
        );
        let rect = [0.5, 0.5, 0.9, 0.9];
        scene.apply(Edit::SetBlockRect { index: 0, rect }).unwrap();
        assert_eq!(scene.blend[0].rect, rect);
        let err = scene
            .apply(Edit::SetBlockRect {
                index: 3,
                rect: [0.0, 0.0, 1.0, 1.0],
            })
            .unwrap_err();
        assert_eq!(err.to_string(), "there is no block 3 (the scene has 1)");
        let err = scene
            .apply(Edit::SetGrid {
                size: 512,
                cell_size: f64::NAN,
            })
            .unwrap_err();
        assert!(err.to_string().contains("cell_size"), "{err}");
    }

    /// An edit that would leave a value out of range is refused with the message the scene
    /// file's check gives for the same value, and changes nothing: a script's edit is held
    /// to what the file is held to.
    #[test]
    fn an_edit_out_of_range_is_refused_with_the_files_message() {
        let scene = Scene::default();
        let mut hostile = vec![
            Edit::AddRiver(RiverStroke {
                phi: 0,
                ..stroke(0.5)
            }),
            Edit::AddLine {
                kind: LineKind::Ridge,
                line: SketchLine {
                    points: vec![[0.5, 0.5]],
                    height: None,
                    heights: None,
                },
            },
            Edit::AddPeak(SketchPeak {
                at: [1.5, 0.5],
                height: None,
            }),
            Edit::SetGrid {
                size: 5,
                cell_size: 10.0,
            },
            Edit::SetGrid {
                size: 512,
                cell_size: f64::NAN,
            },
            Edit::SetLocation(Some(super::super::Location {
                lat: 95.0,
                lon: 0.0,
            })),
            Edit::SetParams(Params {
                theta: 0.0,
                ..Params::default()
            }),
            Edit::SetDetail(DetailSettings {
                window: 2,
                ..Default::default()
            }),
            Edit::SetStyle(Some(StyleSettings {
                strength: 9.0,
                ..StyleSettings::bundled("mountains").expect("a bundled style")
            })),
            Edit::SetTextures(TextureRules {
                snow_above: 2.0,
                ..Default::default()
            }),
        ];
        for field in [
            "strength_spread",
            "soft_rock_strength",
            "years",
            "talus_deg",
        ] {
            let mut erosion = ErosionSettings::default();
            match field {
                "strength_spread" => erosion.strength_spread = 5.0,
                "soft_rock_strength" => erosion.soft_rock_strength = 0.0,
                "years" => erosion.years = f64::INFINITY,
                _ => erosion.talus_deg = Some(-3.0),
            }
            hostile.push(Edit::SetErosion(Some(erosion)));
        }
        // The grid bounds the detail's output: a size whose levels would exceed it.
        let detailed = Scene {
            detail: DetailSettings {
                levels: 3,
                ..Default::default()
            },
            ..Scene::default()
        };
        let mut cases: Vec<(Scene, Edit)> =
            hostile.into_iter().map(|e| (scene.clone(), e)).collect();
        cases.push((
            detailed,
            Edit::SetGrid {
                size: 4096,
                cell_size: 10.0,
            },
        ));
        for (scene, edit) in cases {
            let mut unchecked = scene.clone();
            unchecked.change(edit.clone()).unwrap();
            let Err(SceneError::Invalid { field, problem }) = unchecked.validate() else {
                panic!("{edit:?} is not out of range");
            };
            let mut edited = scene.clone();
            let refused = edited.apply(edit.clone());
            assert_eq!(
                refused,
                Err(EditError::Invalid { field, problem }),
                "{edit:?}"
            );
            assert_eq!(edited, scene, "a refused edit changes nothing: {edit:?}");
        }
    }
}
