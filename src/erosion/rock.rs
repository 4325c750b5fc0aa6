//! Rock hardness: the erodibility `K` of the stream-power law varying in space, patches of
//! harder and softer rock, so that valleys are not all cut at one spacing.
//!
//! Where rock is uniform, stream power against hillslope creep sets one valley spacing
//! everywhere (Perron, Kirchner and Dietrich 2009, "Formation of evenly spaced ridges and
//! valleys", Nature 460): the eroded terrain's wavelet log-variance then stands out at that
//! one level. Real ranges cut rocks of different strength; weak rock is dissected finely and
//! lowered, hard rock stands in broader, higher massifs (Moglen and Bras 1995, "The effect of
//! spatial heterogeneities on geomorphic expression in a model of basin evolution", Water
//! Resources Research 31(10), who vary `K` in space the same way). The field here is `K`
//! times `contrast^v`, `v` the seeded fBm of [`crate::noise`] at the scale of `patch_m`
//! metres clamped to `[-1/2, 1/2]`: the hardest rock erodes `contrast` times slower than the
//! softest. Positions are in metres, so the same scene has the same rock at any resolution
//! and on the coarse grid of a large map.

use crate::noise::{FbmGrid, Perlin};

/// fBm octaves of the hardness field.
const OCTAVES: u32 = 4;
/// Amplitude ratio between octaves.
const ROUGHNESS: f64 = 0.5;

/// The erodibility factor of each cell of an `n` x `n` map of `cell_m` cells (row-major), or
/// none (empty: uniform rock) where `contrast` is 1. O(cells x octaves).
pub fn erodibility_factors(
    n: usize,
    cell_m: f64,
    contrast: f64,
    patch_m: f64,
    seed: u64,
) -> Vec<f32> {
    if contrast == 1.0 || n == 0 {
        return Vec::new();
    }
    let mut out = vec![0.0; n * n];
    Rock::new(n, cell_m, contrast, patch_m, seed).rows(0, &mut out);
    out
}

/// The hardness field of one map, to be sampled row by row ([`Rock::rows`]).
pub struct Rock {
    perlin: Perlin,
    n: usize,
    /// fBm cycles across the map.
    cycles: f64,
    ln_contrast: f64,
}

impl Rock {
    pub fn new(n: usize, cell_m: f64, contrast: f64, patch_m: f64, seed: u64) -> Self {
        Self {
            perlin: Perlin::new(crate::terrain::stage_seed(seed, "rock")),
            n,
            cycles: n as f64 * cell_m / patch_m,
            ln_contrast: contrast.ln(),
        }
    }

    /// Fills `out` (whole rows) with the factors of the rows from `first_row` on. The same
    /// values however the rows are split. O(cells of the rows x octaves + n x octaves).
    pub fn rows(&self, first_row: usize, out: &mut [f32]) {
        self.window([0, first_row], self.n, out);
    }

    /// Fills `out` (rows of `width` cells) with the factors of the window of the map whose
    /// first cell is (`x0`, `y0`): the same values as [`rows`](Self::rows) there (a world's
    /// tile sampling the rock of the whole world, `crate::world::refine`). The window must
    /// lie inside the map. O(cells of the window x octaves + n x octaves).
    pub fn window(&self, [x0, y0]: [usize; 2], width: usize, out: &mut [f32]) {
        let n = self.n.max(1);
        let fbm = FbmGrid::new(&self.perlin, n, self.cycles, OCTAVES, ROUGHNESS);
        for (k, v) in out.iter_mut().enumerate() {
            let (x, y) = (x0 + k % width.max(1), y0 + k / width.max(1));
            *v = (self.ln_contrast * fbm.at(x, y).clamp(-0.5, 0.5)).exp() as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factors span the contrast (softest over hardest), average about 1, vary at the
    /// patch scale, and are the same rock at two resolutions of one map.
    #[test]
    fn patches_span_the_contrast_at_their_scale() {
        assert!(erodibility_factors(64, 100.0, 1.0, 1000.0, 1).is_empty());
        let k = erodibility_factors(256, 40.0, 4.0, 1500.0, 7);
        let (lo, hi) = k
            .iter()
            .fold((f32::MAX, 0.0f32), |(l, h), v| (l.min(*v), h.max(*v)));
        assert!(lo >= 0.5 - 1e-6 && hi <= 2.0 + 1e-6, "{lo} {hi}");
        assert!(hi / lo > 3.0, "the field reaches both ends: {lo} {hi}");
        let mean_log = k.iter().map(|v| f64::from(*v).ln()).sum::<f64>() / k.len() as f64;
        assert!(mean_log.abs() < 0.3, "{mean_log}");
        // Neighbours a cell apart are alike; cells a patch apart are not.
        let step = |d: usize| {
            (0..256 * 200)
                .map(|i| f64::from((k[i] / k[i + d]).ln()).abs())
                .sum::<f64>()
                / (256.0 * 200.0)
        };
        assert!(
            step(1) * 5.0 < step(256 * 38),
            "{} {}",
            step(1),
            step(256 * 38)
        );
        // The same map at half the resolution samples the same rock.
        let coarse = erodibility_factors(128, 80.0, 4.0, 1500.0, 7);
        let (mut diff, mut count) = (0.0, 0);
        for y in 0..128 {
            for x in 0..128 {
                diff += f64::from((coarse[y * 128 + x] / k[2 * y * 256 + 2 * x]).ln()).abs();
                count += 1;
            }
        }
        assert!(
            diff / f64::from(count) < 0.05,
            "{}",
            diff / f64::from(count)
        );
    }
}
