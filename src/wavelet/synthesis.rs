//! New levels of detail (seed paper 001: GSA step 3-4, LSA eq. 8, MGR eq. 9).
//!
//! The source becomes the coarse signal of `K` new levels: it is placed on every `2^K`-th
//! vertex of a `2^K (n - 1) + 1` grid, every other vertex receives one zero-mean Gaussian
//! detail coefficient, and the inverse transform of [`super::lifting`] runs from the coarsest
//! new level to the finest. A coefficient of band `t` at new-level depth `j` (0 for the first
//! new level, -1 for the next...) has the variance the fitted line gives there:
//!
//! - global (GSA, eqs. 2 and 7): `sigma^2 = 2^(a^t - n gamma^t)`, one per level and band;
//! - local (LSA, eq. 8): `sigma^2(r) = 2^(a^t(r) - n gamma^t(r))` from the fit at the source
//!   cell `r` nearest to the coefficient, each level's mean over the map calibrated to the
//!   global line (the local fit places the energy, the global one sets its total); or, with
//!   [`LocalParams::as_written`], eq. 8's variance exactly as the paper writes it.
//!
//! The energy-reduction mask (MGR, eq. 9) scales each coefficient by
//! `sqrt(1 - sum_{(k,l)} c_{k,l} ||psi||_{D(k,l)})`: the mask is summed under the squared taps
//! of the coefficient's synthesis filter on its level's grid, normalised to unit energy
//! (`psi~ = (-1, -2, 6, -2, -1) / 8` across a high-pass axis, `phi~ = (1, 2, 1) / 2` across a
//! low-pass one). A coefficient whose support lies wholly under white is removed, one under
//! black is kept, and the ones straddling an edge fade, which gives the smooth transitions of
//! Sec. 4.2. With every coefficient removed the output is the bilinear interpolation of the
//! source and every source sample keeps its value exactly.
//!
//! Cost: O(output cells) time; memory: the output, plus the mask resampled to the output
//! when a mask is given, plus `3 K` source-sized tables of standard deviations.

use super::WaveletError;
use super::analysis::{self, Analysis, AnalysisParams, LocalFit, LocalParams, Transformed};
use super::lifting::{self, Band};
use super::mask::Mask;
use super::rng;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::parallel;

/// Largest number of new levels (each multiplies the cell count by about 4).
pub const MAX_LEVELS: u32 = 3;

/// Largest output accepted: 8193^2 cells (256 MiB as `f32`).
pub const MAX_OUTPUT_CELLS: u64 = 8193 * 8193;

/// Where the variances of the new coefficients come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scope {
    /// One line per band for the whole terrain (GSA).
    Global,
    /// One line per band and location, from a window of coefficients (LSA).
    Local(LocalParams),
}

/// Parameters of [`amplify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmplifyParams {
    /// New levels, 1 to [`MAX_LEVELS`].
    pub levels: u32,
    pub scope: Scope,
    pub seed: u64,
    pub analysis: AnalysisParams,
}

impl Default for AmplifyParams {
    fn default() -> Self {
        Self {
            levels: 1,
            scope: Scope::Global,
            seed: 1,
            analysis: AnalysisParams::default(),
        }
    }
}

/// Side length after `levels` new levels.
pub fn output_len(n: usize, levels: u32) -> usize {
    ((n - 1) << levels) + 1
}

/// An amplified terrain and the statistics it was made from.
pub struct Amplified {
    pub field: Heightfield,
    pub analysis: Analysis,
    /// Milliseconds per phase (`strahler bench wavelet`, `amplify --report`).
    pub timings: Timings,
    /// `field`, bit for bit, still on the GPU that made it (the GPU path).
    pub gpu: Option<crate::gpu::GpuField>,
    /// The detail's RMS ([`detail_rms`]) where the GPU measured it beside the synthesis
    /// (where it runs the heavy stages: hardware, or every stage asked of it); `None`
    /// elsewhere.
    pub rms: Option<DetailRms>,
}

/// Wall-clock milliseconds of the phases of [`amplify`].
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Forward transform of the source, the line fits (and the local fits), sigma tables.
    pub analysis: f64,
    /// Gaussian coefficients (and the mask factors) written into the output grid.
    pub fill: f64,
    /// The inverse lifting of the new levels (on the GPU: upload, kernels and readback).
    pub inverse: f64,
}

/// Milliseconds since `clock`, restarting it.
pub(crate) fn lap(clock: &mut web_time::Instant) -> f64 {
    let now = web_time::Instant::now();
    let ms = (now - *clock).as_secs_f64() * 1e3;
    *clock = now;
    ms
}

/// Checks parameters and sizes before any allocation.
pub fn check(source: &Heightfield, params: &AmplifyParams) -> Result<(usize, usize), WaveletError> {
    if !(1..=MAX_LEVELS).contains(&params.levels) {
        return Err(WaveletError::Levels(params.levels));
    }
    if let Scope::Local(local) = params.scope
        && (local.window == 0 || local.window > 65 || local.window.is_multiple_of(2))
    {
        return Err(WaveletError::Window(local.window));
    }
    let (w, h) = (source.width(), source.height());
    let (ow, oh) = (output_len(w, params.levels), output_len(h, params.levels));
    if (ow as u64) * (oh as u64) > MAX_OUTPUT_CELLS {
        return Err(WaveletError::OutputTooLarge {
            width: ow,
            height: oh,
            limit: MAX_OUTPUT_CELLS,
        });
    }
    Ok((ow, oh))
}

/// Standard deviations of the new coefficients in the lifting domain, per new level (k = 1
/// is the coarsest new level) and band, per source cell (local) or as one value (global).
pub struct SigmaTables {
    pub levels: u32,
    /// `(levels * 3)` tables, index `(k - 1) * 3 + band`; each of length 1 or `w * h`.
    pub tables: Vec<Vec<f32>>,
    pub source_width: usize,
    pub source_height: usize,
}

impl SigmaTables {
    /// The tables for `levels` new levels above a `w x h` source: from the global lines, or
    /// per cell from the local fit (calibrated or as written).
    pub fn build(
        analysis: &Analysis,
        local: Option<&LocalFit>,
        levels: u32,
        w: usize,
        h: usize,
    ) -> Self {
        let mut tables = Vec::with_capacity(levels as usize * 3);
        for k in 1..=levels {
            let depth = 1 - k as i32;
            for band in Band::ALL {
                let norm = band.normalisation(depth);
                let to_sigma = |log2_var: f64| ((log2_var.exp2()).sqrt() / norm) as f32;
                let table = match (local, analysis.fits[band.index()]) {
                    (_, None) => vec![0.0],
                    (Some(fit), _) if !fit.calibrated => (0..w * h)
                        .map(|i| to_sigma(fit.log2_variance(band, i, depth)))
                        .collect(),
                    (Some(fit), Some(line)) => {
                        // Eq. 8 per cell, the level's mean energy calibrated to the line.
                        let log2_var: Vec<f64> = (0..w * h)
                            .map(|i| fit.log2_variance(band, i, depth))
                            .collect();
                        let mean = log2_var.iter().map(|v| v.exp2()).sum::<f64>() / (w * h) as f64;
                        let shift = line.log2_variance(depth) - mean.max(1e-300).log2();
                        log2_var.iter().map(|v| to_sigma(v + shift)).collect()
                    }
                    (None, Some(line)) => vec![to_sigma(line.log2_variance(depth))],
                };
                tables.push(table);
            }
        }
        Self {
            levels,
            tables,
            source_width: w,
            source_height: h,
        }
    }

    /// The standard deviation for new level `k`, `band`, nearest source cell (sx, sy).
    pub fn sigma(&self, k: u32, band: Band, sx: usize, sy: usize) -> f32 {
        let table = &self.tables[(k as usize - 1) * 3 + band.index()];
        if table.len() == 1 {
            table[0]
        } else {
            table[sy * self.source_width + sx]
        }
    }
}

/// Squared synthesis taps normalised to unit energy: across a high-pass axis (offsets -2..2)
/// and across a low-pass axis (offsets -1..1).
const HIGH_ENERGY: [f32; 5] = [1.0 / 46.0, 4.0 / 46.0, 36.0 / 46.0, 4.0 / 46.0, 1.0 / 46.0];
const LOW_ENERGY: [f32; 3] = [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0];

/// Energy weights of a band's synthesis filter along x and along y.
fn energy_taps(band: Band) -> (&'static [f32], &'static [f32]) {
    match band {
        Band::Vertical => (&HIGH_ENERGY, &LOW_ENERGY),
        Band::Horizontal => (&LOW_ENERGY, &HIGH_ENERGY),
        Band::Diagonal => (&HIGH_ENERGY, &HIGH_ENERGY),
    }
}

/// Eq. 9: the factor `sqrt(1 - sum c ||psi||)` for a coefficient at output cell (x, y) whose
/// level has stride `s`, reading the mask resampled to the output grid (clamped at borders).
pub fn mask_factor(
    mask: &[f32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    s: usize,
    band: Band,
) -> f32 {
    let (tx, ty) = energy_taps(band);
    let (rx, ry) = (tx.len() / 2, ty.len() / 2);
    let mut absorbed = 0.0f32;
    for (dy, wy) in ty.iter().enumerate() {
        let yy = (y as isize + (dy as isize - ry as isize) * s as isize).clamp(0, h as isize - 1);
        let row = &mask[yy as usize * w..(yy as usize + 1) * w];
        let mut sum = 0.0f32;
        for (dx, wx) in tx.iter().enumerate() {
            let xx =
                (x as isize + (dx as isize - rx as isize) * s as isize).clamp(0, w as isize - 1);
            sum += wx * row[xx as usize];
        }
        absorbed += wy * sum;
    }
    (1.0 - absorbed).max(0.0).sqrt()
}

/// Everything one row of the coefficient fill reads.
struct FillInputs<'a> {
    source: &'a Heightfield,
    sigma: &'a SigmaTables,
    mask: Option<&'a [f32]>,
    levels: u32,
    key: u32,
    width: usize,
    height: usize,
}

impl FillInputs<'_> {
    /// Writes output row `y`: source samples on the stride-`2^K` vertices, a synthetic
    /// coefficient everywhere else.
    fn fill_row(&self, y: usize, row: &mut [f32]) {
        let k_levels = self.levels;
        let top = 1usize << k_levels;
        let (sw, sh) = (self.source.width(), self.source.height());
        let sy = ((y + top / 2) >> k_levels).min(sh - 1);
        for (x, out) in row.iter_mut().enumerate() {
            let bits = (x | y) | top;
            let t = bits.trailing_zeros();
            if t >= k_levels {
                *out = self.source.data()[(y >> k_levels) * sw + (x >> k_levels)];
                continue;
            }
            let s = 1usize << t;
            let k = k_levels - t;
            let Some(band) = Band::at((x >> t) & 1 == 1, (y >> t) & 1 == 1) else {
                *out = 0.0;
                continue;
            };
            let sx = ((x + top / 2) >> k_levels).min(sw - 1);
            let sigma = self.sigma.sigma(k, band, sx, sy);
            let mut value = sigma * rng::gaussian(self.key, x as u32, y as u32);
            if let Some(mask) = self.mask {
                value *= mask_factor(mask, self.width, self.height, x, y, s, band);
            }
            *out = value;
        }
    }
}

/// Rows filled between two checkpoints (keeps the browser responsive on the web).
const ROWS_PER_SLICE: usize = 256;

/// Analysis of the source and the standard-deviation tables for `params`.
pub fn prepare(
    source: &Heightfield,
    params: &AmplifyParams,
) -> Result<(Analysis, SigmaTables), WaveletError> {
    check(source, params)?;
    let transformed = Transformed::of(source)?;
    let analysis = analysis::analyze_transformed(&transformed, &params.analysis);
    let local = match params.scope {
        Scope::Global => None,
        Scope::Local(local) => Some(analysis::local_fit(&transformed, &analysis, &local)),
    };
    drop(transformed);
    let sigma = SigmaTables::build(
        &analysis,
        local.as_ref(),
        params.levels,
        source.width(),
        source.height(),
    );
    Ok((analysis, sigma))
}

/// Adds `params.levels` synthetic levels of detail to `source` (CPU). Same source, mask and
/// seed give the same bits on every platform and thread count.
pub async fn amplify(
    source: &Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
    ctx: &JobCtx,
) -> Result<Amplified, AmplifyFailure> {
    let (ow, oh) = check(source, params)?;
    ctx.checkpoint(0.0, "analysing the wavelet statistics")
        .await?;
    let mut clock = web_time::Instant::now();
    let mut timings = Timings::default();
    let (analysis, sigma) = prepare(source, params)?;
    timings.analysis = lap(&mut clock);
    ctx.checkpoint(0.15, "drawing detail coefficients").await?;
    let mask_grid = mask.filter(|m| !m.is_clear()).map(|m| m.resampled(ow, oh));
    let inputs = FillInputs {
        source,
        sigma: &sigma,
        mask: mask_grid.as_deref(),
        levels: params.levels,
        key: rng::seed_key(params.seed),
        width: ow,
        height: oh,
    };
    let mut out = vec![0.0f32; ow * oh];
    for (slice, rows) in out.chunks_mut(ROWS_PER_SLICE * ow).enumerate() {
        let first_row = slice * ROWS_PER_SLICE;
        let rows_here = rows.len() / ow;
        let per_band = rows_here.div_ceil(parallel::bands(ow, rows_here)).max(1);
        parallel::for_each_band(rows, per_band * ow, |band, chunk| {
            for (r, row) in chunk.chunks_mut(ow).enumerate() {
                inputs.fill_row(first_row + band * per_band + r, row);
            }
        });
        let done = (first_row + rows_here) as f32 / oh as f32;
        ctx.checkpoint(0.15 + 0.6 * done, "drawing detail coefficients")
            .await?;
    }
    drop(mask_grid);
    timings.fill = lap(&mut clock);
    for t in (0..params.levels).rev() {
        lifting::inverse_level(&mut out, ow, oh, 1 << t);
        ctx.checkpoint(0.95, "inverse wavelet transform").await?;
    }
    timings.inverse = lap(&mut clock);
    let field =
        Heightfield::from_vec(ow, oh, out).map_err(|e| WaveletError::Internal(e.to_string()))?;
    Ok(Amplified {
        field,
        analysis,
        timings,
        gpu: None,
        rms: None,
    })
}

/// Why [`amplify`] stopped.
#[derive(Debug, thiserror::Error)]
pub enum AmplifyFailure {
    #[error(transparent)]
    Wavelet(#[from] WaveletError),
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// How much synthetic detail an amplified terrain carries: the RMS of its difference from the
/// spline-linear (bilinear) interpolation of the source, over the cells a mask leaves free
/// (value below 0.01) and over those it covers fully (value 0.99 and above).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DetailRms {
    pub unmasked: f64,
    /// `None` without a mask or where no cell is fully covered.
    pub masked: Option<f64>,
}

impl DetailRms {
    /// From the sums of squared detail and the cell counts: `[free sum, free cells, covered
    /// sum, covered cells]` (the CPU's rows and the GPU's workgroups both sum these).
    pub fn from_sums([free, free_n, covered, covered_n]: [f64; 4]) -> Self {
        Self {
            unmasked: (free / free_n.max(1.0)).sqrt(),
            masked: (covered_n > 0.0).then(|| (covered / covered_n).sqrt()),
        }
    }
}

/// Measures [`DetailRms`] of `amplified` (made from `source` with `levels` new levels).
/// O(output cells), in row bands on every thread natively; each row's sums are kept and
/// added in row order, so the result does not depend on the number of threads.
pub fn detail_rms(
    source: &Heightfield,
    amplified: &Heightfield,
    levels: u32,
    mask: Option<&Mask>,
) -> DetailRms {
    let (sw, sh) = (source.width(), source.height());
    let f = 1usize << levels;
    let (ow, oh) = (amplified.width(), amplified.height());
    let mask = mask.filter(|m| !m.is_clear());
    let du = 1.0 / (ow.max(2) - 1) as f64;
    let dv = 1.0 / (oh.max(2) - 1) as f64;
    let at = |i: usize, j: usize| f64::from(source.data()[j.min(sh - 1) * sw + i.min(sw - 1)]);
    // Per row: (free sum, free cells, covered sum, covered cells).
    let row_sums = |y: usize| {
        let mut sums = [0.0f64; 4];
        let y0 = (y / f).min(sh.saturating_sub(2));
        let ty = (y as f64 - (y0 * f) as f64) / f as f64;
        for x in 0..ow {
            let x0 = (x / f).min(sw.saturating_sub(2));
            let tx = (x as f64 - (x0 * f) as f64) / f as f64;
            let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
            let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
            let d = f64::from(amplified.data()[y * ow + x]) - (top * (1.0 - ty) + bottom * ty);
            let m = mask.map_or(0.0, |m| m.sample(x as f64 * du, y as f64 * dv));
            if m < 0.01 {
                sums[0] += d * d;
                sums[1] += 1.0;
            } else if m >= 0.99 {
                sums[2] += d * d;
                sums[3] += 1.0;
            }
        }
        sums
    };
    let mut rows = vec![[0.0f64; 4]; oh];
    let band = oh.div_ceil(crate::parallel::bands(ow, oh));
    crate::parallel::for_each_band(&mut rows, band, |k, sums| {
        for (i, s) in sums.iter_mut().enumerate() {
            *s = row_sums(k * band + i);
        }
    });
    DetailRms::from_sums(rows.iter().fold([0.0f64; 4], |mut t, r| {
        t.iter_mut().zip(r).for_each(|(t, r)| *t += r);
        t
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 8 as written gives the new coefficients `sigma^2 = 2^(a - n gamma)` with no
    /// calibration: on the doubling details (gamma 2, ordinate -2 at depth 0) the first new
    /// level's horizontal details have variance 2^-2 and the next 2^-4, in normalised units.
    #[test]
    fn eq_8_as_written_sets_the_new_levels_variances() {
        let t = super::analysis::tests::doubling_details();
        let global = analysis::analyze_transformed(&t, &AnalysisParams::default());
        let local = LocalParams {
            as_written: true,
            ..LocalParams::default()
        };
        let fit = analysis::local_fit(&t, &global, &local);
        let tables = SigmaTables::build(&global, Some(&fit), 2, t.width, t.height);
        let band = Band::Horizontal;
        for (k, log2_var) in [(1u32, -2.0f64), (2, -4.0)] {
            let depth = 1 - k as i32;
            let sigma = f64::from(tables.sigma(k, band, 16, 16)) * band.normalisation(depth);
            assert!(
                (sigma * sigma - log2_var.exp2()).abs() < 1e-5,
                "level {k}: {sigma}"
            );
        }
    }
}
