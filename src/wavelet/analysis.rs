//! Wavelet statistics of a terrain (seed paper 001, Secs. 2.2, 3.2 and 3.3).
//!
//! - Global scope (GSA): per level and band the variance of the detail coefficients (eq. 6),
//!   taken as zero-mean (the mean square), then the line `log2 Var = -n gamma + a` (eq. 7)
//!   over the levels with at least [`AnalysisParams::min_coefficients`] coefficients (the paper
//!   starts at 16). `n` counts levels from the coarsest analysed one; for fBm of Hurst
//!   exponent H the slope is `gamma = 2H + 2` with the L2-normalised filter bank used here.
//! - Local scope (LSA): the same fit per location from a window of `W x W` coefficients of
//!   each of the finest levels (the same count at every level), giving `gamma^t(r)` and
//!   `a^t(r)` for eq. 8. Window sums come from summed-area tables, so the cost is
//!   O(levels x cells) whatever the window size.
//!
//! Variances are stored for the L2-normalised bank ([`Band::normalisation`]); the lifting code
//! works unnormalised and converts.

use super::WaveletError;
use super::lifting::{self, Band, band_count, for_each_coefficient};
use crate::heightfield::Heightfield;

/// Parameters of the global analysis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalysisParams {
    /// Levels whose band has fewer coefficients are shown but not fitted (paper: 16).
    pub min_coefficients: usize,
}

impl Default for AnalysisParams {
    fn default() -> Self {
        Self {
            min_coefficients: 16,
        }
    }
}

/// Statistics of one decomposition level.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelStats {
    /// 1 = the finest detail of the analysed grid, growing towards coarse levels.
    pub depth: u32,
    /// The paper's level index `n`: 0 = the coarsest analysed level.
    pub level: u32,
    /// Coefficients per band (H, V, D).
    pub counts: [usize; 3],
    /// Mean square of the normalised coefficients per band (eq. 6).
    pub variances: [f64; 3],
    /// Whether each band's variance entered the line fit.
    pub fitted: [bool; 3],
}

/// The fitted line of eq. 7 for one band, expressed by depth: `log2 Var(depth) = intercept +
/// gamma * depth` (depth 0 is the first level finer than the analysed grid).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFit {
    /// Decay of log2 variance per level towards finer levels (the paper's gamma).
    pub gamma: f64,
    /// log2 variance extrapolated to depth 0.
    pub intercept: f64,
    /// Root-mean-square residual of the fit in log2 units.
    pub residual: f64,
    /// How many levels entered the fit.
    pub levels_used: usize,
}

impl LineFit {
    /// log2 of the normalised variance at `depth` (negative depths are finer still).
    pub fn log2_variance(&self, depth: i32) -> f64 {
        self.intercept + self.gamma * f64::from(depth)
    }

    /// The paper's ordinate `a` of eq. 7 for a pyramid of `levels` levels (n = levels - depth).
    pub fn paper_a(&self, levels: u32) -> f64 {
        self.intercept + self.gamma * f64::from(levels)
    }
}

/// Global statistics of a terrain: the table `strahler analyze` prints.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    pub width: usize,
    pub height: usize,
    /// Finest first.
    pub levels: Vec<LevelStats>,
    /// Per band (H, V, D); `None` where fewer than two levels had non-zero variance and
    /// enough coefficients (a flat or tiny terrain).
    pub fits: [Option<LineFit>; 3],
}

impl Analysis {
    /// The realism report's spectral slope: the mean of the bands' fitted gammas ("bands
    /// pooled"); `None` without any fit.
    pub fn pooled_gamma(&self) -> Option<f64> {
        let gammas: Vec<f64> = self.fits.iter().flatten().map(|f| f.gamma).collect();
        (!gammas.is_empty()).then(|| gammas.iter().sum::<f64>() / gammas.len() as f64)
    }
}

/// The forward transform of a terrain kept for the local analysis.
pub struct Transformed {
    pub width: usize,
    pub height: usize,
    pub levels: u32,
    pub data: Vec<f32>,
}

impl Transformed {
    /// Forward transform of `field` over every level it allows. NaN cells are refused: fill
    /// the voids first.
    pub fn of(field: &Heightfield) -> Result<Self, WaveletError> {
        let levels = analysable_levels(field)?;
        let (width, height) = (field.width(), field.height());
        let mut data = field.data().to_vec();
        lifting::forward(&mut data, width, height, levels);
        Ok(Self {
            width,
            height,
            levels,
            data,
        })
    }
}

/// How many levels the analysis of `field` runs over (every level its size allows). NaN cells
/// are refused (fill the voids first), and so are grids too small for two levels.
pub fn analysable_levels(field: &Heightfield) -> Result<u32, WaveletError> {
    let voids = field.data().iter().filter(|v| !v.is_finite()).count();
    if voids > 0 {
        return Err(WaveletError::NoData { cells: voids });
    }
    let (width, height) = (field.width(), field.height());
    let levels = lifting::max_levels(width, height);
    if levels < 2 {
        return Err(WaveletError::TooSmall { width, height });
    }
    Ok(levels)
}

/// Least-squares line through `(x, y)` points: (slope, intercept, rms residual).
fn fit_line(points: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx == 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let rss: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    Some((slope, intercept, (rss / n).sqrt()))
}

/// Global scope analysis (GSA steps 1-2) of an already transformed terrain.
pub fn analyze_transformed(t: &Transformed, params: &AnalysisParams) -> Analysis {
    let energies: Vec<[f64; 3]> = (1..=t.levels)
        .map(|depth| {
            let s = 1usize << (depth - 1);
            Band::ALL.map(|band| {
                let norm = band.normalisation(depth as i32);
                let mut sum = 0.0f64;
                for_each_coefficient(&t.data, t.width, t.height, s, band, |_, _, v| {
                    sum += (f64::from(v) * norm).powi(2);
                });
                sum
            })
        })
        .collect();
    Analysis::from_energies(t.width, t.height, &energies, params)
}

impl Analysis {
    /// GSA steps 1-2 from each level's energy: `energies[depth - 1][band]` is the sum of the
    /// squared normalised coefficients of `band` at `depth` (finest first). Eq. 6 divides
    /// it by the band's count, eq. 7 fits the line.
    pub fn from_energies(
        width: usize,
        height: usize,
        energies: &[[f64; 3]],
        params: &AnalysisParams,
    ) -> Analysis {
        let depths = energies.len() as u32;
        let mut levels = Vec::with_capacity(energies.len());
        for (depth, sums) in (1..=depths).zip(energies) {
            let s = 1usize << (depth - 1);
            let mut counts = [0; 3];
            let mut variances = [0.0; 3];
            for band in Band::ALL {
                let count = band_count(width, height, s, band);
                counts[band.index()] = count;
                variances[band.index()] = if count > 0 {
                    sums[band.index()] / count as f64
                } else {
                    0.0
                };
            }
            levels.push(LevelStats {
                depth,
                level: depths - depth,
                counts,
                variances,
                fitted: [false; 3],
            });
        }
        let mut fits = [None; 3];
        for band in Band::ALL {
            let b = band.index();
            let mut points = Vec::new();
            for stats in &mut levels {
                if stats.counts[b] >= params.min_coefficients && stats.variances[b] > 0.0 {
                    stats.fitted[b] = true;
                    points.push((f64::from(stats.depth), stats.variances[b].log2()));
                }
            }
            fits[b] = fit_line(&points).map(|(gamma, intercept, residual)| LineFit {
                gamma,
                intercept,
                residual,
                levels_used: points.len(),
            });
        }
        Analysis {
            width,
            height,
            levels,
            fits,
        }
    }
}

/// Global scope analysis of a terrain.
pub fn analyze(field: &Heightfield, params: &AnalysisParams) -> Result<Analysis, WaveletError> {
    Ok(analyze_transformed(&Transformed::of(field)?, params))
}

/// Parameters of the local (LSA) estimation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalParams {
    /// Window side in coefficients (odd; 3 is the paper's choice).
    pub window: usize,
    /// How many of the finest levels enter each local fit (at least 2).
    pub levels: u32,
    /// Eq. 8 exactly as written: each location's raw fit of eq. 7 gives its coefficients'
    /// variance, with no bias correction, no shrinkage towards the global slope and no
    /// calibration of the levels' energy (see [`local_fit`]). Off: the calibrated scope.
    pub as_written: bool,
}

impl Default for LocalParams {
    fn default() -> Self {
        Self {
            window: 3,
            levels: 3,
            as_written: false,
        }
    }
}

/// Largest local slope kept; noisy windows can give absurd extrapolations otherwise.
pub const MAX_LOCAL_GAMMA: f64 = 8.0;

/// Per-location fits of eq. 7 (LSA), at the analysed grid's resolution, per band.
pub struct LocalFit {
    pub width: usize,
    pub height: usize,
    /// gamma^t(r) per band, row-major.
    pub gamma: [Vec<f32>; 3],
    /// log2 variance at depth 0 per band (eq. 8's `a^t(r)` shifted to depth 0).
    pub intercept: [Vec<f32>; 3],
    /// Whether the synthesis calibrates each level's mean energy to the global line (the
    /// calibrated scope) or takes eq. 8's variances as they are ([`LocalParams::as_written`]).
    pub calibrated: bool,
}

impl LocalFit {
    /// log2 normalised variance of `band` at `depth` for cell `i`.
    pub fn log2_variance(&self, band: Band, i: usize, depth: i32) -> f64 {
        let b = band.index();
        f64::from(self.intercept[b][i]) + f64::from(self.gamma[b][i]) * f64::from(depth)
    }
}

/// A summed-area table of one band's squared normalised coefficients at one level.
struct WindowSums {
    nx: usize,
    ny: usize,
    table: Vec<f64>,
}

impl WindowSums {
    fn new(t: &Transformed, depth: u32, band: Band) -> Self {
        let s = 1usize << (depth - 1);
        let (px, py) = band.parities();
        let half = |len: usize, p: usize| {
            let n = lifting::count_at(len, s);
            if p == 0 { n.div_ceil(2) } else { n / 2 }
        };
        let (nx, ny) = (half(t.width, px), half(t.height, py));
        let norm = band.normalisation(depth as i32);
        let mut table = vec![0.0f64; (nx + 1) * (ny + 1)];
        let stride = nx + 1;
        for_each_coefficient(&t.data, t.width, t.height, s, band, |i, j, v| {
            let (ci, cj) = (i / 2, j / 2);
            table[(cj + 1) * stride + ci + 1] = (f64::from(v) * norm).powi(2);
        });
        for j in 1..=ny {
            for i in 1..=nx {
                let k = j * stride + i;
                table[k] += table[k - 1] + table[k - stride] - table[k - stride - 1];
            }
        }
        Self { nx, ny, table }
    }

    /// `log2(max(mean_around(i, j), floor)) + bias` for every coefficient (i, j) of the
    /// level, row-major (`nx` per row): what each cell's fit reads, computed once per
    /// coefficient rather than once per cell (a level of stride `s` has a `4 s^2`-th as many
    /// coefficients as the grid has cells). O(coefficients).
    fn log_means(&self, window: usize, floor: f64, bias: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.nx * self.ny);
        for j in 0..self.ny {
            for i in 0..self.nx {
                out.push(self.mean_around(i, j, window).max(floor).log2() + bias);
            }
        }
        out
    }

    /// Mean over a `window`-wide square around coefficient (i, j), shifted inside the grid so
    /// that it always holds the same number of coefficients where the grid allows.
    fn mean_around(&self, i: usize, j: usize, window: usize) -> f64 {
        let span = |c: usize, n: usize| {
            let w = window.min(n);
            let lo = c.saturating_sub(window / 2).min(n - w);
            (lo, lo + w)
        };
        let (x0, x1) = span(i.min(self.nx - 1), self.nx);
        let (y0, y1) = span(j.min(self.ny - 1), self.ny);
        let stride = self.nx + 1;
        let sum = self.table[y1 * stride + x1]
            - self.table[y0 * stride + x1]
            - self.table[y1 * stride + x0]
            + self.table[y0 * stride + x0];
        sum / ((x1 - x0) * (y1 - y0)) as f64
    }
}

/// The band coefficient index nearest to grid cell `x` at stride `s` with parity `p`: band
/// samples sit at `(2i + p) s`.
fn nearest_coefficient(x: usize, s: usize, p: usize) -> usize {
    let pos = x as f64 / s as f64 - p as f64;
    (pos / 2.0).round().max(0.0) as usize
}

/// For each of `len` grid cells along an axis, the nearest of the `n` coefficients at stride
/// `s` and parity `p` (clamped to the last, as [`WindowSums::mean_around`] clamps).
fn nearest(len: usize, s: usize, p: usize, n: usize) -> Vec<usize> {
    (0..len)
        .map(|x| nearest_coefficient(x, s, p).min(n - 1))
        .collect()
}

/// Local scope estimation (LSA, Sec. 3.3.1): for every cell of the analysed grid and every
/// band, the fit of eq. 7 to the windowed variances of the `params.levels` finest levels.
///
/// A window of a few coefficients gives a noisy log-variance, and eq. 8 extrapolates it:
/// - the log of a mean of `N` squared Gaussian coefficients is low by about `1 / (N ln 2)`
///   (delta method); it is added back;
/// - the local slopes are shrunk towards the global one by the share of their spread across
///   the map that is not estimation noise (empirical Bayes, with the noise of a slope fitted
///   to logs of `N`-sample means: `2 / (N ln^2 2) / Sxx`).
///
/// The synthesis then calibrates each level's mean energy to the global line
/// ([`super::synthesis::SigmaTables`]), so the local fit decides where the detail goes and
/// the global statistics how much there is in all.
///
/// Windows with zero energy are floored at a millionth of the level's global variance, so
/// flat areas extrapolate to (almost) no detail rather than to NaN.
///
/// With [`LocalParams::as_written`] the fit is the paper's alone (Sec. 3.3.1-3.3.3): the
/// least-squares line of eq. 7 through the windows' log-variances, `gamma^t(r)` its slope
/// and `a^t(r)` its ordinate, unclamped, and eq. 8's `2^(a - n gamma)` is the new
/// coefficients' variance as it stands (only the zero-energy floor remains, since a log of 0
/// has no line).
pub fn local_fit(t: &Transformed, global: &Analysis, params: &LocalParams) -> LocalFit {
    let design = LocalDesign::new(t.levels, params);
    let (w, h) = (t.width, t.height);
    let mut gamma: [Vec<f32>; 3] = Default::default();
    let mut intercept: [Vec<f32>; 3] = Default::default();
    for band in Band::ALL {
        let b = band.index();
        let (px, py) = band.parities();
        // Per level: the windows' log-variances per coefficient, and the coefficient
        // nearest to each column and row of the grid.
        let mut log_means = Vec::new();
        let mut columns = Vec::new();
        let mut rows = Vec::new();
        for d in 1..=design.levels {
            let sums = WindowSums::new(t, d, band);
            let floor = LocalDesign::floor(global, d, b);
            log_means.push((
                sums.nx,
                sums.log_means(design.window, floor, design.log_bias),
            ));
            let s = 1usize << (d - 1);
            columns.push(nearest(w, s, px, sums.nx));
            rows.push(nearest(h, s, py, sums.ny));
        }
        // Pass 1: raw local slopes and mean logs, and the spread statistics.
        let mut raw_slope = vec![0.0f64; w * h];
        let mut mean_logs = vec![0.0f64; w * h];
        let mut logs = vec![0.0f64; design.levels as usize];
        let (mut slope_sum, mut slope_sq) = (0.0f64, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                for (k, (nx, level)) in log_means.iter().enumerate() {
                    logs[k] = level[rows[k][y] * nx + columns[k][x]];
                }
                let mean_log = logs.iter().sum::<f64>() / logs.len() as f64;
                let sxy: f64 = (1..=design.levels)
                    .zip(&logs)
                    .map(|(d, l)| (f64::from(d) - design.mean_depth) * (l - mean_log))
                    .sum();
                let slope = sxy / design.sxx;
                raw_slope[y * w + x] = slope;
                mean_logs[y * w + x] = mean_log;
                slope_sum += slope;
                slope_sq += slope * slope;
            }
        }
        let (centre, keep) = design.shrinkage(global, b, slope_sum, slope_sq, (w * h) as f64);
        let mut g = vec![0.0f32; w * h];
        let mut a = vec![0.0f32; w * h];
        for i in 0..w * h {
            let slope = design.shrunk(raw_slope[i], centre, keep);
            g[i] = slope as f32;
            a[i] = (mean_logs[i] - slope * design.mean_depth) as f32;
        }
        gamma[b] = g;
        intercept[b] = a;
    }
    LocalFit {
        width: w,
        height: h,
        gamma,
        intercept,
        calibrated: !params.as_written,
    }
}

/// What every location's fit of eq. 7 shares (LSA), on the CPU ([`local_fit`]) and on the
/// GPU: the analysed depths and the corrections for a window of `window^2` coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalDesign {
    /// The fits run through depths `1..=levels`.
    pub levels: u32,
    /// Window side in coefficients.
    pub window: usize,
    pub mean_depth: f64,
    /// Sum of the squared deviations of the depths from their mean.
    pub sxx: f64,
    /// Added to each window's log2 mean square (the delta-method bias; 0 as written).
    pub log_bias: f64,
    /// Variance of a fitted slope that is estimation noise alone.
    pub slope_noise: f64,
    pub as_written: bool,
}

impl LocalDesign {
    /// The design for a transform of `analysable` levels.
    pub fn new(analysable: u32, params: &LocalParams) -> Self {
        let levels = params.levels.clamp(2, analysable);
        let window = params.window.max(1);
        let depths: Vec<f64> = (1..=levels).map(f64::from).collect();
        let mean_depth = depths.iter().sum::<f64>() / depths.len() as f64;
        let sxx: f64 = depths.iter().map(|d| (d - mean_depth).powi(2)).sum();
        let n_window = (window * window) as f64;
        let log_bias = if params.as_written {
            0.0
        } else {
            1.0 / (n_window * std::f64::consts::LN_2)
        };
        let analytic_log_var = 2.0 / n_window / std::f64::consts::LN_2.powi(2);
        Self {
            levels,
            window,
            mean_depth,
            sxx,
            log_bias,
            slope_noise: analytic_log_var / sxx,
            as_written: params.as_written,
        }
    }

    /// The least mean square a window of `band` at `depth` is given: a millionth of the
    /// level's global variance, so flat areas extrapolate to (almost) no detail, not NaN.
    pub fn floor(global: &Analysis, depth: u32, band: usize) -> f64 {
        (global.levels[depth as usize - 1].variances[band] * 1e-6).max(1e-30)
    }

    /// The centre and the kept share of the shrinkage of one band's slopes, from their sum
    /// and sum of squares over `cells` locations (see [`local_fit`]).
    pub fn shrinkage(
        &self,
        global: &Analysis,
        band: usize,
        slope_sum: f64,
        slope_sq: f64,
        cells: f64,
    ) -> (f64, f64) {
        let centre = global.fits[band].map_or(slope_sum / cells, |f| f.gamma);
        let spread = (slope_sq / cells - (slope_sum / cells).powi(2)).max(0.0);
        let keep = if spread > 0.0 {
            ((spread - self.slope_noise) / spread).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (centre, keep)
    }

    /// A location's slope after the shrinkage (as written: the raw slope).
    pub fn shrunk(&self, raw: f64, centre: f64, keep: f64) -> f64 {
        if self.as_written {
            raw
        } else {
            (centre + keep * (raw - centre)).clamp(0.0, MAX_LOCAL_GAMMA)
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_an_exact_line() {
        let points: Vec<(f64, f64)> = (1..6).map(|d| (d as f64, 3.0 * d as f64 - 7.0)).collect();
        let (slope, intercept, residual) = fit_line(&points).unwrap();
        assert!((slope - 3.0).abs() < 1e-12 && (intercept + 7.0).abs() < 1e-12);
        assert!(residual < 1e-12);
    }

    #[test]
    fn nan_cells_are_refused_with_their_count() {
        let mut field = Heightfield::filled(9, 9, 1.0).unwrap();
        field.data_mut()[4] = f32::NAN;
        assert!(matches!(
            analyze(&field, &AnalysisParams::default()),
            Err(WaveletError::NoData { cells: 1 })
        ));
    }

    #[test]
    fn flat_terrain_has_no_fit() {
        let field = Heightfield::filled(65, 65, 120.0).unwrap();
        let analysis = analyze(&field, &AnalysisParams::default()).unwrap();
        assert!(analysis.fits.iter().all(Option::is_none));
    }

    /// A transformed 33 x 33 grid whose horizontal-band details have normalised value 1, 2
    /// and 4 at depths 1, 2 and 3 (every other coefficient 0).
    pub(crate) fn doubling_details() -> Transformed {
        let (w, h) = (33, 33);
        let mut data = vec![0.0f32; w * h];
        let band = Band::Horizontal;
        let (px, py) = band.parities();
        for depth in 1..=3u32 {
            let s = 1usize << (depth - 1);
            let value = (1u32 << (depth - 1)) as f64 / band.normalisation(depth as i32);
            let (nx, ny) = (lifting::count_at(w, s), lifting::count_at(h, s));
            for j in (py..ny).step_by(2) {
                for i in (px..nx).step_by(2) {
                    data[j * s * w + i * s] = value as f32;
                }
            }
        }
        Transformed {
            width: w,
            height: h,
            levels: 5,
            data,
        }
    }

    /// Eq. 8 as written against a hand computation: the windows' mean squared normalised
    /// details are 1, 4 and 16 at depths 1, 2, 3, so log2 Var = 0, 2, 4: the line of eq. 7 has
    /// slope gamma = 2 and, at depth 0, ordinate 0 - 2 = -2 at every location. The calibrated
    /// scope adds the log bias of a 9-sample mean (1 / (9 ln 2)) to the ordinate instead.
    #[test]
    fn local_fit_as_written_is_the_papers_line_through_the_window_variances() {
        let t = doubling_details();
        let global = analyze_transformed(&t, &AnalysisParams::default());
        let params = LocalParams {
            window: 3,
            levels: 3,
            as_written: true,
        };
        let fit = local_fit(&t, &global, &params);
        let b = Band::Horizontal.index();
        assert!(!fit.calibrated);
        for i in [0, 16 * 33 + 16, 33 * 33 - 1] {
            assert!((fit.gamma[b][i] - 2.0).abs() < 1e-5, "{}", fit.gamma[b][i]);
            assert!(
                (fit.intercept[b][i] + 2.0).abs() < 1e-5,
                "{}",
                fit.intercept[b][i]
            );
            // Eq. 8 at the first new level (depth 0) and the next (depth -1).
            assert!((fit.log2_variance(Band::Horizontal, i, 0) + 2.0).abs() < 1e-5);
            assert!((fit.log2_variance(Band::Horizontal, i, -1) + 4.0).abs() < 1e-5);
        }
        let calibrated = local_fit(
            &t,
            &global,
            &LocalParams {
                as_written: false,
                ..params
            },
        );
        let centre = 16 * 33 + 16;
        let bias = 1.0 / (9.0 * std::f64::consts::LN_2);
        assert!(calibrated.calibrated);
        assert!(
            (f64::from(calibrated.intercept[b][centre]) - (-2.0 + bias)).abs() < 1e-4,
            "{}",
            calibrated.intercept[b][centre]
        );
    }
}
