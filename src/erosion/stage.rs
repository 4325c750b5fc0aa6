//! Erosion as a stage of the scene's pipeline: which cells are base level, the uplift map
//! from the design, the solver run in steps with the job's ticks between them, and the
//! drainage check of the eroded terrain.

use std::ops::Range;
use std::sync::Arc;

use serde::Serialize;
use thiserror::Error;

use super::coarse::{self, MAX_SOLVER_SIDE};
use super::gpu::{self, GpuErosionError, GpuInput};
use super::nearest::{NearestChannel, Transform};
use super::outlets::{Keep, border_outlets, border_outlets_in_steps};
use super::{CHUNK_CELLS, Eroder, ErosionError, ErosionParams};
use crate::compute::Backend;
use crate::gpu::GpuField;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::parallel;
use crate::skeleton::CellKind;
use crate::terrain::{Generated, drainage};

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
        // The features carry the DEM's ranges and basins already.
        s.uplift_contrast = 1.0;
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

/// What the erosion stage reports.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct ErosionReport {
    pub preset: String,
    pub steps: u32,
    pub years: f64,
    /// Cells kept at their height (rivers, valleys, their banks, the map border).
    pub base_level_cells: usize,
    /// Mean and largest lowering of the land, metres (negative = raised by uplift).
    pub mean_depth_m: f64,
    pub max_depth_m: f64,
    /// Drainage of the eroded terrain (after depression filling).
    pub drainage: drainage::Drainage,
    pub conditioning: drainage::Conditioning,
    /// Where the solver ran: "cpu" or "gpu" (the GPU when the pipeline's backend is one and
    /// it holds the solver's fields, see [`super::gpu`]).
    #[serde(deserialize_with = "backend_name")]
    pub backend: BackendName,
    pub millis: f64,
    /// Whether the page's Web Worker ran it ([`super::offload`]); never natively.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub in_worker: bool,
    /// How close the sketch's peaks and ridges came to their drawn heights (`hold.rs`); absent
    /// when the scene has none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held: Option<super::hold::Held>,
}

/// "cpu" or "gpu". An alias, so that serde's derive does not borrow the field from the
/// input (it would for a `&str` it can see); [`backend_name`] reads it back.
pub type BackendName = &'static str;

/// [`ErosionReport::backend`] read back ("cpu" or "gpu").
fn backend_name<'de, D: serde::Deserializer<'de>>(from: D) -> Result<&'static str, D::Error> {
    let name = <String as serde::Deserialize>::deserialize(from)?;
    match name.as_str() {
        "cpu" => Ok("cpu"),
        "gpu" => Ok("gpu"),
        other => Err(serde::de::Error::unknown_variant(other, &["cpu", "gpu"])),
    }
}

/// The erosion stage's output.
#[derive(Debug)]
pub struct Eroded {
    pub field: Arc<Heightfield>,
    /// Drainage area in m^2 of the last step (the "drainage area" layer).
    pub drainage_area: Arc<Heightfield>,
    pub report: ErosionReport,
    pub millis: f64,
    /// `field`, bit for bit, on the GPU that eroded it (the GPU solver, when the CPU's
    /// conditioning found nothing left to fill).
    pub gpu: Option<GpuField>,
}

impl Eroded {
    /// How much each cell was lowered (metres; negative where uplift raised it): the
    /// "erosion depth" layer.
    pub fn depth(&self, before: &Heightfield) -> Vec<f32> {
        before
            .data()
            .iter()
            .zip(self.field.data())
            .map(|(b, a)| b - a)
            .collect()
    }
}

#[derive(Debug, Error)]
pub enum StageError {
    #[error("{0}")]
    Solver(#[from] ErosionError),
    #[error("{0}")]
    Field(#[from] crate::heightfield::HeightfieldError),
    /// The page's Web Worker failed on the stage (its message).
    #[error("{0}")]
    Worker(String),
    #[error("cancelled")]
    Cancelled(#[from] Cancelled),
    /// The correction that holds the drawn heights could not be solved (`hold.rs`).
    #[error("holding the drawn peaks and ridges: {0}")]
    Hold(String),
}

/// Base level: river and valley cells and `band` cells around them, and the valley floors
/// ([`super::floodplain`]; no band around a floor: its edge meets the hillslope). The map
/// border is not base level as a whole: the land drains to the drawn rivers (which leave the
/// map at their estuaries) and to a few outlets on the border that [`Prepared`] adds
/// ([`super::outlets`]), rather than off every edge. A scene with no river or valley at
/// all (a sketch of peaks and ridges) drains off the map's border instead. O(cells x band).
pub fn base_level(kinds: &[CellKind], n: usize, band: u32) -> Vec<bool> {
    let mut base = channel_cells(kinds);
    if !base.contains(&true) {
        return border_cells(n);
    }
    for _ in 0..band {
        let grown = base.clone();
        widen(&grown, &mut base, n, 0..n);
    }
    add_floors(&mut base, kinds);
    base
}

/// Marks the valley-floor cells as base level.
fn add_floors(base: &mut [bool], kinds: &[CellKind]) {
    for (b, k) in base.iter_mut().zip(kinds) {
        *b |= *k == CellKind::Floor;
    }
}

/// The cells on the map's edge: the base level of a map without channels.
pub(super) fn border_cells(n: usize) -> Vec<bool> {
    let mut base = vec![false; n * n];
    for i in 0..n {
        for cell in [i, (n - 1) * n + i, i * n, i * n + n - 1] {
            base[cell] = true;
        }
    }
    base
}

/// [`base_level`] in bands of rows with the job's ticks between them.
async fn base_level_in_bands(
    kinds: &[CellKind],
    n: usize,
    band: u32,
    ctx: &JobCtx,
) -> Result<Vec<bool>, Cancelled> {
    let mut base = channel_cells(kinds);
    if !base.contains(&true) {
        return Ok(border_cells(n));
    }
    for _ in 0..band {
        let grown = base.clone();
        in_row_bands(ctx, PREPARING, &mut base, n, |rows, part| {
            widen(&grown, part, n, rows)
        })
        .await?;
    }
    add_floors(&mut base, kinds);
    Ok(base)
}

/// The river and valley cells.
fn channel_cells(kinds: &[CellKind]) -> Vec<bool> {
    kinds
        .iter()
        .map(|k| matches!(k, CellKind::River | CellKind::Valley))
        .collect()
}

/// Marks the cells of `rows` next to a cell of `grown` (one more cell of band) in `rows_out`,
/// those rows of the base level.
fn widen(grown: &[bool], rows_out: &mut [bool], n: usize, rows: Range<usize>) {
    let first = rows.start;
    for y in rows {
        for x in 0..n {
            if grown[y * n + x] {
                continue;
            }
            let near = (y.saturating_sub(1)..(y + 2).min(n))
                .any(|yy| (x.saturating_sub(1)..(x + 2).min(n)).any(|xx| grown[yy * n + xx]));
            rows_out[(y - first) * n + x] = near;
        }
    }
}

/// Runs `work` on consecutive bands of the rows `0..rows` (rows of `width` cells), about
/// [`CHUNK_CELLS`] cells a band, with a tick of `ctx` before each: so an O(cells) pass
/// holds the browser's main thread for a few milliseconds at a time, never for all of it.
pub(super) async fn in_bands(
    ctx: &JobCtx,
    (progress, message): (f32, &str),
    rows: usize,
    width: usize,
    mut work: impl FnMut(Range<usize>),
) -> Result<(), Cancelled> {
    let band = (CHUNK_CELLS / width.max(1)).max(1);
    for start in (0..rows).step_by(band) {
        ctx.tick(progress, message).await?;
        work(start..(start + band).min(rows));
    }
    Ok(())
}

/// [`in_bands`] over the rows of `data` (rows of `width` values), each piece handed the
/// rows it writes (`work(rows, those rows of data)`): natively a piece holds
/// [`CHUNK_CELLS`] cells per thread and is split among the threads ([`parallel`]), on the
/// web one thread runs it. Every row is computed the same way on any number of threads.
pub(super) async fn in_row_bands<T: Send>(
    ctx: &JobCtx,
    (progress, message): (f32, &str),
    data: &mut [T],
    width: usize,
    work: impl Fn(Range<usize>, &mut [T]) + Sync,
) -> Result<(), Cancelled> {
    let width = width.max(1);
    let rows = data.len() / width;
    let threads = parallel::threads();
    let band = (CHUNK_CELLS * threads / width).max(1);
    for start in (0..rows).step_by(band) {
        ctx.tick(progress, message).await?;
        let end = (start + band).min(rows);
        let per_thread = (end - start).div_ceil(threads).max(1);
        let piece = &mut data[start * width..end * width];
        parallel::for_each_band(piece, per_thread * width, |k, part| {
            let first = start + k * per_thread;
            work(first..first + part.len() / width, part);
        });
    }
    Ok(())
}

/// The progress and message reported while the stage prepares the solver's fields.
pub(super) const PREPARING: (f32, &str) = (0.05, "eroding: preparing");
/// ... and while it brings a coarse solver grid back to the full one, and measures.
pub(super) const FINISHING: (f32, &str) = (0.9, "eroding: back to the full grid");

/// Each cell's nearest river or valley cell by straight-line distance (the exact transform
/// of [`super::nearest`], O(cells)): that cell's height and the distance in cells. A map
/// without channels uses its lowest height at distance 0.
pub fn nearest_channel(field: &Heightfield, kinds: &[CellKind]) -> NearestChannel {
    let mut transform = channel_transform(field, kinds);
    while !transform.advance(usize::MAX) {}
    transform.finish()
}

/// [`nearest_channel`] in bands of about [`CHUNK_CELLS`] cells with the job's ticks between
/// them (the same values).
pub(super) async fn nearest_channel_in_steps(
    field: &Heightfield,
    kinds: &[CellKind],
    ctx: &JobCtx,
    (progress, message): (f32, &str),
) -> Result<NearestChannel, Cancelled> {
    let rows = (CHUNK_CELLS / field.width().max(1)).max(1);
    let mut transform = channel_transform(field, kinds);
    loop {
        ctx.tick(progress, message).await?;
        if transform.advance(rows) {
            return Ok(transform.finish());
        }
    }
}

fn channel_transform<'a>(field: &'a Heightfield, kinds: &'a [CellKind]) -> Transform<'a> {
    Transform::new(field, |i| {
        matches!(kinds[i], CellKind::River | CellKind::Valley)
    })
}

/// Share of the largest uplift rate that the land beside the rivers gets.
pub const RIVERSIDE_UPLIFT: f32 = 0.15;

/// The uplift map (m/yr) of a design whose rivers' heights are its `kinds`' held channels
/// (`channel`: each cell's nearest one, [`nearest_channel`]): uniform at `max_m_per_yr` where
/// the design has grown branches ([`CellKind::Grown`]), else [`uplift_from_design`].
///
/// The branches' long profiles then make the relief, as in a block of rock rising evenly:
/// the law stands their headwaters high and steep, the main valleys low, so the ranges rise
/// between the largest rivers and away from the trunk. An uplift that follows the design's
/// height above the held channels (here the trunks alone) would only slow the land along the
/// trunk: on the default scene at 10 km the hypsometric integral stayed 0.23 and the spectral
/// bump 1.95, uniform uplift gives 0.35 and 1.68. A design without grown branches (a sketch,
/// or a rebuild from a DEM's features, whose lines carry the DEM's relief) keeps the
/// design-shaped uplift: for a rebuild uniform uplift cost 0.06 of SSIM against the DEM.
pub fn uplift_map(
    field: &Heightfield,
    kinds: &[CellKind],
    channel: &[f32],
    max_m_per_yr: f64,
) -> Vec<f32> {
    if kinds.contains(&CellKind::Grown) {
        vec![max_m_per_yr as f32; kinds.len()]
    } else {
        uplift_from_design(field, channel, max_m_per_yr)
    }
}

/// The uplift map (m/yr) from the design: with `r` the design's height above its nearest
/// channel (`channel`, from [`nearest_channel`]) over the largest such height,
/// `U = max_m_per_yr * (s + (1 - s) (1 - (1 - r)^2))`, `s` = [`RIVERSIDE_UPLIFT`].
///
/// The whole range rises, as rock uplift does (the rivers then cut their valleys into it),
/// and the rate levels off towards the design's highest ground: land in proportion to `r`
/// alone would stay flat beside every river (no uplift there, the valley floors left as the
/// design drew them: flat strips 8 cells wide at 50 km) and rise fastest in the map's corners,
/// farthest from the rivers, which then hold the highest ground of every map.
pub fn uplift_from_design(field: &Heightfield, channel: &[f32], max_m_per_yr: f64) -> Vec<f32> {
    let above: Vec<f32> = field
        .data()
        .iter()
        .zip(channel)
        .map(|(h, b)| (h - b).max(0.0))
        .collect();
    let top = above.iter().copied().fold(0.0f32, f32::max);
    let max = max_m_per_yr as f32;
    let s = RIVERSIDE_UPLIFT;
    above
        .iter()
        .map(|a| {
            let r = if top > 0.0 { a / top } else { 0.0 };
            max * (s + (1.0 - s) * (1.0 - (1.0 - r) * (1.0 - r)))
        })
        .collect()
}

/// Adds zero-mean noise of standard deviation `sigma` metres to every cell that is not base
/// level: a hash of the seed and the cell (SplitMix64), two uniforms to one Gaussian
/// (Box-Muller), so the same seed gives the same bits everywhere. O(cells).
pub fn roughen(heights: &mut [f32], base: &[bool], sigma: f64, seed: u64) {
    roughen_from(heights, base, sigma, seed, 0);
}

/// [`roughen`] of a run of the cells that starts at cell `first`.
pub(super) fn roughen_from(
    heights: &mut [f32],
    base: &[bool],
    sigma: f64,
    seed: u64,
    first: usize,
) {
    if sigma <= 0.0 {
        return;
    }
    let mix = crate::noise::splitmix64;
    for (i, (h, fixed)) in (first..).zip(heights.iter_mut().zip(base)) {
        if *fixed {
            continue;
        }
        let r = mix(seed ^ mix(i as u64 + 0x9e37_79b9_7f4a_7c15));
        let u1 = ((r >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        let u2 = (mix(r) >> 11) as f64 / (1u64 << 53) as f64;
        let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        *h += (sigma * g) as f32;
    }
}

/// How far from a river (cells) the land is kept above the river's height.
pub(super) const FLOOR_CELLS: f32 = 8.0;

/// The near-river floor: within [`FLOOR_CELLS`] of a river no land goes below it (a
/// centimetre more per cell away, so floors still drain to it), so a river never ends up
/// hanging on a levee above its valley. Farther away the land is free: floors of different
/// rivers would meet in steps there.
pub(super) fn floor_near_rivers(near: &NearestChannel, cells: f32) -> Vec<f32> {
    near.base
        .iter()
        .zip(&near.distance)
        .map(|(h, d)| if *d <= cells { h + 0.01 * d } else { f32::MIN })
        .collect()
}

/// The solver's inputs for `field` (square, cells `cell_m` wide) with the rivers of `kinds`
/// as base level: the roughened heights, base level, uplift (m/yr) and near-river floor. The
/// CPU and the GPU solver start from exactly these.
#[derive(Clone)]
pub struct Prepared {
    pub heights: Vec<f32>,
    pub base: Vec<bool>,
    /// m/yr; empty: none.
    pub uplift: Vec<f32>,
    pub floor: Vec<f32>,
    /// The seed of the solver's random receivers ([`super::Eroder::with_seed`]).
    pub seed: u64,
    /// Each cell's factor on the erodibility (rock hardness); empty: uniform.
    pub erodibility: Vec<f32>,
    /// Beds of hard and soft rock (the erodibility varying with height); `None`: no beds.
    pub strata: Option<super::Strata>,
    /// Each cell's factor on the talus slope's tangent (rock strength,
    /// [`super::SlopeStrength`]); empty: no talus angle, or the same everywhere.
    pub strength: Vec<f32>,
    /// The grown branches' guided receivers ([`super::Eroder::with_guide`]): a D8 code per
    /// cell, 8 where the solver picks; empty: none.
    pub guide: Vec<u8>,
    /// The border's outlets ([`super::outlets`]), already base level in `base`.
    pub outlets: Vec<usize>,
}

impl Prepared {
    /// The CPU solver of these fields (an `n` x `n` grid of `cell_m` cells) as the stage runs
    /// it: the random receivers of the seed, the rock's erodibility, and the threshold-slope
    /// limit at the talus angle, varied by the rock's strength, where one is set.
    pub fn into_eroder(
        self,
        n: usize,
        cell_m: f64,
        params: ErosionParams,
    ) -> Result<Eroder, ErosionError> {
        let eroder = Eroder::new(self.heights, n, n, cell_m, self.base, self.uplift, params)?
            .with_floor(self.floor)?
            .with_guide(self.guide)?
            .with_seed(self.seed)
            .with_erodibility(self.erodibility)?
            .with_strata(self.strata);
        // The talus relaxation moves scree below the angle; the limit cuts what it could not.
        Ok(match params.talus_deg {
            Some(talus) => eroder.with_slope_limit(talus, self.strength)?,
            None => eroder,
        })
    }

    /// The GPU solver's input for these fields (an `n` x `n` grid of `cell_m` cells).
    pub fn gpu_input(&self, n: usize, cell_m: f64, params: ErosionParams) -> GpuInput<'_> {
        GpuInput {
            heights: &self.heights,
            width: n,
            height: n,
            cell_m,
            base_level: &self.base,
            uplift: &self.uplift,
            floor: Some(&self.floor),
            params,
            seed: Some(self.seed),
            erodibility: &self.erodibility,
            strata: self.strata,
            strength: &self.strength,
            fill_pits: true,
            guide: &self.guide,
        }
    }

    /// The inputs for `field`, cells `cell_m` wide, the border's outlets leaving the sketch's
    /// `held` cells standing (`&[]`: none). O(cells x band).
    pub fn new(
        field: &Heightfield,
        kinds: &[CellKind],
        settings: &ErosionSettings,
        cell_m: f64,
        seed: u64,
        held: &[u32],
    ) -> Self {
        let n = field.width();
        let mut base = base_level(kinds, n, settings.river_band);
        let near = nearest_channel(field, kinds);
        let mut uplift = uplift_map(field, kinds, &near.base, settings.uplift_m_per_kyr / 1000.0);
        ranges_of(settings, (n, cell_m, seed), &near, held).raise(0, &mut uplift);
        let floor = floor_near_rivers(&near, FLOOR_CELLS);
        let mut heights = field.data().to_vec();
        let keep = Keep::of(held, &near.base, cell_m, settings.talus_deg);
        let outlets = match settings.border {
            Border::Open => border_outlets(field, kinds, &base, keep),
            Border::Closed => Vec::new(),
        };
        super::outlets::open(&outlets, &mut base, &mut heights, &near.base);
        roughen(&mut heights, &base, settings.roughness_m, seed);
        Self {
            guide: super::guide::guided_receivers(field.data(), kinds, n),
            heights,
            base,
            uplift,
            floor,
            seed,
            erodibility: rock_of(settings, n, cell_m, seed),
            strata: settings.strata(),
            strength: strength_of(settings, n, cell_m, seed),
            outlets,
        }
    }

    /// [`Self::new`] in pieces of about [`CHUNK_CELLS`] cells with the job's ticks between
    /// them (the stage's way: the same values).
    pub async fn prepare(
        field: &Heightfield,
        kinds: &[CellKind],
        settings: &ErosionSettings,
        cell_m: f64,
        seed: u64,
        held: &[u32],
        ctx: &JobCtx,
    ) -> Result<Self, Cancelled> {
        let n = field.width();
        let mut base = base_level_in_bands(kinds, n, settings.river_band, ctx).await?;
        let near = nearest_channel_in_steps(field, kinds, ctx, PREPARING).await?;
        ctx.tick(PREPARING.0, PREPARING.1).await?;
        let mut uplift = uplift_map(field, kinds, &near.base, settings.uplift_m_per_kyr / 1000.0);
        let ranges = ranges_of(settings, (n, cell_m, seed), &near, held);
        in_row_bands(ctx, PREPARING, &mut uplift, n, |rows, part| {
            ranges.raise(rows.start, part);
        })
        .await?;
        let floor = floor_near_rivers(&near, FLOOR_CELLS);
        let mut heights = field.data().to_vec();
        let keep = Keep::of(held, &near.base, cell_m, settings.talus_deg);
        let outlets = match settings.border {
            Border::Open => {
                border_outlets_in_steps(field, kinds, &base, keep, ctx, PREPARING).await?
            }
            Border::Closed => Vec::new(),
        };
        super::outlets::open(&outlets, &mut base, &mut heights, &near.base);
        in_row_bands(ctx, PREPARING, &mut heights, n, |rows, h| {
            let cells = rows.start * n..rows.end * n;
            roughen_from(
                h,
                &base[cells.clone()],
                settings.roughness_m,
                seed,
                cells.start,
            );
        })
        .await?;
        let erodibility = rock_in_bands(settings, n, cell_m, seed, ctx).await?;
        let strength = strength_in_bands(settings, n, cell_m, seed, ctx).await?;
        let guide = super::guide::guided_receivers_in(field.data(), kinds, n, ctx).await?;
        Ok(Self {
            guide,
            heights,
            base,
            uplift,
            floor,
            seed,
            erodibility,
            strata: settings.strata(),
            strength,
            outlets,
        })
    }
}

/// The ranges and basins of `settings` on an `n` x `n` map of `cell_m` cells
/// ([`super::Ranges`]), to multiply its uplift by, with basins along the drawn rivers and
/// valleys (`near`, [`nearest_channel`]) where the sketch holds no peak or ridge (`held`
/// empty): a sketch of them draws its ranges itself, and a basin beside a river would pull a
/// peak sketched a few kilometres from it below its height.
pub(super) fn ranges_of(
    settings: &ErosionSettings,
    (n, cell_m, seed): (usize, f64, u64),
    near: &NearestChannel,
    held: &[u32],
) -> super::Ranges {
    let ranges = super::Ranges::new(
        n,
        cell_m,
        settings.uplift_contrast,
        settings.uplift_scale_m,
        seed,
    );
    if held.is_empty() {
        ranges.with_basins(&near.distance)
    } else {
        ranges
    }
}

/// The erodibility factors of `settings`' rock on an `n` x `n` map of `cell_m` cells (empty
/// for uniform rock). O(cells).
pub(super) fn rock_of(settings: &ErosionSettings, n: usize, cell_m: f64, seed: u64) -> Vec<f32> {
    super::erodibility_factors(
        n,
        cell_m,
        settings.rock_contrast,
        settings.rock_patch_m,
        seed,
    )
}

/// [`rock_in_bands`] with the painted hard rock of `anchors` (empty: uniform rock, nothing
/// painted). Made where it is read and dropped after, not kept through the solve: a field
/// of the map's size.
async fn rock_with_painting(
    settings: &ErosionSettings,
    anchors: &Anchors<'_>,
    (n, cell_m, seed): (usize, f64, u64),
    ctx: &JobCtx,
) -> Result<Vec<f32>, Cancelled> {
    let mut rock = rock_in_bands(settings, n, cell_m, seed, ctx).await?;
    anchors.painted.harden(&mut rock, n);
    Ok(rock)
}

/// [`rock_of`] in bands of rows with the job's ticks between them (the same values).
pub(super) async fn rock_in_bands(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Vec<f32>, Cancelled> {
    if settings.rock_contrast == 1.0 {
        return Ok(Vec::new());
    }
    let rock = super::Rock::new(
        n,
        cell_m,
        settings.rock_contrast,
        settings.rock_patch_m,
        seed,
    );
    field_in_bands(n, ctx, |first_row, rows| rock.rows(first_row, rows)).await
}

/// The rock's strength factors on the talus slope of `settings` on an `n` x `n` map of
/// `cell_m` cells (empty without a talus angle). O(cells x octaves).
pub(super) fn strength_of(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
) -> Vec<f32> {
    if settings.talus_deg.is_none() {
        return Vec::new();
    }
    let mut factors = vec![0.0f32; n * n];
    super::SlopeStrength::new(n, cell_m, seed, settings.strength_spread).rows(0, &mut factors);
    factors
}

/// Share of the rock's spread of strength the flanks of held peaks and ridges keep
/// ([`erode_field_within`]).
const HELD_STRENGTH_SHARE: f32 = 0.5;

/// [`strength_of`] in bands of rows with the job's ticks between them (the same values).
pub(super) async fn strength_in_bands(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Vec<f32>, Cancelled> {
    if settings.talus_deg.is_none() {
        return Ok(Vec::new());
    }
    let strength = super::SlopeStrength::new(n, cell_m, seed, settings.strength_spread);
    field_in_bands(n, ctx, |first_row, rows| strength.rows(first_row, rows)).await
}

/// An `n` x `n` field of one value a cell, filled by `fill(first_row, rows)` in bands of
/// whole rows with the job's ticks between them (the same values however it is split).
async fn field_in_bands(
    n: usize,
    ctx: &JobCtx,
    fill: impl Fn(usize, &mut [f32]) + Sync,
) -> Result<Vec<f32>, Cancelled> {
    let mut field = vec![0.0f32; n * n];
    in_row_bands(ctx, PREPARING, &mut field, n, |rows, part| {
        fill(rows.start, part)
    })
    .await?;
    Ok(field)
}

/// What the design fixes beyond the cell kinds, from the skeleton
/// ([`crate::skeleton::Skeleton`]): the cells the erosion holds and the outlets inside the map.
#[derive(Clone, Copy, Debug, Default)]
pub struct Anchors<'a> {
    /// The sketch's peak and ridge cells, held at their drawn heights (`hold.rs`); ascending.
    pub held: &'a [u32],
    /// River mouths inside the map, where water leaves it besides the border; ascending.
    pub mouths: &'a [u32],
    /// The cells of the rivers' trunks, the strokes ([`crate::skeleton::Skeleton::trunk`]):
    /// held at their design heights, while the other river cells, the grown branches, are
    /// channels whose heights the law sets (`guide.rs`); empty: every river held.
    pub trunk: &'a [u32],
    /// Each cell's Strahler order ([`crate::skeleton::Skeleton::river_order`]): first-order
    /// branches are left to the land (`guide.rs`); empty: every branch guided.
    pub order: &'a [u8],
    /// What the user painted over the design: faster uplift, harder rock.
    pub painted: super::Painted<'a>,
    /// The design's heights of the skeleton's cells ([`crate::skeleton::Skeleton::heights`]),
    /// which tell a river's way down where branches are let go (`guide.rs`); empty: none.
    pub heights: &'a [f32],
    /// Meandering river cells and how far inside their belt each lies, in cells
    /// ([`crate::skeleton::Skeleton::belt`]): the valley floor is that much wider beside
    /// them (`floodplain.rs`); empty: no meanders.
    pub belt: &'a [(u32, f32)],
}

impl<'a> From<&'a crate::skeleton::Skeleton> for Anchors<'a> {
    fn from(skeleton: &'a crate::skeleton::Skeleton) -> Self {
        Self {
            held: &skeleton.held,
            mouths: &skeleton.mouths,
            trunk: &skeleton.trunk,
            order: &skeleton.river_order,
            painted: super::Painted::default(),
            heights: &skeleton.heights,
            belt: &skeleton.belt,
        }
    }
}

/// Runs the solver on `field` (square, cells `cell_m` wide) with the rivers of `kinds` as
/// base level ([`Prepared::prepare`], then [`run_solver`]); returns the eroded heights, the
/// last drainage area and the backend that ran. O(cells) per step.
#[allow(clippy::too_many_arguments)]
pub(super) async fn solve(
    field: &Heightfield,
    kinds: &[CellKind],
    anchors: Anchors<'_>,
    settings: &ErosionSettings,
    cell_m: f64,
    seed: u64,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Solved, StageError> {
    let mut prepared =
        Prepared::prepare(field, kinds, settings, cell_m, seed, anchors.held, ctx).await?;
    let n = field.width();
    anchors.painted.raise(&mut prepared.uplift, n);
    anchors.painted.harden(&mut prepared.erodibility, n);
    super::hold::pin(&mut prepared.floor, field.data(), anchors.held);
    let fill_on_gpu = anchors.mouths.is_empty();
    let outlets = std::mem::take(&mut prepared.outlets);
    let solved = run_solver(
        prepared,
        field.width(),
        cell_m,
        settings.params(),
        fill_on_gpu,
        backend,
        ctx,
    )
    .await?;
    Ok(Solved { outlets, ..solved })
}

/// What a solver run gives back.
pub(super) struct Solved {
    pub heights: Vec<f32>,
    /// The last step's drainage area.
    pub area: Vec<f32>,
    /// Where it ran: "cpu" or "gpu".
    pub ran_on: &'static str,
    /// What the GPU solver's own depression filling raised (none on the CPU, whose surface
    /// the stage's conditioning fills).
    pub conditioning: Option<drainage::Conditioning>,
    /// `heights` on the GPU that solved them, if one did.
    pub gpu: Option<GpuField>,
    /// The border's outlets the run drained to ([`Prepared::outlets`]); empty from
    /// [`run_solver`] alone.
    pub outlets: Vec<usize>,
}

/// Runs `params` on the `n` x `n` fields of `prepared` (cells `cell_m` wide) on the GPU
/// when `backend` is one that holds the fields (else, or if the GPU fails, on the CPU, in
/// pieces with the job's ticks between them). The GPU fills the last step's pits from the
/// map's border when `fill_on_gpu` (false where water also leaves the map inside it: the
/// stage's conditioning then fills them on the CPU). O(cells) per step.
pub(super) async fn run_solver(
    prepared: Prepared,
    n: usize,
    cell_m: f64,
    params: ErosionParams,
    fill_on_gpu: bool,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Solved, StageError> {
    if let Backend::Gpu(context) = backend
        && context.runs_heavy_stages()
    {
        if gpu::fits(context, n, n) {
            let input = GpuInput {
                fill_pits: fill_on_gpu,
                ..prepared.gpu_input(n, cell_m, params)
            };
            match gpu::erode(context, input, ctx).await {
                Ok(out) => {
                    return Ok(Solved {
                        heights: out.heights,
                        area: out.area,
                        ran_on: "gpu",
                        conditioning: out.conditioning,
                        gpu: Some(out.on_gpu),
                        outlets: Vec::new(),
                    });
                }
                Err(GpuErosionError::Gpu(err)) => {
                    log::warn!("erosion on the GPU failed ({err}): eroding on the CPU");
                }
                Err(GpuErosionError::Input(err)) => return Err(err.into()),
                Err(GpuErosionError::Cancelled(c)) => return Err(c.into()),
            }
        } else {
            log::warn!("a {n} x {n} erosion grid does not fit this GPU: eroding on the CPU");
        }
    }
    let mut eroder = prepared.into_eroder(n, cell_m, params)?;
    let steps = params.steps.max(1);
    // Piece by piece (a band of rows, a run of the stack, a few lakes), so the browser gets
    // its turn every few milliseconds.
    while eroder.steps_done() < steps {
        let done = eroder.steps_done();
        ctx.tick(
            0.1 + 0.8 * done as f32 / steps as f32,
            &format!("eroding: step {} of {steps}", done + 1),
        )
        .await?;
        eroder.advance();
    }
    let area = eroder.drainage_area().to_vec();
    Ok(Solved {
        heights: eroder.into_heights(),
        area,
        ran_on: "cpu",
        conditioning: None,
        gpu: None,
        outlets: Vec::new(),
    })
}

/// The angle the walls of the network's valley floors are brought back to where the preset
/// has no threshold slope (the old hills' creep alone): the young mountains' talus angle.
const FLOOR_WALL_DEG: f64 = 35.0;

/// Cuts valley floors beside the large channels of the eroded `heights` (`n` x `n`, cells
/// `cell_m` wide; `area` the solver's drainage area), keeping the base level and the `held`
/// design cells, then lowers what stands above the floors steeper than the rock's angle (its
/// strength varied as the solver's), carried out from the floors (`network_floors.rs`).
/// `held_limit` is the mask the held design's flanks were limited by, if any, reused here.
/// Returns whether any floor was cut. O(floor and lowered cells log cells), plus the rock's
/// strength, O(cells), where there is no `held_limit`.
async fn floors_of_the_network(
    heights: &mut [f32],
    area: &[f32],
    (base, held_limit): (&[bool], Option<&super::slope_limit::Mask>),
    (settings, anchors): (&ErosionSettings, &Anchors<'_>),
    (n, cell_m, seed): (usize, f64, u64),
    ctx: &JobCtx,
) -> Result<bool, StageError> {
    ctx.tick(0.95, "eroding: the network's valley floors")
        .await?;
    let mut fixed = base.to_vec();
    for &i in anchors.held {
        fixed[i as usize] = true;
    }
    let rock = rock_with_painting(settings, anchors, (n, cell_m, seed), ctx).await?;
    let cut = super::network_floors::cut(heights, area, &fixed, &rock, n, cell_m);
    drop(rock);
    let Some(floor) = cut else {
        return Ok(false);
    };
    // The held flanks' own mask where they were limited, so the limit here does not cut
    // them back (it exists wherever held cells and a talus angle do).
    let built;
    let mask = match held_limit {
        Some(mask) => mask,
        None => {
            let strength = strength_in_bands(settings, n, cell_m, seed, ctx).await?;
            let talus = settings.talus_deg.unwrap_or(FLOOR_WALL_DEG);
            built = super::slope_limit::Mask::new(n, n, cell_m, talus).with_strength(strength);
            &built
        }
    };
    ctx.tick(0.95, "eroding: the floors' walls").await?;
    let seeds = (0..n * n).filter(|&i| floor[i]);
    for (f, on_floor) in fixed.iter_mut().zip(&floor) {
        *f |= *on_floor;
    }
    mask.relax_from(heights, &fixed, seeds);
    Ok(true)
}

/// Erodes the hydrology stage's terrain: the rivers as base level, uplift from the design,
/// then depression filling and the drainage check ([`erode_field`] of its terrain and
/// skeleton).
pub async fn erode_terrain(
    hydrology: &Generated,
    settings: &ErosionSettings,
    painted: super::Painted<'_>,
    cell_m: f64,
    seed: u64,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Eroded, StageError> {
    let kinds = &hydrology.skeleton.kinds;
    let anchors = Anchors {
        painted,
        ..(&hydrology.skeleton).into()
    };
    #[cfg(target_arch = "wasm32")]
    if matches!(backend, Backend::Cpu) {
        let task =
            super::offload::Task::new(&hydrology.terrain, kinds, anchors, settings, cell_m, seed);
        if let Some(eroded) = in_the_worker(task, ctx).await? {
            return Ok(eroded);
        }
    }
    erode_field(
        &hydrology.terrain,
        kinds,
        anchors,
        settings,
        cell_m,
        seed,
        backend,
        ctx,
    )
    .await
}

/// Erodes `task` in the page's Web Worker ([`crate::jobs::worker`]); `None` where there is
/// none (the caller then erodes on the page's thread).
#[cfg(target_arch = "wasm32")]
async fn in_the_worker(
    task: super::offload::Task,
    ctx: &JobCtx,
) -> Result<Option<Eroded>, StageError> {
    use crate::jobs::worker::{CallError, call};
    match call(super::offload::KIND, task.into_parcel(), ctx).await {
        Ok(parcel) => {
            let mut eroded = super::offload::result_from_parcel(parcel)
                .map_err(|e| StageError::Worker(e.to_string()))?;
            eroded.report.in_worker = true;
            Ok(Some(eroded))
        }
        Err(CallError::Unavailable(reason)) => {
            log::info!("erosion on the page's thread: {reason}");
            Ok(None)
        }
        Err(CallError::Cancelled(c)) => Err(StageError::Cancelled(c)),
        Err(CallError::Failed(message)) => Err(StageError::Worker(message)),
    }
}

/// Erodes the square `field` with the rivers and valleys of `kinds` as base level: uplift
/// from the design, then depression filling and the drainage check. Maps larger than
/// [`MAX_SOLVER_SIDE`] are eroded on a grid of blocks, brought back to full resolution and
/// refined there by one more step of the law (`coarse.rs`). O(cells) per step, every O(cells) pass in pieces of about
/// [`CHUNK_CELLS`] cells with the job's ticks between them.
#[allow(clippy::too_many_arguments)]
pub async fn erode_field(
    field: &Heightfield,
    kinds: &[CellKind],
    anchors: Anchors<'_>,
    settings: &ErosionSettings,
    cell_m: f64,
    seed: u64,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Eroded, StageError> {
    erode_field_within(
        field,
        kinds,
        anchors,
        settings,
        cell_m,
        seed,
        backend,
        ctx,
        MAX_SOLVER_SIDE,
    )
    .await
}

/// [`erode_field`] with a solver grid of at most `max_side` cells a side (the pipeline's is
/// [`MAX_SOLVER_SIDE`]; tests take a smaller one to see the coarse-to-fine path at small
/// sizes).
#[allow(clippy::too_many_arguments)]
pub async fn erode_field_within(
    field: &Heightfield,
    kinds: &[CellKind],
    anchors: Anchors<'_>,
    settings: &ErosionSettings,
    cell_m: f64,
    seed: u64,
    backend: &Backend,
    ctx: &JobCtx,
    max_side: usize,
) -> Result<Eroded, StageError> {
    let n = field.width();
    // Every walk below orders cells by height: a NaN would break them, so it is an error here.
    if let Some(index) = field.data().iter().position(|v| !v.is_finite()) {
        return Err(ErosionError::NonFinite {
            what: "terrain heights",
            index,
        }
        .into());
    }
    let design = field;
    let grown = super::guide::shape(kinds, &anchors, settings.relief);
    let kinds = grown.as_deref().unwrap_or(kinds);
    ctx.tick(PREPARING.0, "eroding: valley floors").await?;
    let floors = {
        // Floors are narrower in hard rock: the rock the solver erodes, painted included.
        let rock = rock_with_painting(settings, &anchors, (n, cell_m, seed), ctx).await?;
        let (mouths, belt) = (anchors.mouths, anchors.belt);
        super::floodplain::valley_floors(design, kinds, mouths, belt, &rock, cell_m)?
    };
    let (field, kinds) = match &floors {
        Some((floored, floor_kinds)) => (floored, floor_kinds.as_slice()),
        None => (design, kinds),
    };
    let coves = super::floodplain::lift_coves(field, kinds, cell_m);
    let field = coves.as_ref().unwrap_or(field);
    let base = base_level_in_bands(kinds, n, settings.river_band, ctx).await?;
    let base_level_cells = base.iter().filter(|b| **b).count();
    let factor = n.div_ceil(max_side.max(1));
    let solved = if factor <= 1 {
        solve(field, kinds, anchors, settings, cell_m, seed, backend, ctx).await?
    } else {
        coarse::erode_coarse_to_fine(
            field,
            kinds,
            anchors,
            base.clone(),
            settings,
            cell_m,
            seed,
            factor,
            backend,
            ctx,
        )
        .await?
    };
    let area = Heightfield::from_vec(n, n, solved.area)?;
    let mut heights = solved.heights;
    // The flanks of held peaks and ridges stand within the talus slope varied by the rock's
    // strength, as the solver held them, so they are not cones of planes. Half the solver's
    // spread of strength (factors 0.85-1 at the default spread): with all of it a peak
    // sketched at 1200 m on a 10 km map stood 11% short (1072 m), the angle carrying less
    // height from the rivers.
    let limit = match settings.talus_deg {
        Some(talus) if !anchors.held.is_empty() => {
            let mut strength = strength_in_bands(settings, n, cell_m, seed, ctx).await?;
            for s in &mut strength {
                *s = 1.0 - HELD_STRENGTH_SHARE * (1.0 - *s);
            }
            Some(super::slope_limit::Mask::new(n, n, cell_m, talus).with_strength(strength))
        }
        _ => None,
    };
    let held = super::hold::hold_design(
        &mut heights,
        design.data(),
        anchors.held,
        &base,
        n,
        limit.as_ref(),
        ctx,
    )
    .await?;
    let floored = floors_of_the_network(
        &mut heights,
        area.data(),
        (&base, limit.as_ref()),
        (settings, &anchors),
        (n, cell_m, seed),
        ctx,
    )
    .await?;
    // The grown branches' water runs down the branches on the finished surface too.
    let guide = super::guide::guided_receivers_in(field.data(), kinds, n, ctx).await?;
    ctx.tick(0.95, "eroding: the branches' beds").await?;
    let burnt = super::guide::burn(
        &mut heights,
        field.data(),
        kinds,
        &guide,
        n,
        (cell_m, settings.talus_deg),
    );
    drop(guide);
    let mut eroded = Heightfield::from_vec(n, n, heights)?;
    let (conditioning, drainage) =
        drainage::condition_and_measure(&mut eroded, kinds, anchors.mouths, ctx).await?;
    // The GPU's copy is the terrain as long as the CPU raised no cell after reading it; the
    // branches' beds, burnt on the CPU, are written back to it.
    let gpu = solved
        .gpu
        .filter(|_| conditioning.raised_cells == 0 && held.is_none());
    if let (Some(field), Backend::Gpu(context), true) = (&gpu, backend, burnt > 0 || floored) {
        field.write(context, eroded.data());
    }
    let conditioning = drainage::merge(solved.conditioning, conditioning);
    let (mut sum, mut max) = (0.0f64, f64::NEG_INFINITY);
    in_bands(ctx, (0.97, "eroding: measuring"), n, n, |rows| {
        let cells = rows.start * n..rows.end * n;
        for (b, a) in design.data()[cells.clone()]
            .iter()
            .zip(&eroded.data()[cells])
        {
            let d = f64::from(b - a);
            sum += d;
            max = max.max(d);
        }
    })
    .await?;
    Ok(Eroded {
        field: Arc::new(eroded),
        drainage_area: Arc::new(area),
        report: ErosionReport {
            preset: settings.preset.clone(),
            steps: settings.steps.max(1),
            years: settings.years,
            base_level_cells,
            mean_depth_m: sum / (n * n).max(1) as f64,
            max_depth_m: max.max(0.0),
            drainage,
            conditioning,
            backend: solved.ran_on,
            millis: 0.0,
            in_worker: false,
            held,
        },
        millis: 0.0,
        gpu,
    })
}
