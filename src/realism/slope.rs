//! Slope by Horn's 3x3 gradient and its percentiles.
//!
//! Horn, B. K. P. (1981). Hill shading and the reflectance map. Proceedings of the IEEE 69(1),
//! 14-47: the gradient is the 1-2-1 weighted difference of the outer columns (rows) of the
//! 3x3 window, divided by 8 cell sizes.

use super::grid::Grid;

/// The percentiles reported, as fractions.
pub(super) const PERCENTILES: [f64; 5] = [0.10, 0.25, 0.50, 0.75, 0.90];

/// Slope (degrees) of every interior cell, in raster order.
pub(super) fn slopes_deg(g: &Grid, interior: &[bool]) -> Vec<f64> {
    let w = g.w;
    let mut out = Vec::new();
    for (i, _) in interior.iter().enumerate().filter(|(_, m)| **m) {
        // a b c / d e f / g h i  (row above = a b c); interior cells have all 8 neighbours.
        let z = |o: usize| g.z[o];
        let (n, s) = (i - w, i + w);
        let (a, b, c) = (z(n - 1), z(n), z(n + 1));
        let (d, f) = (z(i - 1), z(i + 1));
        let (gg, h, ii) = (z(s - 1), z(s), z(s + 1));
        let dzdx = ((c + 2.0 * f + ii) - (a + 2.0 * d + gg)) / (8.0 * g.cx);
        let dzdy = ((gg + 2.0 * h + ii) - (a + 2.0 * b + c)) / (8.0 * g.cy);
        out.push(dzdx.hypot(dzdy).atan().to_degrees());
    }
    out
}

/// Linear-interpolated percentiles (the "linear" / type-7 definition, numpy's default) of
/// `values`, which this reorders. All zeros when `values` is empty. `O(n)` per percentile
/// (selection instead of a full sort).
pub(super) fn percentiles(values: &mut [f64], fractions: &[f64; 5]) -> [f64; 5] {
    let mut out = [0.0; 5];
    if values.is_empty() {
        return out;
    }
    let last = values.len() - 1;
    // Ascending ranks, so that each selection only has to look right of the previous one.
    let mut order = [0, 1, 2, 3, 4];
    order.sort_by(|&a, &b| fractions[a].total_cmp(&fractions[b]));
    let mut start = 0;
    for k in order {
        let p = fractions[k];
        let rank = if p.is_nan() {
            0.0
        } else {
            p.clamp(0.0, 1.0) * last as f64
        };
        let lo = (rank.floor() as usize).clamp(start, last);
        let (_, &mut v_lo, right) =
            values[start..].select_nth_unstable_by(lo - start, f64::total_cmp);
        let v_hi = right.iter().copied().min_by(f64::total_cmp).unwrap_or(v_lo);
        out[k] = v_lo + (v_hi - v_lo) * (rank - lo as f64).max(0.0);
        start = lo;
    }
    out
}
