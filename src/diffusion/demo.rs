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
}
