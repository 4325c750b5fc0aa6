//! The skeleton raster (seed paper 000, Sec. V-A): rivers and ridges drawn onto the grid with
//! Bresenham's algorithm and heights by eq. 5, as the fixed cells of the diffusion.

pub mod enrich;
pub mod noise;
mod raster;
pub mod sketch;

use glam::DVec2;

use crate::diffusion::{Constraints, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::ridge::RidgeSegment;
use crate::river::RiverNetwork;
use noise::{FbmGrid, Perlin};
use raster::{Band, Line};

/// What a skeleton cell is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CellKind {
    Free = 0,
    River = 1,
    Ridge = 2,
    /// Added around the skeleton by MD/MDI enrichment (`enrich`).
    Enriched = 3,
    /// A sketched valley line (`sketch`): a channel that drains to its mouth.
    Valley = 4,
}

/// Noise of eq. 5 on ridges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseParams {
    /// Amplitude of F(P) in metres.
    pub amplitude: f64,
    /// Octaves of the fBm.
    pub octaves: u32,
    /// Amplitude ratio between octaves (persistence).
    pub roughness: f64,
    /// Base frequency in cycles per map width.
    pub frequency: f64,
}

impl Default for NoiseParams {
    fn default() -> Self {
        Self {
            amplitude: 25.0,
            octaves: 5,
            roughness: 0.5,
            frequency: 8.0,
        }
    }
}

/// The rasterised skeleton: heights and kinds per cell.
#[derive(Clone, Debug)]
pub struct Skeleton {
    pub size: usize,
    pub heights: Vec<f32>,
    pub kinds: Vec<CellKind>,
    /// Strahler order of river cells (0 elsewhere), for the layers.
    pub river_order: Vec<u8>,
}

impl Skeleton {
    /// The diffusion problem: skeleton cells fixed, the rest free (starting at the mean).
    pub fn constraints(&self) -> Constraints {
        let n = self.size;
        let mut fixed = FixedMask::new(n, n);
        let (mut sum, mut count) = (0.0f64, 0usize);
        for (i, k) in self.kinds.iter().enumerate() {
            if *k != CellKind::Free {
                fixed.fix(i % n, i / n);
                sum += f64::from(self.heights[i]);
                count += 1;
            }
        }
        let mean = if count > 0 {
            (sum / count as f64) as f32
        } else {
            0.0
        };
        let initial = self
            .kinds
            .iter()
            .zip(&self.heights)
            .map(|(k, h)| if *k == CellKind::Free { mean } else { *h })
            .collect();
        Constraints::new(
            Heightfield::from_vec(n, n, initial).expect("size x size cells"),
            fixed,
        )
        .expect("skeleton heights are finite")
    }

    pub fn fixed_cells(&self) -> usize {
        self.kinds.iter().filter(|k| **k != CellKind::Free).count()
    }
}

/// Map units to the nearest cell of an `n` x `n` grid.
pub fn to_cell(p: DVec2, n: usize) -> (i64, i64) {
    let s = (n - 1) as f64;
    ((p.x * s).round() as i64, (p.y * s).round() as i64)
}

/// Bresenham's line from `a` to `b` (both included), 8-connected.
pub fn bresenham(a: (i64, i64), b: (i64, i64), mut visit: impl FnMut(i64, i64)) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = (
        if a.0 < b.0 { 1 } else { -1 },
        if a.1 < b.1 { 1 } else { -1 },
    );
    let mut err = dx + dy;
    loop {
        visit(x, y);
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// Rasterises rivers and ridges on an `n` x `n` grid.
///
/// Heights along each segment follow eq. 5: linear from start to end, plus `F(P)` on ridges
/// (fractal Perlin noise, `noise.amplitude` metres, once per ridge cell). Rivers get no noise,
/// so every river cell keeps a lower neighbour downstream (drainage by construction), and a
/// cell claimed by a river and a ridge stays a river; two rivers keep the lower height, two
/// ridges the higher. Rivers are drawn 4-connected (a diagonal Bresenham step gets its corner
/// cell too) so that water cannot leak between two diagonal river cells.
///
/// Drawn in bands of rows ([`raster`]): one per thread natively, bands of 2^17 cells one at a
/// time on the web with the job's ticks between them. O(length of all segments in cells +
/// segments x bands each spans + ridge cells x octaves).
pub async fn rasterise(
    rivers: &[RiverNetwork],
    orders: &[Vec<u32>],
    ridges: &[RidgeSegment],
    n: usize,
    noise: &NoiseParams,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Skeleton, Cancelled> {
    let mut sk = Skeleton {
        size: n,
        heights: vec![0.0; n * n],
        kinds: vec![CellKind::Free; n * n],
        river_order: vec![0; n * n],
    };
    let ridge_lines: Vec<Line> = ridges
        .iter()
        .map(|r| Line {
            a: to_cell(DVec2::from(r.a), n),
            b: to_cell(DVec2::from(r.b), n),
            start: f64::from(r.height_a),
            rise: f64::from(r.height_b - r.height_a),
            order: 0,
        })
        .collect();
    let river_lines: Vec<Line> = rivers
        .iter()
        .zip(orders)
        .flat_map(|(net, order)| {
            net.link_pairs().map(|(p, c)| Line {
                a: to_cell(net.nodes[p], n),
                b: to_cell(net.nodes[c], n),
                start: f64::from(net.height[p]),
                rise: f64::from(net.height[c]) - f64::from(net.height[p]),
                order: order[c].min(255) as u8,
            })
        })
        .collect();
    let threads = crate::compute::parallel::threads();
    let band_rows = if cfg!(target_arch = "wasm32") {
        ((1usize << 17) / n.max(1)).max(1)
    } else {
        n.div_ceil(threads).max(1)
    };
    let (ridges_of, rivers_of) = (
        raster::by_band(&ridge_lines, n, band_rows),
        raster::by_band(&river_lines, n, band_rows),
    );
    let perlin = Perlin::new(seed);
    let fbm = FbmGrid::new(&perlin, n, noise.frequency, noise.octaves, noise.roughness);
    let band_cells = band_rows * n;
    let bands: Vec<Band<'_>> = sk
        .heights
        .chunks_mut(band_cells)
        .zip(sk.kinds.chunks_mut(band_cells))
        .zip(sk.river_order.chunks_mut(band_cells))
        .enumerate()
        .map(|(k, ((heights, kinds), river_order))| Band {
            n,
            first_row: k * band_rows,
            heights,
            kinds,
            river_order,
        })
        .collect();
    let mut bands = bands.into_iter().enumerate().peekable();
    while bands.peek().is_some() {
        let step: Vec<_> = bands.by_ref().take(threads).collect();
        crate::compute::parallel::for_each_item(step, |(k, mut band)| {
            for &i in &ridges_of[k] {
                band.ridge(&ridge_lines[i as usize]);
            }
            for &i in &rivers_of[k] {
                band.river(&river_lines[i as usize]);
            }
            band.ridge_noise(noise.amplitude, &fbm);
        });
        ctx.tick(0.2, "rasterising the skeleton").await?;
    }
    Ok(sk)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bresenham_hits_both_ends_without_gaps() {
        let mut cells = Vec::new();
        bresenham((0, 0), (7, 3), |x, y| cells.push((x, y)));
        assert_eq!(cells.first(), Some(&(0, 0)));
        assert_eq!(cells.last(), Some(&(7, 3)));
        for w in cells.windows(2) {
            assert!((w[1].0 - w[0].0).abs() <= 1 && (w[1].1 - w[0].1).abs() <= 1);
        }
        assert_eq!(cells.len(), 8);
    }
}
