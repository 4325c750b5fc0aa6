//! The Braun–Willett stack (Braun & Willett 2013, their recursive `add_to_stack`): for each
//! base-level cell in index order, its whole donor tree in depth-first pre-order, donors
//! taken in D8 order, so every receiver comes before its donors.
//!
//! A cell drains only within its own tree, so trees can be walked, and later summed and
//! solved ([`Network::independent_runs`]), at the same time. The walk splits the cells into
//! one band a thread; each band's roots have their trees walked into a buffer of that
//! band's, and the buffers are laid end to end in band order: the stack a single walk over
//! every root in index order makes, whatever the number of threads.

use std::ops::Range;

use super::flow::Network;
use super::grid::Grid;
use crate::parallel;

/// Below this many cells, the stack is walked, and its runs summed and solved, on one
/// thread (spawning would cost more).
const MIN_PARALLEL_CELLS: usize = 1 << 15;

/// The threads the trees go to: natively every thread; in the page one. Measured in the
/// page's threaded build on two threads (`BENCH_THREADS=only node web/tests/bench.mjs`),
/// the trees on both threads made the erosion slower (1024^2 3316 -> 3713 ms, 2048^2 6286 ->
/// 6488 ms): a wasm thread wakes slowly for each run, and wasm's atomic stores are
/// sequentially consistent (a locked exchange each on x86), where natively a relaxed store is
/// a plain one.
pub(super) fn tree_threads() -> usize {
    if cfg!(target_arch = "wasm32") {
        1
    } else {
        parallel::threads()
    }
}

/// One band's share of the stack's walk: the trees of the base-level cells in `next..end`.
#[derive(Default)]
pub(super) struct TreeWalk {
    /// The next cell to look at for a base-level root, and the band's end.
    next: usize,
    end: usize,
    /// The trees walked so far, in stack order (the first band's become the stack).
    out: Vec<u32>,
    /// Cells found but not walked yet (the recursion's stack), donors pushed in reverse D8
    /// order so that they pop in D8 order.
    pending: Vec<u32>,
    /// Where each tree starts in `out`.
    roots: Vec<u32>,
    done: bool,
}

impl TreeWalk {
    /// Walks on by about `cells` cells; returns whether the band's trees are all walked.
    fn walk(&mut self, donors: &[u8], off: &[isize; 9], base: &[bool], cells: usize) -> bool {
        let mut left = cells;
        loop {
            while let Some(&node) = self.pending.last() {
                if left == 0 {
                    return false;
                }
                left -= 1;
                self.pending.pop();
                self.out.push(node);
                let node = node as usize;
                let mut donors = donors[node];
                while donors != 0 {
                    let k = 7 - donors.leading_zeros() as usize;
                    donors ^= 1 << k;
                    self.pending.push(node.wrapping_add_signed(off[k]) as u32);
                }
            }
            match (self.next..self.end).find(|&i| base[i]) {
                Some(root) => {
                    self.next = root + 1;
                    self.roots.push(self.out.len() as u32);
                    self.pending.push(root as u32);
                }
                None => {
                    self.next = self.end;
                    self.done = true;
                    return true;
                }
            }
        }
    }
}

impl Network {
    /// Starts building the stack (see [`walk_stack`](Self::walk_stack)) in one band a
    /// thread.
    pub(super) fn start_stack(&mut self, grid: Grid) {
        let n = grid.len();
        let bands = if n < MIN_PARALLEL_CELLS {
            1
        } else {
            tree_threads()
        };
        self.start_stack_in(n, bands);
    }

    /// [`start_stack`](Self::start_stack) in `bands` bands of cells.
    pub(super) fn start_stack_in(&mut self, n: usize, bands: usize) {
        let bands = bands.clamp(1, n.max(1));
        self.walks.resize_with(bands, TreeWalk::default);
        for (k, walk) in self.walks.iter_mut().enumerate() {
            walk.next = n * k / bands;
            walk.end = n * (k + 1) / bands;
            walk.out.clear();
            walk.pending.clear();
            walk.roots.clear();
            walk.done = false;
        }
        // The first band writes straight into the stack's buffer.
        self.stack.clear();
        self.roots.clear();
        std::mem::swap(&mut self.walks[0].out, &mut self.stack);
        std::mem::swap(&mut self.walks[0].roots, &mut self.roots);
    }

    /// Builds the stack, continuing the walk by about `cells` cells a band; returns whether
    /// it is complete. Cells draining into a pit are not reached, so `stack.len() <
    /// grid.len()` signals remaining pits. O(cells) over a whole build; memory: the stack,
    /// and the later bands' trees until they are laid after the first band's.
    pub(super) fn walk_stack(&mut self, base: &[bool], cells: usize) -> bool {
        let (donors, off) = (&self.donors, &self.off);
        let walks: Vec<&mut TreeWalk> = self.walks.iter_mut().filter(|w| !w.done).collect();
        parallel::for_each_item(walks, |walk| {
            walk.walk(donors, off, base, cells);
        });
        if !self.walks.iter().all(|w| w.done) {
            return false;
        }
        let (first, rest) = self.walks.split_at_mut(1);
        std::mem::swap(&mut first[0].out, &mut self.stack);
        std::mem::swap(&mut first[0].roots, &mut self.roots);
        for walk in rest {
            let start = self.stack.len() as u32;
            self.roots.extend(walk.roots.iter().map(|r| r + start));
            self.stack.extend_from_slice(&walk.out);
        }
        true
    }

    /// Splits `run` of the stack into one run a thread (one if short), cut only where a
    /// base-level cell's tree starts: a cell's receiver is in its own tree, so no cell of a
    /// part drains into another part, and the parts can be computed at once, each in stack
    /// order, giving the bits of the run computed whole. O(threads log roots).
    pub(super) fn independent_runs(&self, run: Range<usize>) -> Vec<Range<usize>> {
        let parts = if run.len() < MIN_PARALLEL_CELLS {
            1
        } else {
            tree_threads()
        };
        self.runs_between_trees(run, parts)
    }

    /// [`independent_runs`](Self::independent_runs) in at most `parts` parts.
    pub(super) fn runs_between_trees(&self, run: Range<usize>, parts: usize) -> Vec<Range<usize>> {
        let mut cuts = vec![run.start];
        for k in 1..parts {
            let target = run.start + run.len() * k / parts;
            let next = self.roots.partition_point(|&r| (r as usize) < target);
            let cut = self.roots.get(next).map_or(run.end, |&r| r as usize);
            if cut > cuts[cuts.len() - 1] && cut < run.end {
                cuts.push(cut);
            }
        }
        cuts.push(run.end);
        cuts.windows(2).map(|c| c[0]..c[1]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{grid_of, rough_surface};
    use super::*;

    /// A routed rough surface draining to its border and to a line inside it.
    fn routed() -> (Network, Vec<bool>) {
        let (w, h) = (96, 80);
        let grid = grid_of(w, h, 10.0);
        let (mut z, base) = rough_surface(w, h, 5, 60.0);
        let mut net = Network::new(grid);
        net.route(grid, &mut z, &base);
        assert_eq!(net.stack.len(), w * h);
        (net, base)
    }

    /// Walked in bands, in pieces of any size, the stack and its trees' starts are those
    /// of one walk over every root in turn.
    #[test]
    fn bands_walk_the_stack_one_walk_makes() {
        let (mut net, base) = routed();
        let n = base.len();
        let (stack, roots) = (net.stack.clone(), net.roots.clone());
        assert_eq!(roots.len(), base.iter().filter(|b| **b).count());
        assert!(roots.iter().all(|&r| base[stack[r as usize] as usize]));
        for bands in [2, 3, 7] {
            for cells in [1, 37, usize::MAX] {
                net.start_stack_in(n, bands);
                while !net.walk_stack(&base, cells) {}
                assert!(
                    net.stack == stack && net.roots == roots,
                    "{bands} bands of {cells}"
                );
            }
        }
    }

    /// No cell of a part drains into another part: the parts' receivers lie in their own
    /// part, or, for the first part only, before it (computed earlier).
    #[test]
    fn no_cell_drains_across_the_runs() {
        let (net, _) = routed();
        let n = net.stack.len();
        let mut place = vec![0; n];
        for (k, &i) in net.stack.iter().enumerate() {
            place[i as usize] = k;
        }
        let receivers = net.receiver_indices();
        for run in [0..n, 1000..5000, 17..n - 3] {
            for parts in [2, 3, 5] {
                let runs = net.runs_between_trees(run.clone(), parts);
                // Fewer where one tree spans two cuts; one would prove nothing.
                assert!((2..=parts).contains(&runs.len()), "{run:?} in {parts}");
                assert!(runs.windows(2).all(|r| r[0].end == r[1].start));
                assert_eq!(
                    (runs[0].start, runs[runs.len() - 1].end),
                    (run.start, run.end)
                );
                for (k, part) in runs.iter().enumerate() {
                    for &i in &net.stack[part.clone()] {
                        let to = place[receivers[i as usize] as usize];
                        let inside = to < part.end && (k == 0 || to >= part.start);
                        assert!(inside, "cell {i} of part {k} drains to place {to}");
                    }
                }
            }
        }
    }
}
