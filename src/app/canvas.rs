//! What the central map keeps between frames: the view and its overlays, the tool, the
//! selection, the mask being painted, the pictures before and after erosion,
//! and a dropped file being read.

use std::borrow::Cow;

use glam::DVec2;

use crate::jobs::JobHandle;
use crate::scene::{RiverStroke, Scene};
use crate::wavelet::Mask;

use super::map_view::{Hover, MapView, Overlay, Tool};
use super::picture::Picture;

/// A vector item of the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Item {
    River(usize),
    Ridge(usize),
    Valley(usize),
    Peak(usize),
}

/// What a dropped file is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImportTarget {
    /// The detail mask: a PNG dropped while the mask tool is active.
    Mask,
    /// The DEM panel: any elevation file otherwise.
    Dem,
    /// A scene (`.json`): replaces the document.
    Scene,
}

/// A dropped file's name, what it is for, and its contents.
pub type Dropped = (String, ImportTarget, Result<Vec<u8>, String>);

pub struct Canvas {
    pub map: MapView,
    pub tool: Tool,
    pub overlay: Overlay,
    pub hover: Option<Hover>,
    /// Which map layers are drawn.
    pub layers: super::layers::Layers,
    /// The vector item the Select tool picked, and whether it is being dragged.
    pub selected: Option<Item>,
    pub moving: bool,
    /// The mask being painted, decoded, at the scene's size (the scene keeps it as PNG): the
    /// detail's energy reduction, the uplift or the hard rock (`mask_kind`); a brush stroke
    /// (with the mask tools' brush) paints here and becomes an edit when it ends.
    pub mask: Mask,
    pub mask_kind: crate::scene::MaskKind,
    /// The mask changed outside the frame loop (a loaded scene): redraw its overlay.
    pub mask_overlay_stale: bool,
    /// The pictures the Erosion section's before/after toggle switches between (after
    /// erosion, before it), and which one is shown.
    pub pictures: Option<(Picture, Option<Picture>)>,
    pub showing_before: bool,
    /// A dropped file being read (the browser reads files asynchronously).
    pub import_job: Option<JobHandle<Dropped>>,
    /// The rivers' courses as the map draws and picks them.
    pub courses: Courses,
}

/// The rivers' courses as the map draws and picks them ([`Scene::river_courses`]), computed
/// again only when the rivers, their wander or the seed change, not every frame.
#[derive(Default)]
pub struct Courses {
    /// What the courses were computed for: the rivers, the wander, the seed.
    key: Option<(Vec<RiverStroke>, f64, u64)>,
    courses: Vec<Vec<DVec2>>,
}

impl Courses {
    /// Points along each course (bends down to a sixth of the stroke,
    /// [`crate::river::course`]).
    const POINTS: usize = 48;

    fn fresh_for(&self, scene: &Scene) -> bool {
        self.key.as_ref().is_some_and(|(rivers, wander, seed)| {
            *rivers == scene.rivers && *wander == scene.params.wander && *seed == scene.seed
        })
    }

    /// Brings the courses up to date with `scene` (once a frame).
    pub fn refresh(&mut self, scene: &Scene) {
        if !self.fresh_for(scene) {
            self.courses = scene.river_courses(Self::POINTS);
            self.key = Some((scene.rivers.clone(), scene.params.wander, scene.seed));
        }
    }

    /// The courses of `scene`'s rivers, in their order: the kept ones where they are up to
    /// date, else computed now.
    pub fn of(&self, scene: &Scene) -> Cow<'_, [Vec<DVec2>]> {
        if self.fresh_for(scene) {
            Cow::Borrowed(&self.courses)
        } else {
            Cow::Owned(scene.river_courses(Self::POINTS))
        }
    }
}

impl Default for Canvas {
    fn default() -> Self {
        Self {
            map: MapView::default(),
            tool: Tool::default(),
            overlay: Overlay::default(),
            hover: None,
            layers: Default::default(),
            selected: None,
            moving: false,
            mask: Mask::new(512, 512).expect("a 512 x 512 mask is within limits"),
            mask_kind: Default::default(),
            mask_overlay_stale: false,
            pictures: None,
            showing_before: false,
            import_job: None,
            courses: Courses::default(),
        }
    }
}

/// The messages the side panel shows: the last error, and a passing notice (a file saved, a
/// mask imported). The top of the panel lists them; the section where the error's action
/// was taken shows it too, beside its buttons.
#[derive(Default)]
pub struct Messages {
    pub error: Option<String>,
    /// Where the error's action was taken.
    pub error_at: Place,
    pub notice: Option<String>,
    /// Errors set so far (each `set_error_at`), so a script's command can tell whether it
    /// was refused.
    pub errors: u64,
}

/// Where in the side panel an action was taken, for its error to be shown there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Place {
    /// The document, the run, or anywhere without a section of its own: the top only.
    #[default]
    Top,
    /// The DEM panel: uploads, blocks, voids, features, network comparison.
    Dem,
    /// The mask tools: painting, importing, deriving from the rivers.
    Mask,
}

/// What the side panel says about the last run.
#[derive(Default)]
pub struct RunSummaries {
    pub terrain: Option<String>,
    /// The grid side and the diffusion's numbers.
    pub last_run: Option<(usize, crate::diffusion::selftest::RunSummary)>,
    pub detail: Option<String>,
}

/// The Compute check: the CPU/GPU self-test, and the GPU kernels built ahead of the runs.
#[derive(Default)]
pub struct ComputeCheck {
    pub job: Option<
        JobHandle<Result<crate::diffusion::selftest::SelfTest, crate::diffusion::DiffusionError>>,
    >,
    pub result: Option<Result<crate::diffusion::selftest::SelfTest, String>>,
    /// Builds the GPU kernels of the chosen backend (see [`crate::pipeline::warm_kernels`]);
    /// `None` once done, or where the runs compute on the CPU.
    pub kernels: Option<JobHandle<Result<(), crate::pipeline::WarmError>>>,
    /// The "Compute on" choice the kernels were last built (or found unneeded) for: another
    /// choice builds its own.
    pub warmed_for: Option<crate::compute::BackendChoice>,
}
