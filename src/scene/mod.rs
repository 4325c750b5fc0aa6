//! The scene: the user's document, as versioned JSON. Everything else (rivers, ridges,
//! terrain) is rebuilt from it, so the app, `window.strahler` and the command line give the
//! same terrain for the same scene.
//!
//! Coordinates are map units, (0, 0) north-west to (1, 1) south-east, so one scene renders at
//! any size. Missing fields take the documented defaults (see [`Scene::default`] and
//! `docs/scene-format.md`); unknown fields and invalid values are errors that name the field.

mod edit;
mod file;
mod patch;
mod validate;

pub use edit::{Edit, EditError, LineKind};
pub use patch::Patch;

use glam::DVec2;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::river::Stroke;
use crate::terrain::TerrainParams;

/// The version this build writes and reads.
pub const VERSION: u32 = 1;

/// Caps on what a scene may ask for, so that no scene (from a file, the page's automation or
/// the command line) can take unbounded time or memory. Each is checked by
/// [`Scene::validate`], whose message names the field and the limit.
///
/// Rivers: each grows a network and prints a note when trimmed.
pub const MAX_RIVERS: usize = 64;
/// Points of one sketched ridge or valley line.
pub const MAX_SKETCH_POINTS: usize = 10_000;
/// Points of all sketched lines together.
pub const MAX_SKETCH_POINTS_TOTAL: usize = 20_000;
/// Sketched ridges, valleys and peaks together.
pub const MAX_SKETCH_ITEMS: usize = 2_500;
/// Blended blocks (each a Poisson solve).
pub const MAX_BLEND_BLOCKS: usize = 64;
/// The most reference cells all blend blocks of a scene hold together (two 8192^2 windows:
/// decoding and resampling them takes a few seconds; 64 of that size took 199 s).
pub const MAX_BLEND_REFERENCE_CELLS: u64 = 2 * 8192 * 8192;
/// The smallest cell, in metres (1 cm): below it the slopes' arithmetic leaves `f32`.
pub const MIN_CELL_SIZE_M: f64 = 0.01;
/// Width of the map in metres (10000 km).
pub const MAX_MAP_WIDTH_M: f64 = 1.0e7;
/// The largest scene file read (a mask PNG in base64 included).
pub const MAX_SCENE_BYTES: u64 = 64 << 20;
/// The most characters of a parser message shown (a message may quote the file).
const MAX_MESSAGE_CHARS: usize = 300;

#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    /// Malformed JSON, an unknown field or a value of the wrong type (serde names it).
    #[error("scene: {0}")]
    Parse(String),
    #[error("scene: {field}: {problem}")]
    Invalid { field: String, problem: String },
}

/// One river as drawn: estuary first, then the point giving flow direction and extent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RiverStroke {
    pub estuary: [f64; 2],
    pub toward: [f64; 2],
    /// Generator index phi, 1 to 6.
    #[serde(default = "default_phi")]
    pub phi: u32,
    /// MaxDepth of eq. 3, 1 to 16.
    #[serde(default = "default_depth")]
    pub depth: u32,
}

fn default_phi() -> u32 {
    3
}

/// MaxDepth 5: a network of a few hundred nodes, main valleys a few kilometres apart on the
/// default 10 km map, with room between them for the erosion stage to carve the tributaries
/// (see the defaults in `docs/scene-format.md`).
pub fn default_depth() -> u32 {
    5
}

impl From<RiverStroke> for Stroke {
    fn from(r: RiverStroke) -> Self {
        Stroke {
            estuary: DVec2::from(r.estuary),
            toward: DVec2::from(r.toward),
            phi: r.phi,
            max_depth: r.depth,
        }
    }
}

impl From<Stroke> for RiverStroke {
    fn from(s: Stroke) -> Self {
        Self {
            estuary: s.estuary.to_array(),
            toward: s.toward.to_array(),
            phi: s.phi,
            depth: s.max_depth,
        }
    }
}

/// Fractal noise of eq. 5.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseSettings {
    /// Amplitude in metres.
    pub amplitude: f64,
    pub octaves: u32,
    /// Amplitude ratio between octaves.
    pub roughness: f64,
}

impl Default for NoiseSettings {
    fn default() -> Self {
        let n = crate::skeleton::NoiseParams::default();
        Self {
            amplitude: n.amplitude,
            octaves: n.octaves,
            roughness: n.roughness,
        }
    }
}

/// MD/MDI enrichment (Sec. V-B).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnrichSettings {
    /// MDI + MD passes (0 = off).
    pub passes: u32,
    /// Distance limit L in cells.
    pub distance_limit: u32,
    /// What L limits: "skeleton" (no point farther than L cells from the skeleton; the
    /// default) or "points" (the paper as written: no interpolation between points more than
    /// L cells apart).
    #[serde(with = "file::distance_rule")]
    pub distance_rule: crate::skeleton::enrich::DistanceRule,
}

impl Default for EnrichSettings {
    fn default() -> Self {
        let e = crate::skeleton::enrich::EnrichParams::default();
        Self {
            passes: e.passes,
            distance_limit: e.distance_limit,
            distance_rule: e.rule,
        }
    }
}

/// The paper's global parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Branching angle theta in degrees.
    pub theta: f64,
    /// River slope in metres per metre of channel.
    pub river_slope: f64,
    /// How far each drawn river's course wanders from the straight stroke: the standard
    /// deviation of its sideways offset, in stroke lengths (0 to 0.2; 0 is the paper's
    /// straight trunk, and a file without the field). See `river::course`.
    #[serde(default = "straight_course")]
    pub wander: f64,
    /// The drawn rivers' meanders: the largest angle to the valley and the wavelength in
    /// channel widths (none by default; `river::hydraulic`).
    #[serde(skip_serializing_if = "crate::river::hydraulic::Meanders::is_default")]
    pub meanders: crate::river::hydraulic::Meanders,
    /// alpha of eq. 4.
    pub alpha: f64,
    pub noise: NoiseSettings,
    pub enrich: EnrichSettings,
    /// Gaussian smoothing and added fBm on the filled terrain, kept off the rivers.
    #[serde(with = "file::post")]
    pub post: crate::diffusion::PostFilter,
}

impl Default for Params {
    fn default() -> Self {
        let t = TerrainParams::default();
        Self {
            theta: t.rivers.theta_deg,
            river_slope: t.rivers.slope,
            wander: t.rivers.wander,
            meanders: t.rivers.meanders,
            alpha: t.ridges.alpha,
            noise: NoiseSettings::default(),
            enrich: EnrichSettings::default(),
            post: Default::default(),
        }
    }
}

/// The wander of a scene file that does not name one: the straight trunks it was made with.
fn straight_course() -> f64 {
    0.0
}

/// The parameters of a scene file without a `params` section: the defaults, the trunks
/// straight as in [`straight_course`].
fn params_of_a_file() -> Params {
    Params {
        wander: straight_course(),
        ..Params::default()
    }
}

/// A sketched ridge or valley line (seed paper 003): map-unit points, optional height (m),
/// or a height per point (lines extracted from a real DEM).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SketchLine {
    pub points: Vec<[f64; 2]>,
    #[serde(default)]
    pub height: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heights: Option<Vec<f64>>,
}

/// A sketched peak point with an optional height (m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SketchPeak {
    pub at: [f64; 2],
    #[serde(default)]
    pub height: Option<f64>,
}

/// Sketched features: extra constraints beside the grown rivers and ridges.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SketchSettings {
    pub ridges: Vec<SketchLine>,
    /// Valleys start at their mouth (first point).
    pub valleys: Vec<SketchLine>,
    pub peaks: Vec<SketchPeak>,
}

impl SketchSettings {
    /// The pipeline's form.
    pub fn to_sketch(&self) -> crate::skeleton::sketch::Sketch {
        use crate::skeleton::sketch;
        let line = |l: &SketchLine| sketch::SketchLine {
            points: l.points.iter().map(|p| DVec2::from(*p)).collect(),
            height: l.height,
            heights: l.heights.clone(),
        };
        sketch::Sketch {
            ridges: self.ridges.iter().map(line).collect(),
            valleys: self.valleys.iter().map(line).collect(),
            peaks: self
                .peaks
                .iter()
                .map(|p| sketch::SketchPeak {
                    at: DVec2::from(p.at),
                    height: p.height,
                })
                .collect(),
        }
    }

    /// The features extracted from a DEM (seed 003, Sec. 3.1) as editable sketch items,
    /// with the DEM's heights. `scale` maps the features' map units into the scene's square
    /// map (1 for a square DEM; a non-square one fills the square along its longer side).
    ///
    /// A large DEM can give more features than a scene holds ([`MAX_SKETCH_ITEMS`],
    /// [`MAX_SKETCH_POINTS_TOTAL`]): then the same share of each kind is kept, the most
    /// significant first (the extraction sorts lines longest first, peaks highest first).
    pub fn from_features(f: &crate::features::Features, scale: [f64; 2]) -> Self {
        let at = |p: &[f64; 2]| [p[0] * scale[0], p[1] * scale[1]];
        let line = |l: &crate::features::FeatureLine| SketchLine {
            points: l.points.iter().map(at).collect(),
            height: None,
            heights: Some(l.heights.clone()),
        };
        let items = f.ridges.len() + f.valleys.len() + f.peaks.len();
        let points: usize = f
            .ridges
            .iter()
            .chain(&f.valleys)
            .map(|l| l.points.len())
            .sum();
        let share = (MAX_SKETCH_ITEMS as f64 / items.max(1) as f64)
            .min(MAX_SKETCH_POINTS_TOTAL as f64 / points.max(1) as f64)
            .min(1.0);
        let kept = |n: usize| ((n as f64 * share).floor() as usize).min(n);
        let mut ridges: Vec<SketchLine> =
            f.ridges[..kept(f.ridges.len())].iter().map(line).collect();
        let mut valleys: Vec<SketchLine> = f.valleys[..kept(f.valleys.len())]
            .iter()
            .map(line)
            .collect();
        // Rounding down keeps the count; the points can still be over when the kept lines
        // are the long ones: drop the shortest kept line of the longer list until they fit.
        let total = |r: &[SketchLine], v: &[SketchLine]| -> usize {
            r.iter().chain(v).map(|l| l.points.len()).sum()
        };
        while total(&ridges, &valleys) > MAX_SKETCH_POINTS_TOTAL {
            if ridges.len() >= valleys.len() {
                ridges.pop();
            } else {
                valleys.pop();
            }
        }
        Self {
            ridges,
            valleys,
            peaks: f.peaks[..kept(f.peaks.len())]
                .iter()
                .map(|(p, h)| SketchPeak {
                    at: at(p),
                    height: Some(*h),
                })
                .collect(),
        }
    }

    /// Whether there is nothing sketched.
    pub fn is_empty(&self) -> bool {
        self.ridges.is_empty() && self.valleys.is_empty() && self.peaks.is_empty()
    }

    /// From the pipeline's form.
    pub fn from_sketch(s: &crate::skeleton::sketch::Sketch) -> Self {
        let line = |l: &crate::skeleton::sketch::SketchLine| SketchLine {
            points: l.points.iter().map(|p| p.to_array()).collect(),
            height: l.height,
            heights: l.heights.clone(),
        };
        Self {
            ridges: s.ridges.iter().map(line).collect(),
            valleys: s.valleys.iter().map(line).collect(),
            peaks: s
                .peaks
                .iter()
                .map(|p| SketchPeak {
                    at: p.at.to_array(),
                    height: p.height,
                })
                .collect(),
        }
    }
}

/// The document.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scene {
    pub version: u32,
    /// Cells per side of the square map.
    pub size: usize,
    /// Horizontal cell size in metres at `size`.
    pub cell_size: f64,
    /// Multiplier applied to heights on export.
    pub vertical_scale: f64,
    pub seed: u64,
    pub rivers: Vec<RiverStroke>,
    /// Absent: the defaults, with the straight trunks of files written before `wander`.
    #[serde(default = "params_of_a_file")]
    pub params: Params,
    pub sketch: SketchSettings,
    pub detail: DetailSettings,
    /// Stream-power erosion of the designed terrain, the rivers as base level; `null` = off,
    /// absent = the default preset.
    #[serde(with = "file::erosion")]
    pub erosion: Option<crate::erosion::ErosionSettings>,
    /// Detail from a real terrain's spectrum added into the existing levels (after erosion,
    /// before the new detail levels); absent or `null` = off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub style: Option<StyleSettings>,
    /// Blocks of real terrain blended in by the Poisson equation, solved in order.
    #[serde(skip_serializing_if = "Vec::is_empty", with = "file::blocks")]
    pub blend: Vec<crate::blend::BlendBlock>,
    /// Where the exported splat map puts rock, snow and sediment; absent = the defaults.
    #[serde(default, skip_serializing_if = "TextureRules::is_default")]
    pub textures: TextureRules,
    /// Where the map lies on Earth: its centre. Exports then georeference the heightmap in
    /// the centre's UTM zone and give the rivers in longitude and latitude; absent = a
    /// local metric grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub location: Option<Location>,
    /// Masks painted for the erosion: faster uplift, harder rock; absent = none.
    #[serde(default, skip_serializing_if = "ErosionMasks::is_empty")]
    pub erosion_masks: ErosionMasks,
}

/// A place on Earth: WGS84 latitude and longitude in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Location {
    pub lat: f64,
    pub lon: f64,
}

/// The rules of the exported splat map (`crate::export::maps::splat_weights`): ground steeper
/// than `rock_slope_deg` is rock, ground above `snow_above` of the height range is snow,
/// ground draining more than `sediment_area_m2` is sediment, the rest grass; each transition
/// `softness` of its threshold wide.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TextureRules {
    pub rock_slope_deg: f64,
    pub snow_above: f64,
    pub sediment_area_m2: f64,
    pub softness: f64,
}

impl Default for TextureRules {
    fn default() -> Self {
        let d = crate::export::SplatRules::default();
        Self {
            rock_slope_deg: d.rock_slope_deg,
            snow_above: d.snow_above,
            sediment_area_m2: d.sediment_area_m2,
            softness: d.softness,
        }
    }
}

impl TextureRules {
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The export stage's rules.
    pub fn splat(&self) -> crate::export::SplatRules {
        crate::export::SplatRules {
            rock_slope_deg: self.rock_slope_deg,
            snow_above: self.snow_above,
            sediment_area_m2: self.sediment_area_m2,
            softness: self.softness,
        }
    }
}

/// Style from real terrain (`crate::wavelet::style`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StyleSettings {
    /// A bundled style's name (`crate::wavelet::style::STYLES`), or where a measured one
    /// came from (e.g. "from volcano.tif"); for the user.
    pub name: String,
    /// Seed 001's gamma per band (H, V, D) the detail follows, 1 to 6.
    pub gamma: [f64; 3],
    /// Fraction of the missing variance added, 0 to 2.
    #[serde(default = "one")]
    pub strength: f64,
}

fn one() -> f64 {
    1.0
}

impl StyleSettings {
    /// A bundled style by name.
    pub fn bundled(name: &str) -> Option<Self> {
        crate::wavelet::style::bundled(name).map(|gamma| Self {
            name: name.to_owned(),
            gamma,
            strength: 1.0,
        })
    }
}

/// Wavelet levels of detail (seed paper 001) added on top of the generated terrain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetailSettings {
    /// New levels, 0 (off) to 3; each turns `n` cells into `2n - 1` per side.
    pub levels: u32,
    /// "global" (GSA), "local" (LSA, calibrated) or "local-paper" (LSA with eq. 8 exactly
    /// as written).
    pub scope: String,
    /// LSA window in coefficients (odd, 1 to 65).
    pub window: usize,
    /// The energy-reduction mask as a base64 greyscale PNG (white removes the synthetic
    /// detail), any resolution; absent = no mask.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mask_png: Option<String>,
}

impl Default for DetailSettings {
    fn default() -> Self {
        Self {
            levels: 0,
            scope: "global".into(),
            window: 3,
            mask_png: None,
        }
    }
}

impl DetailSettings {
    /// The synthesis parameters (`seed` is the scene's, mixed per stage by the caller).
    pub fn params(&self, seed: u64) -> crate::wavelet::AmplifyParams {
        use crate::wavelet::{AmplifyParams, LocalParams, Scope};
        AmplifyParams {
            levels: self.levels.max(1),
            scope: match self.scope.as_str() {
                "local" | "local-paper" => Scope::Local(LocalParams {
                    window: self.window,
                    as_written: self.scope == "local-paper",
                    ..Default::default()
                }),
                _ => Scope::Global,
            },
            seed,
            ..Default::default()
        }
    }

    /// The decoded mask, if any.
    pub fn mask(&self) -> Result<Option<crate::wavelet::Mask>, SceneError> {
        decode_mask(self.mask_png.as_deref(), "detail.mask_png")
    }

    /// Stores `mask` (or removes it when `None` or clear).
    pub fn set_mask(&mut self, mask: Option<&crate::wavelet::Mask>) {
        self.mask_png = encode_mask(mask);
    }
}

/// A mask stored as a base64 greyscale PNG, decoded (`None` when absent); `field` names it in
/// the error.
fn decode_mask(
    text: Option<&str>,
    field: &str,
) -> Result<Option<crate::wavelet::Mask>, SceneError> {
    use base64::Engine as _;
    let Some(text) = text else {
        return Ok(None);
    };
    let invalid = |problem: String| SceneError::Invalid {
        field: field.into(),
        problem,
    };
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(text.trim())
        .map_err(|e| invalid(format!("is not base64: {e}")))?;
    crate::wavelet::Mask::from_png(&bytes, crate::dem::ReadLimits::default())
        .map(Some)
        .map_err(|e| invalid(e.to_string()))
}

/// A mask as the scene stores it: a base64 greyscale PNG, or `None` for none or a clear mask.
fn encode_mask(mask: Option<&crate::wavelet::Mask>) -> Option<String> {
    use base64::Engine as _;
    mask.filter(|m| !m.is_clear())
        .and_then(|m| m.to_png().ok())
        .map(|png| base64::engine::general_purpose::STANDARD.encode(png))
}

/// What a painted mask does: calm the synthetic detail, raise the land faster, or make the
/// rock harder.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum MaskKind {
    /// The detail's energy-reduction mask (`detail.mask_png`).
    #[default]
    Detail,
    /// Faster uplift where painted (`erosion_masks.uplift_png`).
    Uplift,
    /// Harder rock where painted (`erosion_masks.hard_rock_png`).
    HardRock,
}

impl MaskKind {
    pub const ALL: [MaskKind; 3] = [MaskKind::Detail, MaskKind::Uplift, MaskKind::HardRock];

    /// The name scripts use (`paintMask({target})`, `generate --mask KIND=PNG`).
    pub fn name(self) -> &'static str {
        match self {
            MaskKind::Detail => "detail",
            MaskKind::Uplift => "uplift",
            MaskKind::HardRock => "hard-rock",
        }
    }

    /// The kind named `name`, or `None`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Where the scene file keeps it.
    pub fn field(self) -> &'static str {
        match self {
            MaskKind::Detail => "detail.mask_png",
            MaskKind::Uplift => "erosion_masks.uplift_png",
            MaskKind::HardRock => "erosion_masks.hard_rock_png",
        }
    }
}

/// Masks the user paints for the erosion (greyscale PNGs in base64, any resolution, white =
/// the full effect; absent = none): where ranges rise (faster uplift) and where the rock is
/// harder. They belong to the scene, not to the erosion's settings, so a change of terrain
/// type keeps them. See [`crate::erosion::Painted`] for what they do.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ErosionMasks {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uplift_png: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hard_rock_png: Option<String>,
}

impl ErosionMasks {
    pub fn is_empty(&self) -> bool {
        self.uplift_png.is_none() && self.hard_rock_png.is_none()
    }
}

impl Scene {
    /// The painted mask of `kind`, decoded (`None` when there is none).
    pub fn mask(&self, kind: MaskKind) -> Result<Option<crate::wavelet::Mask>, SceneError> {
        decode_mask(self.mask_text(kind), kind.field())
    }

    fn mask_text(&self, kind: MaskKind) -> Option<&str> {
        match kind {
            MaskKind::Detail => self.detail.mask_png.as_deref(),
            MaskKind::Uplift => self.erosion_masks.uplift_png.as_deref(),
            MaskKind::HardRock => self.erosion_masks.hard_rock_png.as_deref(),
        }
    }

    /// Stores the painted mask of `kind` (removes it when `None` or clear).
    pub fn set_mask(&mut self, kind: MaskKind, mask: Option<&crate::wavelet::Mask>) {
        let text = encode_mask(mask);
        match kind {
            MaskKind::Detail => self.detail.mask_png = text,
            MaskKind::Uplift => self.erosion_masks.uplift_png = text,
            MaskKind::HardRock => self.erosion_masks.hard_rock_png = text,
        }
    }
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            version: VERSION,
            size: 512,
            cell_size: 10_000.0 / 512.0,
            vertical_scale: 1.0,
            seed: 1,
            rivers: Vec::new(),
            params: Params::default(),
            sketch: SketchSettings::default(),
            detail: DetailSettings::default(),
            erosion: Some(crate::erosion::ErosionSettings::default()),
            style: None,
            blend: Vec::new(),
            textures: TextureRules::default(),
            location: None,
            erosion_masks: ErosionMasks::default(),
        }
    }
}

impl Scene {
    /// Parses and validates a scene. The top level must be a JSON object: serde would read an
    /// array positionally, field by field.
    pub fn from_json(text: &str) -> Result<Self, SceneError> {
        let parse = |message: String| {
            SceneError::Parse(match message.char_indices().nth(MAX_MESSAGE_CHARS) {
                Some((end, _)) => format!("{}...", &message[..end]),
                None => message,
            })
        };
        // A byte-order mark (editors on Windows write one) is not part of the JSON.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let first = text.trim_start().chars().next();
        if first != Some('{') {
            let got = match first {
                None => "nothing".to_owned(),
                Some('[') => "an array".to_owned(),
                // Escaped, so an invisible character is seen.
                Some(c) => format!("{c:?}"),
            };
            return Err(parse(format!(
                "a scene is a JSON object ({{\"version\": 1, ...}}), got {got}"
            )));
        }
        // The path of the value serde refused (`params.noise.octaves: invalid type...`), so a
        // wrong type names its field as a wrong value does.
        let named = |e: serde_path_to_error::Error<serde_json::Error>| {
            let path = e.path().to_string();
            parse(if path == "." {
                e.inner().to_string()
            } else {
                format!("{path}: {}", e.inner())
            })
        };
        let scene: Scene = if declared_version(text).is_some_and(|v| v != u64::from(VERSION)) {
            // Another format: brought up to this one as JSON (or refused), then read.
            let mut value: serde_json::Value =
                serde_json::from_str(text).map_err(|e| parse(e.to_string()))?;
            file::migrate(&mut value)?;
            serde_path_to_error::deserialize(value).map_err(named)?
        } else {
            let mut de = serde_json::Deserializer::from_str(text);
            let scene = serde_path_to_error::deserialize(&mut de).map_err(named)?;
            de.end().map_err(|e| parse(e.to_string()))?;
            scene
        };
        scene.validate()?;
        Ok(scene)
    }

    /// Serialised in this build's format.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The scene of a real DEM's features (seed 003, Sec. 3.1): the DEM's size and cell size,
    /// no rivers, the features as the sketch with the DEM's heights (a non-square DEM fills
    /// the square map from its north-west corner). The user edits it and regenerates.
    pub fn from_features(
        found: &crate::features::Features,
        width: usize,
        height: usize,
        cell_m: f64,
    ) -> Result<Self, SceneError> {
        if found.ridges.is_empty() && found.valleys.is_empty() && found.peaks.is_empty() {
            return Err(SceneError::Invalid {
                field: "sketch".into(),
                problem: "the DEM gave no ridge, valley or peak (is it flat?); there is nothing \
                          to rebuild a terrain from"
                    .into(),
            });
        }
        let side = width.max(height).clamp(16, 8192);
        let span = (side - 1).max(1) as f64;
        let scale = [
            width.saturating_sub(1) as f64 / span,
            height.saturating_sub(1) as f64 / span,
        ];
        let scene = Scene {
            size: side,
            cell_size: cell_m,
            sketch: SketchSettings::from_features(found, scale),
            // The sketch carries the DEM's heights and its valleys drain as the DEM does; the
            // erosion dissects that relief as land between the lines.
            erosion: Some(crate::erosion::ErosionSettings::rebuild(
                found.height_range(),
                found.hilltop_curvature_per_m(cell_m),
            )),
            ..Scene::default()
        };
        scene.validate()?;
        Ok(scene)
    }

    /// Width of the map in metres (`cell_size` x `size`), whatever size a run has.
    pub fn map_width(&self) -> f64 {
        self.cell_size * self.size as f64
    }

    /// The strokes of the rivers.
    pub fn strokes(&self) -> Vec<Stroke> {
        self.rivers.iter().copied().map(Stroke::from).collect()
    }

    /// The course of each river as the terrain draws its trunk (its stroke bent by the
    /// scene's wander, [`crate::river::course`]): `points + 1` points from the estuary to the
    /// stroke's end, map units, in the rivers' order.
    pub fn river_courses(&self, points: usize) -> Vec<Vec<DVec2>> {
        let strokes = self.strokes();
        let seed = crate::terrain::stage_seed(self.seed, "rivers");
        crate::river::courses_of(&strokes, self.params.wander, seed)
            .iter()
            .zip(&strokes)
            .map(|(course, stroke)| course.trunk(stroke, points))
            .collect()
    }

    /// The pipeline parameters at the scene's own size.
    pub fn terrain_params(&self) -> TerrainParams {
        let mut t = TerrainParams {
            size: self.size,
            seed: self.seed,
            ..Default::default()
        };
        t.rivers.theta_deg = self.params.theta;
        t.rivers.slope = self.params.river_slope;
        t.rivers.wander = self.params.wander;
        t.rivers.meanders = self.params.meanders;
        t.ridges.alpha = self.params.alpha;
        t.ridges.map_width_m = self.cell_size * self.size as f64;
        t.rivers.map_width_m = t.ridges.map_width_m;
        t.noise.amplitude = self.params.noise.amplitude;
        t.noise.octaves = self.params.noise.octaves;
        t.noise.roughness = self.params.noise.roughness;
        t.enrich.passes = self.params.enrich.passes;
        t.enrich.distance_limit = self.params.enrich.distance_limit;
        t.enrich.rule = self.params.enrich.distance_rule;
        t.sketch = self.sketch.to_sketch();
        t.post = self.params.post;
        t
    }
}

/// The format `text` declares (its `version`, when a number), read without building the
/// document.
fn declared_version(text: &str) -> Option<u64> {
    #[derive(Deserialize)]
    struct Version {
        version: Option<serde_json::Value>,
    }
    serde_json::from_str::<Version>(text)
        .ok()
        .and_then(|v| v.version)
        .and_then(|v| v.as_u64())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A large DEM's features are cut to what a scene holds, the same share of each kind and
    /// the most significant first; a DEM with none is refused, not written as an empty scene.
    #[test]
    fn features_fit_the_scene_or_are_refused() {
        use crate::features::{FeatureLine, Features};
        let line = |n: usize, len: usize| FeatureLine {
            points: (0..len)
                .map(|i| [0.1 + i as f64 * 1e-3, 0.1 + n as f64 * 1e-4])
                .collect(),
            heights: vec![100.0; len],
        };
        let found = Features {
            ridges: (0..900).map(|n| line(n, 30)).collect(),
            valleys: (0..900).map(|n| line(n, 10)).collect(),
            peaks: (0..200).map(|n| ([0.5, 0.5], 1000.0 - n as f64)).collect(),
            ..Features::default()
        };
        let scene = Scene::from_features(&found, 512, 512, 30.0).unwrap();
        let s = &scene.sketch;
        let items = s.ridges.len() + s.valleys.len() + s.peaks.len();
        assert!(items <= MAX_SKETCH_ITEMS && items > 500, "{items}");
        assert_eq!(s.ridges[0].points.len(), 30);
        assert_eq!(s.peaks[0].height, Some(1000.0), "the highest peak is kept");
        assert!(s.ridges.len() < 900 && s.valleys.len() < 900 && s.peaks.len() < 200);
        let err = Scene::from_features(&Features::default(), 64, 64, 30.0).unwrap_err();
        assert!(
            err.to_string().contains("no ridge, valley or peak"),
            "{err}"
        );
    }

    #[test]
    fn round_trips_and_fills_defaults() {
        let scene = Scene::from_json(
            r#"{"version": 1, "rivers": [{"estuary": [0.5, 1], "toward": [0.5, 0.3]}]}"#,
        )
        .unwrap();
        assert_eq!(scene.size, 512);
        assert_eq!(scene.rivers[0].phi, 3);
        assert_eq!(Scene::from_json(&scene.to_json()).unwrap(), scene);
    }

    #[test]
    fn unknown_and_invalid_fields_are_named() {
        let err = Scene::from_json(r#"{"version": 1, "colour": "red"}"#).unwrap_err();
        assert!(err.to_string().contains("unknown field `colour`"), "{err}");
        let err = Scene::from_json(
            r#"{"version": 1, "rivers": [{"estuary": [0.5, 1], "toward": [0.5, 0.3], "phi": 9}]}"#,
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "scene: rivers[0].phi: must be 1 to 6, got 9"
        );
        let err =
            Scene::from_json(r#"{"version": 1, "params": {"noise": {"octaves": 0}}}"#).unwrap_err();
        assert!(err.to_string().contains("params.noise.octaves"), "{err}");
        let err = Scene::from_json(r#"{"version": 1, "sketch": {"peaks": [{"at": [0.5, 1.5]}]}}"#)
            .unwrap_err();
        assert!(err.to_string().contains("sketch.peaks[0].at"), "{err}");
        let err =
            Scene::from_json(r#"{"version": 1, "sketch": {"ridges": [{"points": [[0.1, 0.1]]}]}}"#)
                .unwrap_err();
        assert!(err.to_string().contains("sketch.ridges[0].points"), "{err}");
        let err = Scene::from_json(r#"{"version": 2}"#).unwrap_err();
        assert!(err.to_string().contains("version"), "{err}");
        assert!(Scene::from_json("{not json").is_err());
    }

    #[test]
    fn arrays_are_not_scenes() {
        // serde would read this positionally: version 1, size 64.
        let err = Scene::from_json("[1, 64]").unwrap_err();
        assert!(err.to_string().contains("JSON object"), "{err}");
        assert!(Scene::from_json("  \n").is_err());
        assert!(Scene::from_json(" {\"version\": 1}").is_ok());
        let long = format!(r#"{{"version": 1, "{}": 1}}"#, "x".repeat(100_000));
        let err = Scene::from_json(&long).unwrap_err();
        assert!(
            err.to_string().len() < 400,
            "{} chars",
            err.to_string().len()
        );
    }

    #[test]
    fn caps_name_the_field_and_the_limit() {
        let river = RiverStroke {
            estuary: [0.5, 1.0],
            toward: [0.5, 0.3],
            phi: 3,
            depth: 8,
        };
        let mut scene = Scene {
            rivers: vec![river; MAX_RIVERS],
            ..Default::default()
        };
        assert!(scene.validate().is_ok());
        scene.rivers.push(river);
        let err = scene.validate().unwrap_err().to_string();
        assert!(
            err.contains("rivers") && err.contains("at most 64"),
            "{err}"
        );

        let line = |n: usize| SketchLine {
            points: (0..n).map(|i| [i as f64 / n as f64, 0.5]).collect(),
            height: None,
            heights: None,
        };
        let mut scene = Scene::default();
        scene.sketch.ridges.push(line(MAX_SKETCH_POINTS + 1));
        let err = scene.validate().unwrap_err().to_string();
        assert!(
            err.contains("sketch.ridges[0].points") && err.contains("10000"),
            "{err}"
        );
        scene.sketch.ridges = vec![line(MAX_SKETCH_POINTS); 3];
        let err = scene.validate().unwrap_err().to_string();
        assert!(err.contains(&MAX_SKETCH_POINTS_TOTAL.to_string()), "{err}");
        scene.sketch.ridges.clear();
        scene.sketch.peaks = vec![
            SketchPeak {
                at: [0.5, 0.5],
                height: None
            };
            MAX_SKETCH_ITEMS + 1
        ];
        let err = scene.validate().unwrap_err().to_string();
        assert!(
            err.contains(&format!("{MAX_SKETCH_ITEMS} ridges, valleys and peaks")),
            "{err}"
        );
    }

    #[test]
    fn huge_cell_sizes_are_refused_not_panics() {
        let err = Scene::from_json(r#"{"version": 1, "cell_size": 1e36}"#).unwrap_err();
        assert!(err.to_string().contains("cell_size"), "{err}");
        let err =
            Scene::from_json(r#"{"version": 1, "cell_size": 1e308, "size": 8192}"#).unwrap_err();
        assert!(err.to_string().contains("cell_size"), "{err}");
    }
}
