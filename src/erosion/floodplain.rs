//! Valley floors that widen downstream: before erosion, the land beside each drawn river is
//! cut down to a floor that rises gently away from the channel, as wide as the river's
//! drainage area asks, and kept as base level with the river.
//!
//! Valley-floor width grows with drainage area as a power near 1/2 (Tomkin et al. 2003,
//! "Controls on valley-floor width"; Snyder et al. 2003; the same scaling as channel width in
//! hydraulic geometry, Leopold & Maddock 1953, since discharge grows with area). Here the
//! floor's half-width is `W = k sqrt(A)` ([`HALF_WIDTH_PER_SQRT_AREA`]: about 85 m either
//! side of a 50 km^2 river, 420 m for 1250 km^2), reached from the nearest channel cell in
//! Euclidean distance, so floors have no grid shape, and its height is the channel's plus
//! [`CROSS_RISE`] of the distance (a floodplain drains to its river), and never below the
//! highest river cell beside it (so each river cell still drains along its own river). A
//! floor only lowers the design, never raises it. A river too small for one cell of floor
//! keeps the V of its valley. Departure from the papers: seed 000 keeps the
//! design's heights beside the rivers and erosion (Braun & Willett 2013) cuts only by stream
//! power, which leaves every valley V-shaped, a flat groove one river wide.
//!
//! The area is the design's D8 drainage area towards the map's edge and the river mouths
//! inside it (Priority-Flood routing, as the solver's), gathered along the rivers to their
//! estuaries, so the floor is set before the solver runs and both backends start from it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::{ErosionError, receivers_and_area};
use crate::heightfield::Heightfield;
use crate::skeleton::CellKind;

/// `k` of the floor's half-width `W = k sqrt(A)` (metres per metre of sqrt(area)).
pub const HALF_WIDTH_PER_SQRT_AREA: f64 = 0.012;

/// How much a floor rises per metre away from its channel (0.4%).
pub const CROSS_RISE: f64 = 0.004;

/// The widest half-floor, in cells.
const MAX_HALF_WIDTH_CELLS: f64 = 32.0;

/// The design with its valley floors cut in, and the floor cells marked
/// [`CellKind::Floor`] in a copy of `kinds` (`None` where no river is large enough for a
/// floor). `field` is square, cells `cell_m` wide; `mouths` are the river mouths inside the
/// map ([`crate::skeleton::Skeleton::mouths`]). O(cells log cells) for the routing, plus
/// O(floor cells log floor cells).
pub fn valley_floors(
    field: &Heightfield,
    kinds: &[CellKind],
    mouths: &[u32],
    cell_m: f64,
) -> Result<Option<(Heightfield, Vec<CellKind>)>, ErosionError> {
    let n = field.width();
    let channel: Vec<bool> = kinds
        .iter()
        .map(|k| matches!(k, CellKind::River | CellKind::Valley))
        .collect();
    if !channel.contains(&true) {
        return Ok(None);
    }
    // Water leaves the map at its edge and at the mouths inside it (the rivers' estuaries):
    // with the channels as sinks instead, a channel cell would only gather the slopes beside
    // it, not its river's basin.
    let mut edge = super::stage::border_cells(n);
    for &i in mouths {
        edge[i as usize] = true;
    }
    let routing = receivers_and_area(field.data(), n, n, cell_m, &edge)?;
    let half_width: Vec<f32> = routing
        .area
        .iter()
        .map(|a| {
            let cells = HALF_WIDTH_PER_SQRT_AREA * f64::from(*a).sqrt() / cell_m;
            cells.min(MAX_HALF_WIDTH_CELLS) as f32
        })
        .collect();
    let sources = (0..n * n).filter(|&i| channel[i] && half_width[i] >= 1.0);
    let nearest = nearest_within(n, sources, &half_width);
    let z = field.data();
    let mut heights = z.to_vec();
    let mut floored = kinds.to_vec();
    let mut any = false;
    for (i, near) in nearest.iter().enumerate() {
        let Some((source, distance)) = near else {
            continue;
        };
        if channel[i] {
            continue;
        }
        let floor = z[*source as usize] + (CROSS_RISE * f64::from(*distance) * cell_m) as f32;
        // Never below a river beside it: each river cell keeps its steepest way down along
        // its own river (a floor cell of a lower reach nearby would take the water across).
        let banks = highest_channel_beside(z, &channel, n, i)
            .map_or(f32::MIN, |h| h + (CROSS_RISE * cell_m) as f32);
        heights[i] = heights[i].min(floor.max(banks));
        floored[i] = CellKind::Floor;
        any = true;
    }
    if !any {
        return Ok(None);
    }
    let field = Heightfield::from_vec(n, n, heights).map_err(|_| ErosionError::InvalidParam {
        field: "heights",
        problem: "the floors changed the grid's size (a bug)".into(),
    })?;
    Ok(Some((field, floored)))
}

/// The highest channel cell among the 8 neighbours of cell `i`, if any.
fn highest_channel_beside(z: &[f32], channel: &[bool], n: usize, i: usize) -> Option<f32> {
    let (x, y) = (i % n, i / n);
    let mut highest: Option<f32> = None;
    for yy in y.saturating_sub(1)..(y + 2).min(n) {
        for xx in x.saturating_sub(1)..(x + 2).min(n) {
            let j = yy * n + xx;
            if channel[j] {
                highest = Some(highest.map_or(z[j], |h| h.max(z[j])));
            }
        }
    }
    highest
}

/// For each cell of an `n` x `n` grid, the nearest of `sources` (cell index) and the
/// Euclidean distance to it in cells, among the sources whose `reach` (cells) it is within;
/// `None` beyond every reach. Dijkstra's order with each cell carrying its nearest source
/// (the propagation of Danielsson's vector distance transform), so the distance is measured
/// to the source itself, not along grid steps.
fn nearest_within(
    n: usize,
    sources: impl Iterator<Item = usize>,
    reach: &[f32],
) -> Vec<Option<(u32, f32)>> {
    let mut best: Vec<Option<(u32, f32)>> = vec![None; n * n];
    let mut heap = BinaryHeap::new();
    for s in sources {
        best[s] = Some((s as u32, 0.0));
        heap.push(Reverse((0u32, s as u32)));
    }
    while let Some(Reverse((bits, i))) = heap.pop() {
        let i = i as usize;
        let Some((source, d)) = best[i] else { continue };
        if d.to_bits() != bits {
            continue;
        }
        let s = source as usize;
        let (sx, sy) = ((s % n) as f32, (s / n) as f32);
        let (x, y) = (i % n, i / n);
        for yy in y.saturating_sub(1)..(y + 2).min(n) {
            for xx in x.saturating_sub(1)..(x + 2).min(n) {
                let j = yy * n + xx;
                let dj = (xx as f32 - sx).hypot(yy as f32 - sy);
                if dj <= reach[s] && best[j].is_none_or(|(_, old)| dj < old) {
                    best[j] = Some((source, dj));
                    heap.push(Reverse((dj.to_bits(), j as u32)));
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A river down a tilted valley: the floor is wider downstream (more area), flat across
    /// within the rise, never above the design, and its cells drain to the river.
    #[test]
    fn floors_widen_downstream_and_rise_from_the_river() {
        // The half-width in cells is k sqrt(area in cells): 0.012 sqrt(32000) = 2 cells for
        // the half of this map that drains to the river.
        let n = 256;
        let cell = 50.0;
        let mid = n / 2;
        // A V valley along x = mid, falling towards y = n - 1 at 1%.
        let data: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                let across = (x as f32 - mid as f32).abs() * cell as f32 * 0.3;
                (n - y) as f32 * cell as f32 * 0.01 + across
            })
            .collect();
        let field = Heightfield::from_vec(n, n, data.clone()).unwrap();
        let mut kinds = vec![CellKind::Free; n * n];
        for y in 0..n {
            kinds[y * n + mid] = CellKind::River;
        }
        let (floored, marked) = valley_floors(&field, &kinds, &[], cell)
            .unwrap()
            .expect("a floor");
        let width = |y: usize| {
            (0..n)
                .filter(|x| marked[y * n + x] == CellKind::Floor)
                .count()
        };
        assert!(
            width(n - 2) > width(n / 4),
            "{} vs {}",
            width(n - 2),
            width(n / 4)
        );
        assert!(width(n - 2) >= 3, "{}", width(n - 2));
        let z = floored.data();
        for i in 0..n * n {
            assert!(z[i] <= data[i]);
            if marked[i] == CellKind::Floor {
                let (x, y) = (i % n, i / n);
                let river = z[y * n + mid];
                let d = (x as f64 - mid as f64).abs();
                if d >= 2.0 {
                    let rise = f64::from(z[i] - river);
                    assert!((rise - CROSS_RISE * d * cell).abs() < 1e-2, "{i}: {rise}");
                } else {
                    // Beside the river: above every river cell it touches.
                    let upstream = z[y.saturating_sub(1) * n + mid];
                    assert!(z[i] > upstream.max(river), "{i}");
                }
            }
        }
    }

    /// Distances are Euclidean from the source, not counted in grid steps: the floor of a
    /// single source is a disc.
    #[test]
    fn the_reach_is_a_disc() {
        let n = 41;
        let reach = vec![10.0f32; n * n];
        let c = 20 * n + 20;
        let best = nearest_within(n, std::iter::once(c), &reach);
        let inside = best.iter().filter(|b| b.is_some()).count() as f64;
        let disc = std::f64::consts::PI * 100.0;
        assert!((inside - disc).abs() / disc < 0.05, "{inside} vs {disc}");
        assert_eq!(best[20 * n + 27].map(|b| b.1), Some(7.0));
        let diagonal = best[(20 + 6) * n + 26].unwrap().1;
        assert!((diagonal - 72f32.sqrt()).abs() < 1e-5, "{diagonal}");
    }
}
