//! Depression filling: Priority-Flood + epsilon (Barnes, Lehman & Mulla 2014,
//! "Priority-Flood: An optimal depression-filling and watershed-labeling algorithm
//! for digital elevation models", Computers & Geosciences 62, Algorithm 3).
//!
//! Choice: lakes are *filled to their sill* (plus a strictly increasing epsilon
//! gradient away from the sill, one `f32` ulp per cell), rather than routed across a
//! graph of basins (Cordonnier et al. 2019). Filling is simple, exact, and leaves a
//! surface on which every free cell has a strictly lower D8 neighbour, so the plain
//! steepest-descent receivers of Braun & Willett reach base level from everywhere.
//! The filled volume acts like instant lake sedimentation.
//!
//! Cost: only cells that do *not* already drain to base level are flooded. The flood
//! is seeded with the already-routed cells (those on the stack) that border an
//! unrouted one, so a step with a few small pits costs O(pit catchments * log)
//! plus one O(cells) scan, not a global O(cells log cells) flood.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

use super::grid::Grid;

/// Heap entry ordered so that `BinaryHeap` pops the lowest height first, ties by
/// lowest index (deterministic).
#[derive(Clone, Copy)]
struct Low {
    h: f32,
    i: u32,
}

impl PartialEq for Low {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Low {}
impl PartialOrd for Low {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Low {
    fn cmp(&self, other: &Self) -> Ordering {
        other.h.total_cmp(&self.h).then(other.i.cmp(&self.i))
    }
}

/// A fixed-size bit set (n/8 bytes).
struct Bits(Vec<u64>);

impl Bits {
    fn new(n: usize) -> Self {
        Bits(vec![0; n.div_ceil(64)])
    }
    fn get(&self, i: usize) -> bool {
        self.0[i / 64] >> (i % 64) & 1 == 1
    }
    fn set(&mut self, i: usize) {
        self.0[i / 64] |= 1 << (i % 64);
    }
}

/// Raises every cell that is not on `routed` (the stack: cells with a strictly
/// descending receiver path to base level) so that it gets a strictly lower neighbour
/// leading to a routed cell. Routed cells are never changed. Returns the number of
/// cells flooded.
pub(super) fn fill_unrouted(grid: Grid, h: &mut [f32], routed: &[u32]) -> usize {
    let n = grid.len();
    let mut closed = Bits::new(n);
    for &i in routed {
        closed.set(i as usize);
    }
    // Seeds: routed neighbours of unrouted cells (duplicates are harmless).
    let mut open = BinaryHeap::new();
    for i in (0..n).filter(|&i| !closed.get(i)) {
        let (x, y) = grid.xy(i);
        for d in 0..8 {
            if let Some(j) = grid.neighbour(x, y, d).filter(|&j| closed.get(j)) {
                open.push(Low { h: h[j], i: j as u32 });
            }
        }
    }
    // Cells raised into a depression are handled first, in FIFO order (Barnes'
    // "pit queue"), which keeps the epsilon gradient short.
    let mut pit = VecDeque::new();
    let mut flooded = 0;
    while let Some(c) = pit.pop_front().or_else(|| open.pop().map(|e| e.i as usize)) {
        let hc = h[c];
        let (x, y) = grid.xy(c);
        for d in 0..8 {
            let Some(j) = grid.neighbour(x, y, d) else { continue };
            if closed.get(j) {
                continue;
            }
            closed.set(j);
            flooded += 1;
            if h[j] <= hc {
                h[j] = hc.next_up();
                pit.push_back(j);
            } else {
                open.push(Low { h: h[j], i: j as u32 });
            }
        }
    }
    flooded
}
