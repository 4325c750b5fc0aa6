//! Ridges from the river network (seed paper 000, Sec. V-A): the Voronoi diagram of all
//! river nodes (spade), minus the edges that cross the network; what is left separates river
//! basins and becomes the ridge lines, with heights by eq. 4.

use glam::DVec2;
use serde::Serialize;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};
use thiserror::Error;

use crate::river::RiverNetwork;
use crate::river::network::SegmentIndex;

#[derive(Debug, Error)]
pub enum RidgeError {
    #[error("the ridges' Voronoi diagram could not be built from the river nodes: {0}")]
    Voronoi(String),
}

/// One straight ridge piece with the heights of its ends (metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RidgeSegment {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub height_a: f32,
    pub height_b: f32,
    /// Eq. 4's `alpha * d` at each end: how far the ridge stands above its three nearest river
    /// nodes (metres). Bounds the noise eq. 5 adds, so a ridge never sinks below its rivers.
    pub relief_a: f32,
    pub relief_b: f32,
}

/// A Voronoi vertex (a ridge node) with its eq. 4 height and relief `alpha * d`.
#[derive(Clone, Copy, Debug, Default)]
struct RidgeNode {
    at: DVec2,
    height: f32,
    relief: f32,
}

/// Ridge parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RidgeParams {
    /// alpha of eq. 4: metres of ridge height per metre of distance to the nearest river node.
    pub alpha: f64,
    /// Width of the map in metres.
    pub map_width_m: f64,
}

impl Default for RidgeParams {
    fn default() -> Self {
        Self {
            alpha: 0.12,
            map_width_m: 10_000.0,
        }
    }
}

struct RiverPoint {
    position: Point2<f64>,
    height: f32,
}

impl HasPosition for RiverPoint {
    type Scalar = f64;

    fn position(&self) -> Point2<f64> {
        self.position
    }
}

/// Extracts the ridges of `rivers`.
///
/// Each Voronoi vertex is the circumcentre of a Delaunay triangle of river nodes, so its three
/// nearest river nodes are that triangle's corners and eq. 4 reads
/// `H_q = max(H_p1, H_p2, H_p3) + alpha * d` with `d` the circumradius (computed once per
/// triangle). Voronoi edges are kept when they are finite, are not the bisector of a river
/// link itself (consecutive nodes of one river are never separated by a watershed), and, once
/// clipped to the map, cross no river link. O(n log n) for n river nodes: the triangulation,
/// then O(1) per edge on average for the crossing test against a bucket grid of the links,
/// run on all threads natively.
pub fn extract(
    rivers: &[RiverNetwork],
    params: &RidgeParams,
) -> Result<Vec<RidgeSegment>, RidgeError> {
    let total: usize = rivers.iter().map(|r| r.nodes.len()).sum();
    let mut points = Vec::with_capacity(total);
    // Every node's downstream neighbour, numbered across all networks (NO_PARENT at estuaries).
    let mut parent = Vec::with_capacity(total);
    let finest = rivers.iter().map(|r| r.link_length).fold(1.0f64, f64::min);
    let links = rivers.iter().map(RiverNetwork::links).sum();
    let mut index = SegmentIndex::new(finest.max(1e-3), links);
    for net in rivers {
        let offset = points.len() as u32;
        for (i, p) in net.nodes.iter().enumerate() {
            points.push(RiverPoint {
                // A coordinate closer to 0 than spade takes (2^-142, e.g. an estuary at
                // x = 1e-320) is 0 for every purpose here.
                position: spade::mitigate_underflow(Point2::new(p.x, p.y)),
                height: net.height[i],
            });
            parent.push(net.parent[i].map_or(NO_PARENT, |p| offset + p));
        }
        for (p, c) in net.link_pairs() {
            index.insert(net.nodes[p], net.nodes[c]);
        }
    }
    if points.len() < 3 {
        return Ok(Vec::new());
    }
    let triangulation: DelaunayTriangulation<RiverPoint> =
        DelaunayTriangulation::bulk_load_stable(points)
            .map_err(|e| RidgeError::Voronoi(e.to_string()))?;

    // Voronoi vertices with their eq. 4 heights, by Delaunay face.
    let mut vertices = vec![RidgeNode::default(); triangulation.num_all_faces()];
    for face in triangulation.inner_faces() {
        let c = face.circumcenter();
        let corners = face.vertices();
        let top = corners
            .iter()
            .map(|v| v.data().height)
            .fold(f32::MIN, f32::max);
        let p = corners[0].position();
        let d = ((c.x - p.x).powi(2) + (c.y - p.y).powi(2)).sqrt() * params.map_width_m;
        let relief = (params.alpha * d) as f32;
        vertices[face.fix().index()] = RidgeNode {
            at: DVec2::new(c.x, c.y),
            height: top + relief,
            relief,
        };
    }
    let is_link = |s: usize, t: usize| parent[s] == t as u32 || parent[t] == s as u32;
    let mut candidates = Vec::new();
    for edge in triangulation.undirected_voronoi_edges() {
        let [v0, v1] = edge.vertices();
        let (Some(f0), Some(f1)) = (v0.as_delaunay_face(), v1.as_delaunay_face()) else {
            continue;
        };
        let [s, t] = edge.as_delaunay_edge().vertices();
        if is_link(s.fix().index(), t.fix().index()) {
            continue;
        }
        // Rivers lie inside the map, so only the clipped part can cross them.
        if let Some(segment) = clip(vertices[f0.fix().index()], vertices[f1.fix().index()]) {
            candidates.push(segment);
        }
    }
    let mut crossing = vec![false; candidates.len()];
    let band = candidates.len().div_ceil(crate::parallel::threads()).max(1);
    crate::parallel::for_each_band(&mut crossing, band, |k, flags| {
        for (flag, r) in flags.iter_mut().zip(&candidates[k * band..]) {
            *flag = index.intersects(DVec2::from(r.a), DVec2::from(r.b));
        }
    });
    Ok(candidates
        .into_iter()
        .zip(crossing)
        .filter_map(|(r, crossing)| (!crossing).then_some(r))
        .collect())
}

/// `parent` of an estuary in [`extract`].
const NO_PARENT: u32 = u32::MAX;

/// Clips `a -> b` to the unit square (Liang-Barsky), interpolating heights and reliefs
/// linearly.
fn clip(from: RidgeNode, to: RidgeNode) -> Option<RidgeSegment> {
    let (a, b) = (from.at, to.at);
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-d.x, a.x), (d.x, 1.0 - a.x), (-d.y, a.y), (d.y, 1.0 - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 || !(a.is_finite() && b.is_finite()) {
        return None;
    }
    // Clamp away the rounding of a + d t at the border.
    let (pa, pb) = (
        (a + d * t0).clamp(DVec2::ZERO, DVec2::ONE),
        (a + d * t1).clamp(DVec2::ZERO, DVec2::ONE),
    );
    let lerp = |u: f32, v: f32, t: f64| u + (v - u) * t as f32;
    Some(RidgeSegment {
        a: [pa.x, pa.y],
        b: [pb.x, pb.y],
        height_a: lerp(from.height, to.height, t0),
        height_b: lerp(from.height, to.height, t1),
        relief_a: lerp(from.relief, to.relief, t0),
        relief_b: lerp(from.relief, to.relief, t1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::river::network::segments_intersect;
    use crate::river::{RiverParams, Stroke, grow_all};

    #[test]
    fn ridges_never_cross_rivers_stay_inside_and_stand_above_them() {
        let strokes = [
            Stroke {
                estuary: DVec2::new(0.3, 1.0),
                toward: DVec2::new(0.3, 0.3),
                phi: 2,
                max_depth: 8,
            },
            Stroke {
                estuary: DVec2::new(1.0, 0.4),
                toward: DVec2::new(0.5, 0.3),
                phi: 3,
                max_depth: 7,
            },
        ];
        let rivers: Vec<_> = grow_all(&strokes, &RiverParams::default(), &Default::default(), 3)
            .into_iter()
            .map(|r| r.network)
            .collect();
        let ridges = extract(&rivers, &RidgeParams::default()).unwrap();
        assert!(ridges.len() > 50, "{} ridges", ridges.len());
        let river_top = rivers
            .iter()
            .flat_map(|r| r.height.iter().copied())
            .fold(0.0f32, f32::max);
        let mut above = 0;
        for r in &ridges {
            let (a, b) = (DVec2::from(r.a), DVec2::from(r.b));
            for p in [a, b] {
                assert!((0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y));
            }
            for net in &rivers {
                for (p, c) in net.link_pairs() {
                    assert!(!segments_intersect(a, b, net.nodes[p], net.nodes[c]));
                }
            }
            if r.height_a.min(r.height_b) > 0.0 {
                above += 1;
            }
        }
        assert_eq!(above, ridges.len(), "every ridge is above the estuaries");
        assert!(
            ridges.iter().any(|r| r.height_a > river_top),
            "some ridges top the rivers"
        );
    }

    #[test]
    fn clipping_keeps_the_inside_part_with_interpolated_heights() {
        let node = |x: f64, y: f64, height: f32, relief: f32| RidgeNode {
            at: DVec2::new(x, y),
            height,
            relief,
        };
        let s = clip(node(-1.0, 0.5, 0.0, 10.0), node(1.0, 0.5, 100.0, 30.0)).unwrap();
        assert_eq!(s.a, [0.0, 0.5]);
        assert!((s.height_a - 50.0).abs() < 1e-4);
        assert!((s.relief_a - 20.0).abs() < 1e-4);
        assert_eq!((s.height_b, s.relief_b), (100.0, 30.0));
        assert!(clip(node(2.0, 2.0, 0.0, 0.0), node(3.0, 3.0, 1.0, 0.0)).is_none());
    }
}
