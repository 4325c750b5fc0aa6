//! What the user paints for the erosion: where ranges rise and where the rock is harder.
//!
//! The uplift from the design ([`super::uplift_from_design`]) and the rock's patches and beds
//! ([`super::rock`], [`super::Strata`]) come from the drawing and the seed. Painted masks
//! (values 0 to 1, white = the full effect) add the user's own large-scale structure, as
//! landscape-evolution models take uplift and erodibility as spatial fields (Braun and
//! Willett 2013 write `U(x, y)`; Moglen and Bras 1995 vary `K` in space):
//! - **uplift**: the uplift rate is multiplied by `1 + UPLIFT_GAIN * v`, so a painted band
//!   rises as a range, up to three times faster than the design alone would raise it;
//! - **hard rock**: the erodibility is divided by `HARD_ROCK^v`, so painted rock erodes up to
//!   four times slower and stands as a massif or a ridge of resistant rock (at ten the
//!   massif barely took a valley in 2 Myr and stood in planar facets at the talus angle);
//!   and where the rock field's soft units stand gentler (`erosion.soft_rock_strength`),
//!   painted rock is as strong as its hard units ([`Painted::firm`]), so a massif painted
//!   on soft rock stands steep too.
//!
//! Masks are resampled to the grid they act on (bilinear, [`Mask::resampled`]), so the same
//! painting acts alike at every resolution and on the coarse grid of a large map.

use crate::wavelet::Mask;

/// How much faster the land rises under a white uplift mask, over the design's rate.
pub const UPLIFT_GAIN: f32 = 2.0;
/// How many times harder the rock is under a white hard-rock mask.
pub const HARD_ROCK: f32 = 4.0;

/// The painted masks the erosion reads (none: the design's own fields).
#[derive(Clone, Copy, Debug, Default)]
pub struct Painted<'a> {
    pub uplift: Option<&'a Mask>,
    pub hard_rock: Option<&'a Mask>,
}

impl Painted<'_> {
    /// Multiplies the uplift (m/yr, `n` x `n`; empty: none) under the uplift mask. O(cells).
    pub fn raise(&self, uplift: &mut [f32], n: usize) {
        let Some(mask) = self.uplift else { return };
        if uplift.is_empty() {
            return;
        }
        for (u, v) in uplift.iter_mut().zip(mask.resampled(n, n)) {
            *u *= 1.0 + UPLIFT_GAIN * v.clamp(0.0, 1.0);
        }
    }

    /// Divides the erodibility factors (`n` x `n`; empty: uniform rock, made explicit here
    /// when there is a hard-rock mask) under the hard-rock mask. O(cells).
    pub fn harden(&self, erodibility: &mut Vec<f32>, n: usize) {
        self.harden_window(erodibility, n, [0, 0], [n, n]);
    }

    /// [`Self::harden`] on the window of an `n` x `n` map `size` cells from `at`
    /// (`erodibility` holds the window's cells): the same factors at those cells.
    /// O(cells of the window).
    pub fn harden_window(
        &self,
        erodibility: &mut Vec<f32>,
        n: usize,
        at: [usize; 2],
        size: [usize; 2],
    ) {
        let Some(mask) = self.hard_rock else { return };
        if erodibility.is_empty() {
            *erodibility = vec![1.0; size[0] * size[1]];
        }
        let ln_hard = HARD_ROCK.ln();
        for (k, v) in erodibility.iter_mut().zip(mask.window(n, at, size)) {
            *k *= (-ln_hard * v.clamp(0.0, 1.0)).exp();
        }
    }

    /// Moves the rock's strength factors (`n` x `n`, [`super::SlopeStrength`]) towards
    /// `sound`, the same rock's factors without its soft units, by the hard-rock mask's
    /// value: white is as strong as the hard units. No mask, or no factors, changes nothing.
    /// O(cells).
    pub fn firm(&self, strength: &mut [f32], sound: &[f32], n: usize) {
        self.firm_window(strength, sound, n, [0, 0], [n, n]);
    }

    /// [`Self::firm`] on the window of an `n` x `n` map `size` cells from `at` (`strength`
    /// and `sound` hold the window's cells): the same factors at those cells.
    /// O(cells of the window).
    pub fn firm_window(
        &self,
        strength: &mut [f32],
        sound: &[f32],
        n: usize,
        at: [usize; 2],
        size: [usize; 2],
    ) {
        let Some(mask) = self.hard_rock else { return };
        if strength.is_empty() || sound.len() != strength.len() {
            return;
        }
        for ((s, h), v) in strength.iter_mut().zip(sound).zip(mask.window(n, at, size)) {
            *s += v.clamp(0.0, 1.0) * (h - *s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White raises the uplift threefold and hardens the rock fourfold; black changes nothing;
    /// no mask leaves the fields as they were (no uplift stays none).
    #[test]
    fn masks_scale_the_fields_where_painted() {
        let mut mask = Mask::new(4, 4).expect("a mask");
        let values: Vec<f32> = (0..16).map(|i| if i % 4 < 2 { 1.0 } else { 0.0 }).collect();
        mask = Mask::from_values(4, 4, values).unwrap_or(mask);
        let painted = Painted {
            uplift: Some(&mask),
            hard_rock: Some(&mask),
        };
        let mut uplift = vec![1e-3; 16];
        painted.raise(&mut uplift, 4);
        assert!((uplift[0] - 3e-3).abs() < 1e-9 && (uplift[3] - 1e-3).abs() < 1e-9);
        let mut k = Vec::new();
        painted.harden(&mut k, 4);
        assert!((k[0] - 1.0 / HARD_ROCK).abs() < 1e-6 && (k[3] - 1.0).abs() < 1e-6);
        let mut none = Vec::new();
        painted.raise(&mut none, 4);
        assert!(none.is_empty());
        let mut untouched = vec![2.0; 16];
        Painted::default().harden(&mut untouched, 4);
        assert_eq!(untouched, vec![2.0; 16]);
        // Painted rock is as strong as the hard units under white, unchanged under black.
        let mut strength = vec![0.3; 16];
        painted.firm(&mut strength, &[0.8; 16], 4);
        assert!((strength[0] - 0.8).abs() < 1e-6 && (strength[3] - 0.3).abs() < 1e-6);
        let mut none = vec![0.3; 16];
        Painted::default().firm(&mut none, &[0.8; 16], 4);
        assert_eq!(none, vec![0.3; 16]);
    }
}
