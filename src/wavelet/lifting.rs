//! The spline-linear biorthogonal wavelet (CDF 5/3) by lifting, in place, 2D separable, in the
//! vertex-preserving interleaved layout (seed paper 001, Secs. 2.2, 3.1 and 4.1).
//!
//! One level at stride `s` works on the samples at multiples of `s`. Along one axis they are
//! `x_0, x_1, ..., x_{n-1}`; the even ones become the coarse signal (they sit on the vertices of
//! the coarser mesh) and the odd ones the detail:
//!
//! - predict: `d_i = x_{2i+1} - (x_{2i} + x_{2i+2}) / 2`
//! - update:  `c_i = x_{2i} + (d_{i-1} + d_i) / 4`
//!
//! which is eq. 1 with the 5/3 analysis filters `h = (-1, 2, 6, 2, -1) / 8`, `g = (-1, 2, -1) / 2`.
//! The boundary is whole-sample symmetric (`x_{-k} = x_k`, `x_{n-1+k} = x_{n-1-k}`), so any
//! length works, odd or even. The inverse runs the steps backwards with opposite signs, which
//! makes reconstruction perfect up to rounding. With every detail zero the inverse gives
//! `x_{2i} = c_i` and `x_{2i+1} = (c_i + c_{i+1}) / 2`: the spline-linear (bilinear, in 2D)
//! interpolation of the coarse samples, which keep their values (Sec. 4.1, Fig. 7 centre).
//!
//! In 2D a level lifts every row of the stride-`s` sub-grid along x, then every column along
//! y; the inverse undoes y, then x. After the level, the stride-`2s` sub-grid holds the coarse
//! signal and the other stride-`s` positions the details: x odd / y even is the vertical band
//! (high-pass along x), x even / y odd the horizontal band (high-pass along y), both odd the
//! diagonal band (Mallat's naming).
//!
//! Cost: O(samples) per level, so O(w h) for a full transform; no memory beyond the grid.

use crate::parallel;

/// The two lifting steps, forward (analysis) or backward (synthesis).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    /// Odd samples minus half the sum of their even neighbours (forward), or plus (inverse).
    Predict(f32),
    /// Even samples plus a quarter of the sum of their odd neighbours (forward), or minus.
    Update(f32),
}

impl Step {
    /// Parity of the samples this step changes (the others are only read).
    fn target_parity(self) -> usize {
        match self {
            Step::Predict(_) => 1,
            Step::Update(_) => 0,
        }
    }

    fn coefficient(self) -> f32 {
        match self {
            Step::Predict(c) | Step::Update(c) => c,
        }
    }
}

const FORWARD: [Step; 2] = [Step::Predict(-0.5), Step::Update(0.25)];
const INVERSE: [Step; 2] = [Step::Update(-0.25), Step::Predict(0.5)];

/// Number of samples along an axis of length `len` at stride `s`.
pub fn count_at(len: usize, s: usize) -> usize {
    (len - 1) / s + 1
}

/// How many levels a `w` x `h` grid can be decomposed into: each level needs at least two
/// samples along both axes.
pub fn max_levels(w: usize, h: usize) -> u32 {
    let mut levels = 0;
    let mut s = 1usize;
    while w > 0 && h > 0 && count_at(w, s) >= 2 && count_at(h, s) >= 2 {
        levels += 1;
        s *= 2;
    }
    levels
}

/// Indices of the two neighbours of sample `i` (of `n`) under whole-sample symmetry.
pub fn neighbours(i: usize, n: usize) -> (usize, usize) {
    let left = if i == 0 { 1 } else { i - 1 };
    let right = if i + 1 < n { i + 1 } else { i - 1 };
    (left, right)
}

/// Applies `step` along x to every row of the stride-`s` sub-grid.
fn along_x(data: &mut [f32], w: usize, h: usize, s: usize, step: Step) {
    let n = count_at(w, s);
    let c = step.coefficient();
    let parity = step.target_parity();
    let rows: Vec<&mut [f32]> = data.chunks_mut(w).take(h).step_by(s).collect();
    parallel::for_each_item(rows, |row| {
        for i in (parity..n).step_by(2) {
            let (l, r) = neighbours(i, n);
            let sum = row[l * s] + row[r * s];
            row[i * s] += c * sum;
        }
    });
}

/// Applies `step` along y to every column of the stride-`s` sub-grid, row by row (cache
/// friendly): each changed row reads its two neighbours of the other parity.
fn along_y(data: &mut [f32], w: usize, h: usize, s: usize, step: Step) {
    let n = count_at(h, s);
    let c = step.coefficient();
    let parity = step.target_parity();
    let mut targets: Vec<(usize, &mut [f32])> = Vec::with_capacity(n / 2 + 1);
    let mut sources: Vec<&[f32]> = Vec::with_capacity(n / 2 + 1);
    for (k, row) in data.chunks_mut(w).take(h).step_by(s).enumerate() {
        if k % 2 == parity {
            targets.push((k, row));
        } else {
            sources.push(row);
        }
    }
    // Sub-grid row k of the other parity is sources[k / 2].
    parallel::for_each_item(targets, |(k, row)| {
        let (l, r) = neighbours(k, n);
        let (above, below) = (sources[l / 2], sources[r / 2]);
        for x in (0..w).step_by(s) {
            row[x] += c * (above[x] + below[x]);
        }
    });
}

/// One forward level at stride `s` (rows, then columns).
pub fn forward_level(data: &mut [f32], w: usize, h: usize, s: usize) {
    debug_assert_eq!(data.len(), w * h);
    for step in FORWARD {
        along_x(data, w, h, s, step);
    }
    for step in FORWARD {
        along_y(data, w, h, s, step);
    }
}

/// One inverse level at stride `s` (columns, then rows): undoes [`forward_level`].
pub fn inverse_level(data: &mut [f32], w: usize, h: usize, s: usize) {
    debug_assert_eq!(data.len(), w * h);
    for step in INVERSE {
        along_y(data, w, h, s, step);
    }
    for step in INVERSE {
        along_x(data, w, h, s, step);
    }
}

/// `levels` forward levels at strides 1, 2, 4, ... (`levels` at most [`max_levels`]).
pub fn forward(data: &mut [f32], w: usize, h: usize, levels: u32) {
    for level in 0..levels {
        forward_level(data, w, h, 1 << level);
    }
}

/// Undoes [`forward`] with the same `levels`.
pub fn inverse(data: &mut [f32], w: usize, h: usize, levels: u32) {
    for level in (0..levels).rev() {
        inverse_level(data, w, h, 1 << level);
    }
}

/// The three detail bands of the 2D transform (Mallat's naming).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Band {
    /// Low-pass along x, high-pass along y: horizontal edges (`d^1`).
    Horizontal,
    /// High-pass along x, low-pass along y: vertical edges (`d^2`).
    Vertical,
    /// High-pass along both axes (`d^3`).
    Diagonal,
}

impl Band {
    pub const ALL: [Band; 3] = [Band::Horizontal, Band::Vertical, Band::Diagonal];

    pub fn index(self) -> usize {
        match self {
            Band::Horizontal => 0,
            Band::Vertical => 1,
            Band::Diagonal => 2,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Band::Horizontal => "H",
            Band::Vertical => "V",
            Band::Diagonal => "D",
        }
    }

    /// The band of the detail at sub-grid parities (`odd_x`, `odd_y`); `None` for the coarse.
    pub fn at(odd_x: bool, odd_y: bool) -> Option<Band> {
        match (odd_x, odd_y) {
            (false, false) => None,
            (true, false) => Some(Band::Vertical),
            (false, true) => Some(Band::Horizontal),
            (true, true) => Some(Band::Diagonal),
        }
    }

    /// Parities (`odd_x`, `odd_y`) of this band's samples in the stride-`s` sub-grid.
    pub fn parities(self) -> (usize, usize) {
        match self {
            Band::Horizontal => (0, 1),
            Band::Vertical => (1, 0),
            Band::Diagonal => (1, 1),
        }
    }

    /// Factor from this implementation's lifting coefficients to those of the L2-normalised
    /// filter bank (analysis low-pass summing to sqrt 2, high-pass `g / sqrt 2`), for a detail
    /// at `depth` (1 = the finest level of the analysed grid, 0 and below = levels synthesised
    /// above it). Each coarser level gains 2 (sqrt 2 per axis); within a level a high-pass axis
    /// contributes 1/sqrt 2 and a low-pass axis sqrt 2.
    pub fn normalisation(self, depth: i32) -> f64 {
        let level_gain = 2f64.powi(depth - 1);
        match self {
            Band::Horizontal | Band::Vertical => level_gain,
            Band::Diagonal => level_gain * 0.5,
        }
    }
}

/// Calls `f(x, y, value)` for every sample of `band` at stride `s` (its coefficients of the
/// level whose detail lives at stride `s`).
pub fn for_each_coefficient(
    data: &[f32],
    w: usize,
    h: usize,
    s: usize,
    band: Band,
    mut f: impl FnMut(usize, usize, f32),
) {
    let (px, py) = band.parities();
    let (nx, ny) = (count_at(w, s), count_at(h, s));
    for j in (py..ny).step_by(2) {
        let row = &data[j * s * w..(j * s + 1) * w];
        for i in (px..nx).step_by(2) {
            f(i, j, row[i * s]);
        }
    }
}

/// Number of coefficients of `band` at stride `s`.
pub fn band_count(w: usize, h: usize, s: usize, band: Band) -> usize {
    let (px, py) = band.parities();
    let (nx, ny) = (count_at(w, s), count_at(h, s));
    let along = |n: usize, p: usize| if p == 0 { n.div_ceil(2) } else { n / 2 };
    along(nx, px) * along(ny, py)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pseudo_random(n: usize, seed: u32) -> Vec<f32> {
        let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state as f32 / u32::MAX as f32) * 1000.0 - 300.0
            })
            .collect()
    }

    #[test]
    fn perfect_reconstruction_for_odd_even_and_tiny_sizes() {
        for &(w, h) in &[
            (2, 2),
            (3, 2),
            (5, 7),
            (16, 9),
            (33, 33),
            (100, 37),
            (129, 64),
        ] {
            let original = pseudo_random(w * h, (w * 31 + h) as u32);
            let mut data = original.clone();
            let levels = max_levels(w, h);
            forward(&mut data, w, h, levels);
            assert_ne!(data, original, "{w}x{h}: the transform changed nothing");
            inverse(&mut data, w, h, levels);
            let err = data
                .iter()
                .zip(&original)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(err <= 1e-5 * 1000.0, "{w}x{h}: max error {err}");
        }
    }

    #[test]
    fn zero_details_give_linear_interpolation_keeping_the_vertices() {
        // Coarse 3x3 at stride 2 inside a 5x5 grid, all details zero.
        let coarse = [1.0, 5.0, -2.0, 4.0, 0.0, 8.0, 3.0, 3.0, 7.0];
        let (w, h) = (5, 5);
        let mut data = vec![0.0f32; w * h];
        for j in 0..3 {
            for i in 0..3 {
                data[2 * j * w + 2 * i] = coarse[j * 3 + i];
            }
        }
        inverse_level(&mut data, w, h, 1);
        for j in 0..3 {
            for i in 0..3 {
                assert_eq!(data[2 * j * w + 2 * i], coarse[j * 3 + i]);
            }
        }
        // Edge midpoint and cell centre are the linear / bilinear interpolations.
        assert_eq!(data[1], (1.0 + 5.0) / 2.0);
        assert_eq!(data[w + 1], (1.0 + 5.0 + 4.0 + 0.0) / 4.0);
    }

    #[test]
    fn linear_ramps_have_no_detail_inside() {
        // The 5/3 high-pass has two vanishing moments: a plane gives zero detail away from the
        // border (the symmetric extension bends it at an even-length end).
        let (w, h) = (17, 9);
        let mut data: Vec<f32> = (0..w * h)
            .map(|k| 3.0 * (k % w) as f32 - 2.0 * (k / w) as f32 + 10.0)
            .collect();
        forward_level(&mut data, w, h, 1);
        for band in Band::ALL {
            for_each_coefficient(&data, w, h, 1, band, |_, _, v| {
                assert!(v.abs() < 1e-4, "{band:?} detail {v}")
            });
        }
    }

    #[test]
    fn band_counts_partition_the_grid() {
        for &(w, h) in &[(5, 5), (6, 9), (100, 37)] {
            let s = 1;
            let details: usize = Band::ALL.iter().map(|&b| band_count(w, h, s, b)).sum();
            let coarse = count_at(w, 2) * count_at(h, 2);
            assert_eq!(details + coarse, w * h);
        }
        assert_eq!(max_levels(5, 5), 3);
        assert_eq!(max_levels(1024, 1024), 10);
        assert_eq!(max_levels(1, 9), 0);
    }
}
