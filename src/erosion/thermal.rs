//! Thermal (talus) erosion: material slides from a cell to its lower D8 neighbours
//! wherever the slope exceeds `tan(talus)`.
//!
//! Each pass visits the free cells in a fixed order (alternating forward and backward
//! scans to avoid a directional bias) and updates in place: with `e_j = (h_i - h_j) -
//! tan(talus) * L_ij` the excess drop towards neighbour `j`, the cell loses
//! `0.5 * max_j e_j`, shared among the neighbours with `e_j > 0` in proportion to `e_j`.
//! Half the largest excess never over-shoots the steepest link below the talus, so
//! passes converge geometrically. Mass is conserved exactly up to `f32` rounding,
//! except that material given to a base-level cell leaves the map (base level is fixed).

use super::grid::{D8_DIST, Grid};

/// Relaxation passes per time step.
pub(super) const THERMAL_PASSES: usize = 3;

/// Applies `THERMAL_PASSES` relaxation passes.
pub(super) fn relax(grid: Grid, h: &mut [f32], base: &[bool], talus_deg: f64) {
    let limit: [f32; 8] = D8_DIST.map(|d| (talus_deg.to_radians().tan() * d * grid.cell) as f32);
    let n = grid.len();
    for pass in 0..THERMAL_PASSES {
        for k in 0..n {
            let i = if pass % 2 == 0 { k } else { n - 1 - k };
            if !base[i] {
                relax_cell(grid, h, base, i, &limit);
            }
        }
    }
}

fn relax_cell(grid: Grid, h: &mut [f32], base: &[bool], i: usize, limit: &[f32; 8]) {
    let (x, y) = grid.xy(i);
    let hi = h[i];
    let mut excess = [0.0f32; 8];
    let mut nb = [usize::MAX; 8];
    let (mut max, mut total) = (0.0f32, 0.0f32);
    for d in 0..8 {
        if let Some(j) = grid.neighbour(x, y, d) {
            let e = hi - h[j] - limit[d];
            if e > 0.0 {
                excess[d] = e;
                nb[d] = j;
                max = max.max(e);
                total += e;
            }
        }
    }
    if max <= 0.0 {
        return;
    }
    let moved = 0.5 * max;
    h[i] = hi - moved;
    for d in 0..8 {
        let j = nb[d];
        if j != usize::MAX && !base[j] {
            h[j] += moved * excess[d] / total;
        }
    }
}
