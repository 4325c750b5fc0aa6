//! The rasters the 3D shader reads, prepared once per terrain on the CPU (natively on a
//! worker thread, in the page as a job that yields: the app's "3D view" job), or on a
//! hardware GPU ([`super::gpu_maps`], the same rasters to rounding).
//!
//! - B-spline control points (`R32Float`, read with `textureLoad`, so no float filtering is
//!   needed: WebGL2 and WebGPU both have it): the control points whose bicubic B-spline,
//!   the limit of seed 004's subdivision (eqs. 2-3), passes through every sample (see
//!   [`super::subdivision`]); the vertex stage evaluates that surface,
//! - surface gradients `(dz/dx, dz/dy)` in metres per metre (`Rg16Float`, filterable
//!   everywhere), central differences of the samples, from which the shader derives
//!   per-pixel normals for any exaggeration,
//! - roughness `e` of seed 004's eq. 5 (`R8Unorm`): seed 001's local-scope statistic, the
//!   local standard deviation of the finest wavelet level's detail ([`Spectral::roughness`]),
//! - the Hurst exponent `H` of eq. 4 from seed 001's spectral slope ([`hurst_from_gamma`]),
//! - a water mask of the river network (`R8Unorm`, [`water_mask`]).
//!
//! A field larger than the device's texture limit is box-filtered down by an integer factor
//! (the 3D view then shows that resolution; exports are unaffected). O(cells).

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::river::keepout::point_segment;
use crate::skeleton::RiverPiece;
use crate::wavelet::analysis::{self, AnalysisParams, Transformed};
use crate::wavelet::lifting::Band;

use super::lod::ChunkTree;
use super::subdivision;

/// Eq. 4's `H` when the terrain gives no spectral fit (flat or tiny): the fixed value the
/// view used before it measured one.
pub const DEFAULT_HURST: f32 = 0.8;

/// The range `H` is clamped to: fBm needs `0 < H < 1`; below 0.1 the detail's octaves
/// hardly decay (white noise, one spike per vertex), at 1 they decay as fast as a smooth
/// surface's. Real land measures gamma 2.5 to 4.5 (seed 001), H 0.25 to 1.25.
pub const HURST_RANGE: (f32, f32) = (0.1, 1.0);

/// Half-width (cells) of the window of [`Spectral::roughness`]: 9 x 9 cells, about 40 detail
/// coefficients (3/4 of the cells hold one), enough for a standard deviation within ~10 %.
pub const ROUGHNESS_RADIUS: usize = 4;

/// The prepared rasters of one terrain.
#[derive(Clone, Debug)]
pub struct TerrainMaps {
    pub width: usize,
    pub height: usize,
    /// Metres per cell (after any reduction).
    pub cell: f32,
    /// The bicubic B-spline control points (metres) whose surface passes through the
    /// heights ([`subdivision::interpolating`]); non-finite cells were replaced by the lowest
    /// height first.
    pub control: Vec<f32>,
    /// The gradients and the roughness, on the CPU or in textures on the GPU.
    pub rasters: Rasters,
    /// Eq. 4's Hurst exponent, from the terrain's own spectral slope ([`hurst_from_gamma`]).
    pub hurst: f32,
    /// The lowest and highest sample (metres).
    pub zmin: f32,
    pub zmax: f32,
    /// Height ranges of the chunks, from the control points (the surface lies within them).
    pub tree: ChunkTree,
}

/// Where a terrain's gradient and roughness rasters are.
#[derive(Clone, Debug)]
pub enum Rasters {
    /// Made on the CPU; the renderer uploads them.
    Cpu {
        /// `(dz/dx, dz/dy)` per cell as IEEE half floats.
        gradients: Vec<[u16; 2]>,
        /// Eq. 5's roughness `e` per cell, 0..=255 for 0..=1 ([`Spectral::roughness`]).
        roughness: Vec<u8>,
    },
    /// Made on the GPU the view draws with ([`super::gpu_maps`]): textures to bind as they
    /// are, the control points' among them.
    Gpu(super::gpu_maps::GpuRasters),
}

impl TerrainMaps {
    /// Prepares `field` (cells of `cell` metres) for a device whose textures are at most
    /// `max_side` texels wide.
    /// Natively the rasters are made on all threads (the gradients in row bands, the
    /// spectral measures beside the control points, each of those in bands or blocks); the
    /// same bits as on one thread.
    pub fn new(field: &Heightfield, cell: f32, max_side: usize) -> Self {
        let base = Base::of(field, cell, max_side);
        let (w, h) = (base.width, base.height);
        let gradients = gradients(&base.heights, w, h, base.cell);
        let ((hurst, roughness), control) = crate::parallel::join(
            || spectral(&base.heights, w, h),
            || subdivision::interpolating(&base.heights, w, h),
        );
        base.finish(
            Rasters::Cpu {
                gradients,
                roughness,
            },
            control,
            hurst,
        )
    }

    /// [`Self::new`] as a job that stops when cancelled. Natively (a worker thread) it checks
    /// before and after [`Self::new`]; in the page it yields between bands of rows and
    /// between stages, so the browser keeps painting. The same maps either way.
    pub async fn prepare(
        field: &Heightfield,
        cell: f32,
        max_side: usize,
        job: &JobCtx,
    ) -> Result<Self, Cancelled> {
        if !cfg!(target_arch = "wasm32") {
            job.checkpoint(0.0, "3D view: surface maps").await?;
            let maps = Self::new(field, cell, max_side);
            job.checkpoint(1.0, "3D view: surface maps").await?;
            return Ok(maps);
        }
        let base = Base::of(field, cell, max_side);
        let (w, h) = (base.width, base.height);
        let mut gradients = Vec::with_capacity(w * h);
        for start in (0..h).step_by(256) {
            job.checkpoint(0.3 * start as f32 / h as f32, "3D view: surface normals")
                .await?;
            let rows = start..(start + 256).min(h);
            let first = gradients.len();
            gradients.resize(first + rows.len() * w, [0; 2]);
            gradient_rows(
                &base.heights,
                w,
                h,
                base.cell,
                rows,
                &mut gradients[first..],
            );
        }
        job.checkpoint(0.3, "3D view: wavelet roughness").await?;
        let (hurst, roughness) = spectral(&base.heights, w, h);
        let mut control = base.heights.clone();
        for start in (0..h).step_by(256) {
            job.checkpoint(
                0.6 + 0.2 * start as f32 / h as f32,
                "3D view: smooth surface",
            )
            .await?;
            subdivision::interpolate_rows(&mut control, w, start..(start + 256).min(h));
        }
        for start in (0..w).step_by(256) {
            job.checkpoint(
                0.8 + 0.2 * start as f32 / w as f32,
                "3D view: smooth surface",
            )
            .await?;
            subdivision::interpolate_columns(&mut control, w, h, start..(start + 256).min(w));
        }
        Ok(base.finish(
            Rasters::Cpu {
                gradients,
                roughness,
            },
            control,
            hurst,
        ))
    }

    /// The gradients and the roughness where they were made on the CPU.
    pub fn cpu_rasters(&self) -> Option<(&[[u16; 2]], &[u8])> {
        match &self.rasters {
            Rasters::Cpu {
                gradients,
                roughness,
            } => Some((gradients, roughness)),
            Rasters::Gpu(_) => None,
        }
    }

    /// Height (metres) of the drawn surface (without the synthetic detail) at world position
    /// `(x, y)` metres, clamped to the map: the B-spline the shader evaluates.
    pub fn ground(&self, x: f32, y: f32) -> f32 {
        subdivision::evaluate(
            &self.control,
            self.width,
            self.height,
            x / self.cell,
            y / self.cell,
        )
    }

    /// World size of the map (metres).
    pub fn extent(&self) -> (f32, f32) {
        (
            (self.width - 1) as f32 * self.cell,
            (self.height - 1) as f32 * self.cell,
        )
    }
}

/// Heights ready for the textures (reduced, no-data filled), before gradients and the tree.
pub(super) struct Base {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) cell: f32,
    pub(super) heights: Vec<f32>,
    zmin: f32,
    zmax: f32,
}

impl Base {
    pub(super) fn of(field: &Heightfield, cell: f32, max_side: usize) -> Self {
        let (w, h) = (field.width(), field.height());
        let (lo, hi) = field.finite_range().unwrap_or((0.0, 0.0));
        let factor = Self::factor(field, max_side);
        let (heights, width, height) = if factor == 1 {
            let data = field
                .data()
                .iter()
                .map(|&z| if z.is_finite() { z } else { lo })
                .collect();
            (data, w, h)
        } else {
            reduce(field, factor, lo)
        };
        Self {
            width,
            height,
            cell: cell * factor as f32,
            heights,
            zmin: lo,
            zmax: hi.max(lo + 1e-3),
        }
    }

    /// By how much `field` is reduced to fit `max_side` texels a side (1: not reduced).
    pub(super) fn factor(field: &Heightfield, max_side: usize) -> usize {
        let (w, h) = (field.width(), field.height());
        w.max(h).div_ceil(max_side.max(2)).max(1)
    }

    /// [`Self::of`] of a field that needs neither reducing nor filling, without copying
    /// its heights (`heights` is left empty: the caller has them elsewhere); `range` is the
    /// field's [`Heightfield::finite_range`], which the caller has measured.
    pub(super) fn unchanged(field: &Heightfield, cell: f32, range: Option<(f32, f32)>) -> Self {
        let (lo, hi) = range.unwrap_or((0.0, 0.0));
        Self {
            width: field.width(),
            height: field.height(),
            cell,
            heights: Vec::new(),
            zmin: lo,
            zmax: hi.max(lo + 1e-3),
        }
    }

    /// The maps, with the chunk tree built from the control points. O(cells).
    pub(super) fn finish(self, rasters: Rasters, control: Vec<f32>, hurst: f32) -> TerrainMaps {
        drop(self.heights);
        let field = Heightfield::from_vec(self.width, self.height, control)
            .expect("a prepared field is valid");
        let tree = ChunkTree::new(&field);
        TerrainMaps {
            width: self.width,
            height: self.height,
            cell: self.cell,
            control: field.into_vec(),
            rasters,
            hurst,
            zmin: self.zmin,
            zmax: self.zmax,
            tree,
        }
    }
}

/// Eq. 4's `H` from seed 001's spectral slope `gamma` of the wavelet detail variances
/// (`gamma = 2 H + 2` for fBm with the L2-normalised bank, seed 001 Sec. 2.3), clamped to
/// [`HURST_RANGE`]; [`DEFAULT_HURST`] without a finite slope.
pub fn hurst_from_gamma(gamma: Option<f64>) -> f32 {
    match gamma {
        Some(g) if g.is_finite() => (((g - 2.0) / 2.0) as f32).clamp(HURST_RANGE.0, HURST_RANGE.1),
        _ => DEFAULT_HURST,
    }
}

/// Eq. 4's `H` and eq. 5's roughness of a `w x h` grid of heights, from one wavelet
/// transform (seed 001): `H` from the spectral slope the realism report prints (the bands'
/// mean gamma of [`analysis::analyze_transformed`]), the roughness from the finest level's
/// detail ([`Spectral::roughness`]). A grid too small to transform gets [`DEFAULT_HURST`] and a
/// middling roughness (0.5) everywhere. O(cells).
pub fn spectral(heights: &[f32], w: usize, h: usize) -> (f32, Vec<u8>) {
    match Spectral::of(heights, w, h) {
        Some(spectral) => (spectral.hurst, spectral.roughness()),
        None => (DEFAULT_HURST, vec![128u8; w * h]),
    }
}

/// What [`spectral`] measures before the roughness's windows: `H`, and the finest level's
/// squared, L2-normalised detail with its mean (the GPU path, `gpu_maps`, measures the same
/// from its own transform).
struct Spectral {
    hurst: f32,
    width: usize,
    height: usize,
    /// Per cell, 0 on the coarse (even, even) cells.
    squares: Vec<f32>,
    /// Mean of the squares over the detail cells (f64 sum, row-major).
    mean: f64,
}

impl Spectral {
    /// `None` for a grid too small to transform. O(cells).
    fn of(heights: &[f32], w: usize, h: usize) -> Option<Self> {
        let field = Heightfield::from_vec(w, h, heights[..w * h].to_vec()).ok()?;
        let t = Transformed::of(&field).ok()?;
        drop(field);
        let global = analysis::analyze_transformed(&t, &AnalysisParams::default());
        let gammas: Vec<f64> = global.fits.iter().flatten().map(|f| f.gamma).collect();
        let gamma = (!gammas.is_empty()).then(|| gammas.iter().sum::<f64>() / gammas.len() as f64);
        let mut squares = t.data;
        let mean = squared_detail(&mut squares, w, h);
        Some(Self {
            hurst: hurst_from_gamma(gamma),
            width: w,
            height: h,
            squares,
            mean,
        })
    }

    /// The scale the window's standard deviation is multiplied by: 0.5 at the map's root
    /// mean square; `None` for a map without detail (roughness 0 everywhere).
    fn scale(&self) -> Option<f64> {
        roughness_scale(self.mean)
    }

    /// Eq. 5's roughness `e` per cell: the standard deviation of the L2-normalised finest
    /// detail in a `(2 r + 1)^2` window ([`ROUGHNESS_RADIUS`]), seed 001's local scope (LSA,
    /// Sec. 3.3.1, eq. 8's windowed variance at the finest level), divided by twice its root
    /// mean square over the map and clamped to 1: 0.5 is ground as rough as the map's
    /// average, 1 twice as rough or more, 0 smooth. O(cells).
    fn roughness(mut self) -> Vec<u8> {
        let (w, h) = (self.width, self.height);
        match self.scale() {
            Some(scale) => window_roughness(&mut self.squares, w, h, scale),
            None => vec![0u8; w * h],
        }
    }
}

/// Replaces `data`, a grid transformed at least one level (`src/wavelet/lifting.rs`, CDF
/// 5/3, interleaved: the finest level's detail coefficients sit on the cells with an odd
/// coordinate), by its squared, L2-normalised finest detail (0 on the coarse (even, even)
/// cells) and returns the squares' mean over the detail cells (0 where
/// there are none). O(cells), serial (the f64 sum in row-major order).
fn squared_detail(data: &mut [f32], w: usize, h: usize) -> f64 {
    let (mut total, mut count) = (0.0f64, 0usize);
    for y in 0..h {
        for x in 0..w {
            let v = &mut data[y * w + x];
            *v = match Band::at(x % 2 == 1, y % 2 == 1) {
                Some(band) => {
                    let d = f64::from(*v) * band.normalisation(1);
                    total += d * d;
                    count += 1;
                    (d * d) as f32
                }
                None => 0.0,
            };
        }
    }
    if count > 0 { total / count as f64 } else { 0.0 }
}

/// The roughness's scale for a finest detail of mean square `mean`: 1 / (2 x its root mean
/// square); `None` without detail.
pub(super) fn roughness_scale(mean: f64) -> Option<f64> {
    (mean > 0.0 && mean.is_finite()).then(|| 1.0 / (2.0 * mean.sqrt()))
}

/// The mean square of the finest level's normalised detail over its three bands, from a
/// global analysis (the mean [`squared_detail`] returns, to float rounding).
pub(super) fn finest_mean(analysis: &analysis::Analysis) -> f64 {
    let Some(finest) = analysis.levels.first() else {
        return 0.0;
    };
    let count: usize = finest.counts.iter().sum();
    let total: f64 = finest
        .variances
        .iter()
        .zip(finest.counts)
        .map(|(v, n)| v * n as f64)
        .sum();
    if count > 0 { total / count as f64 } else { 0.0 }
}

/// The roughness of squared detail `data` (used as scratch): each cell's window standard
/// deviation times `scale`, in 0..=255.
fn window_roughness(data: &mut [f32], w: usize, h: usize, scale: f64) -> Vec<u8> {
    let r = ROUGHNESS_RADIUS;
    // Horizontal window sums, in place (a prefix sum per row), in row bands.
    let threads = crate::parallel::threads();
    let rows = h.div_ceil(threads).max(1);
    crate::parallel::for_each_band(data, rows * w, |_, band| {
        let mut prefix = vec![0.0f64; w + 1];
        for row in band.chunks_mut(w) {
            for (x, &v) in row.iter().enumerate() {
                prefix[x + 1] = prefix[x] + f64::from(v);
            }
            for (x, v) in row.iter_mut().enumerate() {
                *v = (prefix[(x + r + 1).min(w)] - prefix[x.saturating_sub(r)]) as f32;
            }
        }
    });
    // Vertical window sums, running per column from the top (so a column's sums round the
    // same whichever block it is in), one block of columns per thread.
    let data: &[f32] = data;
    let width = w.div_ceil(threads).max(1);
    let blocks: Vec<_> = (0..w)
        .step_by(width)
        .map(|start| start..(start + width).min(w))
        .collect();
    let mut parts = vec![Vec::new(); blocks.len()];
    crate::parallel::for_each_item(
        blocks.iter().zip(parts.iter_mut()).collect(),
        |(columns, part)| *part = window_sigma(data, w, h, columns.clone(), scale),
    );
    let mut out = vec![0u8; w * h];
    for (columns, part) in blocks.iter().zip(&parts) {
        for (row, values) in out
            .chunks_exact_mut(w)
            .zip(part.chunks_exact(columns.len()))
        {
            row[columns.clone()].copy_from_slice(values);
        }
    }
    out
}

/// [`window_roughness`]'s last step on the columns `columns`: each cell's window sum down the
/// columns (from `data`'s horizontal sums), over the window's detail cells (its cells less
/// its (even, even) ones), as a standard deviation times `scale`, in 0..=255. Row-major,
/// `columns.len()` wide.
fn window_sigma(
    data: &[f32],
    w: usize,
    h: usize,
    columns: std::ops::Range<usize>,
    scale: f64,
) -> Vec<u8> {
    let r = ROUGHNESS_RADIUS;
    let evens = |a: usize, b: usize| b / 2 - a.div_ceil(2) + 1;
    let segment = |y: usize| &data[y * w + columns.start..y * w + columns.end];
    let mut sums = vec![0.0f64; columns.len()];
    for y in 0..r.min(h) {
        for (s, &v) in sums.iter_mut().zip(segment(y)) {
            *s += f64::from(v);
        }
    }
    let mut out = Vec::with_capacity(columns.len() * h);
    for y in 0..h {
        if y + r < h {
            for (s, &v) in sums.iter_mut().zip(segment(y + r)) {
                *s += f64::from(v);
            }
        }
        if y > r {
            for (s, &v) in sums.iter_mut().zip(segment(y - r - 1)) {
                *s -= f64::from(v);
            }
        }
        let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
        for (x, &sum) in columns.clone().zip(&sums) {
            let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
            let cells = (x1 - x0 + 1) * (y1 - y0 + 1);
            let n = cells - evens(x0, x1) * evens(y0, y1);
            let sigma = (sum.max(0.0) / n.max(1) as f64).sqrt();
            out.push(((sigma * scale).min(1.0) * 255.0).round() as u8);
        }
    }
    out
}

/// Box filter by `factor` (finite cells only).
fn reduce(field: &Heightfield, factor: usize, fill: f32) -> (Vec<f32>, usize, usize) {
    let (w, h) = (field.width(), field.height());
    let (rw, rh) = (w.div_ceil(factor), h.div_ceil(factor));
    let mut out = vec![fill; rw * rh];
    for (j, row) in out.chunks_mut(rw).enumerate() {
        for (i, v) in row.iter_mut().enumerate() {
            let (mut sum, mut n) = (0.0f64, 0u32);
            for y in j * factor..((j + 1) * factor).min(h) {
                for x in i * factor..((i + 1) * factor).min(w) {
                    let z = field.data()[y * w + x];
                    if z.is_finite() {
                        sum += f64::from(z);
                        n += 1;
                    }
                }
            }
            if n > 0 {
                *v = (sum / f64::from(n)) as f32;
            }
        }
    }
    (out, rw, rh)
}

/// The gradients of every cell, in row bands on all threads natively.
fn gradients(heights: &[f32], w: usize, h: usize, cell: f32) -> Vec<[u16; 2]> {
    let mut out = vec![[0u16; 2]; w * h];
    let rows = h.div_ceil(crate::parallel::threads()).max(1);
    crate::parallel::for_each_band(&mut out, rows * w.max(1), |k, band| {
        let start = k * rows;
        gradient_rows(heights, w, h, cell, start..start + band.len() / w, band);
    });
    out
}

/// The largest finite half float: steeper gradients (a cliff on centimetre cells) are clamped
/// to it rather than stored as infinities.
const MAX_HALF: f32 = 65504.0;

/// Central differences (one-sided at the border), metres per metre, of `rows` into `out`
/// (their cells, row-major), clamped to [`MAX_HALF`].
fn gradient_rows(
    heights: &[f32],
    w: usize,
    h: usize,
    cell: f32,
    rows: std::ops::Range<usize>,
    out: &mut [[u16; 2]],
) {
    let at = |x: usize, y: usize| heights[y * w + x];
    for (y, row) in rows.zip(out.chunks_exact_mut(w)) {
        for (x, v) in row.iter_mut().enumerate() {
            let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let dx = (at(xb, y) - at(xa, y)) / (((xb - xa).max(1)) as f32 * cell);
            let dy = (at(x, yb) - at(x, ya)) / (((yb - ya).max(1)) as f32 * cell);
            *v = [
                f16_bits(dx.clamp(-MAX_HALF, MAX_HALF)),
                f16_bits(dy.clamp(-MAX_HALF, MAX_HALF)),
            ];
        }
    }
}

/// Width in metres of a river of Strahler order `order`: 2.5 m for a first-order creek,
/// doubling with each order (Horton's laws give drainage areas about four times larger per
/// order, and hydraulic geometry (Leopold and Maddock 1953) widths growing as the square root
/// of discharge, so about twice as wide per order): 40 m at order 5, 160 m at order 7.
pub fn river_width_m(order: u8) -> f32 {
    2.5 * 2f32.powi(i32::from(order.max(1)) - 1)
}

/// The river network as a water mask on a `size` x `size` grid of cells `cell_m` metres
/// wide: each cell's share of water (0 to 255) from the rivers' courses
/// ([`RiverPiece`]s, in cells) at their widths ([`river_width_m`]), at least one cell wide;
/// a river narrower than half a cell stays dry (so only real rivers look like water,
/// whatever the map's scale). A cell's share falls from full to none over the cell across
/// the bank (`half width + 1/2 - distance`, clamped): sampled linearly, the banks follow the
/// course below the cell, not the cells' staircase. O(pieces x their cells).
pub fn water_mask(pieces: &[RiverPiece], size: usize, cell_m: f32) -> Vec<u8> {
    let mut out = vec![0u8; size * size];
    if size == 0 || cell_m.is_nan() || cell_m <= 0.0 {
        return out;
    }
    for piece in pieces {
        let width = river_width_m(piece.order);
        if width < 0.5 * cell_m {
            continue;
        }
        let half = (0.5 * width / cell_m).max(0.5);
        // A long piece in parts of a few cells, each over its own box of cells (the share is
        // the largest over the parts, the share of the nearest).
        let (a, b) = (piece.a, piece.b);
        let length = (b[0] - a[0]).hypot(b[1] - a[1]);
        let parts = (length / PART_CELLS).ceil().clamp(1.0, 1e6) as usize;
        for k in 0..parts {
            let along = |t: f32| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            let part = RiverPiece {
                a: along(k as f32 / parts as f32),
                b: along((k + 1) as f32 / parts as f32),
                order: piece.order,
            };
            wet(&mut out, size, &part, half);
        }
    }
    out
}

/// The longest part of a piece [`water_mask`] takes at a time, in cells.
const PART_CELLS: f32 = 4.0;

/// Raises the water of the cells of `out` (`size` a side) within reach of `piece` to their
/// share of a river `half` cells wide each side of it.
fn wet(out: &mut [u8], size: usize, piece: &RiverPiece, half: f32) {
    let reach = half + 0.5;
    let (lo, hi) = (
        [piece.a[0].min(piece.b[0]), piece.a[1].min(piece.b[1])],
        [piece.a[0].max(piece.b[0]), piece.a[1].max(piece.b[1])],
    );
    let last = (size - 1) as f32;
    let cells = |from: f32, to: f32| {
        let from = (from - reach).ceil().clamp(0.0, last) as usize;
        let to = (to + reach).floor().clamp(0.0, last) as usize;
        from..=to
    };
    let (a, b) = (
        glam::DVec2::from(piece.a.map(f64::from)),
        glam::DVec2::from(piece.b.map(f64::from)),
    );
    for y in cells(lo[1], hi[1]) {
        for x in cells(lo[0], hi[0]) {
            let d = point_segment(glam::DVec2::new(x as f64, y as f64), a, b) as f32;
            let share = (half + 0.5 - d).clamp(0.0, 1.0);
            let v = (share * 255.0).round() as u8;
            let cell = &mut out[y * size + x];
            *cell = (*cell).max(v);
        }
    }
}

/// Nearest-sample reduction of a square mask to at most `max_side` texels per side.
pub fn reduce_mask(mask: &[u8], side: usize, max_side: usize) -> (Vec<u8>, usize) {
    if side <= max_side {
        return (mask[..side * side].to_vec(), side);
    }
    let factor = side.div_ceil(max_side);
    let out_side = side.div_ceil(factor);
    let out = (0..out_side * out_side)
        .map(|k| {
            let (x, y) = ((k % out_side) * factor, (k / out_side) * factor);
            // Keep thin rivers: any water cell in the block counts.
            let mut v = 0;
            for yy in y..(y + factor).min(side) {
                for xx in x..(x + factor).min(side) {
                    v = v.max(mask[yy * side + xx]);
                }
            }
            v
        })
        .collect();
    (out, out_side)
}

/// IEEE 754 half-precision bits of `v` (round to nearest; overflow to infinity, tiny
/// values to zero): the `Rg16Float` texture format.
pub fn f16_bits(v: f32) -> u16 {
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    if v.is_nan() {
        return sign | 0x7e00;
    }
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mantissa = bits & 0x007f_ffff;
    if exp >= 31 {
        return sign | 0x7c00;
    }
    if exp <= 0 {
        if exp < -10 {
            return sign;
        }
        // Subnormal half.
        let m = (mantissa | 0x0080_0000) >> (1 - exp);
        let rounded = (m + 0x1000) >> 13;
        return sign | rounded as u16;
    }
    let rounded = ((exp as u32) << 10 | (mantissa >> 13)) + ((mantissa >> 12) & 1);
    if rounded >= 0x7c00 {
        return sign | 0x7c00;
    }
    sign | rounded as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The maps of a rough terrain with a few no-data cells, pinned: the rasters are made in
    /// bands and blocks on all threads natively and in steps in the page, and must be these
    /// bits whichever way (the checksum was taken from the serial code before the bands).
    #[test]
    fn the_maps_are_pinned_bits() {
        let mut field = crate::wavelet::fbm::diamond_square(301, 203, 0.7, 11).unwrap();
        for i in [5, 4000, 30_000] {
            field.data_mut()[i] = f32::NAN;
        }
        let maps = TerrainMaps::new(&field, 30.0, 4096);
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let mut add = |word: u32| {
            for b in word.to_le_bytes() {
                hash = (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        maps.control.iter().for_each(|v| add(v.to_bits()));
        let (gradients, roughness) = maps.cpu_rasters().unwrap();
        gradients
            .iter()
            .for_each(|g| add(u32::from(g[0]) << 16 | u32::from(g[1])));
        roughness.iter().for_each(|&e| add(u32::from(e)));
        add(maps.hurst.to_bits());
        assert_eq!(format!("{hash:016x}"), "f7538200884e25cb");
    }

    fn from_f16(h: u16) -> f32 {
        let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
        let exp = i32::from((h >> 10) & 0x1f);
        let m = f32::from(h & 0x3ff);
        sign * match exp {
            0 => m * 2f32.powi(-24),
            31 => f32::INFINITY,
            e => (1.0 + m / 1024.0) * 2f32.powi(e - 15),
        }
    }

    #[test]
    fn half_floats_round_trip_within_their_precision() {
        for v in [0.0f32, 1.0, -2.5, 0.1234, 1e-3, -7.75e-5, 300.0, 65000.0] {
            let back = from_f16(f16_bits(v));
            assert!((back - v).abs() <= v.abs() * 1e-3 + 1e-7, "{v} -> {back}");
        }
        assert_eq!(from_f16(f16_bits(1e6)), f32::INFINITY);
        let nan = f16_bits(f32::NAN);
        assert!(nan & 0x7c00 == 0x7c00 && nan & 0x3ff != 0);
    }

    #[test]
    fn a_plane_has_its_slope_everywhere_and_ground_interpolates() {
        let (w, h) = (40, 30);
        let data = (0..w * h)
            .map(|i| 0.5 * (i % w) as f32 - 0.25 * (i / w) as f32)
            .collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let maps = TerrainMaps::new(&field, 2.0, 4096);
        for g in maps.cpu_rasters().unwrap().0 {
            assert!((from_f16(g[0]) - 0.25).abs() < 1e-3);
            assert!((from_f16(g[1]) + 0.125).abs() < 1e-3);
        }
        assert!((maps.ground(3.0, 5.0) - (0.5 * 1.5 - 0.25 * 2.5)).abs() < 1e-4);
    }

    #[test]
    fn large_fields_are_reduced_to_the_texture_limit() {
        let field = Heightfield::filled(1000, 500, 7.0).unwrap();
        let maps = TerrainMaps::new(&field, 1.0, 256);
        assert!(maps.width <= 256 && maps.height <= 256);
        assert_eq!(maps.cell, 4.0);
        assert!(maps.control.iter().all(|&z| (z - 7.0).abs() < 1e-4));
    }

    #[test]
    fn no_data_cells_never_reach_the_mesh() {
        let mut field = Heightfield::filled(64, 64, 3.0).unwrap();
        field.data_mut()[100] = f32::NAN;
        let maps = TerrainMaps::new(&field, 1.0, 4096);
        assert!(maps.control.iter().all(|z| z.is_finite()));
    }

    #[test]
    fn the_hurst_exponent_follows_the_spectral_slope() {
        // gamma = 2H + 2, clamped to the sane range, the old fixed value without a fit.
        assert!((hurst_from_gamma(Some(3.6)) - 0.8).abs() < 1e-6);
        assert!((hurst_from_gamma(Some(3.0)) - 0.5).abs() < 1e-6);
        assert_eq!(hurst_from_gamma(Some(1.0)), HURST_RANGE.0);
        assert_eq!(hurst_from_gamma(Some(9.0)), HURST_RANGE.1);
        assert_eq!(hurst_from_gamma(None), DEFAULT_HURST);
        assert_eq!(hurst_from_gamma(Some(f64::NAN)), DEFAULT_HURST);
        // Fields of known H (seed 001's check: gamma within 0.35 of 2H + 2, so H within 0.175).
        for hurst in [0.4f32, 0.8] {
            let field = crate::wavelet::fbm::diamond_square(257, 257, hurst, 11).unwrap();
            let maps = TerrainMaps::new(&field, 10.0, 4096);
            assert!(
                (maps.hurst - hurst).abs() <= 0.175,
                "H {hurst}: measured {}",
                maps.hurst
            );
        }
        let rough = crate::wavelet::fbm::diamond_square(257, 257, 0.3, 2).unwrap();
        let smooth = crate::wavelet::fbm::diamond_square(257, 257, 0.9, 2).unwrap();
        let (hr, hs) = (
            TerrainMaps::new(&rough, 10.0, 4096).hurst,
            TerrainMaps::new(&smooth, 10.0, 4096).hurst,
        );
        assert!(hs > hr + 0.3, "rough {hr}, smooth {hs}");
    }

    #[test]
    fn roughness_is_high_where_the_finest_detail_is_strong() {
        // A gentle slope everywhere, with cell-scale noise on the right half only.
        let n = 96;
        let data = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                let mut v = (i as u32).wrapping_mul(2_654_435_761);
                v ^= v >> 15;
                let noise = (v & 0xff) as f32 / 255.0 - 0.5;
                0.3 * x as f32 + 0.1 * y as f32 + if x >= n / 2 { 4.0 * noise } else { 0.0 }
            })
            .collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let maps = TerrainMaps::new(&field, 10.0, 4096);
        let roughness = maps.cpu_rasters().unwrap().1;
        let at = |x: usize, y: usize| roughness[y * n + x];
        // A plane has no detail (the 5/3 predictor is exact on it): e = 0 on the left.
        assert!(at(10, 40) <= 2, "{}", at(10, 40));
        assert!(at(80, 40) >= 150, "{}", at(80, 40));
        // e = sigma / (2 rms of the map): the right half holds all the detail, so its mean
        // square is twice the map's and e = sqrt 2 / 2 = 0.71 there.
        let right = (50..90).map(|x| f32::from(at(x, 50))).sum::<f32>() / 40.0 / 255.0;
        assert!((right - 0.71).abs() < 0.12, "{right}");
    }

    fn piece(a: [f32; 2], b: [f32; 2], order: u8) -> RiverPiece {
        RiverPiece { a, b, order }
    }

    #[test]
    fn water_follows_the_river_width_in_metres() {
        let n = 21;
        let rivers = [
            piece([5.0, 0.0], [5.0, 20.0], 1),   // a creek: 2.5 m
            piece([14.0, 0.0], [14.0, 20.0], 5), // a river: 40 m
        ];
        let wet_columns = |cell: f32| {
            let mask = water_mask(&rivers, n, cell);
            (0..n)
                .filter(|&x| mask[10 * n + x] >= 128)
                .collect::<Vec<_>>()
        };
        // 10 m cells: the creek stays dry, the river is four cells wide, its banks halfway
        // across the cells two from its course (at half their share).
        assert_eq!(wet_columns(10.0), vec![12, 13, 14, 15, 16]);
        let mask = water_mask(&rivers, n, 10.0);
        assert_eq!(mask[10 * n + 14], 255);
        assert_eq!(mask[10 * n + 12], 128);
        assert_eq!(mask[10 * n + 11], 0);
        // 4 m cells: the creek is water too, at least a cell wide.
        assert!(wet_columns(4.0).contains(&5));
        // 100 m cells: even the river is narrower than half a cell.
        assert!(wet_columns(100.0).is_empty());
        assert_eq!(river_width_m(7), 160.0);
    }

    /// A river across the grid's axes: where its water ends, found below the cell from the
    /// shares (linearly between the cells that straddle half), lies the same distance from
    /// its course all along it, within a sixth of a cell (the shares are linear in the
    /// distance over one cell, so two cells straddling the bank can hold one full share);
    /// the cells' staircase, drawn at full or no water, puts it anywhere within a cell.
    #[test]
    fn water_banks_follow_an_oblique_course_not_the_cells() {
        let n = 64;
        let (a, b) = ([4.0, 10.0], [60.0, 38.0]); // a slope of 1/2
        let mask = water_mask(&[piece(a, b, 5)], n, 10.0);
        let slope = (b[1] - a[1]) / (b[0] - a[0]);
        let mut offsets = Vec::new();
        for x in 12..52 {
            let centre = a[1] + slope * (x as f32 - a[0]);
            // Down the column from the course: the first cell under half water.
            let mut y = centre.ceil() as usize;
            while mask[y * n + x] >= 128 {
                y += 1;
            }
            let (wet, dry) = (f32::from(mask[(y - 1) * n + x]), f32::from(mask[y * n + x]));
            let edge = (y - 1) as f32 + (wet - 127.5) / (wet - dry);
            offsets.push(edge - centre);
        }
        let (lo, hi) = offsets
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), v| {
                (l.min(*v), h.max(*v))
            });
        assert!(
            hi - lo < 0.16,
            "the bank wanders {lo}..{hi} cells from the course"
        );
        // Vertical distance of a bank 2 cells from a course of slope 1/2: 2 sqrt(1.25).
        let expected = 2.0 * 1.25f32.sqrt();
        assert!(
            (lo - expected).abs() < 0.1 && (hi - expected).abs() < 0.1,
            "{lo}..{hi}"
        );
    }
}
