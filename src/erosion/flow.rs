//! Flow routing: D8 receivers, the Braun–Willett stack and drainage area.
//!
//! Braun & Willett (2013), section 2 ("receivers", "donors", "stack"): every node `i`
//! has one receiver `r(i)`, its steepest-descent D8 neighbour; the *stack* lists the
//! nodes so that every receiver precedes its donors. It is built by a depth-first walk
//! of the donor tree from each base-level node (their recursive `add_to_stack`).
//! Drainage area follows their eq. for `A_i = sum of cell areas upstream`,
//! accumulated while traversing the stack in reverse.
//!
//! No donor arrays are stored: the donors of `i` are the neighbours `j` with
//! `r(j) = i`, found by looking at the eight neighbours. The walk therefore needs no
//! memory besides the receiver and stack arrays.

use super::grid::{D8_DIST, Grid};

/// Steepest-descent (D8) receiver of every cell. Base-level cells, and free cells
/// without a strictly lower neighbour (pits and flats), are their own receiver.
/// Slopes are `dh / distance`, diagonals at `sqrt(2)` cells.
pub(super) fn receivers(grid: Grid, h: &[f32], base: &[bool], rec: &mut [u32]) {
    let inv: [f32; 8] = D8_DIST.map(|d| (1.0 / d) as f32);
    let w = grid.width;
    for y in 0..grid.height {
        let interior_row = y > 0 && y + 1 < grid.height;
        for x in 0..w {
            let i = y * w + x;
            let mut best = i;
            if !base[i] {
                let hi = h[i];
                let mut steepest = 0.0f32;
                if interior_row && x > 0 && x + 1 < w {
                    // Fast path: all eight neighbours exist.
                    let js = [i - w - 1, i - w, i - w + 1, i - 1, i + 1, i + w - 1, i + w, i + w + 1];
                    for (d, &j) in js.iter().enumerate() {
                        let s = (hi - h[j]) * inv[d];
                        if s > steepest {
                            steepest = s;
                            best = j;
                        }
                    }
                } else {
                    for (d, inv_d) in inv.iter().enumerate() {
                        if let Some(j) = grid.neighbour(x, y, d) {
                            let s = (hi - h[j]) * inv_d;
                            if s > steepest {
                                steepest = s;
                                best = j;
                            }
                        }
                    }
                }
            }
            rec[i] = best as u32;
        }
    }
}

/// Builds the stack: for each base-level cell in index order, its whole donor tree in
/// depth-first pre-order. Cells that drain into a pit instead of base level are not
/// reached; `stack.len() < grid.len()` signals that pits exist (an O(cells) test).
///
/// The walk is iterative and needs no explicit LIFO: going up means "next donor of the
/// current node, scanning its neighbours from direction `d`", going back down means
/// "continue at the receiver, after the direction we came from".
pub(super) fn build_stack(grid: Grid, base: &[bool], rec: &[u32], stack: &mut Vec<u32>) {
    stack.clear();
    for root in 0..grid.len() {
        if !base[root] {
            continue;
        }
        stack.push(root as u32);
        let mut node = root;
        let mut d = 0;
        loop {
            let (x, y) = grid.xy(node);
            let donor = (d..8).find_map(|k| {
                grid.neighbour(x, y, k)
                    .filter(|&j| rec[j] as usize == node)
                    .map(|j| (k, j))
            });
            match donor {
                Some((_, j)) => {
                    stack.push(j as u32);
                    node = j;
                    d = 0;
                }
                None if node == root => break,
                None => {
                    let parent = rec[node] as usize;
                    d = grid.direction(parent, node) + 1;
                    node = parent;
                }
            }
        }
    }
}

/// Drainage area in m^2: each cell contributes `cell^2`, summed over the donor tree by
/// walking the stack from its end (donors before receivers).
pub(super) fn accumulate_area(grid: Grid, rec: &[u32], stack: &[u32], area: &mut [f32]) {
    area.fill((grid.cell * grid.cell) as f32);
    for &i in stack.iter().rev() {
        let r = rec[i as usize];
        if r != i {
            area[r as usize] += area[i as usize];
        }
    }
}
