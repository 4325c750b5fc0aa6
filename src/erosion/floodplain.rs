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
//! **The channel in its floor** follows hydraulic geometry: within half the bankfull width
//! of the river ([`channel_width_m`], `~ A^0.5`, the law the drawn rivers' meanders take their
//! wavelength from: [`crate::river::hydraulic`]) the floor is the channel's bed, at the river's
//! height plus the cross rise; beyond it the floodplain stands a bankfull depth higher
//! ([`bankfull_depth_m`], `~ A^0.4`), so a large river runs in a channel as wide and deep as
//! its water asks, cut into its floodplain. Where the channel is narrower than a cell, the
//! river cell is the channel and the floodplain beside it stands the depth above it.
//!
//! **Opening out.** The half-width jumps where a tributary joins (its area does); each cell
//! takes the floor of its nearest channel cell, so the floor's edge stepped out at a right
//! angle there. The widths are spread along the channel cells wide enough for a floor with a
//! taper ([`WIDENING`], [`taper_along`]), so a floor opens out gradually, up the narrower reach
//! and into the tributary's mouth, each cell's channel sized by the reach its width came from.
//!
//! **Land below the floor.** A floor only lowers the design: land within its reach that
//! stands below the floor's height (near its outer edge, where a tributary's valley comes in)
//! keeps the design, rounded at the cell scale ([`super::floor_along::smooth_cells`]), as base
//! level with the floor.
//!
//! **Rock and footslopes.** A floor is narrower where the rock is hard and wider where it is
//! soft ([`half_width_cells`]: the half-width times the square root of the erodibility), so
//! one river's floor narrows into gorges and opens into basins along its course; and it
//! curves up into a footslope at its edge ([`footslope_m`]) where it meets the valley's walls.
//!
//! The area is the design's D8 drainage area towards the map's edge and the river mouths
//! inside it (Priority-Flood routing, as the solver's), gathered along the rivers to their
//! estuaries, so the floor is set before the solver runs and both backends start from it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::floor_along::{Floors, floor_inputs};
use super::{ErosionError, receivers_and_area};
use crate::heightfield::Heightfield;
pub use crate::river::hydraulic::channel_width_m;
use crate::skeleton::CellKind;

/// `k` of the floor's half-width `W = k sqrt(A)` (metres per metre of sqrt(area)).
pub const HALF_WIDTH_PER_SQRT_AREA: f64 = 0.012;

/// How much a floor rises per metre away from its channel (0.4%).
pub const CROSS_RISE: f64 = 0.004;

/// The slope a floor reaches at its edge over its cross rise (about 8.5 degrees): the
/// footslope where the valley's walls meet its floor ([`footslope_m`]).
pub const FOOTSLOPE: f64 = 0.15;

/// How far a floor stands above its flat profile `across` metres from its channel, on a floor
/// reaching `reach` metres: `FOOTSLOPE reach / 3 (across / reach)^3`, flat at the channel and
/// rising at [`FOOTSLOPE`] at the edge. Real valley floors are not flat to their walls:
/// colluvium and fans shed by the walls build concave footslopes that grade into the
/// floodplain (Ahnert 1996, "Introduction to Geomorphology", ch. 15; the "footslope" of
/// geomorphon and hillslope-profile classifications, Ruhe 1960), where a floor held flat to
/// its edge met walls at the threshold angle in a crease: a canal with straight banks at 50
/// km. Choice: a cubic, the simplest profile flat at the channel with its slope growing
/// smoothly to the edge. It only lowers land less than the flat floor would; its heights
/// still rise away from the channel, so the floor drains to it.
pub fn footslope_m(across: f64, reach: f64) -> f64 {
    if reach <= 0.0 {
        return 0.0;
    }
    let u = (across / reach).clamp(0.0, 1.0);
    FOOTSLOPE * reach / 3.0 * u * u * u
}

/// Bankfull depth at 1 km^2 of drainage area, metres; it grows as `A^0.4` (Leopold and
/// Maddock's depth exponent): 1 m at 100 km^2, 4 m at 1000 km^2.
pub const BANKFULL_DEPTH_AT_KM2: f64 = 0.25;

/// The bankfull depth in metres of a channel draining `area_m2`: how far its floodplain
/// stands above its bed.
pub fn bankfull_depth_m(area_m2: f64) -> f64 {
    // `libm`: the same bits natively and in wasm.
    BANKFULL_DEPTH_AT_KM2 * libm::pow(area_m2.max(0.0) / 1e6, 0.4)
}

/// The widest half-floor, in cells.
const MAX_HALF_WIDTH_CELLS: f64 = 32.0;

/// The half-width in cells of the floor beside a channel draining `area_m2`, on `cell_m`
/// cells, in rock `erodibility` times as erodible as the map's mean (1: the mean rock):
/// `k sqrt(A) sqrt(erodibility)`, at most [`MAX_HALF_WIDTH_CELLS`].
///
/// Valley floors are wide where the rock is weak and narrow to gorges where it is strong:
/// in weak rock the channel undercuts its walls faster than in strong rock, so a river of
/// one size planes a wider floor (Brocard and van der Beek 2006, "Influence of incision rate,
/// rock strength, and bedload supply on bedrock river gradients and valley-flat widths",
/// GSA Special Paper 398; Schanz and Montgomery 2016, "Lithologic controls on valley width
/// and strath terrace formation", Geomorphology 258, who measured floors several times wider
/// in weak mudstone than in strong rock along one river). Choice: the width scales as the
/// square root of the erodibility, as it does with the area, so the default rock's contrast
/// of 10 makes floors from 0.56 to 1.8 times the mean width, where one width along the whole
/// river read as a canal.
pub(super) fn half_width_cells(area_m2: f64, cell_m: f64, erodibility: f32) -> f32 {
    let rock = f64::from(erodibility.max(0.0)).sqrt();
    let cells = HALF_WIDTH_PER_SQRT_AREA * area_m2.sqrt() * rock / cell_m;
    cells.min(MAX_HALF_WIDTH_CELLS) as f32
}

/// The erodibility factor of cell `i` of `rock` (empty: the mean rock, 1).
pub(super) fn rock_at(rock: &[f32], i: usize) -> f32 {
    rock.get(i).copied().unwrap_or(1.0)
}

/// The design with its valley floors cut in, and the floor cells marked
/// [`CellKind::Floor`] in a copy of `kinds` (`None` where no river is large enough for a
/// floor). `field` is square, cells `cell_m` wide; `mouths` are the river mouths inside the
/// map ([`crate::skeleton::Skeleton::mouths`]); `belt` the meandering river cells with how
/// far inside their meander belt each lies, in cells ([`crate::skeleton::Skeleton::belt`]),
/// which widens the floor beside them by as much: a meander's floor spans its belt with
/// straight edges, its loops swinging from one side to the other (a floor as wide around the
/// loops themselves would wave with them). O(cells log cells) for the routing, plus
/// O(floor cells log floor cells).
pub fn valley_floors(
    field: &Heightfield,
    kinds: &[CellKind],
    mouths: &[u32],
    belt: &[(u32, f32)],
    rock: &[f32],
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
    let mut half_width: Vec<f32> = (routing.area.iter().enumerate())
        .map(|(i, a)| half_width_cells(f64::from(*a), cell_m, rock_at(rock, i)))
        .collect();
    // The widths are spread among the channel cells wide enough for a floor only (a river
    // rasterised two cells wide has cells beside its routed course draining little, which
    // keep no floor of their own), and before the meander belts widen them: a belt's slack
    // is laid cell by cell so that the floor spans the belt with straight edges, and spread
    // along the loops it would swing them out again.
    let with_floor: Vec<bool> = (0..n * n)
        .map(|i| channel[i] && half_width[i] >= 1.0)
        .collect();
    let origin = taper_along(&mut half_width, &with_floor, n, WIDENING);
    for &(cell, slack) in belt {
        if let Some(w) = half_width.get_mut(cell as usize)
            && *w >= 1.0
        {
            *w += slack.max(0.0);
        }
    }
    let sources = (0..n * n).filter(|&i| with_floor[i]);
    let nearest = nearest_within(n, sources, &half_width);
    let z = field.data();
    let floors = Floors {
        nearest: &nearest,
        channel: &channel,
        sources: &with_floor,
        n,
    };
    // The channel's size is that of the reach its floor's width came from.
    let inputs = floor_inputs(
        z,
        &floors,
        cell_m,
        |s| routing.area[origin[s] as usize],
        |s| (f64::from(half_width[s]) * cell_m) as f32,
    );
    let mut heights = z.to_vec();
    let mut floored = kinds.to_vec();
    let mut any = false;
    let mut kept: Vec<(usize, f32)> = Vec::new();
    for (i, near) in nearest.iter().enumerate() {
        let Some(_) = near else {
            continue;
        };
        if channel[i] {
            continue;
        }
        let across = f64::from(inputs.across[i]) * cell_m;
        let (area, reach) = (f64::from(inputs.area[i]), f64::from(inputs.reach[i]));
        let floor = floor_height(
            z,
            &channel,
            (n, cell_m),
            (i, inputs.base[i], across, area),
            reach,
        );
        if z[i] < floor && kinds[i] != CellKind::Grown {
            // Land below the floor: the design stays (a branch's own cells as they are).
            kept.push((i, floor));
        }
        heights[i] = heights[i].min(floor);
        floored[i] = CellKind::Floor;
        any = true;
    }
    if !any {
        return Ok(None);
    }
    // The land the floor does not lower keeps the design, whose raster steps beside a grown
    // branch no solver reshapes there: rounded, and never above the floor.
    let cells: Vec<usize> = kept.iter().map(|(i, _)| *i).collect();
    super::floor_along::smooth_cells(&mut heights, &cells, n, |j| {
        nearest[j].is_some() || channel[j]
    });
    for &(i, floor) in &kept {
        heights[i] = heights[i].min(floor);
    }
    let field = Heightfield::from_vec(n, n, heights).map_err(|_| ErosionError::InvalidParam {
        field: "heights",
        problem: "the floors changed the grid's size (a bug)".into(),
    })?;
    Ok(Some((field, floored)))
}

/// The land beside each river raised, where it is lower, a floor's cross rise above the
/// highest river cell it touches; `None` where no cell needed it. A river that wanders at the
/// cell scale rasterises with coves: a bank cell with river on three sides, which the design
/// fills near the lowest of them, so the river cell upstream of the cove drained across the
/// bank instead of along its course. Raised so, each river cell's steepest way down stays
/// on its river (as [`valley_floors`] holds its floors). A cell beside a river cell with no
/// lower river cell around it (its only way down) is left as it is: raised, it would dam
/// that river. O(river cells).
pub fn lift_coves(field: &Heightfield, kinds: &[CellKind], cell_m: f64) -> Option<Heightfield> {
    let n = field.width();
    let channel: Vec<bool> = kinds
        .iter()
        .map(|k| matches!(k, CellKind::River | CellKind::Valley))
        .collect();
    let z = field.data();
    let rise = (CROSS_RISE * cell_m) as f32;
    let around = |i: usize| {
        let (x, y) = (i % n, i / n);
        (y.saturating_sub(1)..(y + 2).min(n))
            .flat_map(move |yy| (x.saturating_sub(1)..(x + 2).min(n)).map(move |xx| yy * n + xx))
            .filter(move |&j| j != i)
    };
    let on_border = |i: usize| {
        let (x, y) = (i % n, i / n);
        x == 0 || y == 0 || x + 1 == n || y + 1 == n
    };
    // Whether a river cell has a way down along its river (or leaves the map).
    let drains_along = |i: usize| on_border(i) || around(i).any(|j| channel[j] && z[j] < z[i]);
    let mut lifted: Option<Vec<f32>> = None;
    for i in (0..n * n).filter(|&i| channel[i]) {
        for j in around(i).filter(|&j| !channel[j]) {
            let rivers = || around(j).filter(|&k| channel[k]);
            let Some(highest) = rivers().map(|k| z[k]).reduce(f32::max) else {
                continue;
            };
            let want = highest + rise;
            if z[j] < want && rivers().all(drains_along) {
                lifted.get_or_insert_with(|| z.to_vec())[j] = want;
            }
        }
    }
    lifted.and_then(|h| Heightfield::from_vec(n, n, h).ok())
}

/// The floor's height at cell `i` (of an `n` x `n` grid of `cell_m` cells), `across` metres
/// from its nearest channel cell, which drains `area` m^2 and has a floor reaching `reach`
/// metres from it, rising from `base` ([`super::floor_along`]): the channel's bed within half the
/// bankfull width, the floodplain a bankfull depth above it beyond, both rising
/// [`CROSS_RISE`] away from the channel and curving up into the footslope
/// ([`footslope_m`]); never below a channel cell of `z` beside it plus one cell's rise (each
/// channel cell keeps its steepest way down along its own channel: a floor cell of a lower
/// reach nearby would take the water across).
pub(super) fn floor_height(
    z: &[f32],
    channel: &[bool],
    (n, cell_m): (usize, f64),
    (i, base, across, area): (usize, f32, f64, f64),
    reach: f64,
) -> f32 {
    let bank = bankfull_depth_m(area) * bank_share(across - channel_width_m(area) / 2.0, cell_m);
    let rise = CROSS_RISE * across + bank + footslope_m(across, reach);
    let floor = base + rise as f32;
    let banks = highest_channel_beside(z, channel, n, i)
        .map_or(f32::MIN, |h| h + (CROSS_RISE * cell_m) as f32);
    floor.max(banks)
}

/// Cells a channel's bank rises over, from its bed to its floodplain.
pub const BANK_CELLS: f64 = 2.0;

/// How much of the bankfull depth a floor cell `beyond` metres past the channel's half-width
/// stands above the bed, on `cell_m` cells: a smoothstep over [`BANK_CELLS`] cells centred
/// on the channel's edge (none a cell inside it, half at the edge, all of it a cell outside),
/// so the channel is as wide as the law asks at mid-bank. A bank held as a step at the
/// half-width aliased on the grid: the distance is to the nearest channel cell, a staircase
/// along a diagonal course, so at 2-5 m cells each bank showed as a dotted line of one-cell
/// notches a bankfull depth high. Real banks are steep, but not steeper than the grid can
/// draw; over two cells the bank's line runs smoothly across the cells. Beside a channel
/// narrower than a cell the first cell still stands nearly the whole depth above it.
pub fn bank_share(beyond: f64, cell_m: f64) -> f64 {
    let t = (beyond / (BANK_CELLS * cell_m) + 0.5).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
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

/// How fast a floor narrows away from a wider reach along its channel, in cells of
/// half-width per cell of channel (0.2: the floor's edge meets the channel at 11 degrees).
///
/// A floor's width follows its channel's drainage area, which jumps where a tributary joins,
/// and each cell takes the floor of its nearest channel cell: so at every junction the
/// floor's edge stepped out at a right angle (boxes along the valley, scallops at 4096^2),
/// where real floors open out over some distance, the wider reach's alluvium reaching up the
/// narrower one (and up the tributary's mouth). Choice: the width spread along the channel
/// cells with this taper ([`taper_along`]); it only widens floors, never past the widest
/// reach near them.
pub const WIDENING: f32 = 0.2;

/// Spreads `width` (cells, one value a cell of an `n` x `n` grid) along the 8-connected
/// cells of `path`: each path cell ends with the most of its own width and every path cell's
/// width less `rate` times the length of the way between them along the path (Euclidean steps
/// of 1 or sqrt(2)). Returns, for each cell, the cell its width came from (itself where it
/// kept its own), whose drainage area then sets its channel's size. Dijkstra's order from the
/// widest cell down (a shortest path in the max-plus sense), so the widths do not depend on
/// the cells' order. Cells off the path keep their width. O(path cells log path cells).
pub(super) fn taper_along(width: &mut [f32], path: &[bool], n: usize, rate: f32) -> Vec<u32> {
    let mut origin: Vec<u32> = (0..width.len() as u32).collect();
    let mut heap: BinaryHeap<(u32, Reverse<u32>)> = (0..width.len())
        .filter(|&i| path[i] && width[i] > 0.0)
        .map(|i| (width[i].to_bits(), Reverse(i as u32)))
        .collect();
    while let Some((bits, Reverse(i))) = heap.pop() {
        let i = i as usize;
        if width[i].to_bits() != bits {
            continue;
        }
        let (x, y) = (i % n, i / n);
        for yy in y.saturating_sub(1)..(y + 2).min(n) {
            for xx in x.saturating_sub(1)..(x + 2).min(n) {
                let j = yy * n + xx;
                if j == i || !path[j] {
                    continue;
                }
                let step = if xx != x && yy != y {
                    std::f32::consts::SQRT_2
                } else {
                    1.0
                };
                let spread = width[i] - rate * step;
                if spread > width[j] {
                    width[j] = spread;
                    origin[j] = origin[i];
                    heap.push((spread.to_bits(), Reverse(j as u32)));
                }
            }
        }
    }
    origin
}

/// For each cell of an `n` x `n` grid, the nearest of `sources` (cell index) and the
/// Euclidean distance to it in cells, among the sources whose `reach` (cells) it is within;
/// `None` beyond every reach. Dijkstra's order with each cell carrying its nearest source
/// (the propagation of Danielsson's vector distance transform), so the distance is measured
/// to the source itself, not along grid steps.
pub(super) fn nearest_within(
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

    /// A channel whose floor's half-width jumps from 2 to 16 cells where a tributary would join:
    /// tapered, the width falls by at most [`WIDENING`] a cell upstream of the jump, is never
    /// less than it was, keeps its widest value, and each cell's width comes from the wide
    /// reach where it was raised. The floor's edge then opens out a cell a column or less,
    /// where it stepped out 3 cells or more at once (the wide reach's disc).
    #[test]
    fn a_floor_opens_out_along_its_channel_not_in_a_step() {
        let n = 80;
        let row = 40;
        let mut channel = vec![false; n * n];
        let mut width = vec![0.0f32; n * n];
        for x in 0..n {
            channel[row * n + x] = true;
            width[row * n + x] = if x < 40 { 2.0 } else { 16.0 };
        }
        let edge_steps = |width: &[f32]| {
            let sources = (0..n * n).filter(|&i| channel[i]);
            let reached = nearest_within(n, sources, width);
            let half = |x: usize| {
                (0..n)
                    .filter(|&y| reached[y * n + x].is_some())
                    .map(|y| y.abs_diff(row))
                    .max()
                    .unwrap_or(0)
            };
            (1..n - 1)
                .map(|x| half(x + 1).abs_diff(half(x)))
                .max()
                .unwrap_or(0)
        };
        assert!(edge_steps(&width) >= 3, "untapered: {}", edge_steps(&width));
        let before = width.clone();
        let origin = taper_along(&mut width, &channel, n, WIDENING);
        for x in 0..n - 1 {
            let (i, j) = (row * n + x, row * n + x + 1);
            assert!(width[i] >= before[i] && width[i] <= 16.0);
            assert!((width[j] - width[i]).abs() <= WIDENING + 1e-5, "{x}");
        }
        assert_eq!(width[row * n + 60], 16.0);
        assert!((width[row * n + 39] - (16.0 - WIDENING)).abs() < 1e-5);
        // Every raised cell's width comes from the nearest wide cell, the one where it jumps.
        assert_eq!(origin[row * n] as usize, row * n + 40);
        assert_eq!(
            origin[row * n + 50] as usize,
            row * n + 50,
            "the wide reach: its own"
        );
        assert!(edge_steps(&width) <= 1, "steps of {}", edge_steps(&width));
        assert!(width.iter().zip(&channel).all(|(w, c)| *c || *w == 0.0));
    }

    /// A channel falling in steps of 1 m every 4 cells: the floor's base beside it no longer
    /// steps with it (the largest jump between neighbours along the valley a third of the
    /// step or less), still falls downstream cell by cell, and stays within the channel's
    /// heights.
    #[test]
    fn the_floors_base_spreads_the_channels_steps() {
        let (w, n) = (40usize, 40usize);
        let mut z = vec![100.0f32; n * n];
        let mut channel = vec![false; n * n];
        for x in 0..w {
            z[20 * n + x] = (x / 4) as f32;
            channel[20 * n + x] = true;
        }
        let reach = vec![6.0f32; n * n];
        let sources = (0..n * n).filter(|&i| channel[i]);
        let nearest = nearest_within(n, sources, &reach);
        let floors = Floors {
            nearest: &nearest,
            channel: &channel,
            sources: &channel,
            n,
        };
        // Cells of 20 m: the one-cell sweeps alone.
        let inputs = floor_inputs(&z, &floors, 20.0, |_| 1.0e8, |_| 120.0);
        let base = inputs.base;
        for y in [17usize, 23] {
            let row: Vec<f32> = (0..w).map(|x| base[y * n + x]).collect();
            let steps: Vec<f32> = row.windows(2).map(|p| p[1] - p[0]).collect();
            let largest = steps.iter().fold(0.0f32, |m, s| m.max(s.abs()));
            assert!(largest <= 0.34, "row {y}: jumps up to {largest}");
            assert!(
                steps.iter().all(|s| *s >= -1e-6),
                "row {y} rises downstream"
            );
            assert!(
                row.iter().all(|b| (0.0..=9.0).contains(b)),
                "row {y}: {row:?}"
            );
        }
    }

    /// A river that steps up a row and back (a cove of two bank cells under the bump): the
    /// design leaves the cove near the lowest river cell beside it, so the river cell
    /// upstream of it drained across the cove. Lifted, every river cell's steepest way down
    /// is a river cell; land already above is untouched.
    #[test]
    fn coves_of_a_wandering_river_are_lifted_above_it() {
        let n = 8;
        let cell = 100.0;
        // The river flows west along row 4, stepping up to row 3 for x = 3..=5.
        let course = [
            (7, 4),
            (6, 4),
            (5, 4),
            (5, 3),
            (4, 3),
            (3, 3),
            (3, 4),
            (2, 4),
            (1, 4),
            (0, 4),
        ];
        let mut kinds = vec![CellKind::Free; n * n];
        let mut data = vec![50.0f32; n * n];
        for (k, &(x, y)) in course.iter().rev().enumerate() {
            kinds[y * n + x] = CellKind::River;
            data[y * n + x] = 10.0 + 0.1 * k as f32;
        }
        // The cove under the bump, filled near the river cells west of it.
        data[4 * n + 4] = 10.25;
        let field = Heightfield::from_vec(n, n, data.clone()).unwrap();
        let lifted = lift_coves(&field, &kinds, cell).expect("the cove is lifted");
        let z = lifted.data();
        for (i, kind) in kinds.iter().enumerate() {
            if *kind != CellKind::River || i % n == 0 {
                continue;
            }
            let (x, y) = (i % n, i / n);
            let mut best = (0.0f32, usize::MAX);
            for yy in y - 1..=y + 1 {
                for xx in x.saturating_sub(1)..(x + 2).min(n) {
                    let j = yy * n + xx;
                    let d = if xx != x && yy != y { 2f32.sqrt() } else { 1.0 };
                    let drop = (z[i] - z[j]) / d;
                    if j != i && drop > best.0 {
                        best = (drop, j);
                    }
                }
            }
            assert_eq!(kinds[best.1], CellKind::River, "cell ({x}, {y})");
        }
        assert!(z[4 * n + 4] > data[4 * n + 4]);
        // Far from the river and already high: the same bits.
        assert_eq!(z[7 * n + 7], data[7 * n + 7]);
        assert!(
            lift_coves(&lifted, &kinds, cell).is_none(),
            "nothing left to lift"
        );
    }

    /// A river down a tilted valley: the floor is wider downstream (more area), flat across
    /// within the rise, never above the design, and its cells drain to the river.
    #[test]
    fn floors_widen_downstream_and_rise_from_the_river() {
        // The half-width in cells is k sqrt(area in cells): 0.012 sqrt(32000) = 2 cells for
        // the half of this map that drains to the river.
        let n = 256;
        let cell = 50.0;
        let mid = n / 2;
        let (data, kinds) = v_valley(n, cell);
        let field = Heightfield::from_vec(n, n, data.clone()).unwrap();
        let (floored, marked) = valley_floors(&field, &kinds, &[], &[], &[], cell)
            .unwrap()
            .expect("a floor");
        let area = routed_area(&data, n, cell);
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
                    // The floodplain: the cross rise over the bank of the channel (all
                    // narrower than a cell here), as deep as the law asks for its area
                    // once past the bank.
                    // And the footslope, curving up to the floor's edge.
                    let rise = f64::from(z[i] - river) - CROSS_RISE * d * cell;
                    let a = f64::from(area[y * n + mid]);
                    let reach = f64::from(half_width_cells(a, cell, 1.0)) * cell;
                    let share = bank_share(d * cell - channel_width_m(a) / 2.0, cell);
                    let bank = bankfull_depth_m(a) * share + footslope_m(d * cell, reach);
                    // Within 5 cm: the floor's area is spread along the valley
                    // (`floor_along`), where this takes the river cell's own.
                    assert!((rise - bank).abs() < 0.05, "{i}: {rise} vs {bank}");
                } else {
                    // Beside the river: above every river cell it touches.
                    let upstream = z[y.saturating_sub(1) * n + mid];
                    assert!(z[i] > upstream.max(river), "{i}");
                }
            }
        }
    }

    /// The footslope: none at the channel, steeper the farther from it, [`FOOTSLOPE`] at the
    /// floor's edge, no higher beyond it, none on a floor of no width.
    #[test]
    fn the_floor_curves_up_into_a_footslope_at_its_edge() {
        let reach = 400.0;
        assert_eq!(footslope_m(0.0, reach), 0.0);
        let slope = |x: f64| footslope_m(x + 0.05, reach) - footslope_m(x - 0.05, reach);
        assert!((slope(reach - 0.05) / 0.1 - FOOTSLOPE).abs() < 1e-3);
        assert!(slope(100.0) < slope(200.0) && slope(200.0) < slope(300.0));
        assert_eq!(footslope_m(2.0 * reach, reach), footslope_m(reach, reach));
        assert_eq!(footslope_m(10.0, 0.0), 0.0);
    }

    /// One valley in rock four times harder than the mean and four times softer: its floor
    /// is about half and twice the mean's width (the square root of the erodibility).
    #[test]
    fn floors_are_narrow_in_hard_rock_and_wide_in_soft() {
        let (n, cell) = (256, 10.0);
        let (data, kinds) = v_valley(n, cell);
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let width = |rock: &[f32]| {
            let (_, marked) = valley_floors(&field, &kinds, &[], &[], rock, cell)
                .unwrap()
                .expect("a floor");
            (0..n)
                .filter(|x| marked[(n - 2) * n + x] == CellKind::Floor)
                .count()
        };
        let rock = |k: f32| vec![k; n * n];
        let (hard, mean, soft) = (width(&rock(0.25)), width(&rock(1.0)), width(&rock(4.0)));
        assert_eq!(mean, width(&[]), "no rock field is the mean rock");
        assert!(hard < mean && mean < soft, "{hard} {mean} {soft}");
        assert!(soft >= 3 * hard, "{hard} {soft}");
    }

    /// A meandering river down a tilted valley, loops 40 cells long swinging 8 cells either
    /// side on a floor 6 to 9 cells wide either side (the proportions of the default scene's
    /// trunk at 70 degrees): given how far inside its belt each river cell lies, the floor
    /// spans the belt with nearly straight edges (they move 7 cells over the lower half of
    /// the map, most of it the floor widening downstream, 2-3 cells a loop where the widths
    /// spread along the river, [`taper_along`]); without, they swing with the loops (18
    /// cells).
    #[test]
    fn a_meander_belt_gives_the_floor_straight_edges() {
        let (n, cell, amplitude, period) = (1024, 10.0, 8.0, 40.0);
        let mid = n / 2;
        let (mut data, _) = v_valley(n, cell);
        let mut kinds = vec![CellKind::Free; n * n];
        let mut belt = Vec::new();
        let loop_x = |y: usize| {
            let phase = std::f64::consts::TAU * y as f64 / period;
            (mid as f64 + amplitude * phase.sin()).round() as usize
        };
        for y in 0..n {
            // 4-connected: the row's cells from the previous row's column to this one's.
            let (from, to) = (loop_x(y.saturating_sub(1)), loop_x(y));
            for x in from.min(to)..=from.max(to) {
                let i = y * n + x;
                kinds[i] = CellKind::River;
                data[i] = (n - y) as f32 * cell as f32 * 0.01;
                let inside = amplitude - (x as f64 - mid as f64).abs();
                belt.push((i as u32, inside.max(0.0) as f32));
            }
        }
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let west_edge = |belt: &[(u32, f32)]| {
            let (_, marked) = valley_floors(&field, &kinds, &[], belt, &[], cell)
                .unwrap()
                .expect("a floor");
            let edges: Vec<usize> = (n / 2..n - 8)
                .map(|y| {
                    (0..n)
                        .find(|&x| matches!(marked[y * n + x], CellKind::Floor | CellKind::River))
                        .expect("a floor on every row")
                })
                .collect();
            edges.iter().max().unwrap() - edges.iter().min().unwrap()
        };
        let (straight, swinging) = (west_edge(&belt), west_edge(&[]));
        assert!(swinging >= 10, "{swinging}");
        assert!(straight * 2 <= swinging, "{straight} against {swinging}");
    }

    /// A V valley of sides at 0.3 along a river down column `n / 2`, falling towards the
    /// last row at 1%: its heights and kinds.
    fn v_valley(n: usize, cell: f64) -> (Vec<f32>, Vec<CellKind>) {
        let mid = n / 2;
        let data = (0..n * n)
            .map(|i| {
                let (x, y) = (i % n, i / n);
                let across = (x as f32 - mid as f32).abs() * cell as f32 * 0.3;
                (n - y) as f32 * cell as f32 * 0.01 + across
            })
            .collect();
        let mut kinds = vec![CellKind::Free; n * n];
        for y in 0..n {
            kinds[y * n + mid] = CellKind::River;
        }
        (data, kinds)
    }

    /// The design's drainage area as [`valley_floors`] routes it (to the map's edge).
    fn routed_area(data: &[f32], n: usize, cell: f64) -> Vec<f32> {
        let edge = crate::erosion::stage::border_cells(n);
        receivers_and_area(data, n, n, cell, &edge).unwrap().area
    }

    /// Hydraulic geometry along a drawn river: the floodplain stands the bankfull depth
    /// above the river, growing downstream as `A^0.4`, and the channel's bed is as wide as
    /// `A^0.5` asks: one cell in the headwaters, three downstream (1 m cells, 1 km^2 at the
    /// outlet: a channel 2.5 m wide and 0.25 m deep).
    #[test]
    fn the_channel_widens_and_deepens_downstream_as_hydraulic_geometry_asks() {
        let n = 1024;
        let cell = 1.0;
        let mid = n / 2;
        let (data, kinds) = v_valley(n, cell);
        let field = Heightfield::from_vec(n, n, data.clone()).unwrap();
        let (floored, _) = valley_floors(&field, &kinds, &[], &[], &[], cell)
            .unwrap()
            .expect("a floor");
        let area = routed_area(&data, n, cell);
        let z = floored.data();
        // The bed: the cells beside the river standing less than half the bank above it.
        let bed_width = |y: usize| {
            let river = z[y * n + mid];
            let half = 0.5 * bankfull_depth_m(f64::from(area[y * n + mid])) as f32;
            1 + (1..8)
                .take_while(|d| z[y * n + mid + d] - river < half)
                .count()
                * 2
        };
        let expected = |y: usize| {
            let w = channel_width_m(f64::from(area[y * n + mid]));
            1 + 2 * (w / 2.0 / cell).floor() as usize
        };
        for y in [n / 8, n / 2, n - 8] {
            assert_eq!(bed_width(y), expected(y), "row {y}");
        }
        assert!(bed_width(n - 8) > bed_width(n / 8));
        let step = |y: usize| {
            let a = f64::from(area[y * n + mid]);
            let foot = footslope_m(4.0 * cell, f64::from(half_width_cells(a, cell, 1.0)) * cell);
            f64::from(z[y * n + mid + 4] - z[y * n + mid]) - CROSS_RISE * 4.0 - foot
        };
        let (a_up, a_down) = (area[n / 8 * n + mid], area[(n - 8) * n + mid]);
        let law = (f64::from(a_down) / f64::from(a_up)).powf(0.4);
        assert!(
            (step(n - 8) / step(n / 8) - law).abs() < 0.02,
            "depths {} and {} for areas {a_up} and {a_down}",
            step(n / 8),
            step(n - 8)
        );
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
