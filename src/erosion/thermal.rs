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

/// Applies `THERMAL_PASSES` relaxation passes in one go.
#[cfg(test)]
pub(super) fn relax(grid: Grid, h: &mut [f32], base: &[bool], talus_deg: f64) {
    let talus = Talus::new(grid, talus_deg);
    for pass in 0..THERMAL_PASSES {
        talus.rows(grid, h, base, pass, 0..grid.height);
    }
}

/// The relaxation of one solver: the largest drop to each D8 neighbour (`tan(talus) *
/// L`) and the neighbours' index offsets.
pub(super) struct Talus {
    limit: [f32; 8],
    off: [isize; 8],
}

impl Talus {
    pub(super) fn new(grid: Grid, talus_deg: f64) -> Self {
        Talus {
            limit: D8_DIST.map(|d| (talus_deg.to_radians().tan() * d * grid.cell) as f32),
            off: grid.offsets(),
        }
    }

    /// Relaxes the rows `scan` of pass `pass` in its scan order (row `yy` of a backward
    /// pass is the map's row `height - 1 - yy`, scanned right to left). Rows must come in
    /// scan order, as cells update in place. O(cells of the rows).
    pub(super) fn rows(
        &self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        pass: usize,
        scan: std::ops::Range<usize>,
    ) {
        let (limit, off) = (&self.limit, self.off);
        let (w, rows) = (grid.width, grid.height);
        let forward = pass.is_multiple_of(2);
        for yy in scan {
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
                relax_cell(h, base, i, &nb, limit);
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
