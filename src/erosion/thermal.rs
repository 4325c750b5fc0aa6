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
pub(super) const THERMAL_PASSES: usize = 2;

/// Applies `THERMAL_PASSES` relaxation passes.
pub(super) fn relax(grid: Grid, h: &mut [f32], base: &[bool], talus_deg: f64) {
    let limit: [f32; 8] = D8_DIST.map(|d| (talus_deg.to_radians().tan() * d * grid.cell) as f32);
    let off = grid.offsets();
    let (w, rows) = (grid.width, grid.height);
    for pass in 0..THERMAL_PASSES {
        let forward = pass % 2 == 0;
        for yy in 0..rows {
            let y = if forward { yy } else { rows - 1 - yy };
            for xx in 0..w {
                let x = if forward { xx } else { w - 1 - xx };
                let i = y * w + x;
                if base[i] {
                    continue;
                }
                let mut nb = [usize::MAX; 8];
                if grid.interior(x, y) {
                    nb = off.map(|o| i.wrapping_add_signed(o));
                    // Fast rejection: most cells are below the talus slope.
                    let hi = h[i];
                    let steep = (0..8).fold(false, |s, d| s | (hi - h[nb[d]] > limit[d]));
                    if !steep {
                        continue;
                    }
                } else {
                    for (d, slot) in nb.iter_mut().enumerate() {
                        *slot = grid.neighbour(x, y, d).unwrap_or(usize::MAX);
                    }
                }
                relax_cell(h, base, i, &nb, &limit);
            }
        }
    }
}

/// Moves material from cell `i` to its neighbours `nb` (`usize::MAX` = none).
#[inline]
fn relax_cell(h: &mut [f32], base: &[bool], i: usize, nb: &[usize; 8], limit: &[f32; 8]) {
    let hi = h[i];
    let mut excess = [0.0f32; 8];
    let (mut max, mut total) = (0.0f32, 0.0f32);
    for d in 0..8 {
        if nb[d] != usize::MAX {
            let e = hi - h[nb[d]] - limit[d];
            if e > 0.0 {
                excess[d] = e;
                max = if e > max { e } else { max };
                total += e;
            }
        }
    }
    if max <= 0.0 {
        return;
    }
    let moved = 0.5 * max;
    h[i] = hi - moved;
    let share = moved / total;
    for d in 0..8 {
        if excess[d] > 0.0 && !base[nb[d]] {
            h[nb[d]] += share * excess[d];
        }
    }
}
