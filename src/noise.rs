//! Fractal Perlin noise F(P) of eq. 5 (seed paper 000): improved gradient noise summed over
//! octaves (fBm). Seeded, and made of additions, multiplications and `floor` only, so the
//! same seed gives the same bits natively and in the browser.

use rand::rngs::ChaCha12Rng;
use rand::{RngExt, SeedableRng};

/// SplitMix64's finaliser (Steele, Lea and Flood 2014, "Fast splittable pseudorandom number
/// generators"): a bijective mix of 64 bits, the hash the stages draw reproducible values from
/// (a seed and a cell index, a link's end points).
pub fn splitmix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The eight 2D gradients of improved noise, picked by the low three bits of the hash:
/// `x + y`, `-x + y`, `x - y`, `-x - y`, `x`, `-x`, `y`, `-y`.
const GRADIENTS: [(f64, f64); 8] = [
    (1.0, 1.0),
    (-1.0, 1.0),
    (1.0, -1.0),
    (-1.0, -1.0),
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
];

/// `v.floor()` by conversion (the standard one is a library call on baseline x86-64); exact
/// wherever `v` fits an `i64`, the standard one elsewhere.
fn floor(v: f64) -> f64 {
    if v.abs() < 9.0e15 {
        let t = v as i64 as f64;
        if t > v { t - 1.0 } else { t }
    } else {
        v.floor()
    }
}

/// One coordinate of a noise sample: its lattice cell (mod 256), offset in the cell and the
/// offset's fade `6t^5 - 15t^4 + 10t^3`.
#[derive(Clone, Copy, Debug)]
struct Coordinate {
    cell: usize,
    offset: f64,
    fade: f64,
}

impl Coordinate {
    fn new(v: f64) -> Self {
        let f = floor(v);
        let t = v - f;
        Self {
            cell: (f as i64 & 255) as usize,
            offset: t,
            fade: t * t * t * (t * (t * 6.0 - 15.0) + 10.0),
        }
    }
}

/// [`Perlin::fbm`] at the cells of an `n` x `n` grid, cell `(x, y)` sampled at
/// `(x / n, y / n)`. A column's coordinate is the same for every cell in it (and equals the
/// row's of the same index), so the coordinates are computed once per octave (O(n x
/// octaves)) and each sample only hashes and blends; the values are the same as
/// [`Perlin::fbm`]'s.
#[derive(Clone, Debug)]
pub struct FbmGrid<'p> {
    perlin: &'p Perlin,
    n: usize,
    /// Per octave, the amplitude and the coordinates of indices `0..n` (octave-major).
    amplitudes: Vec<f64>,
    axis: Vec<Coordinate>,
    norm: f64,
}

impl<'p> FbmGrid<'p> {
    pub fn new(perlin: &'p Perlin, n: usize, frequency: f64, octaves: u32, roughness: f64) -> Self {
        let (mut amplitudes, mut axis) = (Vec::new(), Vec::new());
        let (mut norm, mut amp, mut freq) = (0.0, 1.0, frequency);
        for _ in 0..octaves.clamp(1, 16) {
            amplitudes.push(amp);
            axis.extend((0..n).map(|i| Coordinate::new(i as f64 / n as f64 * freq)));
            norm += amp;
            amp *= roughness;
            freq *= 2.0;
        }
        Self {
            perlin,
            n,
            amplitudes,
            axis,
            norm,
        }
    }

    /// The fBm of cell `(x, y)`, in about [-1, 1].
    pub fn at(&self, x: usize, y: usize) -> f64 {
        let mut sum = 0.0;
        for (o, amp) in self.amplitudes.iter().enumerate() {
            let at = o * self.n;
            sum += amp * self.perlin.lattice(self.axis[at + x], self.axis[at + y]);
        }
        if self.norm > 0.0 {
            sum / self.norm
        } else {
            0.0
        }
    }
}

/// A seeded 2D Perlin noise source.
#[derive(Clone, Debug)]
pub struct Perlin {
    perm: [u8; 512],
}

impl Perlin {
    pub fn new(seed: u64) -> Self {
        let mut table: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut rng = ChaCha12Rng::seed_from_u64(seed);
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
    ///
    /// The gradient is picked from [`GRADIENTS`] by table rather than by a `match` (the hash
    /// is random, so a branch per corner would be mispredicted half the time), and `floor`
    /// is done with a conversion; both give the same values as the textbook form.
    pub fn noise(&self, x: f64, y: f64) -> f64 {
        self.lattice(Coordinate::new(x), Coordinate::new(y))
    }

    /// [`Perlin::noise`] from the lattice cell, offset and fade of each coordinate.
    fn lattice(&self, x: Coordinate, y: Coordinate) -> f64 {
        let p = &self.perm;
        let hash = |i: usize, j: usize| p[(usize::from(p[i & 511]) + j) & 511];
        let grad = |h: u8, x: f64, y: f64| {
            let (gx, gy) = GRADIENTS[usize::from(h & 7)];
            gx * x + gy * y
        };
        let lerp = |t: f64, a: f64, b: f64| a + t * (b - a);
        let (xi, yi) = (x.cell, y.cell);
        let (u, v) = (x.fade, y.fade);
        let (x, y) = (x.offset, y.offset);
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

    /// The textbook form (a `match` on the hash, `f64::floor`), which [`Perlin::noise`]
    /// must equal.
    fn textbook(perlin: &Perlin, x: f64, y: f64) -> f64 {
        let (xf, yf) = (x.floor(), y.floor());
        let (xi, yi) = ((xf as i64 & 255) as usize, (yf as i64 & 255) as usize);
        let (x, y) = (x - xf, y - yf);
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v) = (fade(x), fade(y));
        let p = &perlin.perm;
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

    #[test]
    fn equals_the_textbook_form_including_negative_and_integer_points() {
        let perlin = Perlin::new(42);
        for i in 0..20_000 {
            let (x, y) = (
                (i as f64 * 0.731).sin() * 300.0,
                (i as f64 * 0.377).cos() * 300.0,
            );
            for (x, y) in [(x, y), (x.round(), y), (-x, y.round()), (x * 1e6, -y * 1e6)] {
                let (got, want) = (perlin.noise(x, y), textbook(&perlin, x, y));
                assert!(got == want, "({x}, {y}): {got} != {want}");
            }
        }
        for v in [-2.5, -2.0, -0.0, 0.0, 0.5, 1.0, 3.999_999, 1e17, -1e17] {
            assert_eq!(floor(v), v.floor(), "{v}");
        }
    }

    #[test]
    fn the_grid_form_equals_fbm_bit_for_bit() {
        let perlin = Perlin::new(5);
        for (n, frequency, octaves, roughness) in
            [(97, 8.0, 5, 0.5), (64, 3.3, 1, 0.7), (40, 1.0, 9, 0.9)]
        {
            let grid = FbmGrid::new(&perlin, n, frequency, octaves, roughness);
            for y in 0..n {
                for x in 0..n {
                    let want = perlin.fbm(
                        x as f64 / n as f64,
                        y as f64 / n as f64,
                        frequency,
                        octaves,
                        roughness,
                    );
                    assert_eq!(grid.at(x, y).to_bits(), want.to_bits(), "({x}, {y}) of {n}");
                }
            }
        }
    }

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
