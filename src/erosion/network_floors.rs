//! Valley floors beside the terrain's own large channels: the grown branches and the channels
//! the stream-power law cut, once the solver has set their heights.
//!
//! The drawn rivers get their floors before the solver ([`super::floodplain`]), from the
//! design's routing, and keep them as base level. The rest of the network only exists once the
//! law has cut it, and the law alone leaves every valley a V: the implicit stream-power step
//! (Braun and Willett 2013) lowers the channel, the hillslopes stand at their threshold angle
//! above it, and nothing widens the bottom. Real valleys widen downstream into flat floors as
//! the channel swings across them and undercuts their walls (lateral planation; Tomkin et al.
//! 2003, "Controls on valley-floor width"; Langston and Tucker 2018, "Developing and exploring
//! a theory for the lateral erosion of bedrock channels", Earth Surf. Dynam. 6), so a large
//! valley has low, flat ground along it. At 50 km the real SRTM window has half its land below
//! 0.27 of its relief; with V valleys only, our land stood at 0.4.
//!
//! After the solver, each channel cell draining at least [`MIN_AREA_M2`] is a source of floor
//! as [`super::floodplain::valley_floors`] lays one: half-width `k sqrt(A)`, reached in
//! Euclidean distance, rising [`super::floodplain::CROSS_RISE`] away from the channel and a
//! bankfull depth above it beyond the channel's half-width, never below a channel cell beside
//! it, opening out along the channel where a larger one joins
//! ([`super::floodplain::WIDENING`]). A floor only lowers land. The walls it leaves are
//! brought back to the rock's threshold angle by the stage's slope limit, which takes the
//! floors as base level, as landslides retreat an undercut valley wall. Departure: the papers (seed 000) keep the design's
//! heights beside the rivers and have no floors; the lateral erosion of Langston and Tucker
//! is a process of each time step, where this lays its steady-state result once, at the end.

use super::floodplain::{
    WIDENING, floor_height, half_width_cells, nearest_within, rock_at, taper_along,
};
use super::floor_along::{Floors, floor_inputs};

/// The least drainage area with a valley floor, m^2: 10 km^2. Valleys draining less are
/// bedrock gorges and hollows in mountains, V-shaped (Montgomery and Buffington 1997's
/// colluvial and bedrock reaches lie above it); floors of alluvium appear beside larger
/// rivers. At the floor law's `k` it is a floor 76 m wide.
pub const MIN_AREA_M2: f64 = 10.0e6;

/// Cuts floors into `heights` (`n` x `n`, cells `cell_m` wide) beside every channel whose
/// drainage area (`area`, m^2) is at least [`MIN_AREA_M2`] and asks for a floor a cell wide or
/// more in its rock (`rock`: erodibility factors, empty: the mean rock; floors are narrower in
/// hard rock, [`half_width_cells`]); `fixed` cells (base level and held design) keep their
/// heights. Returns which cells
/// are floor or channel (the sources), `None` where no channel is large enough. O(floor cells
/// log floor cells).
pub fn cut(
    heights: &mut [f32],
    area: &[f32],
    fixed: &[bool],
    rock: &[f32],
    n: usize,
    cell_m: f64,
) -> Option<Vec<bool>> {
    let mut half_width: Vec<f32> = (area.iter().enumerate())
        .map(|(i, &a)| {
            let a = f64::from(a);
            if a < MIN_AREA_M2 {
                return 0.0;
            }
            half_width_cells(a, cell_m, rock_at(rock, i))
        })
        .collect();
    let channel: Vec<bool> = half_width.iter().map(|w| *w >= 1.0).collect();
    if !channel.contains(&true) {
        return None;
    }
    // Floors open out where a larger channel joins, not in a step at the junction.
    let origin = taper_along(&mut half_width, &channel, n, WIDENING);
    let sources = (0..n * n).filter(|&i| channel[i]);
    let nearest = nearest_within(n, sources, &half_width);
    let floors = Floors {
        nearest: &nearest,
        channel: &channel,
        sources: &channel,
        n,
    };
    // Each cell's channel sized by the reach its width came from; sources are never lowered,
    // so the channel heights read here are the solver's.
    let inputs = floor_inputs(
        heights,
        &floors,
        cell_m,
        |s| area[origin[s] as usize],
        |s| (f64::from(half_width[s]) * cell_m) as f32,
    );
    let mut floor = channel.clone();
    for (i, near) in nearest.iter().enumerate() {
        let Some(_) = near else {
            continue;
        };
        if channel[i] || fixed[i] {
            continue;
        }
        let across = f64::from(inputs.across[i]) * cell_m;
        let (a, reach) = (f64::from(inputs.area[i]), f64::from(inputs.reach[i]));
        let level = floor_height(
            heights,
            &channel,
            (n, cell_m),
            (i, inputs.base[i], across, a),
            reach,
        );
        heights[i] = heights[i].min(level);
        floor[i] = true;
    }
    Some(floor)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::erosion::floodplain::{
        CROSS_RISE, HALF_WIDTH_PER_SQRT_AREA, bank_share, bankfull_depth_m, channel_width_m,
        footslope_m,
    };

    /// A V valley draining 100 km^2 along row 20 of 20 m cells, its sides at 30 degrees: the
    /// cut leaves a floor about `2 k sqrt(A)` wide (240 m), a bankfull depth above the channel
    /// beyond its half-width, rising away from it; land beyond the floor, the channel and the
    /// fixed cells are untouched, and every floor cell has a lower neighbour.
    #[test]
    fn a_large_v_valley_gets_a_flat_floor_as_wide_as_its_area_asks() {
        let (n, cell) = (41usize, 20.0f64);
        let side = 30f64.to_radians().tan();
        let mut h = vec![0.0f32; n * n];
        let mut area = vec![1.0e4f32; n * n];
        for y in 0..n {
            for x in 0..n {
                let i = y * n + x;
                let across = (y as f64 - 20.0).abs() * cell;
                // The channel falls 1 m a cell to the west.
                h[i] = (x as f64 + side * across) as f32;
                if y == 20 {
                    area[i] = 1.0e8;
                }
            }
        }
        let mut fixed = vec![false; n * n];
        fixed[17 * n + 5] = true;
        let before = h.clone();
        let floor = cut(&mut h, &area, &fixed, &[], n, cell).expect("a floor");
        let half = HALF_WIDTH_PER_SQRT_AREA * 1.0e4 / cell; // 6 cells
        let bank = |off: f64| {
            let beyond = off * cell - channel_width_m(1.0e8) / 2.0;
            (bankfull_depth_m(1.0e8) * bank_share(beyond, cell)) as f32
        };
        for y in 0..n {
            for x in 0..n {
                let i = y * n + x;
                let off = (y as f64 - 20.0).abs();
                if y == 20 || fixed[i] || off > half {
                    assert_eq!(h[i], before[i], "({x}, {y}) untouched");
                    continue;
                }
                assert!(floor[i], "({x}, {y}) is floor");
                let foot = footslope_m(off * cell, half * cell) as f32;
                let mut want = x as f32 + (CROSS_RISE * off * cell) as f32 + bank(off) + foot;
                if off == 1.0 {
                    // Never below the highest channel cell beside it (the next one upstream,
                    // a metre higher) plus a cell's rise: the bank's first cell is lower.
                    want = want.max((x + 1).min(n - 1) as f32 + (CROSS_RISE * cell) as f32);
                }
                assert!((h[i] - want).abs() < 0.05, "({x}, {y}): {} != {want}", h[i]);
            }
        }
        // Every floor cell drains: a neighbour stands lower.
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let i = y * n + x;
                if floor[i] && y != 20 && !fixed[i] {
                    let lower = (0..9)
                        .map(|k| (y + k / 3 - 1) * n + x + k % 3 - 1)
                        .any(|j| h[j] < h[i]);
                    assert!(lower, "({x}, {y}) is a pit");
                }
            }
        }
    }

    /// Channels draining under [`MIN_AREA_M2`] keep their V: no floor.
    #[test]
    fn small_channels_keep_their_v() {
        let n = 16;
        let mut h: Vec<f32> = (0..n * n).map(|i| ((i / n) as f32 - 8.0).abs()).collect();
        let area = vec![(MIN_AREA_M2 * 0.9) as f32; n * n];
        let before = h.clone();
        assert!(cut(&mut h, &area, &vec![false; n * n], &[], n, 5.0).is_none());
        assert_eq!(h, before);
    }
}
