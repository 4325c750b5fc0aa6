//! Sketched features (seed paper 003, Sec. 3: ridge lines, valley lines and peak points) as
//! extra fixed cells of the skeleton, next to the grown rivers and ridges.
//!
//! Heights, where the sketch gives none, follow the hydrology paper so sketches blend in:
//! a ridge vertex gets eq. 4 from its three nearest river nodes; a valley starts at the
//! height of its nearest river node at its first point (its mouth) and rises along its length
//! with the river slope, so it drains towards its mouth; a peak gets eq. 4 with twice alpha.

use glam::DVec2;

use super::raster::bounded_noise;
use super::{CellKind, NoiseParams, Skeleton, bresenham, to_cell};
use crate::noise::Perlin;
use crate::river::RiverNetwork;

/// A sketched polyline in map units with an optional height in metres, or a height per
/// vertex (lines extracted from a real DEM carry its heights).
#[derive(Clone, Debug, PartialEq)]
pub struct SketchLine {
    pub points: Vec<DVec2>,
    pub height: Option<f64>,
    /// One height per point (metres); when given it wins over `height`.
    pub heights: Option<Vec<f64>>,
}

impl SketchLine {
    /// The given height of vertex `k`, if any.
    pub fn given(&self, k: usize) -> Option<f64> {
        self.heights
            .as_ref()
            .and_then(|h| h.get(k).copied())
            .or(self.height)
    }
}

/// A sketched peak.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SketchPeak {
    pub at: DVec2,
    pub height: Option<f64>,
}

/// All sketched features.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sketch {
    pub ridges: Vec<SketchLine>,
    pub valleys: Vec<SketchLine>,
    pub peaks: Vec<SketchPeak>,
}

/// Heights derived from the river network (eq. 4 style).
struct Heights<'a> {
    rivers: &'a [RiverNetwork],
    alpha: f64,
    map_width_m: f64,
}

impl Heights<'_> {
    /// The `k` nearest river nodes' heights and the distance to the nearest (map units).
    /// O(river nodes) (a selection, not a sort): sketches have few vertices.
    fn nearest(&self, p: DVec2, k: usize) -> (Vec<f32>, f64) {
        let mut all: Vec<(f64, f32)> = self
            .rivers
            .iter()
            .flat_map(|r| {
                r.nodes
                    .iter()
                    .zip(&r.height)
                    .map(|(n, h)| (n.distance(p), *h))
            })
            .collect();
        if all.len() > k {
            all.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0));
            all.truncate(k);
        }
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let d = all.first().map_or(0.0, |a| a.0);
        (all.iter().map(|a| a.1).collect(), d)
    }

    /// Eq. 4's two terms at `p`: `max(H_p1, H_p2, H_p3)` and `alpha * d` (metres).
    fn eq4_terms(&self, p: DVec2) -> (f64, f64) {
        let (heights, d) = self.nearest(p, 3);
        let top = heights.iter().copied().fold(0.0f32, f32::max);
        (f64::from(top), self.alpha * d * self.map_width_m)
    }

    /// Eq. 4: `max(H_p1, H_p2, H_p3) + alpha * d`, with `alpha` scaled by `factor`.
    fn eq4(&self, p: DVec2, factor: f64) -> f64 {
        let (top, rise) = self.eq4_terms(p);
        top + factor * rise
    }
}

/// Rasterises `sketch` into `sk` (after rivers and ridges). Rivers keep their cells; valleys
/// take precedence over ridges and peaks. The ridge and peak cells are listed in
/// [`Skeleton::held`]. O(sketch length in cells + vertices x river nodes).
#[allow(clippy::too_many_arguments)]
pub fn rasterise(
    sk: &mut Skeleton,
    sketch: &Sketch,
    rivers: &[RiverNetwork],
    alpha: f64,
    slope: f64,
    map_width_m: f64,
    noise: &NoiseParams,
    seed: u64,
) {
    let n = sk.size;
    let heights = Heights {
        rivers,
        alpha,
        map_width_m,
    };
    let perlin = Perlin::new(seed);
    let inside = |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < n && (y as usize) < n;
    let put = |sk: &mut Skeleton, x: i64, y: i64, h: f64, kind: CellKind| {
        if !inside(x, y) {
            return;
        }
        let i = y as usize * n + x as usize;
        let rank = |k: CellKind| match k {
            CellKind::River | CellKind::Grown => 3,
            CellKind::Valley => 2,
            CellKind::Ridge | CellKind::Enriched | CellKind::Floor => 1,
            CellKind::Free => 0,
        };
        if rank(kind) >= rank(sk.kinds[i]) {
            sk.kinds[i] = kind;
            sk.heights[i] = h as f32;
            if kind == CellKind::Ridge {
                sk.held.push(i as u32);
            }
        }
    };

    for line in &sketch.ridges {
        // Height and relief above the rivers at each vertex: eq. 4's `alpha * d` for derived
        // heights, the height above the nearest rivers for given ones.
        let vertices: Vec<[f64; 2]> = line
            .points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let (top, rise) = heights.eq4_terms(*p);
                let h = line.given(k).unwrap_or(top + rise);
                [h, h - top]
            })
            .collect();
        draw_polyline(&line.points, &vertices, n, |x, y, [h, relief]| {
            let f = perlin.fbm(
                x as f64 / n as f64,
                y as f64 / n as f64,
                noise.frequency,
                noise.octaves,
                noise.roughness,
            );
            put(
                sk,
                x,
                y,
                h + bounded_noise(noise.amplitude, f, relief),
                CellKind::Ridge,
            );
        });
    }
    for line in &sketch.valleys {
        let Some(mouth) = line.points.first() else {
            continue;
        };
        let base = line.height.unwrap_or_else(|| {
            f64::from(heights.nearest(*mouth, 1).0.first().copied().unwrap_or(0.0))
        });
        let mut along = 0.0;
        let mut vertex_h = Vec::with_capacity(line.points.len());
        for (k, p) in line.points.iter().enumerate() {
            if k > 0 {
                along += p.distance(line.points[k - 1]);
            }
            vertex_h.push([
                line.heights
                    .as_ref()
                    .and_then(|h| h.get(k).copied())
                    .unwrap_or(base + slope * along * map_width_m),
                0.0,
            ]);
        }
        draw_polyline(&line.points, &vertex_h, n, |x, y, [h, _]| {
            put(sk, x, y, h, CellKind::Valley)
        });
    }
    for peak in &sketch.peaks {
        let h = peak.height.unwrap_or_else(|| heights.eq4(peak.at, 2.0));
        let (cx, cy) = to_cell(peak.at, n);
        for dy in -2i64..=2 {
            for dx in -2i64..=2 {
                if dx * dx + dy * dy <= 4 {
                    put(sk, cx + dx, cy + dy, h, CellKind::Ridge);
                }
            }
        }
    }
    // A valley drawn later over a ridge cell takes it: only the ridges and peaks left hold.
    let kinds = &sk.kinds;
    sk.held.retain(|&i| kinds[i as usize] == CellKind::Ridge);
    sk.held.sort_unstable();
    sk.held.dedup();
}

/// Bresenham along each segment with values (height and relief) linear between the vertices
/// (eq. 5 without the noise term, which the caller adds where it applies).
fn draw_polyline(
    points: &[DVec2],
    values: &[[f64; 2]],
    n: usize,
    mut visit: impl FnMut(i64, i64, [f64; 2]),
) {
    for k in 1..points.len() {
        let (a, b) = (to_cell(points[k - 1], n), to_cell(points[k], n));
        let len = (((b.0 - a.0).pow(2) + (b.1 - a.1).pow(2)) as f64)
            .sqrt()
            .max(1.0);
        let (va, vb) = (values[k - 1], values[k]);
        bresenham(a, b, |x, y| {
            let t = ((((x - a.0).pow(2) + (y - a.1).pow(2)) as f64).sqrt() / len).min(1.0);
            visit(x, y, [0, 1].map(|i| va[i] + t * (vb[i] - va[i])));
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 5's noise on a sketched ridge lowers it by at most half its relief above the
    /// rivers, as on the network's ridges (otherwise a low sketched ridge sinks below the
    /// land it should divide); upwards it keeps its full amplitude.
    #[test]
    fn sketched_ridge_noise_lowers_it_by_at_most_half_its_relief() {
        let n = 128;
        let (h0, h1) = (20.0, 60.0);
        let sketch = Sketch {
            ridges: vec![SketchLine {
                points: vec![DVec2::new(0.1, 0.5), DVec2::new(0.9, 0.5)],
                height: None,
                heights: Some(vec![h0, h1]),
            }],
            ..Sketch::default()
        };
        let noise = NoiseParams {
            amplitude: 200.0,
            ..NoiseParams::default()
        };
        let mut sk = Skeleton::empty(n);
        rasterise(&mut sk, &sketch, &[], 0.1, 0.01, 10_000.0, &noise, 7);
        let (a, b) = (
            to_cell(sketch.ridges[0].points[0], n),
            to_cell(sketch.ridges[0].points[1], n),
        );
        let (mut cells, mut raised) = (0, 0);
        for x in a.0..=b.0 {
            let i = a.1 as usize * n + x as usize;
            assert_eq!(sk.kinds[i], CellKind::Ridge);
            let t = (x - a.0) as f64 / (b.0 - a.0) as f64;
            // No rivers: the relief is the ridge's whole height.
            let linear = h0 + t * (h1 - h0);
            let h = f64::from(sk.heights[i]);
            assert!(
                h >= 0.5 * linear - 1e-3,
                "x {x}: {h} below half of {linear}"
            );
            cells += 1;
            raised += usize::from(h > linear + 0.5 * linear);
        }
        assert!(cells > 90);
        assert!(raised > 0, "the noise still raises parts of the ridge");
    }
}
