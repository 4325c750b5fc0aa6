//! Post-filters of the filled terrain (seed paper 000, Sec. V-C): optional Gaussian smoothing
//! and added fractal Perlin noise (fBm), masked so they never touch the rivers.
//!
//! With `u` the diffused terrain, `G_sigma * u` its Gaussian blur (separable, radius 3 sigma,
//! clamped at the border), `F` the fBm of eq. 5's noise and `w` the protection weight,
//!
//! ```text
//!     u'(x) = u(x) + w(x) * (G_sigma * u(x) - u(x) + A * F(x))
//! ```
//!
//! `w` is 0 on river and valley cells and within `protect` cells of them, and rises smoothly
//! to 1 over the next `protect` cells (a chamfer distance transform, O(cells)). A river
//! cell's D8 neighbours are all within one cell of it, so with `protect >= 1.5` the steepest
//! descent from every river cell sees the same heights as before: the filters cannot alter
//! the rivers' drainage. Depressions the noise makes elsewhere are flooded by the pipeline's
//! conditioning, which runs after this.
//!
//! Cost: O(cells x sigma) for the blur, O(cells x octaves) for the noise.

use crate::heightfield::Heightfield;
use crate::noise::Perlin;

/// The post-filter settings (the scene's `params.post`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PostFilter {
    /// Gaussian smoothing, standard deviation in cells (0 = off).
    pub smooth_sigma: f32,
    /// Added fBm amplitude in metres (0 = off).
    pub fbm_amplitude: f32,
    /// fBm features across the map at the coarsest octave.
    pub fbm_frequency: f32,
    pub fbm_octaves: u32,
    /// Amplitude ratio between octaves.
    pub fbm_roughness: f32,
    /// Cells around rivers and valleys left untouched (at least 1.5).
    pub protect: f32,
}

impl Default for PostFilter {
    fn default() -> Self {
        Self {
            smooth_sigma: 0.0,
            fbm_amplitude: 0.0,
            fbm_frequency: 16.0,
            fbm_octaves: 4,
            fbm_roughness: 0.5,
            protect: 2.0,
        }
    }
}

/// Largest smoothing sigma accepted, in cells.
pub const MAX_SIGMA: f32 = 32.0;

impl PostFilter {
    /// Whether the filters change anything.
    pub fn is_active(&self) -> bool {
        self.smooth_sigma > 0.0 || self.fbm_amplitude != 0.0
    }

    /// Checks the values a scene could get wrong; `Err((field, problem))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let check = |ok: bool, field: &'static str, problem: String| {
            if ok { Ok(()) } else { Err((field, problem)) }
        };
        let s = self.smooth_sigma;
        check(
            s.is_finite() && (0.0..=MAX_SIGMA).contains(&s),
            "smooth_sigma",
            format!("must be 0 to {MAX_SIGMA} cells, got {s}"),
        )?;
        let a = self.fbm_amplitude;
        check(
            a.is_finite() && a.abs() <= 10_000.0,
            "fbm_amplitude",
            format!("must be -10000 to 10000 m, got {a}"),
        )?;
        let f = self.fbm_frequency;
        check(
            f.is_finite() && (0.01..=4096.0).contains(&f),
            "fbm_frequency",
            format!("must be 0.01 to 4096, got {f}"),
        )?;
        check(
            (1..=12).contains(&self.fbm_octaves),
            "fbm_octaves",
            format!("must be 1 to 12, got {}", self.fbm_octaves),
        )?;
        let r = self.fbm_roughness;
        check(
            r.is_finite() && (0.0..=1.0).contains(&r),
            "fbm_roughness",
            format!("must be 0 to 1, got {r}"),
        )?;
        let p = self.protect;
        check(
            p.is_finite() && (1.5..=64.0).contains(&p),
            "protect",
            format!("must be 1.5 to 64 cells, got {p}"),
        )
    }
}

/// The protection weight per cell: 0 on `protected` cells and within `radius` cells of them,
/// rising as a smoothstep to 1 at `2 radius`. Distances by a two-pass 3-4 chamfer transform.
pub fn protection(protected: &[bool], width: usize, height: usize, radius: f32) -> Vec<f32> {
    const FAR: f32 = f32::MAX / 4.0;
    let mut d: Vec<f32> = protected
        .iter()
        .map(|&p| if p { 0.0 } else { FAR })
        .collect();
    let (a, b) = (1.0f32, 4.0 / 3.0);
    let idx = |x: usize, y: usize| y * width + x;
    for y in 0..height {
        for x in 0..width {
            let mut v = d[idx(x, y)];
            if x > 0 {
                v = v.min(d[idx(x - 1, y)] + a);
            }
            if y > 0 {
                v = v.min(d[idx(x, y - 1)] + a);
                if x > 0 {
                    v = v.min(d[idx(x - 1, y - 1)] + b);
                }
                if x + 1 < width {
                    v = v.min(d[idx(x + 1, y - 1)] + b);
                }
            }
            d[idx(x, y)] = v;
        }
    }
    for y in (0..height).rev() {
        for x in (0..width).rev() {
            let mut v = d[idx(x, y)];
            if x + 1 < width {
                v = v.min(d[idx(x + 1, y)] + a);
            }
            if y + 1 < height {
                v = v.min(d[idx(x, y + 1)] + a);
                if x + 1 < width {
                    v = v.min(d[idx(x + 1, y + 1)] + b);
                }
                if x > 0 {
                    v = v.min(d[idx(x - 1, y + 1)] + b);
                }
            }
            d[idx(x, y)] = v;
        }
    }
    d.into_iter()
        .map(|dist| {
            let t = ((dist - radius) / radius).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        })
        .collect()
}

/// Normalised Gaussian taps for `sigma` cells: `2 r + 1` weights with `r = ceil(3 sigma)`.
pub fn gaussian_taps(sigma: f32) -> Vec<f32> {
    // Under 0.05 cells a neighbour's weight, e^(-1 / 2 sigma^2) < e^-200, is 0 in f32 (and
    // sigma^2 itself underflows to 0 near 1e-23): no blur, exactly.
    if sigma.is_nan() || sigma < 0.05 {
        return vec![1.0];
    }
    let r = (3.0 * sigma).ceil().max(1.0) as i32;
    let taps: Vec<f32> = (-r..=r)
        .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f32 = taps.iter().sum();
    taps.into_iter().map(|t| t / sum).collect()
}

/// The fBm term `A * F` at cell (x, y) of a `width` x `height` map (map units in, so the
/// noise looks the same at every size).
pub fn fbm_at(perlin: &Perlin, params: &PostFilter, x: usize, y: usize, w: usize, h: usize) -> f32 {
    let u = x as f64 / (w.max(2) - 1) as f64;
    let v = y as f64 / (h.max(2) - 1) as f64;
    params.fbm_amplitude
        * perlin.fbm(
            u,
            v,
            f64::from(params.fbm_frequency),
            params.fbm_octaves,
            f64::from(params.fbm_roughness),
        ) as f32
}

/// The filters on the CPU.
pub fn apply_cpu(
    field: &Heightfield,
    weights: &[f32],
    params: &PostFilter,
    seed: u64,
) -> Heightfield {
    let (w, h) = (field.width(), field.height());
    let u = field.data();
    let blurred = if params.smooth_sigma > 0.0 {
        let taps = gaussian_taps(params.smooth_sigma);
        let r = (taps.len() / 2) as i64;
        let clamp = |i: i64, n: usize| i.clamp(0, n as i64 - 1) as usize;
        let mut tmp = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                tmp[y * w + x] = taps
                    .iter()
                    .enumerate()
                    .map(|(k, t)| t * u[y * w + clamp(x as i64 + k as i64 - r, w)])
                    .sum();
            }
        }
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                out[y * w + x] = taps
                    .iter()
                    .enumerate()
                    .map(|(k, t)| t * tmp[clamp(y as i64 + k as i64 - r, h) * w + x])
                    .sum();
            }
        }
        out
    } else {
        u.to_vec()
    };
    let perlin = (params.fbm_amplitude != 0.0).then(|| Perlin::new(seed));
    let data = (0..w * h)
        .map(|i| {
            let noise = perlin
                .as_ref()
                .map_or(0.0, |p| fbm_at(p, params, i % w, i / w, w, h));
            u[i] + weights[i] * (blurred[i] - u[i] + noise)
        })
        .collect();
    Heightfield::from_vec(w, h, data).expect("same size as the input")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn protection_is_zero_near_rivers_and_one_far_away() {
        let (w, h) = (40, 9);
        let mut rivers = vec![false; w * h];
        (0..h).for_each(|y| rivers[y * w + 5] = true);
        let wt = protection(&rivers, w, h, 2.0);
        for y in 0..h {
            assert_eq!(wt[y * w + 5], 0.0);
            assert_eq!(wt[y * w + 7], 0.0); // 2 cells away
            assert_eq!(wt[y * w + 3], 0.0);
            assert!(wt[y * w + 8] > 0.0 && wt[y * w + 8] < 1.0);
            assert_eq!(wt[y * w + 20], 1.0);
        }
    }

    #[test]
    fn taps_sum_to_one_and_a_plane_survives_the_blur() {
        let taps = gaussian_taps(1.7);
        assert!((taps.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        assert_eq!(taps.len(), 2 * 6 + 1);
        let field =
            Heightfield::from_vec(30, 30, (0..900).map(|i| (i % 30) as f32 * 2.0).collect())
                .unwrap();
        let params = PostFilter {
            smooth_sigma: 1.7,
            ..Default::default()
        };
        let out = apply_cpu(&field, &vec![1.0; 900], &params, 1);
        // Away from the clamped border a linear ramp is a fixed point of a symmetric blur.
        for y in 0..30 {
            for x in 8..22 {
                assert!((out.get(x, y).unwrap() - field.get(x, y).unwrap()).abs() < 1e-3);
            }
        }
    }
}
