//! The branches the L-system grew, as channels whose heights the law sets (the erosion's
//! relief from the physics, [`Relief::Physics`]).
//!
//! A drawn river's trunk (the stroke) is base level: it keeps the heights the design gave it.
//! Its branches, grown by the L-system, used to be base level too, at the design's gentle
//! slope (`river_slope`, 1% by default), so every valley floor of the map lay within a few
//! tens of metres of the trunk's height and the relief came only from hillslopes rising off
//! them: one valley spacing everywhere, most of the land low (hypsometric integral 0.2), no
//! large-scale structure (the spectral bump of issue 32).
//!
//! Here a branch is a channel the solver routes along its course, each of its cells draining
//! to the next one down the branch (a guided receiver, [`guided_receivers`]), while the
//! stream-power law sets its heights like any other channel's: at steady state
//! `S = (U / K)^(1/n) A^(-m/n)` (Braun & Willett 2013), so headwater branches, draining
//! little, stand steep and high, and ranges of faster uplift or harder rock stand higher.
//! First-order links are left to the land ([`grown_kinds`]), and the finished surface has the
//! branches burnt in ([`burn`]) so that its steepest descent follows them too.

use std::borrow::Cow;
use std::ops::Range;

use super::flow::NONE;
use super::grid::{D8, D8_DIST};
use super::stage::{PREPARING, in_row_bands};
use super::{Anchors, Relief};
use crate::jobs::{Cancelled, JobCtx};
use crate::skeleton::{CellKind, Skeleton};

/// The erosion's own kinds with every river cell off the trunks (`trunk`: ascending cells of
/// the strokes, [`Skeleton::trunk`]) marked [`CellKind::Grown`], or [`CellKind::Free`] where
/// it is only on first-order links (`order`: each cell's Strahler order,
/// [`Skeleton::river_order`]; empty: all grown). `None` when there is nothing to mark: no
/// trunk is known (a design given as bare kinds, whose rivers are all held) or every river
/// cell is on one.
///
/// First-order links, the L-system's leaves, are left to the land: with little water of
/// their own, their course competed with the gullies the law cuts beside them, and the
/// steepest descent left 15% of their cells for a slope where it left 2% of the second
/// order's and under 1% of the higher orders' (default scene, 10 km). The law grows the
/// first-order channels where the land gathers them.
pub fn grown_kinds(kinds: &[CellKind], order: &[u8], trunk: &[u32]) -> Option<Vec<CellKind>> {
    if trunk.is_empty() {
        return None;
    }
    let mut on_trunk = trunk.iter().map(|&c| c as usize).peekable();
    let mut any = false;
    let out = kinds
        .iter()
        .enumerate()
        .map(|(i, k)| {
            while on_trunk.next_if(|&c| c < i).is_some() {}
            let trunk = on_trunk.peek() == Some(&i);
            if *k != CellKind::River || trunk {
                return *k;
            }
            any = true;
            if order.get(i).is_some_and(|o| *o <= 1) {
                CellKind::Free
            } else {
                CellKind::Grown
            }
        })
        .collect();
    any.then_some(out)
}

/// The kinds of `skeleton` as the erosion shapes them with `relief` ([`shape`]): the river
/// cells it holds are [`CellKind::River`], the branches it lets the law shape
/// [`CellKind::Grown`].
pub fn shaped_kinds(skeleton: &Skeleton, relief: Relief) -> Cow<'_, [CellKind]> {
    match shape(&skeleton.kinds, &skeleton.into(), relief) {
        Some(kinds) => Cow::Owned(kinds),
        None => Cow::Borrowed(&skeleton.kinds),
    }
}

/// The erosion's kinds for a design with these anchors: with the relief from the physics
/// ([`Relief::Physics`]) [`grown_kinds`], except where the sketch holds peaks or ridges
/// (`held`): a sketch sets the heights of its ranges, and land rising evenly around a peak
/// asked at 600 m stood at 700 m beside it, so there every river stays held at its designed
/// heights, as the sketch's relief was drawn against. `None`: every river held.
pub(super) fn shape(
    kinds: &[CellKind],
    anchors: &Anchors<'_>,
    relief: Relief,
) -> Option<Vec<CellKind>> {
    if relief == Relief::Design || !anchors.held.is_empty() {
        return None;
    }
    let mut grown = grown_kinds(kinds, anchors.order, anchors.trunk)?;
    keep_ways_down(&mut grown, kinds, anchors.heights);
    Some(grown)
}

/// Holds again, as [`CellKind::River`], the grown or freed river cells a held river cell
/// needs to drain: where a branch runs right beside a trunk (a bend brings them together), a
/// trunk cell may have no lower trunk cell around it, only the branch's; left to the law,
/// that cell rose and dammed the trunk. Each held river cell off the map's edge with no
/// lower held channel beside it keeps its lowest lower river neighbour held, and so on
/// downstream (heights fall at each step, so it ends). `heights`: the design's, by cell
/// (empty: nothing to do). O(river cells).
fn keep_ways_down(grown: &mut [CellKind], kinds: &[CellKind], heights: &[f32]) {
    let cells = grown.len();
    if heights.len() != cells {
        return;
    }
    let n = (cells as f64).sqrt().round() as usize;
    if n * n != cells || n < 3 {
        return;
    }
    let held = |k: CellKind| matches!(k, CellKind::River | CellKind::Valley);
    let around = |i: usize| {
        let (x, y) = (i % n, i / n);
        (y - 1..=y + 1).flat_map(move |yy| (x - 1..=x + 1).map(move |xx| yy * n + xx))
    };
    let interior = |i: usize| {
        let (x, y) = (i % n, i / n);
        x > 0 && y > 0 && x + 1 < n && y + 1 < n
    };
    let mut todo: Vec<usize> = (0..cells)
        .filter(|&i| grown[i] == CellKind::River)
        .collect();
    while let Some(i) = todo.pop() {
        if !interior(i) || around(i).any(|j| held(grown[j]) && heights[j] < heights[i]) {
            continue;
        }
        let lowest = around(i)
            .filter(|&j| kinds[j] == CellKind::River && heights[j] < heights[i])
            .min_by(|&a, &b| heights[a].total_cmp(&heights[b]));
        if let Some(j) = lowest {
            grown[j] = CellKind::River;
            todo.push(j);
        }
    }
}

/// Whether water in a cell of this kind runs in a channel of the design.
fn is_channel(kind: CellKind) -> bool {
    matches!(
        kind,
        CellKind::River | CellKind::Valley | CellKind::Grown | CellKind::Floor
    )
}

/// The guided receivers of an `n` x `n` design: for each [`CellKind::Grown`] cell, the D8
/// code (the solver's, [`D8`]) of the channel neighbour it drains to, the steepest strictly
/// lower one on the design's `heights` (the design falls along every river link, so this
/// is the next cell down the branch); [`NONE`] for every other cell, for a grown cell with
/// no lower channel beside it (where two rivers cross, the lower keeps the cell: the solver
/// routes it as free land), and for every cell whose guided way leads to such a cell rather
/// than to a held river, valley or floor: a free cell may drain into its own donors, and a
/// guided way into it would close a loop. Empty when no cell is grown. O(cells).
pub(super) fn guided_receivers(heights: &[f32], kinds: &[CellKind], n: usize) -> Vec<u8> {
    if !kinds.contains(&CellKind::Grown) {
        return Vec::new();
    }
    let mut guide = vec![NONE; n * n];
    guide_rows(heights, kinds, n, 0..n, &mut guide);
    keep_ways_to_held_channels(&mut guide, kinds, n);
    guide
}

/// [`guided_receivers`] in bands of rows with the job's ticks between them (the stage's way
/// on large maps: the same codes).
pub(super) async fn guided_receivers_in(
    heights: &[f32],
    kinds: &[CellKind],
    n: usize,
    ctx: &JobCtx,
) -> Result<Vec<u8>, Cancelled> {
    if !kinds.contains(&CellKind::Grown) {
        return Ok(Vec::new());
    }
    let mut guide = vec![NONE; n * n];
    in_row_bands(ctx, PREPARING, &mut guide, n, |rows, part| {
        guide_rows(heights, kinds, n, rows, part)
    })
    .await?;
    ctx.tick(PREPARING.0, PREPARING.1).await?;
    keep_ways_to_held_channels(&mut guide, kinds, n);
    Ok(guide)
}

/// The codes of the rows `rows` of [`guided_receivers`] into `out`, those rows.
fn guide_rows(heights: &[f32], kinds: &[CellKind], n: usize, rows: Range<usize>, out: &mut [u8]) {
    let first = rows.start * n;
    for (k, code) in out.iter_mut().enumerate() {
        let i = first + k;
        if kinds[i] != CellKind::Grown {
            continue;
        }
        let (x, y) = (i % n, i / n);
        let mut steepest = 0.0f64;
        for (d, (dx, dy)) in D8.iter().enumerate() {
            let (nx, ny) = (x.wrapping_add_signed(*dx), y.wrapping_add_signed(*dy));
            if nx >= n || ny >= n {
                continue;
            }
            let j = ny * n + nx;
            if !is_channel(kinds[j]) {
                continue;
            }
            let slope = f64::from(heights[i] - heights[j]) / D8_DIST[d];
            if slope > steepest {
                steepest = slope;
                *code = d as u8;
            }
        }
    }
}

/// Sets [`NONE`] on every guided cell whose way down the guides ends anywhere but on a held
/// channel (a river, valley or floor: base level). O(cells): each way is walked once, and
/// what it found is kept for the ways that join it.
fn keep_ways_to_held_channels(guide: &mut [u8], kinds: &[CellKind], n: usize) {
    const UNKNOWN: u8 = 0;
    const HELD: u8 = 1;
    const LOOSE: u8 = 2;
    let mut fate = vec![UNKNOWN; guide.len()];
    let next = |guide: &[u8], i: usize| {
        let (dx, dy) = D8[usize::from(guide[i])];
        ((i / n).wrapping_add_signed(dy)) * n + (i % n).wrapping_add_signed(dx)
    };
    let mut way = Vec::new();
    for start in 0..guide.len() {
        if guide[start] == NONE || fate[start] != UNKNOWN {
            continue;
        }
        way.clear();
        let mut i = start;
        let end = loop {
            if fate[i] != UNKNOWN {
                break fate[i];
            }
            if guide[i] == NONE {
                break if kinds[i] == CellKind::Grown {
                    LOOSE
                } else {
                    HELD
                };
            }
            way.push(i);
            i = next(guide, i);
        };
        for &j in &way {
            fate[j] = end;
            if end == LOOSE {
                guide[j] = NONE;
            }
        }
    }
}

/// Stream burning of the grown branches into the eroded `heights` (an `n` x `n` map of
/// `cell_m` cells whose design is `design`, `guide` its [`guided_receivers`]): each branch
/// cell, downstream first, is lowered just below its lowest neighbour off the channels (by
/// [`BURN_MARGIN_M`]) where that keeps it above the cell it drains to and no bank then stands
/// above it steeper than `talus_deg` (35 degrees where there is none), so that the steepest
/// descent of the finished surface runs down the branch as the solver routed it; no cell is
/// lowered more than [`BURN_DEEPEST`] of a cell.
///
/// The solver keeps a branch's course but not its banks: on a steep branch the law can leave
/// a channel cell and the slope beside it within centimetres, and the steepest way then cuts
/// a corner of the branch's 4-connected line into the slope (on the default scene 26% of the
/// branches' cells at 2 km, 5% at 10 km). Hydrologists burn mapped streams into a DEM for
/// the same reason (Hellweger 1997, "AGREE: DEM surface reconditioning system", University
/// of Texas; Saunders 1999); here a cell is lowered only as far as the steepest descent needs,
/// and never into a notch steeper than the talus angle (unbounded, it cut 47 degree notches
/// at 2 km). Returns how many cells were lowered. O(branch cells x log).
pub(super) fn burn(
    heights: &mut [f32],
    design: &[f32],
    kinds: &[CellKind],
    guide: &[u8],
    n: usize,
    (cell_m, talus_deg): (f64, Option<f64>),
) -> usize {
    if guide.is_empty() {
        return 0;
    }
    let tan = talus_deg.unwrap_or(BURN_TALUS_DEG).to_radians().tan();
    let deepest = (BURN_DEEPEST * cell_m) as f32;
    let mut branch: Vec<usize> = (0..n * n).filter(|&i| guide[i] != NONE).collect();
    branch.sort_by(|&a, &b| design[a].total_cmp(&design[b]).then(a.cmp(&b)));
    let mut lowered = 0;
    for i in branch {
        let (x, y) = (i % n, i / n);
        let (dx, dy) = D8[usize::from(guide[i])];
        let r = (y.wrapping_add_signed(dy)) * n + x.wrapping_add_signed(dx);
        let (mut side, mut floor) = (f32::INFINITY, f32::NEG_INFINITY);
        for (d, (dx, dy)) in D8.iter().enumerate() {
            let (nx, ny) = (x.wrapping_add_signed(*dx), y.wrapping_add_signed(*dy));
            if nx >= n || ny >= n {
                continue;
            }
            let j = ny * n + nx;
            floor = floor.max(heights[j] - (tan * D8_DIST[d] * cell_m) as f32);
            if !is_channel(kinds[j]) {
                side = side.min(heights[j]);
            }
        }
        let target = side - BURN_MARGIN_M;
        if target < heights[i]
            && target > heights[r]
            && target >= floor
            && heights[i] - target <= deepest
        {
            heights[i] = target;
            lowered += 1;
        }
    }
    lowered
}

/// How far below its lowest bank a burnt branch cell lies, metres.
pub(super) const BURN_MARGIN_M: f32 = 0.05;
/// The most a branch cell is lowered, in cells of height (a notch of 0.1 cell tilts the
/// faces beside it by under 6 degrees). Where the law left a branch on a slope that falls
/// across its course, only a deeper notch would hold the water, and a line of such notches,
/// a few lowered cells between unlowered ones, drew dotted trails across the hillsides of a
/// 2 km map (notches of 0.2 m and more on 2 m cells) and single pits of up to 4 m at 10 km
/// and 13 m at 50 km. Measured on the default scene at 1024^2, the grown branches' cells
/// that drain along their course without the bound and with it: 2 km 66.2% and 49.6%
/// (the unburnt surface's 49.4%), 10 km 88.4% and 85.9%, 50 km 98.6% and 98.6%; 0.04% of
/// the cells changed at 10 km.
const BURN_DEEPEST: f64 = 0.1;
/// The steepest bank a burnt branch cell may leave where the erosion has no talus angle.
const BURN_TALUS_DEG: f64 = 35.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// The burn lowers a branch cell just below its banks where a shallow notch does it (a
    /// branch whose east bank stands a centimetre below it every other row), and leaves
    /// alone a branch whose bank there stands 0.5 m below it on 2 m cells, whose notches
    /// drew dotted trails across hillsides: no cell goes down more than [`BURN_DEEPEST`]
    /// of a cell.
    #[test]
    fn the_burn_cuts_shallow_notches_only() {
        let (n, cell) = (12, 2.0);
        let down = D8.iter().position(|d| *d == (0, 1)).unwrap() as u8;
        let mut kinds = vec![CellKind::Free; n * n];
        let mut guide = vec![NONE; n * n];
        let mut heights = vec![200.0f32; n * n];
        // Branches down columns 2 and 8, falling 0.1 and 1 m a cell; (column, fall, how far
        // the east bank stands below the branch on even rows).
        let (shallow, deep) = ((2, 0.1, 0.01), (8, 1.0, 0.5));
        for (x, fall, dip) in [shallow, deep] {
            for y in 0..n {
                let h = 100.0 - fall * y as f32;
                heights[y * n + x] = h;
                heights[y * n + x - 1] = h + 0.5;
                heights[y * n + x + 1] = if y % 2 == 0 { h - dip } else { h + 0.5 };
                if y + 1 < n {
                    kinds[y * n + x] = CellKind::Grown;
                    guide[y * n + x] = down;
                }
            }
        }
        let before = heights.clone();
        let lowered = burn(&mut heights, &before, &kinds, &guide, n, (cell, None));
        for y in (2..n - 2).step_by(2) {
            let (x, ..) = shallow;
            assert!(
                heights[y * n + x] < heights[y * n + x + 1],
                "row {y}: below its bank"
            );
            let (x, ..) = deep;
            assert_eq!(
                heights[y * n + x],
                before[y * n + x],
                "row {y}: no deep notch"
            );
        }
        assert!(lowered >= 5, "{lowered}");
        for (a, b) in heights.iter().zip(&before) {
            assert!(b - a <= (BURN_DEEPEST * cell) as f32 + 1e-6, "{b} -> {a}");
        }
    }

    /// A first-order branch right beside a trunk, a trunk cell lower than the next one down
    /// its own course: the branch cell it drains to stays held (the trunk would be dammed),
    /// the rest of the branch is let go, and nothing changes without the design's heights.
    #[test]
    fn a_trunk_keeps_the_branch_cell_it_drains_through() {
        let n = 6;
        let mut kinds = vec![CellKind::Free; n * n];
        let mut heights = vec![50.0f32; n * n];
        let mut trunk = Vec::new();
        for y in 0..n {
            let i = y * n + 2;
            kinds[i] = CellKind::River;
            heights[i] = 2.0 * (n - 1 - y) as f32;
            trunk.push(i as u32);
        }
        // Trunk cell (2, 2) stands below (2, 3), the next one down: it drains only through
        // the branch beside it.
        heights[3 * n + 2] = 5.2;
        heights[2 * n + 2] = 5.0;
        for (y, h) in [(2, 5.5), (3, 4.5), (4, 3.5), (5, 2.5)] {
            kinds[y * n + 3] = CellKind::River;
            heights[y * n + 3] = h;
        }
        let order: Vec<u8> = kinds
            .iter()
            .enumerate()
            .map(|(i, k)| u8::from(*k == CellKind::River && i % n == 3))
            .collect();
        let mut grown = grown_kinds(&kinds, &order, &trunk).expect("a branch");
        assert_eq!(grown[3 * n + 3], CellKind::Free);
        let untouched = grown.clone();
        keep_ways_down(&mut grown, &kinds, &[]);
        assert_eq!(grown, untouched);
        keep_ways_down(&mut grown, &kinds, &heights);
        assert_eq!(grown[3 * n + 3], CellKind::River, "the trunk's way down");
        for y in [2, 4, 5] {
            assert_eq!(grown[y * n + 3], CellKind::Free, "row {y}");
        }
    }

    /// A branch joining a trunk: the trunk's cells stay rivers, the branch's become grown,
    /// and each grown cell is guided to the next one down the branch, the last to the trunk.
    #[test]
    fn a_branch_is_guided_down_its_course_to_the_trunk() {
        let n = 8;
        let mut kinds = vec![CellKind::Free; n * n];
        let mut heights = vec![50.0f32; n * n];
        // The trunk: column 1, rising north from 0 m at the bottom row.
        let mut trunk = Vec::new();
        for y in 0..n {
            let i = y * n + 1;
            kinds[i] = CellKind::River;
            heights[i] = (n - 1 - y) as f32;
            trunk.push(i as u32);
        }
        // The branch: row 3, from the trunk east, rising 2 m a cell.
        for x in 2..n {
            let i = 3 * n + x;
            kinds[i] = CellKind::River;
            heights[i] = heights[3 * n + 1] + 2.0 * (x - 1) as f32;
        }
        let grown = grown_kinds(&kinds, &[], &trunk).unwrap();
        assert!((0..n).all(|y| grown[y * n + 1] == CellKind::River));
        assert!((2..n).all(|x| grown[3 * n + x] == CellKind::Grown));
        let guide = guided_receivers(&heights, &grown, n);
        let west = D8.iter().position(|d| *d == (-1, 0)).unwrap() as u8;
        for x in 3..n {
            assert_eq!(
                guide[3 * n + x],
                west,
                "cell {x} drains west along the branch"
            );
        }
        // The branch's last cell drains into the trunk, down its steepest way.
        let (dx, dy) = D8[usize::from(guide[3 * n + 2])];
        assert_eq!(
            (2 + dx, 3 + dy),
            (1, 4),
            "into the trunk, diagonally downstream"
        );
        assert_eq!(guide.iter().filter(|c| **c != NONE).count(), n - 2);
        // Without a trunk every river is held, as before.
        assert!(grown_kinds(&kinds, &[], &[]).is_none());
        // A first-order branch is left to the land.
        let first = vec![1u8; n * n];
        let leaves = grown_kinds(&kinds, &first, &trunk).unwrap();
        assert!((2..n).all(|x| leaves[3 * n + x] == CellKind::Free));
        assert!((0..n).all(|y| leaves[y * n + 1] == CellKind::River));
    }

    /// A branch cut off from every held river (a dip where two rivers crossed, lower than
    /// the channels around it): none of its cells is guided, since the dip routes as free
    /// land and might drain back into them.
    #[test]
    fn a_branch_that_reaches_no_held_river_is_not_guided() {
        let n = 8;
        let mut kinds = vec![CellKind::Free; n * n];
        let mut heights = vec![50.0f32; n * n];
        for x in 1..n {
            kinds[3 * n + x] = CellKind::Grown;
            heights[3 * n + x] = 10.0 + x as f32;
        }
        assert!(
            guided_receivers(&heights, &kinds, n)
                .iter()
                .all(|c| *c == NONE)
        );
        // Joined to a held river at its lower end, the same branch is guided to it.
        kinds[3 * n] = CellKind::River;
        heights[3 * n] = 0.0;
        let guide = guided_receivers(&heights, &kinds, n);
        assert_eq!(guide.iter().filter(|c| **c != NONE).count(), n - 1);
    }
}
