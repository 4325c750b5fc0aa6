//! Reference fractional-Brownian surfaces of known roughness, for tests and benchmarks of the
//! wavelet statistics: the diamond-square midpoint displacement (Fournier, Fussell and
//! Carpenter 1982) with the displacement's standard deviation shrinking by `2^-H` per halving
//! of the step, which gives increments with `Var ~ tau^(2H)` (seed 001, Sec. 2.3) and so a
//! wavelet variance slope of `gamma = 2H + 2` (seed 001, eq. 2, with a 2D normalised bank).
//! Cost O(cells).

use super::rng;
use crate::heightfield::{Heightfield, HeightfieldError};

/// A `width x height` crop of a diamond-square surface with Hurst exponent `hurst` (0..1) and
/// unit displacement at the coarsest step; the same seed gives the same surface.
pub fn diamond_square(
    width: usize,
    height: usize,
    hurst: f32,
    seed: u64,
) -> Result<Heightfield, HeightfieldError> {
    let side = width.max(height).max(2).next_power_of_two() + 1;
    let key = rng::seed_key(seed);
    let mut z = vec![0.0f32; side * side];
    let mut step = side - 1;
    let mut sigma = 1.0f32;
    let at = |x: usize, y: usize| y * side + x;
    let noise = |x: usize, y: usize, s: f32| s * rng::gaussian(key, x as u32, y as u32);
    while step > 1 {
        let half = step / 2;
        // Diamond: centres of squares.
        for y in (half..side).step_by(step) {
            for x in (half..side).step_by(step) {
                let mean = (z[at(x - half, y - half)]
                    + z[at(x + half, y - half)]
                    + z[at(x - half, y + half)]
                    + z[at(x + half, y + half)])
                    / 4.0;
                z[at(x, y)] = mean + noise(x, y, sigma);
            }
        }
        // Square: edge midpoints, averaging the neighbours that exist.
        for y in (0..side).step_by(half) {
            let start = if (y / half).is_multiple_of(2) {
                half
            } else {
                0
            };
            for x in (start..side).step_by(step) {
                let mut sum = 0.0;
                let mut n = 0.0;
                if x >= half {
                    sum += z[at(x - half, y)];
                    n += 1.0;
                }
                if x + half < side {
                    sum += z[at(x + half, y)];
                    n += 1.0;
                }
                if y >= half {
                    sum += z[at(x, y - half)];
                    n += 1.0;
                }
                if y + half < side {
                    sum += z[at(x, y + half)];
                    n += 1.0;
                }
                z[at(x, y)] = sum / n + noise(x, y, sigma);
            }
        }
        sigma *= 0.5f32.powf(hurst);
        step = half;
    }
    let mut out = Vec::with_capacity(width * height);
    for y in 0..height {
        out.extend_from_slice(&z[y * side..y * side + width]);
    }
    Heightfield::from_vec(width, height, out)
}
