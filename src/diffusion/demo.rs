//! A fixed demonstration problem: a winding valley at sea level and three summits, filled by
//! diffusion. The app shows it on its first screen, `strahler info --check` and the browser
//! self-test run it on both backends and compare, and tests check that it is the same bits
//! on every platform. Geometry is in map units, so the problem exists at any size.

use super::constraints::{Constraints, FixedMask};
use crate::heightfield::Heightfield;

/// Summits: (x, y) in map units, radius in map units, height in metres.
const PEAKS: [(f32, f32, f32, f32); 3] = [
    (0.22, 0.22, 0.02, 620.0),
    (0.70, 0.18, 0.025, 480.0),
    (0.55, 0.82, 0.02, 390.0),
];

/// The demo's constraints on an `n` x `n` grid (`n` >= 4): free cells start at 0 m.
pub fn valley_and_peaks(n: usize) -> Constraints {
    let n = n.max(4);
    let mut fixed = FixedMask::new(n, n);
    let mut heights = Heightfield::filled(n, n, 0.0).expect("n >= 4");
    let scale = (n - 1) as f32;

    // The valley: y = 0.5 + 0.12 sin(3 pi x) at 0 m, 4-connected column to column.
    // `libm` gives the same sine bits natively and in wasm.
    let mut previous: Option<usize> = None;
    for x in 0..n {
        let u = x as f32 / scale;
        let v = 0.5 + 0.12 * libm::sinf(3.0 * core::f32::consts::PI * u);
        let y = libm::roundf(v * scale) as usize;
        let from = previous.unwrap_or(y);
        for yy in from.min(y)..=from.max(y) {
            fixed.fix(x, yy);
        }
        previous = Some(y);
    }

    for (px, py, r, z) in PEAKS {
        let (cx, cy, rr) = (px * scale, py * scale, (r * scale).max(1.0));
        let lo = |c: f32| libm::floorf(c - rr).max(0.0) as usize;
        let hi = |c: f32| (libm::ceilf(c + rr) as usize).min(n - 1);
        for y in lo(cy)..=hi(cy) {
            for x in lo(cx)..=hi(cx) {
                let (dx, dy) = (x as f32 - cx, y as f32 - cy);
                if dx * dx + dy * dy <= rr * rr {
                    fixed.fix(x, y);
                    let i = heights.index(x, y);
                    heights.data_mut()[i] = z;
                }
            }
        }
    }
    Constraints::new(heights, fixed).expect("finite heights, matching sizes")
}

/// A skeleton-like benchmark problem: winding low "rivers" and high "ridges" drawn as
/// 4-connected lines until about `fixed_fraction` of the cells are fixed (the issue's
/// 1.5% is typical of a rasterised river and ridge skeleton). Deterministic in `seed`.
pub fn skeleton_like(n: usize, fixed_fraction: f32, seed: u64) -> Constraints {
    let n = n.max(4);
    let mut rng = XorShift(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let mut fixed = FixedMask::new(n, n);
    let mut heights = Heightfield::filled(n, n, 0.0).expect("n >= 4");
    let target = (fixed_fraction.clamp(0.0, 1.0) * (n * n) as f32) as usize;
    let scale = (n - 1) as f32;
    let mut line = 0u32;
    while fixed.count() < target.max(1) {
        let ridge = line % 2 == 1;
        line += 1;
        // A horizontal or vertical sine wave across the map.
        let (phase, amp, freq, offset) = (
            rng.unit() * core::f32::consts::TAU,
            0.03 + 0.1 * rng.unit(),
            1.0 + 3.0 * rng.unit(),
            0.05 + 0.9 * rng.unit(),
        );
        let vertical = rng.unit() < 0.5;
        let base = if ridge {
            400.0 + 400.0 * rng.unit()
        } else {
            50.0 * rng.unit()
        };
        let tilt = if ridge { 0.0 } else { 150.0 * rng.unit() };
        let mut previous: Option<usize> = None;
        for a in 0..n {
            let t = a as f32 / scale;
            let v = offset + amp * libm::sinf(core::f32::consts::TAU * freq * t + phase);
            let b = libm::roundf(v.clamp(0.0, 1.0) * scale) as usize;
            let from = previous.unwrap_or(b);
            for bb in from.min(b)..=from.max(b) {
                let (x, y) = if vertical { (bb, a) } else { (a, bb) };
                fixed.fix(x, y);
                let i = heights.index(x, y);
                heights.data_mut()[i] = base + tilt * t;
            }
            previous = Some(b);
        }
    }
    Constraints::new(heights, fixed).expect("finite heights, matching sizes")
}

/// A tiny deterministic generator for fixtures (not for terrain: stages use `rand`).
struct XorShift(u64);

impl XorShift {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn has_valley_and_peaks_at_any_size() {
        for n in [4, 64, 257] {
            let p = valley_and_peaks(n);
            assert!(p.fixed().count() >= n, "valley spans every column at n={n}");
            let top = p.initial().finite_range().unwrap().1;
            assert_eq!(top, 620.0);
        }
    }

    #[test]
    fn skeleton_like_hits_the_fixed_fraction() {
        let p = skeleton_like(256, 0.015, 1);
        let fraction = p.fixed().count() as f32 / (256.0 * 256.0);
        assert!((0.015..0.03).contains(&fraction), "{fraction}");
        assert_eq!(
            skeleton_like(64, 0.015, 9).initial().checksum(),
            skeleton_like(64, 0.015, 9).initial().checksum()
        );
    }
}
