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
    ///
    /// Most cells stand below the talus slope, so each row is first checked whole for the
    /// cells that stand above it ([`Self::steep_in_row`], a pass per direction that the
    /// compiler vectorises), and only those are relaxed, with the neighbours along the row of
    /// every cell relaxed before them: a cell becomes steep only when it gains material or a
    /// neighbour loses some, both from relaxing a neighbour, and the rows beside it are
    /// checked when their turn comes. Relaxing a cell below the slope moves nothing, so the
    /// bits are those of looking at every cell in turn.
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
        let mut steep = vec![false; w];
        for yy in scan {
            let y = if forward { yy } else { rows - 1 - yy };
            let inner_row = y > 0 && y + 1 < rows && w > 2;
            let (first, last) = if forward { (0, w - 1) } else { (w - 1, 0) };
            // Whether the cell scanned just before was relaxed (the next one is its neighbour).
            let mut after_relaxed = false;
            let mut from = 0;
            if inner_row {
                self.steep_in_row(h, y * w, &mut steep);
                if !steep.contains(&true) {
                    // Only the row's end cells can move, and its inner cells only after
                    // the first one did.
                    after_relaxed = self.relax_any(grid, h, base, first, y);
                    if !after_relaxed {
                        self.relax_any(grid, h, base, last, y);
                        continue;
                    }
                    from = 1;
                }
            }
            for xx in from..w {
                let x = if forward { xx } else { w - 1 - xx };
                let i = y * w + x;
                if inner_row && x != first && x != last {
                    if !(steep[x] || after_relaxed) || base[i] {
                        after_relaxed = false;
                        continue;
                    }
                    let nb = off.map(|o| i.wrapping_add_signed(o));
                    after_relaxed = relax_cell(h, base, i, &nb, limit);
                } else {
                    after_relaxed = self.relax_any(grid, h, base, x, y);
                }
            }
        }
    }

    /// Relaxes cell `(x, y)` anywhere on the map (its neighbours looked up one by one);
    /// returns whether it moved material.
    fn relax_any(&self, grid: Grid, h: &mut [f32], base: &[bool], x: usize, y: usize) -> bool {
        let i = y * grid.width + x;
        if base[i] {
            return false;
        }
        let mut nb = [usize::MAX; 8];
        for (d, slot) in nb.iter_mut().enumerate() {
            *slot = grid.neighbour(x, y, d).unwrap_or(usize::MAX);
        }
        relax_cell(h, base, i, &nb, &self.limit)
    }

    /// `steep[x]` for the cells of the row starting at `row` (inner columns; the two end
    /// cells are left false): whether the cell stands above the talus slope over any of its
    /// eight neighbours, `h_i - h_j > limit_d`.
    fn steep_in_row(&self, h: &[f32], row: usize, steep: &mut [bool]) {
        let w = steep.len();
        let inner = 1..w - 1;
        let cells = &h[row + inner.start..row + inner.end];
        let flags = &mut steep[inner.clone()];
        flags.fill(false);
        for (&o, &limit) in self.off.iter().zip(&self.limit) {
            let from = (row + inner.start).wrapping_add_signed(o);
            let nb = &h[from..from + cells.len()];
            for ((f, a), b) in flags.iter_mut().zip(cells).zip(nb) {
                *f |= a - b > limit;
            }
        }
        steep[0] = false;
        steep[w - 1] = false;
    }
}

/// Moves material from cell `i` to its neighbours `nb` (`usize::MAX` = none); returns
/// whether it moved any.
#[inline]
fn relax_cell(h: &mut [f32], base: &[bool], i: usize, nb: &[usize; 8], limit: &[f32; 8]) -> bool {
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
        return false;
    }
    let moved = 0.5 * max;
    h[i] = hi - moved;
    let share = moved / total;
    for d in 0..8 {
        if excess[d] > 0.0 && !base[nb[d]] {
            h[nb[d]] += share * excess[d];
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every cell in scan order, each relaxed whatever its slope: what [`Talus::rows`]
    /// computes, which relaxes only the cells its row check finds steep.
    fn every_cell(talus: &Talus, grid: Grid, h: &mut [f32], base: &[bool], pass: usize) {
        let (w, rows) = (grid.width, grid.height);
        for yy in 0..rows {
            let y = if pass.is_multiple_of(2) {
                yy
            } else {
                rows - 1 - yy
            };
            for xx in 0..w {
                let x = if pass.is_multiple_of(2) {
                    xx
                } else {
                    w - 1 - xx
                };
                talus.relax_any(grid, h, base, x, y);
            }
        }
    }

    /// The row check skips no cell that would move: on a rough field with steep spikes,
    /// pits and base-level cells (the map's edges among them), both scan directions give
    /// the bits of relaxing every cell in turn, and the passes moved material.
    #[test]
    fn rows_give_the_bits_of_every_cell_in_turn() {
        let grid = Grid {
            width: 37,
            height: 29,
            cell: 10.0,
        };
        let mut state = 12345u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f64::from(state) / f64::from(u32::MAX)
        };
        let h0: Vec<f32> = (0..grid.len())
            .map(|i| {
                let spike = if next() < 0.05 { 40.0 } else { 0.0 };
                (i % grid.width) as f32 * 2.0 + (10.0 * next()) as f32 + spike
            })
            .collect();
        let base: Vec<bool> = (0..grid.len()).map(|_| next() < 0.1).collect();
        let talus = Talus::new(grid, 35.0);
        let (mut fast, mut slow) = (h0.clone(), h0.clone());
        for pass in 0..4 {
            talus.rows(grid, &mut fast, &base, pass, 0..grid.height);
            every_cell(&talus, grid, &mut slow, &base, pass);
            assert_eq!(fast, slow, "pass {pass}");
        }
        assert_ne!(fast, h0);
    }
}
