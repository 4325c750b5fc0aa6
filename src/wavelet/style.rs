//! Style from real terrain: detail synthesised into the **existing** wavelet levels of a
//! terrain where it is smoother than a real DEM's spectrum says land is (seed paper 001's
//! statistics, used across the terrain's own levels rather than only for new finer ones).
//!
//! A style is the slope gamma of seed 001's fit (eq. 7, `log2 Var = -n gamma + a`) per band,
//! measured on a real DEM: how fast the detail variance falls towards finer levels. Real land
//! keeps detail at every scale (gamma about 2.5 to 4.5); a diffused or eroded design often has
//! too little at some scales. For each band the target line starts at the terrain's own
//! variance at an anchor level (the coarsest level with enough coefficients, where the design
//! is reliable) and falls with the style's gamma towards the cell; at each finer level where
//! the terrain's variance is below the line, zero-mean Gaussian coefficients of the missing
//! variance (times `strength`) are added (GSA step 4 with the style's line). The added
//! detail is faded to nothing near the rivers (its synthesis support must not reach them) and
//! under the painted mask (MGR, eq. 9's idea: white keeps the terrain smooth).
//!
//! Gamma is a power-law exponent, the same at every scale for fBm-like terrain, so a style
//! measured on 90 m SRTM cells applies to a map of 20 m cells (an assumption; real DEMs
//! bend their spectrum at a few hundred metres).
//!
//! Cost: one forward and one inverse transform, O(cells).

use super::WaveletError;
use super::analysis::{AnalysisParams, Transformed, analyze_transformed};
use super::lifting::{self, Band, count_at};
use super::mask::Mask;
use super::rng;
use crate::heightfield::Heightfield;

/// The bundled styles: name, the real DEM they were measured on (in `tests/data`, with its
/// provenance), and gamma per band (H, V, D) from `strahler analyze` of that file. A test
/// measures the files again and holds these numbers to them.
pub const STYLES: &[(&str, &str, [f64; 3])] = &[
    (
        "mountains",
        "srtm_n44e005_384.tif: SRTM3, Baronnies and the Mont Ventoux's north face",
        [3.982, 3.881, 4.461],
    ),
    (
        "lowland",
        "olinda.tif: coastal lowland near Olinda, Brazil (R stars package)",
        [2.927, 2.585, 3.595],
    ),
    (
        "volcanic",
        "volcano_maungawhau.tif: the Maungawhau volcano, Auckland (R's volcano data set)",
        [4.862, 4.538, 4.293],
    ),
];

/// The gamma of a bundled style by name.
pub fn bundled(name: &str) -> Option<[f64; 3]> {
    STYLES.iter().find(|s| s.0 == name).map(|s| s.2)
}

/// A style measured on any DEM (e.g. the one uploaded in the app): its fitted gamma per
/// band. Errors on voids or a DEM too small for two fitted levels.
pub fn measure(dem: &Heightfield) -> Result<[f64; 3], WaveletError> {
    let no_style = |reason| WaveletError::NoStyle {
        width: dem.width(),
        height: dem.height(),
        reason,
    };
    if dem.finite_range().is_some_and(|(lo, hi)| lo == hi) {
        return Err(no_style(
            "every height is the same; a style is measured on slopes",
        ));
    }
    let analysis = analyze_transformed(&Transformed::of(dem)?, &AnalysisParams::default());
    let mut gamma = [0.0; 3];
    for band in Band::ALL {
        gamma[band.index()] = analysis.fits[band.index()]
            .map(|f| f.gamma)
            .ok_or(no_style(
                "a style needs detail on two levels with at least 16 coefficients in each band \
             (a DEM of at least 16 x 16 cells with relief)",
            ))?;
    }
    Ok(gamma)
}

/// Where the added detail must fade out: each cell's distance in cells to the nearest river
/// (or any cell to keep as it is), the banks kept smooth beside it, and the painted mask.
pub struct Keep<'a> {
    pub distance: &'a [f32],
    pub banks: u32,
    pub mask: Option<&'a Mask>,
}

/// What [`apply`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StyleStats {
    /// The anchor depth (levels above the cell) and the levels that received detail.
    pub anchor_depth: u32,
    pub levels_touched: u32,
    /// RMS of the added heights over the map, metres.
    pub added_rms: f64,
}

/// `field` with the style's missing detail added (see the module). Deterministic for a seed.
pub fn apply(
    field: &Heightfield,
    gamma: [f64; 3],
    strength: f64,
    keep: &Keep<'_>,
    seed: u64,
) -> Result<(Heightfield, StyleStats), WaveletError> {
    let (w, h) = (field.width(), field.height());
    let t = Transformed::of(field)?;
    let analysis = analyze_transformed(&t, &AnalysisParams::default());
    // The anchor: the coarsest level with at least 64 coefficients in every band.
    let anchor = analysis
        .levels
        .iter()
        .filter(|l| l.counts.iter().all(|&c| c >= 64))
        .map(|l| l.depth)
        .max()
        .ok_or(WaveletError::NoStyle {
            width: w,
            height: h,
            reason: "adding a style needs a level with at least 64 coefficients in each band \
                     (a terrain of at least 16 x 16 cells)",
        })?;
    let mut data = t.data;
    let mut stats = StyleStats {
        anchor_depth: anchor,
        ..Default::default()
    };
    let key = rng::seed_key(seed);
    for depth in 1..anchor {
        let s = 1usize << (depth - 1);
        let level = &analysis.levels[depth as usize - 1];
        let base = &analysis.levels[anchor as usize - 1];
        let mut touched = false;
        for band in Band::ALL {
            let b = band.index();
            let target = base.variances[b] * 2f64.powf(-gamma[b] * f64::from(anchor - depth));
            let missing = (target - level.variances[b]) * strength;
            if missing.is_nan() || missing <= 0.0 {
                continue;
            }
            touched = true;
            // Back to this implementation's unnormalised coefficients.
            let sigma = (missing.sqrt() / band.normalisation(depth as i32)) as f32;
            let level_key = rng::pcg(key ^ (depth * 4 + b as u32));
            let (px, py) = band.parities();
            let (nx, ny) = (count_at(w, s), count_at(h, s));
            for j in (py..ny).step_by(2) {
                for i in (px..nx).step_by(2) {
                    let (x, y) = (i * s, j * s);
                    let fade = keep_factor(keep, x, y, w, h, s);
                    if fade > 0.0 {
                        data[y * w + x] +=
                            fade * sigma * rng::gaussian(level_key, x as u32, y as u32);
                    }
                }
            }
        }
        stats.levels_touched += u32::from(touched);
    }
    lifting::inverse(&mut data, w, h, t.levels);
    let sum: f64 = data
        .iter()
        .zip(field.data())
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum();
    stats.added_rms = (sum / (w * h).max(1) as f64).sqrt();
    let styled =
        Heightfield::from_vec(w, h, data).map_err(|e| WaveletError::Internal(e.to_string()))?;
    Ok((styled, stats))
}

/// How much of a coefficient at (x, y) of stride `s` to add: none where its synthesis support
/// (2 s cells each way at its own level, about 3 s once the finer levels interpolate it)
/// reaches a kept cell or its banks, all of it one more stride
/// away; times one minus the painted mask there.
fn keep_factor(keep: &Keep<'_>, x: usize, y: usize, w: usize, h: usize, s: usize) -> f32 {
    let d = keep
        .distance
        .get(y * w + x)
        .copied()
        .unwrap_or(f32::INFINITY);
    let reach = (keep.banks as usize + 3 * s) as f32;
    let fade = ((d - reach) / s as f32).clamp(0.0, 1.0);
    let painted = keep.mask.map_or(0.0, |m| {
        m.sample(
            x as f64 / (w.max(2) - 1) as f64,
            y as f64 / (h.max(2) - 1) as f64,
        )
    });
    fade * (1.0 - painted.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled numbers are what the analysis measures on the files they name.
    #[test]
    fn bundled_styles_are_measured_on_their_real_dems() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
        for (name, source, gamma) in STYLES {
            let file = source.split(':').next().unwrap();
            let bytes = std::fs::read(format!("{dir}{file}")).unwrap();
            let dem = crate::dem::geotiff::read(&bytes, Default::default()).unwrap();
            let measured = measure(&dem.field).unwrap();
            for b in 0..3 {
                assert!(
                    (measured[b] - gamma[b]).abs() < 1e-3,
                    "{name}: band {b}: {} vs {}",
                    measured[b],
                    gamma[b]
                );
            }
        }
    }

    /// A smooth surface gets detail at the finer levels, following the style's line, and
    /// none near the kept cells.
    #[test]
    fn detail_goes_where_the_terrain_is_smoother_than_the_style_and_not_near_rivers() {
        let n = 129;
        let data: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
                300.0 * (x * 3.0).sin() * (y * 2.0).cos()
            })
            .collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        // A "river" down column 20: distances by column.
        let distance: Vec<f32> = (0..n * n).map(|i| (i % n).abs_diff(20) as f32).collect();
        let keep = Keep {
            distance: &distance,
            banks: 1,
            mask: None,
        };
        let (styled, stats) = apply(&field, [3.0; 3], 1.0, &keep, 7).unwrap();
        assert!(
            stats.levels_touched >= 2 && stats.added_rms > 0.1,
            "{stats:?}"
        );
        // The river column and its bank on each side are untouched (up to the transform's
        // rounding).
        for y in 0..n {
            for x in 19..=21 {
                let (a, b) = (styled.data()[y * n + x], field.data()[y * n + x]);
                assert!((a - b).abs() < 1e-2, "({x}, {y}): {a} vs {b}");
            }
        }
        // Far from it the fine levels now follow the style: the finest level's variance is
        // within a factor 2 of the line's.
        let after = crate::wavelet::analyze(&styled, &AnalysisParams::default()).unwrap();
        let before = crate::wavelet::analyze(&field, &AnalysisParams::default()).unwrap();
        let fine = |a: &crate::wavelet::Analysis| a.levels[0].variances[0];
        assert!(fine(&after) > 10.0 * fine(&before));
        // Another seed, other detail.
        let (other, _) = apply(&field, [3.0; 3], 1.0, &keep, 8).unwrap();
        assert_ne!(other, styled);
    }
}
