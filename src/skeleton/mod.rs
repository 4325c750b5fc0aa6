//! The skeleton raster (seed paper 000, Sec. V-A): rivers and ridges drawn onto the grid with
//! Bresenham's algorithm and heights by eq. 5, as the fixed cells of the diffusion.

pub mod enrich;
pub mod noise;
pub mod sketch;

use glam::DVec2;

use crate::diffusion::{Constraints, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::ridge::RidgeSegment;
use crate::river::RiverNetwork;
use noise::Perlin;

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
/// (fractal Perlin noise, `noise.amplitude` metres). Rivers get no noise, so every river
/// cell keeps a lower neighbour downstream (drainage by construction), and a cell claimed by
/// a river and a ridge stays a river; two rivers keep the lower height. Rivers are drawn
/// 4-connected (a diagonal Bresenham step gets its corner cell too) so that water cannot leak
/// between two diagonal river cells. O(length of all segments in cells). The job may yield
/// every [`SEGMENTS_PER_TICK`] segments ([`JobCtx::tick`]).
pub async fn rasterise(
    rivers: &[RiverNetwork],
    orders: &[Vec<u32>],
    ridges: &[RidgeSegment],
    n: usize,
    noise: &NoiseParams,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Skeleton, Cancelled> {
    const STAGE: &str = "rasterising the skeleton";
    let mut sk = Skeleton {
        size: n,
        heights: vec![0.0; n * n],
        kinds: vec![CellKind::Free; n * n],
        river_order: vec![0; n * n],
    };
    let inside = |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < n && (y as usize) < n;
    let perlin = Perlin::new(seed);
    for (k, ridge) in ridges.iter().enumerate() {
        if k % SEGMENTS_PER_TICK == 0 {
            ctx.tick(0.2, STAGE).await?;
        }
        let (a, b) = (
            to_cell(DVec2::from(ridge.a), n),
            to_cell(DVec2::from(ridge.b), n),
        );
        let len = (((b.0 - a.0).pow(2) + (b.1 - a.1).pow(2)) as f64)
            .sqrt()
            .max(1.0);
        bresenham(a, b, |x, y| {
            if !inside(x, y) {
                return;
            }
            let i = y as usize * n + x as usize;
            if sk.kinds[i] == CellKind::River {
                return;
            }
            let t = ((((x - a.0).pow(2) + (y - a.1).pow(2)) as f64).sqrt() / len).min(1.0);
            let h = f64::from(ridge.height_a) + t * f64::from(ridge.height_b - ridge.height_a);
            let h = h as f32;
            if sk.kinds[i] == CellKind::Free || h > sk.heights[i] {
                sk.heights[i] = h;
            }
            sk.kinds[i] = CellKind::Ridge;
        });
    }
    add_ridge_noise(&mut sk, noise, &perlin, ctx).await?;
    for (net, order) in rivers.iter().zip(orders) {
        for (k, (p, c)) in net.link_pairs().enumerate() {
            if k % SEGMENTS_PER_TICK == 0 {
                ctx.tick(0.2, STAGE).await?;
            }
            let (a, b) = (to_cell(net.nodes[p], n), to_cell(net.nodes[c], n));
            let (ha, hb) = (f64::from(net.height[p]), f64::from(net.height[c]));
            let len = (((b.0 - a.0).pow(2) + (b.1 - a.1).pow(2)) as f64)
                .sqrt()
                .max(1.0);
            let mut previous: Option<(i64, i64)> = None;
            let put = |x: i64, y: i64, sk: &mut Skeleton| {
                if !inside(x, y) {
                    return;
                }
                let i = y as usize * n + x as usize;
                let t = ((((x - a.0).pow(2) + (y - a.1).pow(2)) as f64).sqrt() / len).min(1.0);
                let h = (ha + t * (hb - ha)) as f32;
                if sk.kinds[i] != CellKind::River || h < sk.heights[i] {
                    sk.heights[i] = h;
                }
                sk.kinds[i] = CellKind::River;
                sk.river_order[i] = sk.river_order[i].max(order[c].min(255) as u8);
            };
            bresenham(a, b, |x, y| {
                if let Some((px, py)) = previous
                    && px != x
                    && py != y
                {
                    // Close the diagonal step with the corner cell (4-connected rivers).
                    put(x, py, &mut sk);
                }
                put(x, y, &mut sk);
                previous = Some((x, y));
            });
        }
    }
    Ok(sk)
}

/// Segments rasterised between two looks at the clock.
const SEGMENTS_PER_TICK: usize = 512;

/// Adds eq. 5's `F(P)` (fractal Perlin noise, `noise.amplitude` metres) to every ridge cell.
/// The noise depends on the cell only, so it is added once per cell after the linear heights
/// of all segments were rasterised (the highest segment wins, as before), not once per
/// segment crossing the cell. O(cells) scan plus O(ridge cells x octaves) noise, in bands of
/// rows gathered on all threads natively, with the job's ticks between groups of bands.
async fn add_ridge_noise(
    sk: &mut Skeleton,
    noise: &NoiseParams,
    perlin: &Perlin,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    if noise.amplitude == 0.0 {
        return Ok(());
    }
    let n = sk.size;
    let band_len = ((1usize << 16) / n.max(1)).max(1) * n;
    let group_len = band_len * crate::compute::parallel::threads();
    let Skeleton { heights, kinds, .. } = sk;
    for (g, group) in heights.chunks_mut(group_len).enumerate() {
        let kinds = &kinds[g * group_len..];
        crate::compute::parallel::for_each_band(group, band_len, |k, band| {
            for (j, h) in band.iter_mut().enumerate() {
                let at = k * band_len + j;
                if kinds[at] != CellKind::Ridge {
                    continue;
                }
                let i = g * group_len + at;
                let (u, v) = ((i % n) as f64 / n as f64, (i / n) as f64 / n as f64);
                let f = noise.amplitude
                    * perlin.fbm(u, v, noise.frequency, noise.octaves, noise.roughness);
                *h = (f64::from(*h) + f) as f32;
            }
        });
        ctx.tick(0.2, "rasterising the skeleton: ridge noise")
            .await?;
    }
    Ok(())
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
