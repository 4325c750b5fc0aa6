//! Flow routing: D8 receivers, the Braun–Willett stack and drainage area.
//!
//! Braun & Willett (2013), node ordering: every node `i` has one receiver `r(i)`, its
//! steepest-descent neighbour (D8 here); the *stack* orders the nodes so that every
//! receiver precedes its donors, built by a depth-first walk of the donor tree from
//! each base-level node (their recursive `add_to_stack`). Drainage area is their
//! `A_i = sum over the donor tree of the cell areas`, accumulated by walking the
//! stack in reverse.
//!
//! Receivers are stored as a D8 direction code per cell (1 byte; [`NONE`] for
//! base-level cells and pits), not as indices, and the donors of each cell as a
//! bitmask of D8 directions (1 byte), so the depth-first walk needs no donor lists;
//! its LIFO lives in the unused end of the stack buffer.

use std::ops::Range;

use super::fill;
use super::grid::{D8_DIST, Grid};

/// Code of a cell without receiver (base level, pit or flat).
pub(super) const NONE: u8 = 8;

/// Receiver codes, donor bitmasks and the stack of one surface.
pub(super) struct Network {
    /// D8 receiver code per cell ([`NONE`]: no receiver).
    pub(super) dir: Vec<u8>,
    /// Bit `d` set: the neighbour in direction `d` drains into this cell.
    pub(super) donors: Vec<u8>,
    /// Cell indices, every receiver before its donors.
    pub(super) stack: Vec<u32>,
    /// Index offset of each receiver code ([`NONE`]: 0).
    pub(super) off: [isize; 9],
}

impl Network {
    pub(super) fn new(grid: Grid) -> Self {
        let n = grid.len();
        let off = grid.offsets();
        Network {
            dir: vec![NONE; n],
            donors: vec![0; n],
            stack: Vec::with_capacity(n),
            off: std::array::from_fn(|k| if k < 8 { off[k] } else { 0 }),
        }
    }

    /// Computes receivers and the stack, filling depressions in `h` first where free
    /// cells have no lower neighbour (see [`fill`]).
    pub(super) fn route(&mut self, grid: Grid, h: &mut [f32], base: &[bool]) {
        self.route_with_budget(grid, h, base, None);
    }

    /// [`route`](Self::route) with an optional cap on the local lake fills (tests use
    /// it to exercise the global fallback).
    pub(super) fn route_with_budget(
        &mut self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        max_fills: Option<usize>,
    ) {
        let mut route = Route::new(max_fills);
        while !self.continue_route(grid, h, base, &mut route, usize::MAX) {}
    }

    /// Continues `route` by about `cells` cells of work (at least one row of receivers, one
    /// lake or one cell of the stack) and returns whether the routing is complete: the same
    /// bits as [`route`](Self::route) however the work is split, as every piece runs in the
    /// same order. O(cells) over a whole routing.
    ///
    /// Receivers come first; then, if there are pits, their lakes are filled one by one;
    /// then the stack is built. If the local fills gave up (their work budget) the stack
    /// misses cells: then all unrouted cells are flooded, and receivers and the stack are
    /// computed once more.
    pub(super) fn continue_route(
        &mut self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        route: &mut Route,
        cells: usize,
    ) -> bool {
        match &mut route.stage {
            RouteStage::Receivers { row, pits } => {
                if *row == 0 {
                    self.donors.fill(0);
                }
                let rows = *row..row
                    .saturating_add(rows_per(cells, grid.width))
                    .min(grid.height);
                *row = rows.end;
                self.receivers(grid, h, base, rows, pits);
                if *row == grid.height {
                    let pits = std::mem::take(pits);
                    route.stage = if route.fell_back || pits.is_empty() {
                        RouteStage::Stack(self.start_stack(grid))
                    } else {
                        let budget = route
                            .max_fills
                            .unwrap_or(fill::LOCAL_FILLS_PER_PIT * pits.len() + 64);
                        RouteStage::Lakes(Box::new(fill::Lakes::new(grid, pits, budget)))
                    };
                }
            }
            RouteStage::Lakes(lakes) => {
                if lakes.fill(grid, h, base, self, cells) {
                    route.stage = RouteStage::Stack(self.start_stack(grid));
                }
            }
            RouteStage::Stack(walk) => {
                if self.walk_stack(base, walk, cells) {
                    route.stage = if self.stack.len() < grid.len() && !route.fell_back {
                        // The local fills gave up (work budget): flood all unrouted cells.
                        route.fell_back = true;
                        RouteStage::Unrouted(Box::new(fill::Unrouted::new(grid, &self.stack)))
                    } else {
                        debug_assert!(!route.fell_back || self.stack.len() == grid.len());
                        RouteStage::Done
                    };
                }
            }
            RouteStage::Unrouted(flood) => {
                if flood.fill(h, &self.dir, cells) {
                    route.stage = RouteStage::Receivers {
                        row: 0,
                        pits: Vec::new(),
                    };
                }
            }
            RouteStage::Done => {}
        }
        matches!(route.stage, RouteStage::Done)
    }

    /// Drainage area in m^2: each cell contributes `cell^2`, summed over the donor tree
    /// by walking the stack from its end (donors before receivers).
    pub(super) fn area(&self, grid: Grid, area: &mut [f32]) {
        start_area(grid, area);
        self.accumulate_area(area, 0..self.stack.len());
    }

    /// Adds the area of the stack's cells `run` to their receivers, walking the run from
    /// its end. Runs must come from the end of the stack to its start, the first after
    /// [`start_area`]; O(cells of the run).
    pub(super) fn accumulate_area(&self, area: &mut [f32], run: Range<usize>) {
        let off = self.off;
        for &i in self.stack[run].iter().rev() {
            let i = i as usize;
            let code = usize::from(self.dir[i]);
            if code != usize::from(NONE) {
                let a = area[i];
                area[i.wrapping_add_signed(off[code])] += a;
            }
        }
    }

    /// Receiver index of every cell (itself when it has none).
    pub(super) fn receiver_indices(&self) -> Vec<u32> {
        let off = self.off;
        let to = |(i, &code): (usize, &u8)| i.wrapping_add_signed(off[usize::from(code)]) as u32;
        self.dir.iter().enumerate().map(to).collect()
    }

    /// Steepest-descent (D8) receiver code of every cell of `rows`: slopes are
    /// `dh / distance`, diagonals at `sqrt(2)` cells, ties to the first direction in `D8`
    /// order. Base-level cells and free cells without a strictly lower neighbour (pits,
    /// flats) get [`NONE`]; the free ones are added to `pits` (an O(cells) pit test). The
    /// donor masks must be cleared before the first rows.
    fn receivers(
        &mut self,
        grid: Grid,
        h: &[f32],
        base: &[bool],
        rows: Range<usize>,
        pits: &mut Vec<usize>,
    ) {
        let off = self.off;
        for y in rows {
            for x in 0..grid.width {
                let i = y * grid.width + x;
                let code = if base[i] {
                    NONE
                } else {
                    steepest(grid, h, x, y, &off)
                };
                self.dir[i] = code;
                if code != NONE {
                    let d = usize::from(code);
                    self.donors[i.wrapping_add_signed(off[d])] |= 1 << (7 - d);
                } else if !base[i] {
                    pits.push(i);
                }
            }
        }
    }

    /// Recomputes the receiver of free cell `i` after local height changes, keeping
    /// the donor masks consistent. Returns whether `i` is now a pit.
    pub(super) fn update_receiver(
        &mut self,
        grid: Grid,
        h: &[f32],
        base: &[bool],
        i: usize,
    ) -> bool {
        if base[i] {
            return false;
        }
        let off = self.off;
        let (x, y) = grid.xy(i);
        let old = usize::from(self.dir[i]);
        let new = steepest(grid, h, x, y, &off);
        if old != NONE as usize {
            self.donors[i.wrapping_add_signed(off[old])] &= !(1 << (7 - old));
        }
        if new != NONE {
            let d = usize::from(new);
            self.donors[i.wrapping_add_signed(off[d])] |= 1 << (7 - d);
        }
        self.dir[i] = new;
        new == NONE
    }

    /// Starts building the stack (see [`walk_stack`](Self::walk_stack)).
    fn start_stack(&mut self, grid: Grid) -> StackWalk {
        let n = grid.len();
        self.stack.resize(n, 0);
        StackWalk {
            root: 0,
            out: 0,
            top: n,
        }
    }

    /// Builds the stack, continuing `walk` by about `cells` cells; returns whether it is
    /// complete. The stack holds, for each base-level cell in index order, its whole donor
    /// tree in depth-first pre-order, donors taken in D8 order, i.e. the order of Braun &
    /// Willett's recursive `add_to_stack`. Cells draining into a pit are not reached, so
    /// `stack.len() < grid.len()` signals remaining pits. O(cells) over a whole build.
    ///
    /// The recursion is replaced by a LIFO of discovered-but-unvisited cells that lives
    /// at the end of the stack buffer itself: visited + pending cells never exceed
    /// `grid.len()`, so the two ends never collide and no extra memory is needed.
    /// Donors are pushed in reverse D8 order so that they pop in D8 order.
    fn walk_stack(&mut self, base: &[bool], walk: &mut StackWalk, cells: usize) -> bool {
        let n = self.stack.len();
        let buf = &mut self.stack[..];
        let mut left = cells;
        loop {
            while walk.top < n {
                if left == 0 {
                    return false;
                }
                left -= 1;
                let node = buf[walk.top] as usize;
                walk.top += 1;
                buf[walk.out] = node as u32;
                walk.out += 1;
                let mut pending = self.donors[node];
                while pending != 0 {
                    let k = 7 - pending.leading_zeros() as usize;
                    pending ^= 1 << k;
                    walk.top -= 1;
                    buf[walk.top] = node.wrapping_add_signed(self.off[k]) as u32;
                }
            }
            match (walk.root..n).find(|&i| base[i]) {
                Some(root) => {
                    walk.root = root + 1;
                    walk.top -= 1;
                    buf[walk.top] = root as u32;
                }
                None => {
                    walk.root = n;
                    self.stack.truncate(walk.out);
                    return true;
                }
            }
        }
    }
}

/// Rows of `width` cells in about `cells` cells (at least one).
pub(super) fn rows_per(cells: usize, width: usize) -> usize {
    (cells / width.max(1)).max(1)
}

/// Sets every cell's own contribution, `cell^2`, before [`Network::accumulate_area`].
pub(super) fn start_area(grid: Grid, area: &mut [f32]) {
    area.fill((grid.cell * grid.cell) as f32);
}

/// A routing in progress ([`Network::continue_route`]).
pub(super) struct Route {
    stage: RouteStage,
    /// Cap on the local lake fills (`None`: [`fill::LOCAL_FILLS_PER_PIT`] per pit, + 64).
    max_fills: Option<usize>,
    /// Whether the fallback flood ran (the second stack is then complete).
    fell_back: bool,
}

impl Route {
    pub(super) fn new(max_fills: Option<usize>) -> Self {
        Route {
            stage: RouteStage::Receivers {
                row: 0,
                pits: Vec::new(),
            },
            max_fills,
            fell_back: false,
        }
    }
}

/// Where a routing stands.
enum RouteStage {
    /// Receivers of the rows from `row` on; the pits found above it.
    Receivers {
        row: usize,
        pits: Vec<usize>,
    },
    Lakes(Box<fill::Lakes>),
    Stack(StackWalk),
    Unrouted(Box<fill::Unrouted>),
    Done,
}

/// The depth-first walk of [`Network::walk_stack`] in progress: the next cell to look at
/// for a base-level root, the stack's length so far and the top of the LIFO (at the end of
/// the stack's buffer).
struct StackWalk {
    root: usize,
    out: usize,
    top: usize,
}

/// D8 code of the steepest strictly lower neighbour of `(x, y)`, or [`NONE`].
#[inline(always)]
fn steepest(grid: Grid, h: &[f32], x: usize, y: usize, off: &[isize; 9]) -> u8 {
    const INV: [f32; 8] = [
        std::f32::consts::FRAC_1_SQRT_2,
        1.0,
        std::f32::consts::FRAC_1_SQRT_2,
        1.0,
        1.0,
        std::f32::consts::FRAC_1_SQRT_2,
        1.0,
        std::f32::consts::FRAC_1_SQRT_2,
    ];
    debug_assert!(
        INV.iter()
            .zip(D8_DIST)
            .all(|(a, d)| (a * d as f32 - 1.0).abs() < 1e-6)
    );
    let i = y * grid.width + x;
    let hi = h[i];
    let interior = grid.interior(x, y);
    let (mut best, mut steepest) = (NONE, 0.0f32);
    for d in 0..8 {
        let j = if interior {
            i.wrapping_add_signed(off[d])
        } else {
            match grid.neighbour(x, y, d) {
                Some(j) => j,
                None => continue,
            }
        };
        let s = (hi - h[j]) * INV[d];
        let better = s > steepest;
        steepest = if better { s } else { steepest };
        best = if better { d as u8 } else { best };
    }
    best
}
