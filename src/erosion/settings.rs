//! The scene's `erosion` section ([`ErosionSettings`]): the preset, the physics' rates and
//! the rock's fields, checked on load, and what each terrain type (preset) sets.

use serde::Serialize;

use super::ErosionParams;
/// The scene's `erosion` section: the stream-power law with uplift and hillslope processes
/// (see [`super`]). Absent from a scene = no erosion.
/// Serialised into the pipeline's stage keys and the Web Worker's parcels; the scene file
/// has its own schema.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ErosionSettings {
    /// The preset these values came from ("custom" once edited); for the user only.
    pub preset: String,
    /// Uplift rate U in metres per thousand years: everywhere alike where the erosion shapes
    /// the grown branches (the relief from the physics, [`Relief::Physics`]); else where the
    /// design stands highest above its nearest river, with [`RIVERSIDE_UPLIFT`] of it beside
    /// the rivers, levelling off towards the highest ground ([`uplift_map`]).
    pub uplift_m_per_kyr: f64,
    /// Erodibility K of the stream-power law, in m^(1-2m) per year.
    pub erodibility: f64,
    /// Drainage-area exponent m.
    pub m: f64,
    /// Slope exponent n (m/n is the concavity, 0.3 to 0.7 in real rivers).
    pub n: f64,
    /// Hillslope diffusivity kappa in m^2 per year.
    pub diffusivity: f64,
    /// Simulated time in years.
    pub years: f64,
    /// Time steps (the implicit scheme is stable at any step).
    pub steps: u32,
    /// Thermal erosion: the talus angle in degrees above which scree slides (absent = off).
    pub talus_deg: Option<f64>,
    /// Cells on each side of a river or valley kept at their designed height with it (the
    /// river's banks), 0 to 16.
    pub river_band: u32,
    /// Cell-scale roughness added to the land before eroding, metres (standard deviation):
    /// water on a smooth plane runs in parallel lines forever, as on no real slope; a little
    /// roughness lets the flow lines meet and branch (as landscape-evolution models start
    /// from a randomly perturbed surface).
    pub roughness_m: f64,
    /// Rock hardness: how many times faster the softest rock erodes than the hardest (the
    /// erodibility K varies in patches between `K / sqrt(c)` and `K sqrt(c)`, see
    /// [`super::erodibility_factors`]); 1 = uniform rock.
    pub rock_contrast: f64,
    /// The size of the patches of harder and softer rock, metres.
    pub rock_patch_m: f64,
    /// Layered rock: the thickness of one hard bed and the soft bed above it, metres; 0 = no
    /// beds (see [`super::Strata`]). Rivers cutting through beds leave cliffs and benches.
    pub strata_m: f64,
    /// How many times faster the soft beds erode than the hard ones (1 = no beds).
    pub strata_contrast: f64,
    /// How much the rock's strength varies under the talus angle: each cell's slope may
    /// reach `tan(talus)` times a factor in `(1 - spread, 1]` ([`super::SlopeStrength`]),
    /// so failed flanks are chutes and ribs, not planes; 0 = one angle everywhere.
    pub strength_spread: f64,
    /// How strong the softest rock of the rock field is: soft rock's threshold slope is this
    /// share of hard rock's, so units of soft rock stand gentler than hard massifs
    /// ([`super::SlopeStrength::with_rock`]); 1 = the rock field leaves the angle alone.
    pub soft_rock_strength: f64,
    /// Ranges and basins: how many times faster the rock rises in the fastest-rising ranges
    /// than in the slowest basins (the uplift varies over `uplift_scale_m`, see
    /// [`super::Ranges`]); 1 = uplift alike everywhere.
    pub uplift_contrast: f64,
    /// The wavelength of the largest ranges and basins, metres.
    pub uplift_scale_m: f64,
    /// Where the relief comes from ([`Relief`]).
    pub relief: Relief,
    /// Whether land beyond the rivers' reach drains off the map's edge ([`Border`]).
    pub border: Border,
}

/// What the map's edge is to the water.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Border {
    /// A window on a larger land: where the network does not reach a stretch of the edge,
    /// a stream leaves the map there ([`super::outlets`]), so the high ground stands on the
    /// divides inside the map, not along its frame.
    #[default]
    Open,
    /// A closed catchment (an island, a basin, a map whose every drop reaches the drawn
    /// rivers): the edge is a divide, and the land farthest from the rivers, its corners
    /// and edges, stands highest.
    Closed,
}

impl Border {
    /// The scene file's word for it.
    pub fn name(self) -> &'static str {
        match self {
            Border::Open => "open",
            Border::Closed => "closed",
        }
    }
}

/// Where an eroded terrain's relief comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Relief {
    /// The physics: the rock rises evenly and the stream-power law sets the long profiles
    /// of the branches the L-system grew (`guide.rs`), their courses kept, so the relief
    /// follows uplift against erodibility: headwaters stand high and steep, the ranges rise
    /// between the largest rivers. The drawn trunks stay at their drawn heights. Where the
    /// sketch holds peaks or ridges, their heights set the ranges: the design's way then.
    Physics,
    /// The design: every river is held at its drawn heights, and the uplift follows the
    /// design's height above its nearest river ([`uplift_from_design`]). Scene files written
    /// before the choice existed erode this way (the same terrain as then).
    #[default]
    Design,
}

impl Relief {
    /// The scene file's word for it.
    pub fn name(self) -> &'static str {
        match self {
            Relief::Physics => "physics",
            Relief::Design => "design",
        }
    }
}

impl Default for ErosionSettings {
    /// The first preset.
    fn default() -> Self {
        let name = super::PRESETS[0];
        let params = super::preset(name).unwrap_or(ErosionParams {
            years: 1.0e6,
            steps: 20,
            erodibility: 2.0e-5,
            m: 0.5,
            n: 1.0,
            diffusivity: 0.01,
            talus_deg: None,
        });
        Self::from_params(name, &params, uplift_of(name))
    }
}

/// The most time steps a scene may ask for.
pub const MAX_SCENE_STEPS: u32 = 1000;

/// The default [`ErosionSettings::rock_contrast`]: the softest rock erodes 10 times faster
/// than the hardest (measured K of sandstone against limestone or granite differ by 10 to
/// 100); at 4 the patches barely show through the threshold slopes.
pub const DEFAULT_ROCK_CONTRAST: f64 = 10.0;
/// The default [`ErosionSettings::rock_patch_m`].
pub const DEFAULT_ROCK_PATCH_M: f64 = 2500.0;

/// The default [`ErosionSettings::uplift_contrast`] of the young-mountains preset: its
/// ranges rise 8 times faster than its basins (at 4 the default scene's hypsometric integral
/// fell from 0.42 to 0.35-0.37 at 10 and 50 km, at 8 to 0.29-0.36, beside real windows'
/// 0.29-0.42).
pub const DEFAULT_UPLIFT_CONTRAST: f64 = 8.0;

/// The default [`ErosionSettings::strata_contrast`] (once beds are asked for): sandstone
/// caprock over shale erodes 5 to 20 times slower (Forte et al. 2016 take 2 to 10 and more).
pub const DEFAULT_STRATA_CONTRAST: f64 = 8.0;

/// The uplift each preset pairs with its erodibility (m per thousand years).
fn uplift_of(preset: &str) -> f64 {
    match preset {
        "badlands" => 2.0,
        // Passive margins and coastal plains rise or sink a few hundredths of a millimetre
        // a year; 0.05 m/kyr against the preset's soft rock gives 77-121 m of relief on
        // 10-50 km maps at 512^2 (135-140 m at 10 km from 1024^2 on).
        "coastal-plain" => 0.05,
        _ => 1.0,
    }
}

/// Where each preset's relief comes from: the mountains' and the coastal plain's from the
/// physics (land rising evenly, the branches' profiles the law's: the design's ridges, over
/// 1000 m on the default scene, would make no plain); the old hills', the badlands' and the mesas'
/// from the design, as they were tuned: with land rising evenly the hills stood 1566 m high
/// and steep, the badlands over 1000 m in coarse ridges instead of dense fine gullies, and the
/// mesas' soft beds no longer bared the hard ones into benches.
fn relief_of(preset: &str) -> Relief {
    match preset {
        "young-mountains" | "coastal-plain" => Relief::Physics,
        _ => Relief::Design,
    }
}

/// The ranges' uplift contrast of a preset: young mountains rise faster in some ranges than
/// in others ([`super::Ranges`]); the presets whose uplift follows the design take their
/// ranges from it.
fn uplift_contrast_of(preset: &str) -> f64 {
    match preset {
        "young-mountains" => DEFAULT_UPLIFT_CONTRAST,
        _ => 1.0,
    }
}

/// The layered rock each preset pairs with its law: (bed thickness in metres, 0 = none;
/// the soft beds' erodibility over the hard beds'), and the contrast of its rock patches.
/// Mesas: 120 m pairs of beds 20 times apart in strength, and weaker patches (2), so that
/// the beds, not the patches, shape the land (chosen by eye on the default scene at 10 km,
/// where it gives some five beds of relief: escarpments round broad benches).
/// How strong a preset's softest rock is ([`ErosionSettings::soft_rock_strength`]): the mesas'
/// beds set where their rock stands steep and where gentle, so their rock field leaves the
/// angle alone; elsewhere [`super::slope_limit::SOFT_ROCK_STRENGTH`].
fn soft_rock_strength_of(preset: &str) -> f64 {
    match preset {
        "mesas" => 1.0,
        _ => super::slope_limit::SOFT_ROCK_STRENGTH,
    }
}

fn rock_of_preset(preset: &str) -> (f64, f64, f64) {
    match preset {
        "mesas" => (120.0, 20.0, 2.0),
        _ => (0.0, DEFAULT_STRATA_CONTRAST, DEFAULT_ROCK_CONTRAST),
    }
}

/// The range of the soil creep a rebuild infers from its DEM, m^2/yr: from the
/// young-mountains preset's (knife-edge crests) to a hundred times it (hilltops rounded over
/// many cells; real soil-mantled hillslopes 0.001-0.05, Roering et al. 2007, the rebuild's
/// uplift being faster than real erosion rates).
const REBUILD_DIFFUSIVITY: (f64, f64) = (0.005, 0.5);

impl ErosionSettings {
    /// The named preset ([`super::PRESETS`]), or `None`.
    pub fn preset(name: &str) -> Option<Self> {
        let params = super::preset(name)?;
        Some(Self::from_params(name, &params, uplift_of(name)))
    }

    /// The erosion of a terrain rebuilt from a real DEM's features, whose heights span
    /// `relief_m`: the young-mountains law for a quarter of its time, with the uplift that
    /// raises the highest ground by a quarter of that relief over the run.
    ///
    /// A rebuild starts from the DEM's own relief (the features carry its heights), so its
    /// erosion has to dissect that relief, not build it: the preset's full uplift (1 m/kyr
    /// for 2 Myr) raised an 88 m coastal lowland into hills. Chosen by eye and by SSIM
    /// against the DEM on the SRTM windows of `tests/data` (`strahler features --rebuild`,
    /// docs/features.md): the full preset scored 0.70 at 10 km, a quarter of its time with
    /// this uplift 0.74, a twentieth 0.80 but left parallel rills on planar flanks.
    ///
    /// The soil creep comes from the DEM: `hilltop_curvature` (1/m, the convex crests'
    /// `-lap(h)`, `features::hilltop_curvature` over the cell's side squared) gives the
    /// diffusivity at which the rebuild's hilltops, lowered at its uplift rate, keep the
    /// DEM's curvature at steady state, `kappa = U / C_HT` (Roering et al. 2007; Hurst et al.
    /// 2012), within [`REBUILD_DIFFUSIVITY`]. The preset's creep (0.005 m^2/yr) cut gullies
    /// a cell apart into DEMs dissected at hundreds of metres: on the SRTM windows the
    /// inferred creep (0.06, 0.08 and 0.21 m^2/yr at 10 km, on the 384^2 crop and on the
    /// whole tile) raised SSIM from 0.755 to 0.790, 0.710 to 0.731 and 0.825 to 0.851.
    /// `None` (no convex crest) keeps the preset's.
    pub fn rebuild(relief_m: f64, hilltop_curvature: Option<f64>) -> Self {
        let mut s = Self::preset("young-mountains").expect("a preset of PRESETS");
        s.preset = "rebuild".into();
        // The features carry the DEM's relief: the uplift follows them (land rising evenly
        // cost the rebuild 0.06 of SSIM against the DEM).
        s.relief = Relief::Design;
        // The features carry the DEM's ranges and basins already, and its steep and gentle
        // ground: rock units of its own would put gentle patches where the DEM has none.
        s.uplift_contrast = 1.0;
        s.soft_rock_strength = 1.0;
        s.years /= 4.0;
        let relief = if relief_m.is_finite() {
            relief_m.max(0.0)
        } else {
            0.0
        };
        s.uplift_m_per_kyr = (0.25 * relief / s.years * 1000.0).min(100.0);
        if let Some(c) = hilltop_curvature.filter(|c| c.is_finite() && *c > 0.0) {
            let kappa = s.uplift_m_per_kyr / 1000.0 / c;
            let (lo, hi) = REBUILD_DIFFUSIVITY;
            s.diffusivity = if kappa.is_finite() {
                kappa.clamp(lo, hi)
            } else {
                hi
            };
        }
        s
    }

    fn from_params(name: &str, p: &ErosionParams, uplift_m_per_kyr: f64) -> Self {
        let (strata_m, strata_contrast, rock_contrast) = rock_of_preset(name);
        Self {
            preset: name.to_owned(),
            uplift_m_per_kyr,
            erodibility: p.erodibility,
            m: p.m,
            n: p.n,
            diffusivity: p.diffusivity,
            years: p.years,
            steps: p.steps,
            talus_deg: p.talus_deg,
            river_band: 1,
            roughness_m: 2.0,
            rock_contrast,
            rock_patch_m: DEFAULT_ROCK_PATCH_M,
            strata_m,
            strata_contrast,
            strength_spread: super::slope_limit::SPREAD,
            soft_rock_strength: soft_rock_strength_of(name),
            uplift_contrast: uplift_contrast_of(name),
            uplift_scale_m: super::ranges::DEFAULT_SCALE_M,
            relief: relief_of(name),
            border: Border::Open,
        }
    }

    /// The beds of layered rock, or `None`.
    pub fn strata(&self) -> Option<super::Strata> {
        super::Strata::new(self.strata_m, self.strata_contrast)
    }

    /// The solver's parameters.
    pub fn params(&self) -> ErosionParams {
        ErosionParams {
            years: self.years,
            steps: self.steps,
            erodibility: self.erodibility,
            m: self.m,
            n: self.n,
            diffusivity: self.diffusivity,
            talus_deg: self.talus_deg,
        }
    }

    /// Checks every value: `Err((field, problem))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.uplift_m_per_kyr.is_finite() && (0.0..=100.0).contains(&self.uplift_m_per_kyr)) {
            return Err((
                "uplift_m_per_kyr",
                format!(
                    "must be 0 to 100 m per thousand years, got {}",
                    self.uplift_m_per_kyr
                ),
            ));
        }
        if !(self.roughness_m.is_finite() && (0.0..=100.0).contains(&self.roughness_m)) {
            return Err((
                "roughness_m",
                format!("must be 0 to 100 m, got {}", self.roughness_m),
            ));
        }
        if !(self.rock_contrast.is_finite() && (1.0..=100.0).contains(&self.rock_contrast)) {
            return Err((
                "rock_contrast",
                format!(
                    "must be 1 (uniform rock) to 100, got {}",
                    self.rock_contrast
                ),
            ));
        }
        if !(self.rock_patch_m.is_finite() && (10.0..=1.0e6).contains(&self.rock_patch_m)) {
            return Err((
                "rock_patch_m",
                format!("must be 10 m to 1000 km, got {}", self.rock_patch_m),
            ));
        }
        if !(self.strata_m.is_finite() && (0.0..=10_000.0).contains(&self.strata_m)) {
            return Err((
                "strata_m",
                format!("must be 0 (no beds) to 10000 m, got {}", self.strata_m),
            ));
        }
        if !(self.strata_contrast.is_finite() && (1.0..=100.0).contains(&self.strata_contrast)) {
            return Err((
                "strata_contrast",
                format!("must be 1 (no beds) to 100, got {}", self.strata_contrast),
            ));
        }
        if !(self.uplift_contrast.is_finite() && (1.0..=100.0).contains(&self.uplift_contrast)) {
            return Err((
                "uplift_contrast",
                format!(
                    "must be 1 (uplift alike everywhere) to 100, got {}",
                    self.uplift_contrast
                ),
            ));
        }
        if !(self.uplift_scale_m.is_finite() && (100.0..=1.0e7).contains(&self.uplift_scale_m)) {
            return Err((
                "uplift_scale_m",
                format!("must be 100 m to 10000 km, got {}", self.uplift_scale_m),
            ));
        }
        if !(self.soft_rock_strength.is_finite() && (0.1..=1.0).contains(&self.soft_rock_strength))
        {
            return Err((
                "soft_rock_strength",
                format!(
                    "must be 0.1 to 1 (soft rock as strong as hard), got {}",
                    self.soft_rock_strength
                ),
            ));
        }
        if !(self.strength_spread.is_finite() && (0.0..=0.9).contains(&self.strength_spread)) {
            return Err((
                "strength_spread",
                format!(
                    "must be 0 (one talus angle) to 0.9, got {}",
                    self.strength_spread
                ),
            ));
        }
        // Physical ranges, and a bound on the work a scene can ask for (the solver itself
        // takes any finite values: tests run 2000 steps of an analytic profile).
        let limits: [(&'static str, f64, f64, &str); 4] = [
            (
                "erodibility",
                self.erodibility,
                1.0,
                "m^(1-2m)/yr (real rock: 1e-7 to 1e-3)",
            ),
            (
                "diffusivity",
                self.diffusivity,
                10.0,
                "m^2/yr (soil creep: 1e-3 to 5e-2)",
            ),
            (
                "years",
                self.years,
                1.0e8,
                "years (landscapes settle within 1e5 to 1e7)",
            ),
            (
                "steps",
                f64::from(self.steps),
                f64::from(MAX_SCENE_STEPS),
                "steps (the presets take 20; each step is one pass over the map)",
            ),
        ];
        for (field, value, max, unit) in limits {
            if value > max {
                return Err((field, format!("must be at most {max} {unit}, got {value}")));
            }
        }
        if self.river_band > 16 {
            return Err((
                "river_band",
                format!("must be 0 to 16 cells, got {}", self.river_band),
            ));
        }
        self.params().validate()
    }
}
