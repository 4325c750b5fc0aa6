//! Fractal Perlin noise F(P) of eq. 5 (seed paper 000): improved gradient noise summed over
//! octaves (fBm). Seeded, and made of additions, multiplications and `floor` only, so the
//! same seed gives the same bits natively and in the browser.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// A seeded 2D Perlin noise source.
#[derive(Clone, Debug)]
pub struct Perlin {
    perm: [u8; 512],
}

impl Perlin {
    pub fn new(seed: u64) -> Self {
        let mut table: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut rng = StdRng::seed_from_u64(seed);
        for i in (1..256).rev() {
            let j = rng.random_range(0..=i);
            table.swap(i, j);
        }
        Self {
            perm: std::array::from_fn(|i| table[i % 256]),
        }
    }

    /// The permutation table (the 256 entries twice), for the WGSL port of [`Perlin::noise`].
    pub fn permutation(&self) -> &[u8; 512] {
        &self.perm
    }

    /// Gradient noise in about [-1, 1], zero at integer lattice points.
    pub fn noise(&self, x: f64, y: f64) -> f64 {
        let (xf, yf) = (x.floor(), y.floor());
        let (xi, yi) = ((xf as i64 & 255) as usize, (yf as i64 & 255) as usize);
        let (x, y) = (x - xf, y - yf);
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v) = (fade(x), fade(y));
        let p = &self.perm;
        let hash = |i: usize, j: usize| p[p[i] as usize + j];
        let grad = |h: u8, x: f64, y: f64| match h & 7 {
            0 => x + y,
            1 => -x + y,
            2 => x - y,
            3 => -x - y,
            4 => x,
            5 => -x,
            6 => y,
            _ => -y,
        };
        let lerp = |t: f64, a: f64, b: f64| a + t * (b - a);
        let n00 = grad(hash(xi, yi), x, y);
        let n10 = grad(hash(xi + 1, yi), x - 1.0, y);
        let n01 = grad(hash(xi, yi + 1), x, y - 1.0);
        let n11 = grad(hash(xi + 1, yi + 1), x - 1.0, y - 1.0);
        lerp(v, lerp(u, n00, n10), lerp(u, n01, n11))
    }

    /// Fractal Brownian motion: `sum_o roughness^o * noise(2^o * frequency * p)`, normalised
    /// so the amplitudes sum to 1 (result in about [-1, 1]).
    pub fn fbm(&self, x: f64, y: f64, frequency: f64, octaves: u32, roughness: f64) -> f64 {
        let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, frequency);
        for _ in 0..octaves.clamp(1, 16) {
            sum += amp * self.noise(x * freq, y * freq);
            norm += amp;
            amp *= roughness;
            freq *= 2.0;
        }
        if norm > 0.0 { sum / norm } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_bounded_and_varied() {
        let a = Perlin::new(1);
        let b = Perlin::new(2);
        let samples: Vec<f64> = (0..2000)
            .map(|i| a.fbm(i as f64 * 0.013, i as f64 * 0.007, 4.0, 5, 0.5))
            .collect();
        assert!(samples.iter().all(|v| v.abs() <= 1.0));
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / samples.len() as f64;
        assert!(mean.abs() < 0.1 && var > 0.005, "mean {mean} var {var}");
        assert_eq!(a.noise(3.0, 7.0), 0.0);
        assert_eq!(
            a.fbm(0.3, 0.4, 3.0, 4, 0.5),
            Perlin::new(1).fbm(0.3, 0.4, 3.0, 4, 0.5)
        );
        assert_ne!(a.fbm(0.3, 0.4, 3.0, 4, 0.5), b.fbm(0.3, 0.4, 3.0, 4, 0.5));
    }
}
