//! The skeleton raster (seed paper 000, Sec. V-A): rivers and ridges drawn onto the grid with
//! Bresenham's algorithm and heights by eq. 5, as the fixed cells of the diffusion.

pub mod enrich;

pub mod meander;
mod raster;
pub mod sketch;

use glam::DVec2;

use crate::diffusion::{Constraints, ConstraintsError, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::noise::{FbmGrid, Perlin};
use crate::ridge::RidgeSegment;
use crate::river::RiverNetwork;
use raster::{Band, Line, RidgeNoise};

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
    /// A valley floor beside a river, set by the erosion stage on its own copy of the kinds
    /// (`erosion::floodplain`): base level with the river, not a channel.
    Floor = 5,
    /// A branch the L-system grew, not a stroke's trunk, set by the erosion stage on its own
    /// copy of the kinds (`erosion::guide`): a channel whose course the solver keeps (each cell
    /// drains to the next one down the branch) while the stream-power law sets its heights.
    Grown = 6,
}

impl CellKind {
    /// The kind whose `as u8` code is `code`.
    pub fn from_code(code: u8) -> Option<Self> {
        use CellKind::*;
        [Free, River, Ridge, Enriched, Valley, Floor, Grown]
            .into_iter()
            .find(|kind| *kind as u8 == code)
    }

    /// Whether the cell is on a river: a drawn one, or a branch the erosion lets the law
    /// shape ([`CellKind::Grown`]).
    pub fn is_river(self) -> bool {
        matches!(self, CellKind::River | CellKind::Grown)
    }
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
    /// The cells of the sketch's ridges and peaks (ascending, each once): the heights the
    /// user asked for, which the erosion holds (`erosion::hold`).
    pub held: Vec<u32>,
    /// The estuary cells of rivers that end inside the map, not on its border (ascending,
    /// each once): water leaves the map there as at the border (`terrain::drainage`), so a
    /// river drawn to a point inside the map flows out at its mouth rather than filling its
    /// catchment into a lake.
    pub mouths: Vec<u32>,
    /// The cells of the rivers' trunks, the strokes the user drew (ascending, each once); the
    /// other river cells are the branches the L-system grew. The erosion holds the trunks at
    /// their drawn heights and lets the law set the branches' (`erosion::guide`).
    pub trunk: Vec<u32>,
    /// The river cells of meandering links with how far inside their meander belt each lies,
    /// in cells ([`meander::course_in_belt`]; ascending by cell, each once): the erosion
    /// widens the valley floor beside them by that much, so the floor spans the belt.
    pub belt: Vec<(u32, f32)>,
    /// The rivers' courses as straight pieces below the cell ([`RiverPiece`]), the lines the
    /// river cells were drawn from: water drawn with banks that follow the course, not the
    /// cells' staircase.
    pub courses: Vec<RiverPiece>,
}

/// A straight piece of a river's course on the skeleton's grid, in cells (the cells' centres
/// at whole numbers, `x` along a row), with the Strahler order of its link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RiverPiece {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub order: u8,
}

impl Skeleton {
    /// The diffusion problem: skeleton cells fixed, the rest free (starting at the mean). A
    /// skeleton height that is not finite (a scene scaled beyond `f32`) is an error naming the
    /// cell, never a panic.
    pub fn constraints(&self) -> Result<Constraints, ConstraintsError> {
        let n = self.size;
        let mut fixed = FixedMask::new(n, n);
        let (mut sum, mut count) = (0.0f64, 0usize);
        for (i, k) in self.kinds.iter().enumerate() {
            if *k != CellKind::Free {
                fixed.fix_index(i);
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

impl Skeleton {
    /// An `n` x `n` skeleton with no cell set.
    pub fn empty(n: usize) -> Self {
        Self {
            size: n,
            heights: vec![0.0; n * n],
            kinds: vec![CellKind::Free; n * n],
            river_order: vec![0; n * n],
            held: Vec::new(),
            mouths: Vec::new(),
            trunk: Vec::new(),
            belt: Vec::new(),
            courses: Vec::new(),
        }
    }
}

/// Draws the river links (`orders`: every node's Strahler order, for the layers) into `sk`,
/// in bands of rows as `bands` says.
///
/// Heights along each link follow eq. 5 without noise: linear from start to end, so every
/// river cell keeps a lower neighbour downstream (drainage by construction). A cell claimed by
/// a river and a ridge stays a river, two rivers keep the lower height, so drawing the ridges
/// ([`rasterise_ridges`]) before or after gives the same skeleton. Rivers are drawn
/// 4-connected (a diagonal Bresenham step gets its corner cell too) so that water cannot leak
/// between two diagonal river cells. O(length of the links in cells + links x bands each
/// spans).
pub async fn rasterise_rivers(
    sk: &mut Skeleton,
    rivers: &[RiverNetwork],
    orders: &[Vec<u32>],
    bands: Bands,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    let n = sk.size;
    let lines: Vec<Line> = rivers
        .iter()
        .zip(orders)
        .flat_map(|(net, order)| {
            net.link_pairs().flat_map(move |(p, c)| {
                let (hp, hc) = (f64::from(net.height[p]), f64::from(net.height[c]));
                let link = (net.nodes[p], net.nodes[c], net.bends(c));
                wandering_link(link, (hp, hc), n, order[c])
            })
        })
        .collect();
    in_bands(sk, &lines, bands, ctx, |band, line| band.river(line)).await?;
    sk.mouths = interior_mouths(rivers, n);
    sk.trunk = trunk_cells(rivers, n);
    sk.belt = belt_cells(rivers, n);
    sk.courses = river_pieces(rivers, orders, n);
    Ok(())
}

/// The straight pieces of every link's wandering (or meandering) course, in cells, with
/// the link's order: [`Skeleton::courses`]. O(pieces).
fn river_pieces(rivers: &[RiverNetwork], orders: &[Vec<u32>], n: usize) -> Vec<RiverPiece> {
    let scale = (n.max(2) - 1) as f64;
    let cell = |p: DVec2| [(p.x * scale) as f32, (p.y * scale) as f32];
    rivers
        .iter()
        .zip(orders)
        .flat_map(|(net, order)| {
            net.link_pairs().flat_map(move |(p, c)| {
                let points = meander::course(net.nodes[p], net.nodes[c], n, net.bends(c));
                let order = order[c].min(255) as u8;
                let pieces: Vec<RiverPiece> = points
                    .windows(2)
                    .map(|w| RiverPiece {
                        a: cell(w[0]),
                        b: cell(w[1]),
                        order,
                    })
                    .collect();
                pieces
            })
        })
        .collect()
}

/// The river cells of the meandering links with their slack inside the belt, in cells
/// ([`Skeleton::belt`]; a cell on two links keeps the larger). O(length of the meandering
/// links in cells).
fn belt_cells(rivers: &[RiverNetwork], n: usize) -> Vec<(u32, f32)> {
    let scale = (n.max(2) - 1) as f64;
    let mut cells = Vec::new();
    for net in rivers {
        for (p, c) in net.link_pairs() {
            let (points, slack) =
                meander::course_in_belt(net.nodes[p], net.nodes[c], n, net.bends(c));
            if slack.iter().all(|s| *s <= 0.0) {
                continue;
            }
            for (w, s) in points.windows(2).zip(slack.windows(2)) {
                let line = Line {
                    a: to_cell(w[0], n),
                    b: to_cell(w[1], n),
                    start: 0.0,
                    rise: 0.0,
                    relief: [0.0; 2],
                    order: 0,
                };
                let cells_inside = (0.5 * (s[0] + s[1]) * scale) as f32;
                raster::river_cells(&line, |x, y| {
                    if (0..n as i64).contains(&x) && (0..n as i64).contains(&y) {
                        cells.push(((y * n as i64 + x) as u32, cells_inside));
                    }
                });
            }
        }
    }
    // Each cell once, with its largest slack.
    cells.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
    cells.dedup_by_key(|c| c.0);
    cells
}

/// The cells of the links that lie on a trunk ([`RiverNetwork::trunk`]), on the same
/// wandering course as they were drawn: [`Skeleton::trunk`]. O(length of the trunks in cells).
fn trunk_cells(rivers: &[RiverNetwork], n: usize) -> Vec<u32> {
    let mut cells = Vec::new();
    for net in rivers {
        for (p, c) in net.link_pairs() {
            if !net.trunk.get(c).copied().unwrap_or(false) {
                continue;
            }
            let heights = (f64::from(net.height[p]), f64::from(net.height[c]));
            let link = (net.nodes[p], net.nodes[c], net.bends(c));
            for line in wandering_link(link, heights, n, 0) {
                raster::river_cells(&line, |x, y| {
                    if (0..n as i64).contains(&x) && (0..n as i64).contains(&y) {
                        cells.push((y * n as i64 + x) as u32);
                    }
                });
            }
        }
    }
    cells.sort_unstable();
    cells.dedup();
    cells
}

/// The cells of the estuaries (the nodes with no parent) that lie inside the map, not on its
/// border: [`Skeleton::mouths`]. O(nodes).
fn interior_mouths(rivers: &[RiverNetwork], n: usize) -> Vec<u32> {
    let inside = 1..(n as i64 - 1);
    let mut mouths: Vec<u32> = rivers
        .iter()
        .flat_map(|net| {
            let roots = net.parent.iter().enumerate().filter(|(_, p)| p.is_none());
            roots.map(|(k, _)| to_cell(net.nodes[k], n))
        })
        .filter(|(x, y)| inside.contains(x) && inside.contains(y))
        .map(|(x, y)| (y * n as i64 + x) as u32)
        .collect();
    mouths.sort_unstable();
    mouths.dedup();
    mouths
}

/// The straight pieces of the wandering (or meandering) course of a link from `a` to `b`
/// ([`meander::course`]), with eq. 5's linear heights from `heights.0` at `a` to `heights.1`
/// at `b` by length along the course.
fn wandering_link(
    (a, b, bends): (DVec2, DVec2, crate::river::hydraulic::Bends),
    heights: (f64, f64),
    n: usize,
    order: u32,
) -> Vec<Line> {
    let points = meander::course(a, b, n, bends);
    let total: f64 = points.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    let height_at = |s: f64| heights.0 + (heights.1 - heights.0) * (s / total.max(1e-300));
    let mut along = 0.0;
    points
        .windows(2)
        .map(|w| {
            let step = (w[1] - w[0]).length();
            let line = Line {
                a: to_cell(w[0], n),
                b: to_cell(w[1], n),
                start: height_at(along),
                rise: height_at(along + step) - height_at(along),
                relief: [0.0; 2],
                order: order.min(255) as u8,
            };
            along += step;
            line
        })
        .collect()
}

/// Draws the ridge segments into `sk` (after or before the rivers) with eq. 5's heights, in
/// bands of rows for the platform ([`Bands::for_platform`]): linear from start to end plus
/// `F(P)` (fractal Perlin noise of `noise.amplitude` metres, which may lower a ridge by at
/// most half its relief above its rivers: [`RidgeNoise`]), the highest ridge winning a cell.
/// O(length of the segments in cells x octaves + segments x bands each spans).
pub async fn rasterise_ridges(
    sk: &mut Skeleton,
    ridges: &[RidgeSegment],
    noise: &NoiseParams,
    seed: u64,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    let n = sk.size;
    let lines: Vec<Line> = ridges
        .iter()
        .map(|r| Line {
            a: to_cell(DVec2::from(r.a), n),
            b: to_cell(DVec2::from(r.b), n),
            start: f64::from(r.height_a),
            rise: f64::from(r.height_b - r.height_a),
            relief: [f64::from(r.relief_a), f64::from(r.relief_b)],
            order: 0,
        })
        .collect();
    let perlin = Perlin::new(seed);
    let fbm = FbmGrid::new(&perlin, n, noise.frequency, noise.octaves, noise.roughness);
    let noise = RidgeNoise {
        amplitude: noise.amplitude,
        fbm: &fbm,
    };
    let bands = Bands::for_platform(n);
    in_bands(sk, &lines, bands, ctx, |band, line| {
        band.ridge(line, &noise)
    })
    .await?;
    free_ridges_beside_rivers(sk);
    Ok(())
}

/// How close (cells, in x and in y) to a river a ridge cell may stand: the river, the bank
/// band erosion keeps with it (1 cell by default) and one cell of slope between them.
const RIDGE_CLEARANCE: i64 = 3;

/// Frees the ridge cells within [`RIDGE_CLEARANCE`] cells of a river cell. A Voronoi ridge
/// runs halfway between river nodes, but a wandering river course ([`meander`]) can pass
/// beside one where nodes are close (at confluences): left fixed, such a cell stands as a
/// wall on the river's bank, steeper than any talus. Freed, the diffusion fills it from the
/// river and the ridge around it. O(ridge cells x 49).
fn free_ridges_beside_rivers(sk: &mut Skeleton) {
    let n = sk.size as i64;
    let r = RIDGE_CLEARANCE;
    let beside_river = |kinds: &[CellKind], i: usize| {
        let (x, y) = ((i as i64) % n, (i as i64) / n);
        (-r..=r).any(|dy| {
            (-r..=r).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                (0..n).contains(&u)
                    && (0..n).contains(&v)
                    && kinds[(v * n + u) as usize] == CellKind::River
            })
        })
    };
    let freed: Vec<usize> = (0..sk.kinds.len())
        .filter(|&i| sk.kinds[i] == CellKind::Ridge && beside_river(&sk.kinds, i))
        .collect();
    for i in freed {
        sk.kinds[i] = CellKind::Free;
        sk.heights[i] = 0.0;
    }
}

/// How a rasterisation splits the grid: bands of `rows` rows, `per_step` of them drawn at once
/// (on as many threads) between two looks at the job's clock.
#[derive(Clone, Copy, Debug)]
pub struct Bands {
    pub rows: usize,
    pub per_step: usize,
}

impl Bands {
    /// One band per thread natively; bands of 2^17 cells one at a time on the web, so the page
    /// keeps painting.
    pub fn for_platform(n: usize) -> Self {
        let threads = crate::parallel::threads();
        if cfg!(target_arch = "wasm32") {
            Self {
                rows: ((1usize << 17) / n.max(1)).max(1),
                per_step: 1,
            }
        } else {
            Self {
                rows: n.div_ceil(threads).max(1),
                per_step: threads,
            }
        }
    }

    /// The whole grid as one band, on the calling thread.
    pub fn whole(n: usize) -> Self {
        Self {
            rows: n.max(1),
            per_step: 1,
        }
    }
}

/// Draws `lines` into `sk` band by band ([`raster`]): every band draws the lines that reach
/// its rows, clipped to them.
async fn in_bands(
    sk: &mut Skeleton,
    lines: &[Line],
    bands: Bands,
    ctx: &JobCtx,
    draw: impl Fn(&mut Band<'_>, &Line) + Sync,
) -> Result<(), Cancelled> {
    let n = sk.size;
    let lines_of = raster::by_band(lines, n, bands.rows);
    let band_cells = bands.rows * n;
    let parts: Vec<Band<'_>> = sk
        .heights
        .chunks_mut(band_cells)
        .zip(sk.kinds.chunks_mut(band_cells))
        .zip(sk.river_order.chunks_mut(band_cells))
        .enumerate()
        .map(|(k, ((heights, kinds), river_order))| Band {
            n,
            first_row: k * bands.rows,
            heights,
            kinds,
            river_order,
        })
        .collect();
    let mut parts = parts.into_iter().enumerate().peekable();
    while parts.peek().is_some() {
        let step: Vec<_> = parts.by_ref().take(bands.per_step).collect();
        crate::parallel::for_each_item(step, |(k, mut band)| {
            for &i in &lines_of[k] {
                draw(&mut band, &lines[i as usize]);
            }
        });
        ctx.tick(0.2, "rasterising the skeleton").await?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn non_finite_heights_are_an_error_not_a_panic() {
        let n = 16;
        let mut kinds = vec![CellKind::Free; n * n];
        kinds[5] = CellKind::River;
        let mut heights = vec![0.0; n * n];
        heights[5] = f32::INFINITY;
        let skeleton = Skeleton {
            size: n,
            heights,
            kinds,
            river_order: vec![0; n * n],
            held: Vec::new(),
            mouths: Vec::new(),
            trunk: Vec::new(),
            belt: Vec::new(),
            courses: Vec::new(),
        };
        let err = skeleton.constraints().unwrap_err();
        assert!(err.to_string().contains("(5, 0)"), "{err}");
    }

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
