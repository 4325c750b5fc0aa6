//! Does the terrain drain along its rivers? D8 steepest descent on the final heights.

use std::ops::Range;

use serde::Serialize;

use super::radix_heap::{RadixHeap, ordered_key};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::skeleton::CellKind;

/// Drainage measures of a terrain (`strahler generate --report`, tests).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Drainage {
    pub river_cells: usize,
    /// River cells whose steepest descent leads to a river cell or off the map.
    pub river_cells_draining: usize,
    pub river_fraction: f64,
    /// Cells whose descent path reaches the map border (an outlet).
    pub cells_to_outlet: usize,
    pub outlet_fraction: f64,
    /// Interior cells with no lower neighbour (pits).
    pub pit_cells: usize,
    pub pit_fraction: f64,
}

const NEIGHBOURS: [(i64, i64, f32); 8] = [
    (-1, 0, 1.0),
    (1, 0, 1.0),
    (0, -1, 1.0),
    (0, 1, 1.0),
    (-1, -1, std::f32::consts::SQRT_2),
    (1, -1, std::f32::consts::SQRT_2),
    (-1, 1, std::f32::consts::SQRT_2),
    (1, 1, std::f32::consts::SQRT_2),
];

/// Rows per step of [`condition_and_measure`]: about 2^16 cells, a few milliseconds.
fn row_bands(w: usize, h: usize) -> impl Iterator<Item = Range<usize>> {
    let rows = ((1usize << 16) / w.max(1)).max(1);
    (0..h)
        .step_by(rows)
        .map(move |start| start..(start + rows).min(h))
}

/// D8 receivers of the cells of `rows`: the neighbour of steepest descent, `None` for a cell
/// with no lower neighbour. Border cells drain off the map when nothing inside is lower.
fn receivers_of_rows(field: &Heightfield, rows: Range<usize>, out: &mut Vec<Option<u32>>) {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    let cells = rows.start as i64 * w..rows.end as i64 * w;
    out.extend(cells.map(|i| {
        let (x, y) = (i % w, i / w);
        let mut best = None;
        let mut steepest = 0.0f32;
        for (dx, dy, dist) in NEIGHBOURS {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let j = ny * w + nx;
            let slope = (z[i as usize] - z[j as usize]) / dist;
            if slope > steepest {
                steepest = slope;
                best = Some(j as u32);
            }
        }
        best
    }));
}

/// Whether any interior cell of `rows` has no strictly lower neighbour (a pit or a flat).
fn rows_have_pits(field: &Heightfield, rows: Range<usize>) -> bool {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    let rows = (rows.start as i64).max(1)..(rows.end as i64).min(h - 1);
    rows.into_iter().any(|y| {
        (1..w - 1).any(|x| {
            let c = z[(y * w + x) as usize];
            !NEIGHBOURS
                .iter()
                .any(|(dx, dy, _)| z[((y + dy) * w + x + dx) as usize] < c)
        })
    })
}

/// Whether any interior cell has no strictly lower neighbour (a pit or a flat). O(cells).
/// A harmonic fill obeys the maximum principle, so pits can only sit on fixed cells; most
/// terrains have none and skip the flooding below.
pub fn has_pits(field: &Heightfield) -> bool {
    rows_have_pits(field, 0..field.height())
}

/// What [`fill_depressions`] changed.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Conditioning {
    /// Cells raised out of a depression.
    pub raised_cells: usize,
    /// Largest raise in metres.
    pub max_raise: f32,
}

/// Priority-Flood with epsilon (Barnes, Lehman and Mulla 2014): floods the terrain inward
/// from the map border in order of height; a cell reached from a higher one is raised just
/// above it (the next representable `f32`), so every cell then has a strictly descending
/// path to the border and no pit remains. Only depressions are touched (rivers, which
/// already descend to their estuaries, are not). O(cells log range) with a radix heap.
///
/// Runs in steps ([`Flood::run`]) so a caller can yield between them.
pub struct Flood {
    closed: Vec<bool>,
    heap: RadixHeap,
    result: Conditioning,
}

impl Flood {
    /// Seeds the flood with the border cells of `field`.
    pub fn new(field: &Heightfield) -> Self {
        let (w, h) = (field.width(), field.height());
        let z = field.data();
        let mut closed = vec![false; z.len()];
        // Heights pop in non-decreasing order (a raised cell sits just above the level that
        // reached it), so a monotone radix heap replaces the binary heap of the paper.
        let mut heap = RadixHeap::new();
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                closed[i] = true;
                heap.push(ordered_key(z[i]), i as u32);
            }
        }
        Self {
            closed,
            heap,
            result: Conditioning::default(),
        }
    }

    /// Pops at most `max_pops` cells; true once the flood has reached every cell.
    pub fn run(&mut self, field: &mut Heightfield, max_pops: usize) -> bool {
        let (w, h) = (field.width() as i64, field.height() as i64);
        let z = field.data_mut();
        let Self {
            closed,
            heap,
            result,
        } = self;
        for _ in 0..max_pops {
            let Some((_, i)) = heap.pop() else {
                return true;
            };
            let level = z[i as usize];
            let (x, y) = (i64::from(i) % w, i64::from(i) / w);
            for (dx, dy, _) in NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if closed[j] {
                    continue;
                }
                closed[j] = true;
                if z[j] <= level {
                    let raised = level.next_up();
                    result.raised_cells += 1;
                    result.max_raise = result.max_raise.max(raised - z[j]);
                    z[j] = raised;
                }
                heap.push(ordered_key(z[j]), j as u32);
            }
        }
        heap.is_empty()
    }

    pub fn result(&self) -> Conditioning {
        self.result
    }
}

/// [`Flood`] in one go.
pub fn fill_depressions(field: &mut Heightfield) -> Conditioning {
    let mut flood = Flood::new(field);
    flood.run(field, usize::MAX);
    flood.result()
}

/// Whether cell `i` of a `w` x `h` grid is on the map border.
fn is_border(i: usize, w: usize, h: usize) -> bool {
    let (x, y) = (i % w, i / w);
    x == 0 || y == 0 || x + 1 == w || y + 1 == h
}

/// Drainage measured in passes over ranges of cells (receivers by rows, then each cell's
/// fate, then the counts), so a caller can yield between ranges. O(cells): each cell's
/// outlet is resolved once along its descent path.
struct Measuring {
    w: usize,
    h: usize,
    recv: Vec<Option<u32>>,
    /// 0 = unknown, 1 = reaches an outlet, 2 = ends in a pit.
    fate: Vec<u8>,
    path: Vec<usize>,
    drainage: Drainage,
}

impl Measuring {
    fn new(field: &Heightfield) -> Self {
        let (w, h) = (field.width(), field.height());
        Self {
            w,
            h,
            recv: Vec::with_capacity(w * h),
            fate: vec![0; w * h],
            path: Vec::new(),
            drainage: Drainage::default(),
        }
    }

    /// Follows the descent from every cell of `starts` (all receivers known).
    fn resolve(&mut self, starts: Range<usize>) {
        let border = |i: usize| is_border(i, self.w, self.h);
        let (recv, fate, path) = (&self.recv, &mut self.fate, &mut self.path);
        let n = fate.len();
        for start in starts {
            let mut i = start;
            while fate[i] == 0 {
                path.push(i);
                match recv[i] {
                    Some(j) => i = j as usize,
                    None => {
                        fate[i] = if border(i) { 1 } else { 2 };
                        break;
                    }
                }
                if path.len() > n {
                    break; // cannot happen with strict descent; guards against NaN heights
                }
            }
            let result = if fate[i] == 0 { 2 } else { fate[i] };
            for &p in path.iter() {
                fate[p] = result;
            }
            path.clear();
        }
    }

    /// Counts the cells of `cells` (all fates known).
    fn tally(&mut self, kinds: &[CellKind], cells: Range<usize>) {
        let border = |i: usize| is_border(i, self.w, self.h);
        let d = &mut self.drainage;
        for i in cells {
            if self.fate[i] == 1 {
                d.cells_to_outlet += 1;
            }
            if self.recv[i].is_none() && !border(i) {
                d.pit_cells += 1;
            }
            if kinds[i] == CellKind::River {
                d.river_cells += 1;
                let ok = match self.recv[i] {
                    Some(j) => kinds[j as usize] == CellKind::River,
                    None => border(i),
                };
                if ok {
                    d.river_cells_draining += 1;
                }
            }
        }
    }

    fn finish(self) -> Drainage {
        let mut d = self.drainage;
        let n = self.fate.len();
        d.river_fraction = d.river_cells_draining as f64 / d.river_cells.max(1) as f64;
        d.outlet_fraction = d.cells_to_outlet as f64 / n as f64;
        d.pit_fraction = d.pit_cells as f64 / n as f64;
        d
    }
}

/// Measures drainage. O(cells).
pub fn measure(field: &Heightfield, kinds: &[CellKind]) -> Drainage {
    let mut m = Measuring::new(field);
    let n = field.width() * field.height();
    receivers_of_rows(field, 0..field.height(), &mut m.recv);
    m.resolve(0..n);
    m.tally(kinds, 0..n);
    m.finish()
}

/// Floods the depressions of `field` if it has pits, then measures its drainage: the same
/// results as [`has_pits`], [`fill_depressions`] and [`measure`], computed in steps of about
/// 2^16 cells with [`JobCtx::tick`] between them, so the browser keeps painting while a
/// large terrain is checked. O(cells log range).
pub async fn condition_and_measure(
    field: &mut Heightfield,
    kinds: &[CellKind],
    ctx: &JobCtx,
) -> Result<(Conditioning, Drainage), Cancelled> {
    const STAGE: &str = "checking drainage";
    let (w, h) = (field.width(), field.height());
    let mut pits = false;
    for rows in row_bands(w, h) {
        // A pit's neighbours in the rows around it are read from the whole field.
        if rows_have_pits(field, rows) {
            pits = true;
            break;
        }
        ctx.tick(0.95, STAGE).await?;
    }
    let mut conditioning = Conditioning::default();
    if pits {
        let mut flood = Flood::new(field);
        while !flood.run(field, 1 << 16) {
            ctx.tick(0.95, "filling depressions").await?;
        }
        conditioning = flood.result();
    }
    let mut m = Measuring::new(field);
    for rows in row_bands(w, h) {
        receivers_of_rows(field, rows, &mut m.recv);
        ctx.tick(0.96, STAGE).await?;
    }
    for rows in row_bands(w, h) {
        m.resolve(rows.start * w..rows.end * w);
        ctx.tick(0.97, STAGE).await?;
    }
    for rows in row_bands(w, h) {
        m.tally(kinds, rows.start * w..rows.end * w);
        ctx.tick(0.98, STAGE).await?;
    }
    Ok((conditioning, m.finish()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilted_plane_drains_and_a_bowl_has_one_pit() {
        let n = 9;
        let plane: Vec<f32> = (0..n * n).map(|i| (i % n) as f32).collect();
        let kinds = vec![CellKind::Free; n * n];
        let d = measure(&Heightfield::from_vec(n, n, plane).unwrap(), &kinds);
        assert_eq!(d.outlet_fraction, 1.0);
        assert_eq!(d.pit_cells, 0);
        let bowl: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 4.0, (i / n) as f32 - 4.0);
                x * x + y * y
            })
            .collect();
        let mut bowl = Heightfield::from_vec(n, n, bowl).unwrap();
        let d = measure(&bowl, &kinds);
        assert!(has_pits(&bowl));
        assert_eq!(d.pit_cells, 1);
        assert_eq!(d.cells_to_outlet, 0);
        // Flooding the bowl leaves no pit and every cell draining out.
        let c = fill_depressions(&mut bowl);
        assert!(c.raised_cells > 0);
        let d = measure(&bowl, &kinds);
        assert_eq!((d.pit_cells, d.outlet_fraction), (0, 1.0));
        assert!(!has_pits(&bowl));
    }

    /// The stepped version gives what the one-shot functions give, pits and all.
    #[test]
    fn stepped_conditioning_and_measuring_match_the_one_shot_functions() {
        let (w, h) = (300, 700);
        let mut rng = 12345u64;
        let heights: Vec<f32> = (0..w * h)
            .map(|i| {
                rng = rng
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = (rng >> 40) as f32 / (1u64 << 24) as f32;
                ((i % w) as f32 * 0.3 + (i / w) as f32 * 0.1) + 20.0 * noise
            })
            .collect();
        let kinds: Vec<CellKind> = (0..w * h)
            .map(|i| {
                if i % w == 150 {
                    CellKind::River
                } else {
                    CellKind::Free
                }
            })
            .collect();
        let mut one_shot = Heightfield::from_vec(w, h, heights).unwrap();
        let mut stepped = one_shot.clone();
        assert!(has_pits(&one_shot));
        let c1 = fill_depressions(&mut one_shot);
        let d1 = measure(&one_shot, &kinds);
        let (c2, d2) = pollster::block_on(condition_and_measure(
            &mut stepped,
            &kinds,
            &JobCtx::detached(),
        ))
        .unwrap();
        assert_eq!(one_shot.checksum(), stepped.checksum());
        assert!(c1.raised_cells > 0);
        assert_eq!(
            (c1.raised_cells, c1.max_raise),
            (c2.raised_cells, c2.max_raise)
        );
        assert_eq!(
            (
                d1.river_cells,
                d1.river_cells_draining,
                d1.cells_to_outlet,
                d1.pit_cells
            ),
            (
                d2.river_cells,
                d2.river_cells_draining,
                d2.cells_to_outlet,
                d2.pit_cells
            )
        );
        assert_eq!((d2.pit_cells, d2.outlet_fraction), (0, 1.0));
    }
}
