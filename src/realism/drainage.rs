//! Drainage density from D8 flow accumulation on a Priority-Flood filled copy.
//!
//! * Depressions are filled with Priority-Flood+ε: Barnes, R., Lehman, C. and Mulla, D. (2014).
//!   Priority-flood: An optimal depression-filling and watershed-labeling algorithm for digital
//!   elevation models. Computers & Geosciences 62, 117-127. doi:10.1016/j.cageo.2013.04.024.
//!   The seeds (outlets) are the map border and, as in Barnes' RichDEM, cells next to no-data.
//!   Each cell reached from a lower-or-equal cell is raised to the next representable `f64`
//!   above it, so every non-outlet cell has a strictly lower neighbour and flats drain.
//! * D8 (O'Callaghan and Mark 1984): each non-outlet cell drains to the neighbour with the
//!   steepest descent `(z - z_n) / distance`; outlets drain off the map.
//! * Flow accumulation in m² (each cell contributes its own area), in topological order.
//! * Channels are cells with accumulation ≥ the threshold; the channel length is the sum, over
//!   channel cells that have a receiver, of the distance to it (one cell or a diagonal), i.e.
//!   the length of the network through cell centres. Density = length (km) / area (km²) of
//!   the finite cells.

use super::grid::{DIRS8, Grid};
use crate::jobs::{CELLS_PER_TICK, Cancelled, JobCtx, finish_inline};
use crate::radix_heap::{RadixHeap, ordered_key_f64};

/// Result of the drainage analysis.
pub(super) struct Drainage {
    /// Channel length (km) per km² of finite cells.
    pub(super) density_per_km: f64,
    /// Among the [`STRAIGHT_TOP_SHARE`] of cells with the largest upstream area, the share
    /// whose flow has kept one D8 direction for [`STRAIGHT_RUN_CELLS`] cells or more
    /// upstream (along the donor of largest area): real land 0.04-0.13, channels locked to
    /// the grid's lines more.
    pub(super) straight_fraction: f64,
}

/// Share of the cells (largest upstream area first) the straight-run measure looks at.
pub const STRAIGHT_TOP_SHARE: f64 = 0.05;
/// Cells of one direction that make a run straight.
pub const STRAIGHT_RUN_CELLS: u32 = 8;

/// Is cell `(r, c)` an outlet: on the border, one of the grid's sinks, or next to a
/// non-finite cell?
fn is_outlet(g: &Grid, r: usize, c: usize) -> bool {
    if r == 0 || c == 0 || r + 1 == g.h || c + 1 == g.w {
        return true;
    }
    if !g.sinks.is_empty() && g.sinks.binary_search(&((r * g.w + c) as u32)).is_ok() {
        return true;
    }
    DIRS8.iter().any(|&(dr, dc)| {
        g.neighbour(r, c, dr, dc)
            .is_none_or(|n| !g.z[n].is_finite())
    })
}

/// Priority-Flood+ε: the filled heights and the outlet flags.
///
/// Heights pop in non-decreasing order (a cell raised sits just above the level that reached
/// it), so a monotone radix heap serves as the priority queue (amortised O(log range) per
/// cell with a small constant, against the binary heap's sift through memory). The result
/// does not depend on the order of equal heights: it is the least `z' >= z` with
/// `z'[i] = max(z[i], next_up(min of z' over the neighbours reached before i))`, the outlets
/// as they are. A terrain that already drains (every other finite cell has a strictly
/// lower finite neighbour, as the pipeline's conditioned terrains do) is that least surface
/// itself and skips the flood: one O(cells) scan. O(cells) memory.
pub(super) fn priority_flood_epsilon(g: &Grid) -> (Vec<f64>, Vec<bool>) {
    finish_inline(|ctx| async move { priority_flood_in(g, &ctx).await })
}

/// [`priority_flood_epsilon`] in a job: a tick after each row of the seeding and every
/// [`CELLS_PER_TICK`] cells the flood takes.
pub(super) async fn priority_flood_in(
    g: &Grid,
    ctx: &JobCtx,
) -> Result<(Vec<f64>, Vec<bool>), Cancelled> {
    const WHAT: &str = "filling depressions";
    let (w, h) = (g.w, g.h);
    let mut z = Vec::with_capacity(w * h);
    ctx.part(0.0, 0.05)
        .for_cells(w * h, WHAT, |cells| z.extend_from_slice(&g.z[cells]))
        .await?;
    let mut closed = ctx
        .part(0.05, 0.1)
        .map_cells(w * h, WHAT, |i| !z[i].is_finite())
        .await?;
    let (seeding, flooding) = (ctx.part(0.1, 0.5), ctx.part(0.5, 1.0));
    let mut outlet = vec![false; w * h];
    let mut heap = RadixHeap::<u64>::new();
    let mut drains = true;
    for r in 0..h {
        seeding.tick_of(r, h, WHAT).await?;
        for c in 0..w {
            let i = r * w + c;
            if closed[i] {
                continue;
            }
            if is_outlet(g, r, c) {
                closed[i] = true;
                outlet[i] = true;
                heap.push(ordered_key_f64(z[i]), i as u32);
            } else if drains {
                drains = DIRS8
                    .iter()
                    .any(|&(dr, dc)| g.neighbour(r, c, dr, dc).is_some_and(|n| z[n] < z[i]));
            }
        }
    }
    if drains {
        return Ok((z, outlet));
    }
    let mut taken = 0;
    while let Some((_, i)) = heap.pop() {
        taken += 1;
        if taken % CELLS_PER_TICK == 0 {
            flooding.tick_of(taken, w * h, WHAT).await?;
        }
        let i = i as usize;
        let zc = z[i];
        let (r, c) = (i / w, i % w);
        for &(dr, dc) in &DIRS8 {
            let Some(n) = g.neighbour(r, c, dr, dc) else {
                continue;
            };
            if closed[n] {
                continue;
            }
            closed[n] = true;
            if z[n] <= zc {
                z[n] = zc.next_up();
            }
            heap.push(ordered_key_f64(z[n]), n as u32);
        }
    }
    Ok((z, outlet))
}

/// The D8 receivers of a grid's cells: for each cell the direction of its step ([`DIRS8`]
/// index, [`Receivers::NONE`] for outlets and no-data), one byte a cell, where a vector of
/// `Option<(usize, f64)>` took 24 (1.6 GB of an 8129^2 export's flow map).
pub(super) struct Receivers {
    dir: Vec<u8>,
    /// Index offset and length (m) of a step in each direction.
    steps: [(isize, f64); 8],
}

impl Receivers {
    const NONE: u8 = u8::MAX;

    pub(super) fn len(&self) -> usize {
        self.dir.len()
    }

    /// The cell `i` drains to and the length of the step, or `None`.
    #[inline]
    pub(super) fn get(&self, i: usize) -> Option<(usize, f64)> {
        let d = self.dir[i];
        (d != Self::NONE).then(|| {
            let (off, len) = self.steps[usize::from(d)];
            (i.wrapping_add_signed(off), len)
        })
    }

    /// [`Self::get`] of every cell in order.
    pub(super) fn iter(&self) -> impl Iterator<Item = Option<(usize, f64)>> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// D8 receiver of every cell (`None` for outlets and no-data) with the length of the step.
/// Non-outlet cells are never on the border, so all their 8 neighbours exist.
pub(super) fn d8_receivers(g: &Grid, z: &[f64], outlet: &[bool]) -> Receivers {
    finish_inline(|ctx| async move { d8_receivers_in(g, z, outlet, &ctx).await })
}

/// [`d8_receivers`] in a job: a tick every [`CELLS_PER_TICK`] cells.
pub(super) async fn d8_receivers_in(
    g: &Grid,
    z: &[f64],
    outlet: &[bool],
    ctx: &JobCtx,
) -> Result<Receivers, Cancelled> {
    let w = g.w as isize;
    let steps = DIRS8.map(|(dr, dc)| (dr * w + dc, g.step_length(dr, dc)));
    let dir = ctx
        .map_cells(z.len(), "routing water", |i| {
            let zi = z[i];
            let mut dir = Receivers::NONE;
            if outlet[i] || !zi.is_finite() {
                return dir;
            }
            let mut best = 0.0;
            for (k, &(off, len)) in steps.iter().enumerate() {
                let Some(n) = i.checked_add_signed(off).filter(|&n| n < z.len()) else {
                    continue;
                };
                let drop = (zi - z[n]) / len;
                if drop > best {
                    best = drop;
                    dir = k as u8;
                }
            }
            dir
        })
        .await?;
    Ok(Receivers { dir, steps })
}

/// Upstream area (m²) of every cell: its own area plus that of all cells draining to it.
pub(super) fn flow_accumulation(g: &Grid, rcv: &Receivers) -> Vec<f64> {
    finish_inline(|ctx| async move { flow_accumulation_in(g, rcv, &ctx).await })
}

/// [`flow_accumulation`] in a job: a tick every [`CELLS_PER_TICK`] cells of each pass.
pub(super) async fn flow_accumulation_in(
    g: &Grid,
    rcv: &Receivers,
    ctx: &JobCtx,
) -> Result<Vec<f64>, Cancelled> {
    const WHAT: &str = "gathering the flow";
    let cell_area = g.cx * g.cy;
    let n = rcv.len();
    let mut area = ctx
        .part(0.0, 0.2)
        .map_cells(g.z.len(), WHAT, |i| {
            if g.z[i].is_finite() { cell_area } else { 0.0 }
        })
        .await?;
    let mut indegree = vec![0u8; n];
    ctx.part(0.2, 0.4)
        .for_cells(n, WHAT, |cells| {
            for i in cells {
                if let Some((j, _)) = rcv.get(i) {
                    indegree[j] += 1;
                }
            }
        })
        .await?;
    // Kahn's topological order: a cell is passed on once all its donors are done.
    // Counted first, so the stack is made once at its size: growing it would copy millions
    // of cells in one go.
    let mut sources = 0;
    ctx.part(0.4, 0.5)
        .for_cells(n, WHAT, |cells| {
            sources += indegree[cells].iter().filter(|&&d| d == 0).count();
        })
        .await?;
    let mut ready: Vec<u32> = Vec::with_capacity(sources);
    ctx.part(0.5, 0.6)
        .for_cells(n, WHAT, |cells| {
            ready.extend(cells.filter(|&i| indegree[i] == 0).map(|i| i as u32));
        })
        .await?;
    let (mut taken, passing) = (0, ctx.part(0.6, 1.0));
    while let Some(i) = ready.pop() {
        taken += 1;
        if taken % CELLS_PER_TICK == 0 {
            passing.tick_of(taken, n, WHAT).await?;
        }
        if let Some((j, _)) = rcv.get(i as usize) {
            area[j] += area[i as usize];
            indegree[j] -= 1;
            if indegree[j] == 0 {
                ready.push(j as u32);
            }
        }
    }
    Ok(area)
}

/// Upstream area (m²) of every cell of `heights` (`w` x `h`, cells `cell_m` wide) by D8 on
/// the Priority-Flood+epsilon surface (the measures' own routing), `None` when the shape or
/// cell size is not valid; no-data cells drain nothing (0).
pub fn drainage_area_m2(heights: &[f32], w: usize, h: usize, cell_m: f64) -> Option<Vec<f64>> {
    drainage_area_m2_with_sinks(heights, w, h, cell_m, &[])
}

/// [`drainage_area_m2`] with water also leaving at the interior cells `sinks` (a designed
/// terrain's river mouths).
pub fn drainage_area_m2_with_sinks(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_m: f64,
    sinks: &[u32],
) -> Option<Vec<f64>> {
    finish_inline(|ctx| async move {
        drainage_area_m2_with_sinks_in(heights, w, h, cell_m, sinks, &ctx).await
    })
}

/// [`drainage_area_m2_with_sinks`] in a job (an export's flow and splat maps): every pass
/// ticks.
pub async fn drainage_area_m2_with_sinks_in(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_m: f64,
    sinks: &[u32],
    ctx: &JobCtx,
) -> Result<Option<Vec<f64>>, Cancelled> {
    let routed = routed_in(heights, w, h, cell_m, sinks, ctx).await?;
    Ok(routed.map(|r| r.area))
}

/// Where each cell of `heights` (`w` x `h`, cells `cell_x_m` x `cell_y_m`) drains by the
/// measures' own routing (D8 on the Priority-Flood+epsilon surface, water leaving at the
/// border and beside no data): the index of the cell it drains to, `u32::MAX` for outlets
/// and no data, and the filled heights (strictly lower at each step down). `None` when the
/// shape or cell size is not valid. O(cells).
pub fn descent(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_x_m: f64,
    cell_y_m: f64,
) -> Option<(Vec<u32>, Vec<f64>)> {
    let mut g = Grid::new(heights, w, h, cell_x_m, cell_y_m)?;
    let (z, outlet) = priority_flood_epsilon(&g);
    g.z = z;
    let rcv = d8_receivers(&g, &g.z, &outlet);
    let to = rcv
        .iter()
        .map(|r| r.map_or(u32::MAX, |(j, _)| j as u32))
        .collect();
    Some((to, g.z))
}

/// The measures' routing of `heights` with water also leaving at `sinks`: the grid with its
/// heights replaced by the Priority-Flood+epsilon surface (no data where the input had
/// none), the D8 receivers and the upstream areas. The input's `f64` copy is let go before
/// the routing allocates its own fields. `None` when the shape or cell size is not valid.
async fn routed_in(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_m: f64,
    sinks: &[u32],
    ctx: &JobCtx,
) -> Result<Option<Routed>, Cancelled> {
    let Some(g) = Grid::new_in(heights, w, h, cell_m, cell_m, &ctx.part(0.0, 0.1)).await? else {
        return Ok(None);
    };
    let mut g = g.with_sinks(sinks);
    let (z, outlet) = priority_flood_in(&g, &ctx.part(0.1, 0.6)).await?;
    g.z = z;
    let rcv = d8_receivers_in(&g, &g.z, &outlet, &ctx.part(0.6, 0.8)).await?;
    let area = flow_accumulation_in(&g, &rcv, &ctx.part(0.8, 1.0)).await?;
    Ok(Some(Routed { g, rcv, area }))
}

/// What [`routed_in`] gives.
struct Routed {
    g: Grid,
    rcv: Receivers,
    area: Vec<f64>,
}

/// The outlet (a cell index) every cell of `heights` drains to by the same D8 routing as
/// [`drainage_area_m2`], and every cell's upstream area (m²); `u32::MAX` for no-data.
/// `None` when the shape or cell size is not valid. Water also leaves at the interior cells
/// `sinks` (a designed terrain's river mouths). O(cells): each chain is walked once.
pub fn outlets(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_m: f64,
    sinks: &[u32],
) -> Option<(Vec<u32>, Vec<f64>)> {
    finish_inline(|ctx| async move { outlets_in(heights, w, h, cell_m, sinks, &ctx).await })
}

/// [`outlets`] in a job (an export's basin map): every pass ticks.
pub async fn outlets_in(
    heights: &[f32],
    w: usize,
    h: usize,
    cell_m: f64,
    sinks: &[u32],
    ctx: &JobCtx,
) -> Result<Option<(Vec<u32>, Vec<f64>)>, Cancelled> {
    let routing = routed_in(heights, w, h, cell_m, sinks, &ctx.part(0.0, 0.9)).await?;
    let Some(Routed { g, rcv, area }) = routing else {
        return Ok(None);
    };
    let ctx = ctx.part(0.9, 1.0);
    let mut out = vec![u32::MAX; rcv.len()];
    let mut path = Vec::new();
    for start in 0..rcv.len() {
        if start % CELLS_PER_TICK == 0 {
            ctx.tick_of(start, rcv.len(), "finding the basins").await?;
        }
        if out[start] != u32::MAX || !g.z[start].is_finite() {
            continue;
        }
        let mut at = start;
        // Walk down until a cell whose outlet is known, or one with no receiver.
        let end = loop {
            if out[at] != u32::MAX {
                break out[at];
            }
            path.push(at);
            match rcv.get(at) {
                Some((next, _)) => at = next,
                None => break at as u32,
            }
        };
        for cell in path.drain(..) {
            out[cell] = end;
        }
    }
    Ok(Some((out, area)))
}

/// Drainage density (km/km²) for channels of upstream area ≥ `threshold_m2`.
pub(super) fn drainage(g: &Grid, threshold_m2: f64) -> Drainage {
    let (z, outlet) = priority_flood_epsilon(g);
    let rcv = d8_receivers(g, &z, &outlet);
    let area = flow_accumulation(g, &rcv);
    let mut length_m = 0.0;
    for (&a, r) in area.iter().zip(rcv.iter()) {
        if let Some((_, step)) = r
            && a >= threshold_m2
        {
            length_m += step;
        }
    }
    let straight_fraction = straight_fraction(&area, &rcv);
    let finite = g.z.iter().filter(|v| v.is_finite()).count();
    let area_km2 = finite as f64 * g.cx * g.cy / 1e6;
    let density_per_km = if area_km2 > 0.0 {
        length_m / 1000.0 / area_km2
    } else {
        0.0
    };
    Drainage {
        density_per_km,
        straight_fraction,
    }
}

/// [`Drainage::straight_fraction`] of the routing `rcv` with upstream areas `area`. Each
/// cell is visited once all its donors were (Kahn's order over the receivers), which carries
/// each cell's run of one direction down to its receiver; its largest donor (by area, ties
/// to the lower index) is then known. The top share is picked by selection on (area, index),
/// a total order, so the set is the one a sort by area would end with. O(cells): the sort by
/// area this replaced took a third of `analyze` at 4096^2 (the test keeps it as the
/// reference, and the two agree).
fn straight_fraction(area: &[f64], rcv: &Receivers) -> f64 {
    let n = rcv.len();
    let mut routed: Vec<usize> = (0..n).filter(|&i| rcv.get(i).is_some()).collect();
    if routed.is_empty() {
        return 0.0;
    }
    // Donors of each cell not yet visited (at most 8).
    let mut waiting = vec![0u8; n];
    for &i in &routed {
        if let Some((j, _)) = rcv.get(i) {
            waiting[j] += 1;
        }
    }
    // The donor of largest area of each cell (usize::MAX: none yet) and each cell's run.
    let mut main = vec![usize::MAX; n];
    let mut run = vec![0u32; n];
    let step = |i: usize| rcv.get(i).map(|(j, _)| j as isize - i as isize);
    let mut ready: Vec<usize> = routed
        .iter()
        .copied()
        .filter(|&i| waiting[i] == 0)
        .collect();
    while let Some(i) = ready.pop() {
        let m = main[i];
        run[i] = if m != usize::MAX && step(m) == step(i) {
            run[m] + 1
        } else {
            1
        };
        if let Some((j, _)) = rcv.get(i) {
            let k = main[j];
            if k == usize::MAX || area[i] > area[k] || (area[i] == area[k] && i < k) {
                main[j] = i;
            }
            waiting[j] -= 1;
            if waiting[j] == 0 && rcv.get(j).is_some() {
                ready.push(j);
            }
        }
    }
    let top = ((routed.len() as f64 * STRAIGHT_TOP_SHARE).ceil() as usize).max(1);
    let first = routed.len() - top;
    routed.select_nth_unstable_by(first, |&a, &b| area[a].total_cmp(&area[b]).then(a.cmp(&b)));
    let straight = routed[first..]
        .iter()
        .filter(|&&i| run[i] >= STRAIGHT_RUN_CELLS)
        .count();
    straight as f64 / top as f64
}

#[cfg(test)]
mod tests {
    use std::cmp::Reverse;
    use std::collections::{BinaryHeap, VecDeque};

    use super::*;

    /// Priority-queue key: the height's bits mapped to an order-preserving `u64` (IEEE total
    /// order) in the high half and the cell index in the low half, reversed so that
    /// `BinaryHeap` (a max-heap) pops the lowest cell first, ties by lowest index.
    fn key(z: f64, i: usize) -> Reverse<u128> {
        let bits = z.to_bits();
        let ordered = if bits >> 63 == 1 {
            !bits
        } else {
            bits | (1 << 63)
        };
        Reverse((u128::from(ordered) << 64) | i as u128)
    }

    /// The cell index of a key.
    fn key_index(k: Reverse<u128>) -> usize {
        (k.0 & u128::from(u64::MAX)) as usize
    }

    /// The binary-heap Priority-Flood+ε with Barnes et al.'s pit queue this module used
    /// before the radix heap: the reference the radix heap must match bit for bit.
    ///
    /// Uses Barnes et al.'s "pit queue" refinement: a cell raised to just above the cell it was
    /// reached from lies in a depression and is processed from a FIFO before the heap, so only
    /// cells above the current flood level pay for the priority queue.
    fn binary_heap_flood(g: &Grid) -> (Vec<f64>, Vec<bool>) {
        let (w, h) = (g.w, g.h);
        let mut z = g.z.clone();
        let mut closed: Vec<bool> = z.iter().map(|v| !v.is_finite()).collect();
        let mut outlet = vec![false; w * h];
        let mut heap = BinaryHeap::new();
        let mut pit = VecDeque::new();
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if !closed[i] && is_outlet(g, r, c) {
                    closed[i] = true;
                    outlet[i] = true;
                    heap.push(key(z[i], i));
                }
            }
        }
        loop {
            let from_pit = match (pit.front(), heap.peek()) {
                (Some(&p), Some(&top)) => z[p] < z[key_index(top)],
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (None, None) => break,
            };
            let i = if from_pit {
                pit.pop_front()
            } else {
                heap.pop().map(key_index)
            };
            let Some(i) = i else { break };
            let zc = z[i];
            let (r, c) = (i / w, i % w);
            for &(dr, dc) in &DIRS8 {
                let Some(n) = g.neighbour(r, c, dr, dc) else {
                    continue;
                };
                if closed[n] {
                    continue;
                }
                closed[n] = true;
                if z[n] <= zc {
                    z[n] = zc.next_up();
                    pit.push_back(n);
                } else {
                    heap.push(key(z[n], n));
                }
            }
        }
        (z, outlet)
    }

    /// Heights with many ties, pits, flats and no-data holes: quantised noise.
    fn quantised(w: usize, h: usize, seed: u64, step: f32) -> Vec<f32> {
        let mut state = seed;
        (0..w * h)
            .map(|i| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let noise = (state >> 40) as f32 / (1u64 << 24) as f32;
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                if noise > 0.97 {
                    return f32::NAN;
                }
                let z = 0.3 * x + 0.2 * y + 20.0 * (0.1 * x).sin() * (0.07 * y).cos() + 8.0 * noise;
                (z / step).round() * step
            })
            .collect()
    }

    #[test]
    fn radix_heap_flood_is_the_binary_heap_flood_bit_for_bit() {
        for (seed, (w, h), step) in [
            (1, (64, 48), 1.0),
            (2, (97, 131), 4.0),
            (3, (200, 150), 0.25),
            (4, (33, 257), 16.0),
        ] {
            let heights = quantised(w, h, seed, step);
            let g = Grid::new(&heights, w, h, 30.0, 30.0).expect("a grid");
            let (fast, fast_outlets) = priority_flood_epsilon(&g);
            let (reference, outlets) = binary_heap_flood(&g);
            assert_eq!(fast_outlets, outlets, "seed {seed}");
            let raised = fast.iter().zip(&g.z).filter(|(a, b)| a != b).count();
            assert!(
                raised > w * h / 50,
                "seed {seed}: only {raised} cells raised"
            );
            for (i, (a, b)) in fast.iter().zip(&reference).enumerate() {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "seed {seed}, cell {i}: {a} vs {b}"
                );
            }
            // The filled surface drains: both leave it as it is (the fast one without
            // flooding).
            let filled = Grid {
                z: reference.clone(),
                ..g
            };
            let (again, _) = priority_flood_epsilon(&filled);
            let (reference_again, _) = binary_heap_flood(&filled);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&reference_again), bits(&reference), "seed {seed}");
            assert_eq!(bits(&again), bits(&reference), "seed {seed}");
        }
    }

    /// The sort-based pass [`straight_fraction`] replaced: cells in ascending (area, index)
    /// come after their donors.
    fn sorted_straight_fraction(area: &[f64], rcv: &Receivers) -> f64 {
        let mut order: Vec<usize> = (0..rcv.len()).filter(|&i| rcv.get(i).is_some()).collect();
        order.sort_by(|&a, &b| area[a].total_cmp(&area[b]).then(a.cmp(&b)));
        let mut main = vec![usize::MAX; rcv.len()];
        let mut run = vec![0u32; rcv.len()];
        let step = |i: usize| rcv.get(i).map(|(j, _)| j as isize - i as isize);
        for &i in &order {
            let m = main[i];
            run[i] = if m != usize::MAX && step(m) == step(i) {
                run[m] + 1
            } else {
                1
            };
            if let Some((j, _)) = rcv.get(i) {
                let k = main[j];
                if k == usize::MAX || area[i] > area[k] || (area[i] == area[k] && i < k) {
                    main[j] = i;
                }
            }
        }
        let top = ((order.len() as f64 * STRAIGHT_TOP_SHARE).ceil() as usize).max(1);
        let straight = order[order.len() - top..]
            .iter()
            .filter(|&&i| run[i] >= STRAIGHT_RUN_CELLS)
            .count();
        straight as f64 / top as f64
    }

    /// The O(cells) straight-run share is the sorted pass's, on rough quantised terrains
    /// (flats, no-data holes) and on planes whose flow keeps one direction (a share of 1).
    #[test]
    fn straight_runs_in_kahns_order_match_the_sorted_pass() {
        for (seed, (w, h), step) in [(1, (64, 48), 1.0), (2, (97, 131), 4.0), (5, (150, 90), 0.5)] {
            let heights = quantised(w, h, seed, step);
            let g = Grid::new(&heights, w, h, 30.0, 30.0).expect("a grid");
            let (z, outlet) = priority_flood_epsilon(&g);
            let rcv = d8_receivers(&g, &z, &outlet);
            let area = flow_accumulation(&g, &rcv);
            let (fast, sorted) = (
                straight_fraction(&area, &rcv),
                sorted_straight_fraction(&area, &rcv),
            );
            assert_eq!(
                fast.to_bits(),
                sorted.to_bits(),
                "seed {seed}: {fast} vs {sorted}"
            );
        }
        let (w, h) = (40, 40);
        let plane: Vec<f32> = (0..w * h).map(|i| (i / w) as f32 * 2.0).collect();
        let g = Grid::new(&plane, w, h, 30.0, 30.0).expect("a grid");
        let (z, outlet) = priority_flood_epsilon(&g);
        let rcv = d8_receivers(&g, &z, &outlet);
        let area = flow_accumulation(&g, &rcv);
        assert_eq!(
            straight_fraction(&area, &rcv),
            sorted_straight_fraction(&area, &rcv)
        );
        assert!(
            straight_fraction(&area, &rcv) > 0.5,
            "a plane's flow runs straight"
        );
    }

    /// A sink inside the map (a designed river's mouth) takes the water of the bowl around
    /// it; without it the bowl is filled and drains over its rim to the border.
    #[test]
    fn a_sink_gathers_its_bowl() {
        let n = 21;
        let bowl: Vec<f32> = (0..n * n)
            .map(|i| ((i % n) as f32 - 10.0).hypot((i / n) as f32 - 10.0))
            .collect();
        let centre = 10 * n + 10;
        let with = drainage_area_m2_with_sinks(&bowl, n, n, 1.0, &[centre as u32]).unwrap();
        // Every cell off the border drains to the sink (the border cells are outlets).
        assert_eq!(with[centre], ((n - 2) * (n - 2)) as f64);
        let (outlet, _) = outlets(&bowl, n, n, 1.0, &[centre as u32]).unwrap();
        assert_eq!(outlet[centre + 1], centre as u32);
        let without = drainage_area_m2(&bowl, n, n, 1.0).unwrap();
        assert!(without[centre] < with[centre] / 2.0, "{}", without[centre]);
    }
}
