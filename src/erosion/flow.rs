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
        let pits = self.receivers(grid, h, base);
        if !pits.is_empty() {
            let budget = max_fills.unwrap_or(fill::LOCAL_FILLS_PER_PIT * pits.len() + 64);
            fill::fill_pits(grid, h, base, self, pits, budget);
        }
        self.build_stack(grid, base);
        if self.stack.len() < grid.len() {
            // The local fills gave up (work budget): flood all unrouted cells.
            fill::fill_unrouted(grid, h, &self.dir, &self.stack);
            self.receivers(grid, h, base);
            self.build_stack(grid, base);
            debug_assert_eq!(self.stack.len(), grid.len());
        }
    }

    /// Drainage area in m^2: each cell contributes `cell^2`, summed over the donor tree
    /// by walking the stack from its end (donors before receivers).
    pub(super) fn area(&self, grid: Grid, area: &mut [f32]) {
        let off = self.off;
        area.fill((grid.cell * grid.cell) as f32);
        for &i in self.stack.iter().rev() {
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

    /// Steepest-descent (D8) receiver code of every cell: slopes are `dh / distance`,
    /// diagonals at `sqrt(2)` cells, ties to the first direction in `D8` order.
    /// Base-level cells and free cells without a strictly lower neighbour (pits,
    /// flats) get [`NONE`]; the free ones are returned (an O(cells) pit test).
    fn receivers(&mut self, grid: Grid, h: &[f32], base: &[bool]) -> Vec<usize> {
        let mut pits = Vec::new();
        self.donors.fill(0);
        let off = self.off;
        for y in 0..grid.height {
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
        pits
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

    /// Builds the stack: for each base-level cell in index order, its whole donor tree
    /// in depth-first pre-order, donors taken in D8 order, i.e. the order of Braun &
    /// Willett's recursive `add_to_stack`. Cells draining into a pit are not reached,
    /// so `stack.len() < grid.len()` signals remaining pits.
    ///
    /// The recursion is replaced by a LIFO of discovered-but-unvisited cells that lives
    /// at the end of the stack buffer itself: visited + pending cells never exceed
    /// `grid.len()`, so the two ends never collide and no extra memory is needed.
    /// Donors are pushed in reverse D8 order so that they pop in D8 order.
    fn build_stack(&mut self, grid: Grid, base: &[bool]) {
        let n = grid.len();
        self.stack.resize(n, 0);
        let buf = &mut self.stack[..];
        let (mut out, mut top) = (0, n);
        for root in (0..n).filter(|&i| base[i]) {
            top -= 1;
            buf[top] = root as u32;
            while top < n {
                let node = buf[top] as usize;
                top += 1;
                buf[out] = node as u32;
                out += 1;
                let mut pending = self.donors[node];
                while pending != 0 {
                    let k = 7 - pending.leading_zeros() as usize;
                    pending ^= 1 << k;
                    top -= 1;
                    buf[top] = node.wrapping_add_signed(self.off[k]) as u32;
                }
            }
        }
        self.stack.truncate(out);
    }
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
