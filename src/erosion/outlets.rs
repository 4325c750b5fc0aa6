//! The map's border as a window on a larger land: a few border cells where the land beyond
//! the reach of the drawn and grown rivers drains off the map.
//!
//! With the border closed (all water to the drawn rivers, a closed catchment) every cell on
//! the map's edge is a divide, and the land farthest along the flow from any channel, the
//! corners and edges the grown branches do not reach, stands highest: 81% of the default
//! scene's top 5% of cells lay within a tenth of the map's width of its edge at 10 km (93%
//! at 2 km, 75% at 50 km), where 10-50 km windows of the SRTM tile N44E005 give 45-55%
//! (60 windows each; [`crate::realism`]'s "high ground on the frame"). Landscape-evolution
//! models give a window of land open boundaries for this reason: border nodes are base
//! level at a fixed height and the land beyond drains across them (Braun and Willett 2013,
//! "A very efficient O(n), implicit and parallel method to solve the stream power equation
//! governing fluvial incision and landscape evolution", Geomorphology 180, Sec. 3).
//!
//! All of the border as base level rims the map with a ring of short catchments, its edges
//! the lowest ground. Here each side is cut into [`PIECES_PER_SIDE`] equal pieces, and a
//! piece that no drawn river leaves through and that the network does not reach (its
//! farthest cell from the rivers, the valleys, their floors and the grown branches at least
//! half the piece away) gets one outlet at that farthest cell, held at the height of
//! its nearest drawn channel: a stream leaving there drains the land the network leaves
//! unclaimed, down to the base level of the rivers beside it. The grown branches keep their
//! catchments, and the divides between the network and the outlets' valleys stand inside
//! the map. A piece gets no outlet where one would stand too close below a sketched peak or
//! ridge for the talus slope to carry it ([`Keep`]): the design holds.
//!
//! A scene whose map is a whole catchment (an island, a closed basin) closes its border
//! (`erosion.border`: [`crate::erosion::Border::Closed`]): then no outlet is made.

use super::CHUNK_CELLS;
use super::nearest::Transform;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::skeleton::CellKind;

/// Pieces of each side of the map that can hold an outlet.
pub const PIECES_PER_SIDE: usize = 3;

/// How far, as a share of a piece, the network must stay from a piece for it to get an
/// outlet. Nearer, the outlets' valleys cut back into the grown branches' heads: with a
/// quarter, the branches' cells draining along them fell from 88.8% to 80.4% on four rivers
/// on a 5 km map (86.3% with a half), from 77.6% to 72.5% on the default scene at 2 km
/// (75.8%).
const UNCLAIMED_SHARE: f32 = 0.5;

/// What an outlet must leave standing: the sketch's held peaks and ridges (`held`, cells of
/// the design `field`), which the threshold slope (`talus_deg`, none: no limit) carries from
/// the outlet's height (`channel`, each cell's nearest channel height), over cells `cell_m`
/// wide.
#[derive(Clone, Copy)]
pub struct Keep<'a> {
    pub held: &'a [u32],
    pub channel: &'a [f32],
    pub cell_m: f64,
    pub talus_deg: Option<f64>,
}

impl<'a> Keep<'a> {
    /// The fields' names in [`Keep`]'s order.
    pub fn of(held: &'a [u32], channel: &'a [f32], cell_m: f64, talus_deg: Option<f64>) -> Self {
        Self {
            held,
            channel,
            cell_m,
            talus_deg,
        }
    }

    /// Whether an outlet at `cell` of the `n` x `n` `design` leaves every held cell standing:
    /// each no higher above the outlet than the talus slope climbs over the distance between
    /// them (the threshold-slope limit would cut it down to that, as it did a ridge drawn at
    /// 900 m a kilometre from an outlet to 782 m). O(held cells).
    fn leaves_standing(&self, cell: usize, design: &[f32], n: usize) -> bool {
        let Some(talus) = self.talus_deg.filter(|_| !self.held.is_empty()) else {
            return true;
        };
        let rise = talus.to_radians().tan() * self.cell_m;
        let (x, y) = ((cell % n) as f64, (cell / n) as f64);
        let base = f64::from(self.channel[cell]);
        self.held.iter().all(|&h| {
            let h = h as usize;
            let d = ((h % n) as f64 - x).hypot((h / n) as f64 - y);
            f64::from(design[h]) - base <= rise * d
        })
    }
}

/// The outlet cells of the square `field` whose cells are `kinds` and base level `base`
/// (row-major), each leaving `keep`'s held cells standing: see the module's docs. None where
/// the border is all base level already (a map without channels) or the map is too small to
/// cut. O(cells + outlets x held cells).
pub fn border_outlets(
    field: &Heightfield,
    kinds: &[CellKind],
    base: &[bool],
    keep: Keep<'_>,
) -> Vec<usize> {
    let mut transform = network_transform(field, kinds);
    while !transform.advance(usize::MAX) {}
    let far = choose(base, &transform.finish().distance, field.width());
    kept(far, field, keep)
}

/// The `outlets` that leave `keep`'s held cells standing.
fn kept(outlets: Vec<usize>, field: &Heightfield, keep: Keep<'_>) -> Vec<usize> {
    let n = field.width();
    outlets
        .into_iter()
        .filter(|&c| keep.leaves_standing(c, field.data(), n))
        .collect()
}

/// [`border_outlets`] in bands of about [`CHUNK_CELLS`] cells with the job's ticks between
/// them (the same cells).
pub(super) async fn border_outlets_in_steps(
    field: &Heightfield,
    kinds: &[CellKind],
    base: &[bool],
    keep: Keep<'_>,
    ctx: &JobCtx,
    (progress, message): (f32, &str),
) -> Result<Vec<usize>, Cancelled> {
    let rows = (CHUNK_CELLS / field.width().max(1)).max(1);
    let mut transform = network_transform(field, kinds);
    loop {
        ctx.tick(progress, message).await?;
        if transform.advance(rows) {
            let far = choose(base, &transform.finish().distance, field.width());
            return Ok(kept(far, field, keep));
        }
    }
}

/// Makes `outlets` base level, each held at its nearest channel's height (`channel`, from
/// [`super::stage::nearest_channel`]).
pub fn open(outlets: &[usize], base: &mut [bool], heights: &mut [f32], channel: &[f32]) {
    for &cell in outlets {
        base[cell] = true;
        heights[cell] = channel[cell];
    }
}

/// Each cell's distance to the network: drawn rivers and valleys, their floors, the grown
/// branches.
fn network_transform<'a>(field: &'a Heightfield, kinds: &'a [CellKind]) -> Transform<'a> {
    Transform::new(field, |i| {
        matches!(
            kinds[i],
            CellKind::River | CellKind::Valley | CellKind::Floor | CellKind::Grown
        )
    })
}

/// The outlets of an `n` x `n` map with base level `base`, each cell `away` cells from the
/// network: in each piece of a side without a base-level cell, the farthest cell (the first
/// of equal ones) when it is at least [`UNCLAIMED_SHARE`] of the piece away. O(n).
fn choose(base: &[bool], away: &[f32], n: usize) -> Vec<usize> {
    if n < 2 * PIECES_PER_SIDE {
        return Vec::new();
    }
    let piece = (n - 1).div_ceil(PIECES_PER_SIDE);
    let unclaimed = UNCLAIMED_SHARE * piece as f32;
    let mut outlets = Vec::new();
    for side in sides(n) {
        for cells in side.chunks(piece) {
            if cells.iter().any(|&c| base[c]) {
                continue;
            }
            let farthest = cells
                .iter()
                .copied()
                .reduce(|best, c| if away[c] > away[best] { c } else { best });
            outlets.extend(farthest.filter(|&c| away[c] >= unclaimed));
        }
    }
    outlets
}

/// The four sides of an `n` x `n` map, `n - 1` cells each, every border cell on exactly one:
/// the top west to east, the east side north to south, the bottom east to west, the west side
/// south to north.
fn sides(n: usize) -> [Vec<usize>; 4] {
    let last = n - 1;
    [
        (0..last).collect(),
        (0..last).map(|y| y * n + last).collect(),
        (1..n).rev().map(|x| last * n + x).collect(),
        (1..n).rev().map(|y| y * n).collect(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn none() -> Keep<'static> {
        Keep {
            held: &[],
            channel: &[],
            cell_m: 1.0,
            talus_deg: Some(35.0),
        }
    }

    #[test]
    fn no_outlet_where_the_talus_could_not_carry_a_held_ridge() {
        let n = 31;
        let (mut field, kinds, base) = river_down_the_middle(n);
        let channel = vec![0.0; n * n];
        let all = border_outlets(&field, &kinds, &base, none());
        assert!(all.contains(&0));
        // A peak 5 cells from the north-west corner, 10 m cells: tan 35 x 50 m = 35 m of
        // rise; at 30 m it stands, at 40 m the corner's outlet would cut it.
        let peak = 3 * n + 4;
        let held = [peak as u32];
        let keep = || Keep {
            held: &held,
            channel: &channel,
            cell_m: 10.0,
            talus_deg: Some(35.0),
        };
        field.data_mut()[peak] = 30.0;
        assert_eq!(border_outlets(&field, &kinds, &base, keep()), all);
        field.data_mut()[peak] = 40.0;
        let kept = border_outlets(&field, &kinds, &base, keep());
        assert!(!kept.contains(&0), "{kept:?}");
        assert_eq!(kept.len(), all.len() - 1);
    }

    /// A river down the middle column (base level), its mouth on the south side.
    fn river_down_the_middle(n: usize) -> (Heightfield, Vec<CellKind>, Vec<bool>) {
        let mut kinds = vec![CellKind::Free; n * n];
        let mut base = vec![false; n * n];
        for y in 0..n {
            kinds[y * n + n / 2] = CellKind::River;
            base[y * n + n / 2] = true;
        }
        let field = Heightfield::from_vec(n, n, vec![10.0; n * n]).expect("a field");
        (field, kinds, base)
    }

    #[test]
    fn pieces_the_network_leaves_get_their_farthest_cell() {
        let n = 31;
        let (field, kinds, base) = river_down_the_middle(n);
        let outlets = border_outlets(&field, &kinds, &base, none());
        // Top and bottom: the middle pieces hold the river; the outer ones reach the corners,
        // 15 cells from it. East and west: every piece lies 15 cells away, its first cell
        // the farthest of equal ones.
        assert_eq!(outlets.len(), 4 + 6, "{outlets:?}");
        for &c in &outlets {
            let x = c % n;
            assert!(
                x.abs_diff(n / 2) >= 14,
                "cell {c} at x {x}: far from the river"
            );
            assert!(!base[c]);
        }
        assert!(outlets.contains(&0), "the north-west corner");
    }

    #[test]
    fn a_branch_reaching_the_border_keeps_its_piece() {
        let n = 31;
        let (field, mut kinds, base) = river_down_the_middle(n);
        // A grown branch along the top row west of the river, and down the west side.
        for kind in &mut kinds[..n / 2] {
            *kind = CellKind::Grown;
        }
        for y in 0..n {
            kinds[y * n] = CellKind::Grown;
        }
        let outlets = border_outlets(&field, &kinds, &base, none());
        let claimed = |c: usize| c.is_multiple_of(n) || (c / n == 0 && c % n < n / 2);
        assert!(!outlets.iter().any(|&c| claimed(c)), "{outlets:?}");
        // The east side (the south-east corner is the south side's), which nothing reaches,
        // keeps its three.
        let east = |c: usize| c % n == n - 1 && c / n < n - 1;
        assert_eq!(outlets.iter().filter(|&&c| east(c)).count(), 3);
    }

    #[test]
    fn a_border_all_base_level_gets_no_outlet() {
        let n = 12;
        let field = Heightfield::from_vec(n, n, vec![1.0; n * n]).expect("a field");
        let base = crate::erosion::stage::border_cells(n);
        let kinds = vec![CellKind::Free; n * n];
        assert!(border_outlets(&field, &kinds, &base, none()).is_empty());
    }

    #[test]
    fn every_border_cell_is_on_one_side() {
        let n = 7;
        let mut seen = vec![0; n * n];
        for side in sides(n) {
            assert_eq!(side.len(), n - 1);
            for c in side {
                seen[c] += 1;
            }
        }
        for (c, count) in seen.iter().enumerate() {
            let (x, y) = (c % n, c / n);
            let border = x == 0 || y == 0 || x == n - 1 || y == n - 1;
            assert_eq!(*count, usize::from(border), "cell {c}");
        }
    }

    #[test]
    fn an_outlet_is_held_at_its_channels_height() {
        let mut base = vec![false; 4];
        let mut heights = vec![50.0; 4];
        open(&[2], &mut base, &mut heights, &[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(base, [false, false, true, false]);
        assert_eq!(heights, [50.0, 50.0, 3.0, 50.0]);
    }

    #[test]
    fn in_steps_the_same_cells() {
        let n = 40;
        let (field, kinds, base) = river_down_the_middle(n);
        let ctx = JobCtx::detached();
        let stepped = pollster::block_on(border_outlets_in_steps(
            &field,
            &kinds,
            &base,
            none(),
            &ctx,
            (0.0, "test"),
        ))
        .expect("not cancelled");
        assert_eq!(stepped, border_outlets(&field, &kinds, &base, none()));
    }

    /// A closed border (the scene's `erosion.border`) gets no outlet: every drop reaches the
    /// rivers, the edge a divide. Open, the same map gets the outlets above.
    #[test]
    fn a_closed_border_gets_no_outlet() {
        use crate::erosion::{Border, ErosionSettings, Prepared};
        let n = 31;
        let (field, kinds, _) = river_down_the_middle(n);
        let outlets = |border| {
            let settings = ErosionSettings {
                border,
                ..ErosionSettings::default()
            };
            Prepared::new(&field, &kinds, &settings, 10.0, 1, &[]).outlets
        };
        assert!(!outlets(Border::Open).is_empty());
        assert!(outlets(Border::Closed).is_empty());
    }
}
