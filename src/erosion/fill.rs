//! Depression filling ("lakes filled to their sill") with Priority-Flood + epsilon
//! (Barnes, Lehman & Mulla 2014, "Priority-Flood: An optimal depression-filling and
//! watershed-labeling algorithm for digital elevation models", Computers &
//! Geosciences 62, Algorithm 3).
//!
//! Choice: depressions are filled to their sill plus a strictly increasing epsilon
//! gradient away from the outlet (one `f32` ulp per cell), rather than routed across
//! a graph of basins (Cordonnier et al. 2019). Filling is simple and exact, and it
//! leaves every free cell with a strictly lower D8 neighbour, so plain
//! steepest-descent receivers reach base level from everywhere. The filled volume
//! acts as instant lake sedimentation.
//!
//! Cost: pits are found during the O(cells) receiver pass, and nothing runs when there
//! are none. Each pit is then filled *locally* ([`fill_pits`]): a priority flood
//! grows the lake from the pit bottom in height order until it reaches a cell lower
//! than the lake level (or a base-level cell): the outlet beyond the sill. The lake is
//! then re-flooded from that outlet with Priority-Flood + epsilon, so it drains there,
//! and receivers are updated around it. If the outlet is itself a pit it is queued, and
//! lakes that spill into each other merge when the later flood climbs over the earlier
//! one. Work is proportional to the lakes, not to their catchments. As a safety net, if
//! a work budget runs out, [`fill_unrouted`] floods every cell not yet draining to base
//! level from the routed ones (the classic algorithm, seeded at base level).

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

use super::flow::{NONE, Network};
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
    fn clear(&mut self, i: usize) {
        self.0[i / 64] &= !(1 << (i % 64));
    }
}

/// Flood state: heights, receiver codes and the closed set.
struct Flood<'a> {
    grid: Grid,
    h: &'a mut [f32],
    dir: &'a [u8],
    closed: Bits,
    open: BinaryHeap<Low>,
    pit: VecDeque<usize>,
    subtree: Vec<usize>,
}

impl Flood<'_> {
    /// Pushes `i` on the heap if it has an open neighbour.
    fn push_if_border(&mut self, i: usize) {
        let (x, y) = self.grid.xy(i);
        if (0..8).any(|d| {
            self.grid
                .neighbour(x, y, d)
                .is_some_and(|j| !self.closed.get(j))
        }) {
            self.open.push(Low {
                h: self.h[i],
                i: i as u32,
            });
        }
    }

    /// Closes `j`, which is higher than a closed neighbour, and its open donor subtree;
    /// afterwards, subtree cells that still border open cells enter the heap.
    fn close_uphill(&mut self, j: usize) {
        let subtree = &mut self.subtree;
        subtree.push(j);
        let mut next = 0;
        while let Some(&x) = subtree.get(next) {
            next += 1;
            let (cx, cy) = self.grid.xy(x);
            for k in 0..8 {
                let Some(y) = self.grid.neighbour(cx, cy, k) else {
                    continue;
                };
                if !self.closed.get(y) && usize::from(self.dir[y]) == 7 - k {
                    self.closed.set(y);
                    subtree.push(y);
                }
            }
        }
        let mut subtree = std::mem::take(&mut self.subtree);
        for &x in &subtree {
            self.push_if_border(x);
        }
        subtree.clear();
        self.subtree = subtree;
    }

    fn run(&mut self) {
        while let Some(c) = self
            .pit
            .pop_front()
            .or_else(|| self.open.pop().map(|e| e.i as usize))
        {
            let hc = self.h[c];
            let (x, y) = self.grid.xy(c);
            for d in 0..8 {
                let Some(j) = self.grid.neighbour(x, y, d) else {
                    continue;
                };
                if self.closed.get(j) {
                    continue;
                }
                self.closed.set(j);
                if self.h[j] <= hc {
                    self.h[j] = hc.next_up();
                    self.pit.push_back(j);
                } else {
                    self.close_uphill(j);
                }
            }
        }
    }
}

/// Fallback: raises every cell that is not on `routed` (the stack: cells with a strictly
/// descending receiver path to base level) so that it gets a strictly lower neighbour
/// leading to a routed cell. Routed cells are never changed. `dir` are the receiver
/// codes of the current heights.
pub(super) fn fill_unrouted(grid: Grid, h: &mut [f32], dir: &[u8], routed: &[u32]) {
    let mut closed = Bits::new(grid.len());
    for &i in routed {
        closed.set(i as usize);
    }
    let mut flood = Flood {
        grid,
        h,
        dir,
        closed,
        open: BinaryHeap::new(),
        pit: VecDeque::new(),
        subtree: Vec::new(),
    };
    for i in 0..grid.len() {
        if flood.closed.get(i) {
            flood.push_if_border(i);
        }
    }
    flood.run();
}

/// Local fills allowed per pit found by the receiver pass (merging lakes need more than
/// one) before falling back to [`fill_unrouted`].
pub(super) const LOCAL_FILLS_PER_PIT: usize = 8;

/// Scratch state of the local fills.
struct Local {
    /// Cells seen by the current flood (cleared after each lake).
    seen: Bits,
    seen_list: Vec<usize>,
    /// Cells of the current lake, as a set and as a list.
    lake: Bits,
    lake_list: Vec<usize>,
    open: BinaryHeap<Low>,
    pit: VecDeque<usize>,
}

/// Fills the depressions of the given pits one by one (see the module docs), updating
/// `net.dir` / `net.donors` around each lake. Stops after `budget` lakes; the caller
/// detects unfinished work through an incomplete stack.
pub(super) fn fill_pits(
    grid: Grid,
    h: &mut [f32],
    base: &[bool],
    net: &mut Network,
    pits: Vec<usize>,
    budget: usize,
) {
    let n = grid.len();
    let mut budget = budget;
    let mut work: VecDeque<usize> = pits.into();
    let mut s = Local {
        seen: Bits::new(n),
        seen_list: Vec::new(),
        lake: Bits::new(n),
        lake_list: Vec::new(),
        open: BinaryHeap::new(),
        pit: VecDeque::new(),
    };
    while let Some(p) = work.pop_front() {
        if base[p] || net.dir[p] != NONE {
            continue; // drained by an earlier lake
        }
        if budget == 0 {
            return;
        }
        budget -= 1;
        if let Some(c) = one_cell_lake(grid, h, base, p) {
            h[p] = h[c].next_up();
            s.lake_list.extend([p, c]);
        } else {
            let Some(outlet) = s.grow_lake(grid, h, base, p) else {
                return;
            };
            s.drain_lake(grid, h, outlet);
            for &c in &s.lake_list {
                s.lake.clear(c); // all were reached; this only guards the invariant
            }
        }
        // Raising the lake only changes the receivers of lake cells and of cells that
        // drained into the lake (their donors); other slopes did not get steeper.
        for &c in &s.lake_list {
            let (donors, off) = (net.donors[c], net.off);
            for j in (0..8)
                .filter(|d| donors >> d & 1 == 1)
                .map(|d| c.wrapping_add_signed(off[d]))
            {
                if net.update_receiver(grid, h, base, j) {
                    work.push_back(j);
                }
            }
            if net.update_receiver(grid, h, base, c) {
                work.push_back(c);
            }
        }
        s.lake_list.clear();
    }
}

/// Fast path for the common pit (most are single cells left by diffusion in a
/// channel): if the lowest neighbour `c` of pit `p` is base level or has another
/// strictly lower neighbour, the full flood would only raise `p` to just above `c`
/// (`c` is the sill, its lower neighbour the outlet). Returns that `c`.
fn one_cell_lake(grid: Grid, h: &[f32], base: &[bool], p: usize) -> Option<usize> {
    let (x, y) = grid.xy(p);
    let lowest = |(x, y): (usize, usize), skip: usize| {
        (0..8)
            .filter_map(|d| grid.neighbour(x, y, d))
            .filter(|&j| j != skip)
            .min_by(|&a, &b| h[a].total_cmp(&h[b]).then(a.cmp(&b)))
    };
    let c = lowest((x, y), p)?;
    if base[c] {
        return Some(c);
    }
    let e = lowest(grid.xy(c), p)?;
    (h[e] < h[c]).then_some(c)
}

impl Local {
    fn see(&mut self, h: &[f32], j: usize) {
        self.seen.set(j);
        self.seen_list.push(j);
        self.open.push(Low {
            h: h[j],
            i: j as u32,
        });
    }

    /// Grows the lake of pit `p` in height order up to its sill; returns the outlet:
    /// the first cell reached that is lower than the lake level, or base level.
    fn grow_lake(&mut self, grid: Grid, h: &[f32], base: &[bool], p: usize) -> Option<usize> {
        let mut level = h[p];
        self.see(h, p);
        let mut outlet = None;
        while let Some(Low { i, .. }) = self.open.pop() {
            let c = i as usize;
            if base[c] || h[c] < level {
                outlet = Some(c);
                break;
            }
            level = h[c];
            self.lake.set(c);
            self.lake_list.push(c);
            let (x, y) = grid.xy(c);
            for j in (0..8).filter_map(|d| grid.neighbour(x, y, d)) {
                if !self.seen.get(j) {
                    self.see(h, j);
                }
            }
        }
        self.open.clear();
        for &j in &self.seen_list {
            self.seen.clear(j);
        }
        self.seen_list.clear();
        outlet
    }

    /// Priority-Flood + epsilon over the lake cells from `outlet`: every lake cell ends
    /// strictly above the cell it was reached from, so the lake drains to the outlet.
    fn drain_lake(&mut self, grid: Grid, h: &mut [f32], outlet: usize) {
        self.open.push(Low {
            h: h[outlet],
            i: outlet as u32,
        });
        while let Some(c) = self
            .pit
            .pop_front()
            .or_else(|| self.open.pop().map(|e| e.i as usize))
        {
            let hc = h[c];
            let (x, y) = grid.xy(c);
            for j in (0..8).filter_map(|d| grid.neighbour(x, y, d)) {
                if !self.lake.get(j) {
                    continue;
                }
                self.lake.clear(j);
                if h[j] <= hc {
                    h[j] = hc.next_up();
                    self.pit.push_back(j);
                } else {
                    self.open.push(Low {
                        h: h[j],
                        i: j as u32,
                    });
                }
            }
        }
    }
}
