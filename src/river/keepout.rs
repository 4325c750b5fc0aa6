//! Ground the grown tributaries stay off: the sketch's peaks and ridges with the flanks their
//! heights need.
//!
//! A network grown by the L-system fills the map with tributaries whatever else the user drew,
//! so a peak sketched at 1200 m could have a river 180 m from it: no rock stands that steep,
//! and the erosion wore the peak down to what the nearby river allowed (150-355 m). The
//! admission of links ([`super::network::admit`]) therefore drops, with everything upstream,
//! every grown link that crosses a sketched ridge or comes nearer to a peak or ridge than its
//! clearance, the horizontal distance over which its height falls at a mountain flank's slope
//! (the caller sets it; see `terrain::keepout`). The strokes themselves are what the user drew
//! and are always kept.

use glam::DVec2;

use super::network::segments_intersect;

/// Shapes the grown links keep clear of: segments (a point is a segment of length 0), each
/// with its clearance, all in map units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Keepout {
    shapes: Vec<(DVec2, DVec2, f64)>,
}

impl Keepout {
    /// Keeps links `clearance` map units away from `at`.
    pub fn add_point(&mut self, at: DVec2, clearance: f64) {
        self.shapes.push((at, at, clearance.max(0.0)));
    }

    /// Keeps links from crossing the segment `a -> b` and `clearance` map units away from it.
    pub fn add_segment(&mut self, a: DVec2, b: DVec2, clearance: f64) {
        self.shapes.push((a, b, clearance.max(0.0)));
    }

    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Whether the link `from -> to` crosses a shape or passes within its clearance.
    /// O(shapes).
    pub fn blocks(&self, from: DVec2, to: DVec2) -> bool {
        self.shapes.iter().any(|&(a, b, clearance)| {
            (a != b && segments_intersect(from, to, a, b))
                || segment_distance(from, to, a, b) < clearance
        })
    }
}

/// The distance between segments `p -> q` and `a -> b` that do not cross: the least of the
/// four end-to-segment distances.
fn segment_distance(p: DVec2, q: DVec2, a: DVec2, b: DVec2) -> f64 {
    point_segment(p, a, b)
        .min(point_segment(q, a, b))
        .min(point_segment(a, p, q))
        .min(point_segment(b, p, q))
}

/// The distance from `x` to the segment `a -> b`.
pub fn point_segment(x: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((x - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    x.distance(a + ab * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_near_a_peak_or_across_a_ridge_are_blocked() {
        let mut keep = Keepout::default();
        keep.add_point(DVec2::new(0.5, 0.5), 0.1);
        keep.add_segment(DVec2::new(0.0, 0.2), DVec2::new(1.0, 0.2), 0.0);
        // Passes the peak 0.05 away: blocked; 0.15 away: kept.
        assert!(keep.blocks(DVec2::new(0.3, 0.55), DVec2::new(0.7, 0.55)));
        assert!(!keep.blocks(DVec2::new(0.3, 0.65), DVec2::new(0.7, 0.65)));
        // Crosses the ridge: blocked even with no clearance; beside it: kept.
        assert!(keep.blocks(DVec2::new(0.9, 0.1), DVec2::new(0.9, 0.3)));
        assert!(!keep.blocks(DVec2::new(0.9, 0.25), DVec2::new(0.9, 0.3)));
        assert!(!Keepout::default().blocks(DVec2::ZERO, DVec2::ONE));
    }
}
