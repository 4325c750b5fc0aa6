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

use super::settings::{Border, ErosionSettings};

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
        let (erodibility, strength) =
            rock_and_strength_in_bands(settings, n, cell_m, seed, ctx).await?;
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
    let rock = rock_field(settings, n, cell_m, seed);
    field_in_bands(n, ctx, |first_row, rows| rock.rows(first_row, rows)).await
}

/// The rock field of `settings` on an `n` x `n` map of `cell_m` cells: its patches of
/// harder and softer rock ([`super::Rock`]).
fn rock_field(settings: &ErosionSettings, n: usize, cell_m: f64, seed: u64) -> super::Rock {
    super::Rock::new(
        n,
        cell_m,
        settings.rock_contrast,
        settings.rock_patch_m,
        seed,
    )
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
    slope_strength(settings, n, cell_m, seed).rows(0, &mut factors);
    factors
}

/// The rock's strength factors on the talus slope of `settings` over a window of an `n` x
/// `n` map of `cell_m` cells, `size` cells (width, height) from `at`, with the painted hard rock
/// of `painted` as strong as the hard units ([`super::Painted::firm`]): the factors the
/// erosion stage gives the map's cells there, sampled over the window alone (a world's tile
/// refined with the world's rock, `crate::world::refine`). Empty without a talus angle.
/// O(cells of the window x octaves + n x octaves).
pub fn strength_in_window(
    settings: &ErosionSettings,
    painted: super::Painted<'_>,
    (n, cell_m, seed): (usize, f64, u64),
    at: [usize; 2],
    size: [usize; 2],
) -> Vec<f32> {
    let sample = |settings: &ErosionSettings| {
        let mut factors = vec![0.0f32; size[0] * size[1]];
        slope_strength(settings, n, cell_m, seed).window(at, size[0], &mut factors);
        factors
    };
    if settings.talus_deg.is_none() {
        return Vec::new();
    }
    let mut strength = sample(settings);
    if painted.hard_rock.is_some() && settings.soft_rock_strength < 1.0 {
        let sound = sample(&ErosionSettings {
            soft_rock_strength: 1.0,
            ..settings.clone()
        });
        painted.firm_window(&mut strength, &sound, n, at, size);
    }
    strength
}

/// The erodibility factors of `settings`' rock over a window of an `n` x `n` map of
/// `cell_m` cells, `size` cells (width, height) from `at`, hardened under the painted hard rock
/// of `painted` ([`super::Painted::harden`]): the factors the erosion stage gives the map's
/// cells there, sampled over the window alone (a world's tile refined with the world's
/// rock, `crate::world::refine`). Empty for uniform rock with nothing painted.
/// O(cells of the window x octaves + n x octaves).
pub fn rock_in_window(
    settings: &ErosionSettings,
    painted: super::Painted<'_>,
    (n, cell_m, seed): (usize, f64, u64),
    at: [usize; 2],
    size: [usize; 2],
) -> Vec<f32> {
    let mut factors = Vec::new();
    if settings.rock_contrast != 1.0 {
        factors = vec![0.0f32; size[0] * size[1]];
        rock_field(settings, n, cell_m, seed).window(at, size[0], &mut factors);
    }
    painted.harden_window(&mut factors, n, at, size);
    factors
}

/// `strength` (the rock's factors of `settings`, [`strength_in_bands`]) as strong as the
/// hard units under the painted hard rock of `anchors` ([`super::Painted::firm`]): a massif
/// painted on soft rock stands as steep as one on hard. Nothing to do without a painting,
/// factors or soft units.
async fn firm_painted_rock(
    strength: &mut [f32],
    settings: &ErosionSettings,
    anchors: &Anchors<'_>,
    (n, cell_m, seed): (usize, f64, u64),
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    if anchors.painted.hard_rock.is_none()
        || strength.is_empty()
        || settings.soft_rock_strength >= 1.0
    {
        return Ok(());
    }
    let hard = sound_strength_in_bands(settings, n, cell_m, seed, ctx).await?;
    anchors.painted.firm(strength, &hard, n);
    Ok(())
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
    let strength = slope_strength(settings, n, cell_m, seed);
    field_in_bands(n, ctx, |first_row, rows| strength.rows(first_row, rows)).await
}

/// [`rock_in_bands`] and [`strength_in_bands`] together, the rock sampled once (the same
/// values): the rock's erodibility factors (unpainted) and its strength factors.
pub(super) async fn rock_and_strength_in_bands(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
    ctx: &JobCtx,
) -> Result<(Vec<f32>, Vec<f32>), Cancelled> {
    let rock = rock_in_bands(settings, n, cell_m, seed, ctx).await?;
    if settings.talus_deg.is_none() {
        return Ok((rock, Vec::new()));
    }
    let strength = slope_strength(settings, n, cell_m, seed);
    let factors = field_in_bands(n, ctx, |first_row, rows| {
        let cells = first_row * n..first_row * n + rows.len();
        strength.rows_on_rock(first_row, rows, rock.get(cells).unwrap_or(&[]));
    })
    .await?;
    Ok((rock, factors))
}

/// [`strength_in_bands`] on the spread of strength alone, every rock unit as strong as the
/// hard ones (`soft_rock_strength` 1).
async fn sound_strength_in_bands(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Vec<f32>, Cancelled> {
    let sound = ErosionSettings {
        soft_rock_strength: 1.0,
        ..settings.clone()
    };
    strength_in_bands(&sound, n, cell_m, seed, ctx).await
}

/// The rock's strength of `settings` on an `n` x `n` map of `cell_m` cells: its spread, and
/// the rock field's units of hard and soft rock ([`super::erodibility_factors`]'s patches),
/// the soft failing at lower angles.
fn slope_strength(
    settings: &ErosionSettings,
    n: usize,
    cell_m: f64,
    seed: u64,
) -> super::SlopeStrength {
    let rock = rock_field(settings, n, cell_m, seed);
    super::SlopeStrength::new(n, cell_m, seed, settings.strength_spread).with_rock(
        rock,
        settings.rock_contrast,
        settings.soft_rock_strength,
    )
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
    firm_painted_rock(
        &mut prepared.strength,
        settings,
        &anchors,
        (n, cell_m, seed),
        ctx,
    )
    .await?;
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
            let mut strength = strength_in_bands(settings, n, cell_m, seed, ctx).await?;
            firm_painted_rock(&mut strength, settings, anchors, (n, cell_m, seed), ctx).await?;
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
            // On the spread alone, not the rock's soft units: a peak sketched on soft rock
            // stood 13% short of its height (1041 m of 1200 on a 10 km map).
            let mut strength = sound_strength_in_bands(settings, n, cell_m, seed, ctx).await?;
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
