//! Counter-based Gaussian numbers for synthetic detail coefficients.
//!
//! Each output cell holds at most one synthetic coefficient, so the cell's coordinates and the
//! seed name its random number: no generator state, any order, any number of threads, and the
//! WGSL kernel (`shaders/wavelet.wgsl`, same hash) draws the same uniforms. The hash is PCG's
//! output permutation used as an integer hash (Jarzynski and Olano, "Hash Functions for GPU
//! Rendering", JCGT 2020); the Gaussian comes from the Box-Muller transform with `libm`'s
//! `logf`/`cosf`, which give the same bits on every platform (native and wasm alike).

/// PCG hash of one 32-bit word.
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The seed folded to one word, computed once per synthesis.
pub fn seed_key(seed: u64) -> u32 {
    pcg((seed as u32) ^ pcg((seed >> 32) as u32))
}

/// Two independent uniform words for cell (x, y).
pub fn cell_words(key: u32, x: u32, y: u32) -> (u32, u32) {
    let h1 = pcg(x ^ pcg(y ^ key));
    let h2 = pcg(h1 ^ 0x9e37_79b9);
    (h1, h2)
}

/// A standard normal number for cell (x, y) (Box-Muller with 24-bit uniforms).
pub fn gaussian(key: u32, x: u32, y: u32) -> f32 {
    let (h1, h2) = cell_words(key, x, y);
    let u1 = ((h1 >> 8) + 1) as f32 / 16_777_216.0; // (0, 1]
    let u2 = (h2 >> 8) as f32 / 16_777_216.0; // [0, 1)
    (-2.0 * libm::logf(u1)).sqrt() * libm::cosf(std::f32::consts::TAU * u2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussians_have_unit_variance_and_no_correlation_between_neighbours() {
        let key = seed_key(7);
        let n = 400u32;
        let (mut sum, mut sq, mut cross) = (0.0f64, 0.0f64, 0.0f64);
        for y in 0..n {
            for x in 0..n {
                let g = f64::from(gaussian(key, x, y));
                sum += g;
                sq += g * g;
                cross += g * f64::from(gaussian(key, x + 1, y));
            }
        }
        let count = f64::from(n * n);
        let mean = sum / count;
        let var = sq / count - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "variance {var}");
        assert!(
            (cross / count).abs() < 0.01,
            "neighbour correlation {}",
            cross / count
        );
        assert_ne!(gaussian(seed_key(1), 3, 4), gaussian(seed_key(2), 3, 4));
    }
}
