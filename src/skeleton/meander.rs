//! River courses that wander: each link of the river network, a straight segment between two
//! nodes in the L-system of seed paper 000, is drawn as a curve through its two nodes.
//!
//! Departure from the paper (which draws the links straight): real channels are not straight
//! between confluences (the sinuosity of mountain rivers is 1.05 to 1.3; Leopold & Wolman
//! 1957), and straight links read as canals with right-angle steps on large maps. The curve is
//! midpoint displacement (Fournier, Fussell & Carpenter 1982): each piece's midpoint moves
//! sideways by up to [`WANDER`] of the piece's length, halving the piece each level, while a
//! piece spans more than [`FINEST_CELLS`] cells. The offsets hash the link's end points, so the
//! coarse course is the same at every map size (a 256^2 preview and the 2048^2 build wander
//! alike) and only the levels a grid resolves are added. Heights stay eq. 5's linear profile,
//! by length along the curve, so every river cell still has a lower neighbour downstream.

use glam::DVec2;

use crate::noise::splitmix64;

/// The most a piece's midpoint moves sideways, as a fraction of the piece's length (0.15
/// gives a sinuosity near 1.1 and keeps a link within a sixth of its length of the straight
/// one, far from the ridges between rivers).
pub const WANDER: f64 = 0.15;

/// Pieces shorter than this many cells are left straight.
const FINEST_CELLS: f64 = 6.0;

/// The most levels of halving (2^6 pieces a link).
const MAX_LEVELS: u32 = 6;

/// The course of the link from `a` to `b` (map units) on an `n`-cell grid: the points of the
/// curve from `a` to `b`, both included.
pub fn course(a: DVec2, b: DVec2, n: usize) -> Vec<DVec2> {
    let cells = (n.max(2) - 1) as f64;
    let mut points = vec![a, b];
    let key = link_key(a, b);
    for level in 0..MAX_LEVELS {
        let piece = (points[1] - points[0]).length() * cells;
        if piece < FINEST_CELLS {
            break;
        }
        let mut finer = Vec::with_capacity(points.len() * 2 - 1);
        for (i, w) in points.windows(2).enumerate() {
            let (p, q) = (w[0], w[1]);
            let along = q - p;
            let side = DVec2::new(-along.y, along.x);
            let u = unit(key, level, i as u32);
            finer.push(p);
            finer.push((p + q) * 0.5 + side * (WANDER * u));
        }
        finer.push(*points.last().unwrap_or(&b));
        points = finer;
    }
    points
}

/// A uniform number in [-1, 1] for piece `i` of `level` of the link `key`.
fn unit(key: u64, level: u32, i: u32) -> f64 {
    let h = splitmix64(
        key ^ (u64::from(level) << 32 | u64::from(i)).wrapping_mul(0x9e37_79b9_7f4a_7c15),
    );
    (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// The link's own key, from its end points' bits (the same at every grid size).
fn link_key(a: DVec2, b: DVec2) -> u64 {
    [a.x, a.y, b.x, b.y]
        .iter()
        .fold(0x5851_f42d_4c95_7f2d, |h, v| splitmix64(h ^ v.to_bits()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The course keeps its ends, stays near the straight link, wanders (sinuosity above 1)
    /// and is the same curve at every grid size, with more points where the grid resolves them.
    #[test]
    fn a_course_wanders_between_its_nodes_alike_at_every_size() {
        let (a, b) = (DVec2::new(0.2, 0.9), DVec2::new(0.5, 0.3));
        let coarse = course(a, b, 128);
        let fine = course(a, b, 2048);
        assert_eq!((coarse[0], *coarse.last().unwrap()), (a, b));
        assert!(fine.len() > coarse.len());
        let straight = (b - a).length();
        let length: f64 = fine.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let sinuosity = length / straight;
        assert!((1.02..1.6).contains(&sinuosity), "{sinuosity}");
        let dir = (b - a) / straight;
        for p in &fine {
            let off = (*p - a).perp_dot(dir).abs();
            assert!(off < 0.25 * straight, "{off}");
        }
        // Every coarse point lies on the fine course.
        for p in &coarse {
            assert!(fine.iter().any(|q| (*q - *p).length() < 1e-12));
        }
        // A short link (under 6 cells) stays straight.
        assert_eq!(course(a, a + DVec2::new(0.002, 0.0), 1024).len(), 2);
    }
}
