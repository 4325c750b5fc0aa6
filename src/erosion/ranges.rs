//! Ranges and basins: the rock uplift rate varying over tens of kilometres, so a map holds
//! high massifs and low basins, not one relief everywhere.
//!
//! Rock uplift is not uniform across a mountain belt: it varies over tens of kilometres with
//! the faults and folds beneath, and the steady-state relief follows it, the channels
//! steeper where the rock rises faster (Whipple and Tucker 1999, "Dynamics of the
//! stream-power river incision model", JGR 104; Kirby and Whipple 2012, "Expression of
//! active tectonics in erosional landscapes", J. Struct. Geol. 44, whose channel steepness
//! maps trace such gradients). With uplift alike everywhere, the law stands every divide at
//! the same height: the default scene's hypsometric integral was 0.42 at 2, 10 and 50 km
//! (real mountain windows 0.15-0.36), the 50 km map one texture of ridges with its highest
//! ground anywhere, and the wavelet spectrum short of variance at the scales above the
//! valleys. The field here multiplies the uplift by `contrast^v`, `v` a seeded fBm in
//! metres (three octaves from `scale_m` down) doubled and clamped to `[-1/2, 1/2]`: the
//! fastest-rising ranges rise `contrast` times faster than the slowest basins. Positions
//! are in metres, so the same scene has the same ranges at any resolution, on the coarse
//! grid of a large map and in a world's global build; a map much smaller than `scale_m`
//! lies within one range or one basin. The painted uplift (`painted.rs`) multiplies it
//! further.

use crate::noise::{FbmGrid, Perlin};

/// The default wavelength of the largest structures, metres (the scene's
/// `erosion.uplift_scale_m`): ranges and basins some 10-15 km across.
pub const DEFAULT_SCALE_M: f64 = 25_000.0;
/// fBm octaves of the field (down to an eighth of its scale).
const OCTAVES: u32 = 3;
/// Amplitude ratio between octaves.
const ROUGHNESS: f64 = 0.5;
/// Gain on the fBm (its normalised sum has a standard deviation of about 0.2): some 5-8% of
/// a large map stands at each clamp, the fastest ranges and the slowest basins.
const GAIN: f64 = 2.0;

/// The ranges of one map, to be applied row by row ([`Ranges::raise`]).
pub struct Ranges {
    perlin: Perlin,
    n: usize,
    /// fBm cycles of the largest octave across the map.
    cycles: f64,
    ln_contrast: f64,
}

impl Ranges {
    /// `contrast` >= 1 (1: uniform uplift); `scale_m` > 0.
    pub fn new(n: usize, cell_m: f64, contrast: f64, scale_m: f64, seed: u64) -> Self {
        Self {
            perlin: Perlin::new(crate::terrain::stage_seed(seed, "ranges")),
            n,
            cycles: n as f64 * cell_m / scale_m,
            ln_contrast: contrast.max(1.0).ln(),
        }
    }

    /// Multiplies `uplift` (whole rows, from row `first_row` on) by the field's factors. The
    /// same values however the rows are split. O(cells of the rows x octaves).
    pub fn raise(&self, first_row: usize, uplift: &mut [f32]) {
        if self.ln_contrast == 0.0 {
            return;
        }
        let n = self.n.max(1);
        let fbm = FbmGrid::new(&self.perlin, n, self.cycles, OCTAVES, ROUGHNESS);
        for (k, u) in uplift.iter_mut().enumerate() {
            let (x, y) = (k % n, first_row + k / n);
            let v = (GAIN * fbm.at(x, y)).clamp(-0.5, 0.5);
            *u *= (self.ln_contrast * v).exp() as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factors(n: usize, cell_m: f64, contrast: f64, seed: u64) -> Vec<f32> {
        let mut f = vec![1.0f32; n * n];
        Ranges::new(n, cell_m, contrast, DEFAULT_SCALE_M, seed).raise(0, &mut f);
        f
    }

    /// The factors span the contrast (fastest over slowest, a share of the map at each
    /// end), vary at the ranges' scale, not the cells', and are the same ranges at two
    /// resolutions of one map; contrast 1 changes nothing.
    #[test]
    fn ranges_span_the_contrast_at_their_scale() {
        assert!(factors(64, 800.0, 1.0, 3).iter().all(|f| *f == 1.0));
        let (n, cell) = (128, 50_000.0 / 128.0);
        let f = factors(n, cell, 8.0, 3);
        let (lo, hi) = f
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        assert!((hi / lo - 8.0).abs() < 1e-3, "span {lo} to {hi}");
        let at = |v: f32| f.iter().filter(|x| (**x - v).abs() < 1e-4).count() as f64;
        let share = (at(lo) / f.len() as f64, at(hi) / f.len() as f64);
        assert!(share.0 > 0.03 && share.1 > 0.03, "{share:?}");
        // Neighbours differ by little: a range is many cells wide.
        let step = (0..n * n - 1)
            .filter(|i| (i + 1) % n != 0)
            .map(|i| (f[i + 1] / f[i]).ln().abs())
            .fold(0.0f32, f32::max);
        assert!(
            step < 0.1 * 8f32.ln(),
            "largest step between neighbours {step}"
        );
        // The same ranges on a grid twice as fine (cell centres at the same metres).
        let fine = factors(2 * n, cell / 2.0, 8.0, 3);
        let mut worst = 0.0f32;
        for y in 0..n {
            for x in 0..n {
                let coarse = f[y * n + x].ln();
                let fine = fine[2 * y * 2 * n + 2 * x].ln();
                worst = worst.max((coarse - fine).abs());
            }
        }
        assert!(worst < 1e-4, "{worst}");
        // Rows split anywhere give the same values.
        let mut rows = vec![1.0f32; n * n];
        let ranges = Ranges::new(n, cell, 8.0, DEFAULT_SCALE_M, 3);
        ranges.raise(0, &mut rows[..40 * n]);
        ranges.raise(40, &mut rows[40 * n..]);
        assert_eq!(rows, f);
    }
}
