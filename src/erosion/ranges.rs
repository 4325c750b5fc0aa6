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
//!
//! **Basins along the drawn rivers** ([`Ranges::with_basins`]): the design says where the
//! ranges are not. Large rivers run along the belts' structural lows, the longitudinal
//! valleys and basins their faults and folds open (the Rhone in the Valais, the Inn, the
//! Indus and Tsangpo behind the Himalaya; Hovius 1996 on the spacing and siting of
//! transverse and longitudinal rivers), so the drawn rivers and valleys pull the field down
//! beside them: `v` less `BASIN_DEPTH (g - mean g)`, `g = exp(-(d / w)^2)` of the distance
//! `d` to the nearest drawn channel, `w` a [`BASIN_WIDTH`] share of the ranges' scale. Less
//! its mean over the map, the term moves no uplift on a map lying wholly within one basin's
//! width (a few kilometres round a river), and raises the ranges between the rivers as much
//! as it lowers the land beside them.

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

/// How far the drawn rivers pull the field down beside them (in the units of `v`, whose
/// clamp is +-1/2): a river's own cells stand half the span lower than the field alone.
const BASIN_DEPTH: f64 = 0.5;
/// The basins' half-width (the `1/e` distance of their Gaussian) as a share of the ranges'
/// scale: 3 km beside a river at the default 25 km.
const BASIN_WIDTH: f64 = 0.125;

/// The ranges of one map, to be applied row by row ([`Ranges::raise`]).
pub struct Ranges {
    perlin: Perlin,
    n: usize,
    /// fBm cycles of the largest octave across the map.
    cycles: f64,
    ln_contrast: f64,
    /// The basins' term of each cell ([`Ranges::with_basins`]); empty: none.
    basins: Vec<f32>,
    cell_m: f64,
    scale_m: f64,
}

impl Ranges {
    /// `contrast` >= 1 (1: uniform uplift); `scale_m` > 0.
    pub fn new(n: usize, cell_m: f64, contrast: f64, scale_m: f64, seed: u64) -> Self {
        Self {
            perlin: Perlin::new(crate::terrain::stage_seed(seed, "ranges")),
            n,
            cycles: n as f64 * cell_m / scale_m,
            ln_contrast: contrast.max(1.0).ln(),
            basins: Vec::new(),
            cell_m,
            scale_m,
        }
    }

    /// The field with basins along the drawn rivers and valleys, `distance` each cell's
    /// distance in cells to the nearest of them ([`super::NearestChannel`]; a map without
    /// them has 0 everywhere, and no basin). O(cells).
    pub fn with_basins(mut self, distance: &[f32]) -> Self {
        if self.ln_contrast == 0.0 || distance.len() != self.n * self.n || distance.is_empty() {
            return self;
        }
        let width_cells = BASIN_WIDTH * self.scale_m / self.cell_m;
        // `g` first, then the term in place: one map-sized field of `f32`.
        let mut basins: Vec<f32> = distance
            .iter()
            .map(|d| {
                let x = f64::from(*d) / width_cells;
                libm::exp(-x * x) as f32
            })
            .collect();
        let mean = basins.iter().map(|g| f64::from(*g)).sum::<f64>() / basins.len() as f64;
        for v in &mut basins {
            *v = (-BASIN_DEPTH * (f64::from(*v) - mean)) as f32;
        }
        self.basins = basins;
        self
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
            let basin = self.basins.get(y * n + x).map_or(0.0, |b| f64::from(*b));
            let v = (GAIN * fbm.at(x, y) + basin).clamp(-0.5, 0.5);
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

    /// The drawn rivers' basins: on a 50 km map the land within 3 km of a river down the
    /// middle rises far slower than the field alone would raise it, the land far from it a
    /// little faster; a 2 km map lies within one basin and keeps its field; a map without
    /// rivers keeps it exactly.
    #[test]
    fn drawn_rivers_lie_in_basins() {
        let ln_factors = |n: usize, cell: f64, basins: bool| -> Vec<f64> {
            let distance: Vec<f32> = (0..n * n)
                .map(|i| ((i % n) as f32 - (n / 2) as f32).abs())
                .collect();
            let mut ranges = Ranges::new(n, cell, 8.0, DEFAULT_SCALE_M, 5);
            if basins {
                ranges = ranges.with_basins(&distance);
            }
            let mut f = vec![1.0f32; n * n];
            ranges.raise(0, &mut f);
            f.iter().map(|v| f64::from(*v).ln()).collect()
        };
        let mean_where = |f: &[f64], n: usize, keep: &dyn Fn(f64) -> bool| {
            let cells: Vec<f64> = (0..n * n)
                .filter(|i| keep(((i % n) as f64 - (n / 2) as f64).abs()))
                .map(|i| f[i])
                .collect();
            cells.iter().sum::<f64>() / cells.len() as f64
        };
        let (n, cell) = (128, 50_000.0 / 128.0);
        let (with, without) = (ln_factors(n, cell, true), ln_factors(n, cell, false));
        let near = |d: f64| d * cell <= 3000.0;
        let far = |d: f64| d * cell >= 12_000.0;
        let ln8 = 8f64.ln();
        let drop = mean_where(&without, n, &near) - mean_where(&with, n, &near);
        assert!(drop > 0.2 * ln8, "near the river: {drop}");
        let rise = mean_where(&with, n, &far) - mean_where(&without, n, &far);
        assert!(rise > 0.0 && rise < 0.2 * ln8, "far from it: {rise}");
        // A 2 km map: within a few per cent of the span.
        let (n, cell) = (64, 2000.0 / 64.0);
        let (with, without) = (ln_factors(n, cell, true), ln_factors(n, cell, false));
        let worst = with
            .iter()
            .zip(&without)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.05 * ln8, "{worst}");
        // No river: the transform gives distance 0 everywhere.
        let mut plain = vec![1.0f32; n * n];
        Ranges::new(n, cell, 8.0, DEFAULT_SCALE_M, 5)
            .with_basins(&vec![0.0; n * n])
            .raise(0, &mut plain);
        let mut field = vec![1.0f32; n * n];
        Ranges::new(n, cell, 8.0, DEFAULT_SCALE_M, 5).raise(0, &mut field);
        assert_eq!(plain, field);
    }
}
