//! Flow routing: one receiver per cell among its 8 neighbours, the Braun–Willett stack and
//! drainage area.
//!
//! Braun & Willett (2013), node ordering: every node `i` has one receiver `r(i)`, a lower
//! neighbour (their steepest descent, or one drawn as below); the *stack* orders the nodes so that every
//! receiver precedes its donors, built by a depth-first walk of the donor tree from
//! each base-level node (their recursive `add_to_stack`). Drainage area is their
//! `A_i = sum over the donor tree of the cell areas`, accumulated by walking the
//! stack in reverse.
//!
//! Which lower neighbour is the receiver ([`Pick`]): the steepest (D8, O'Callaghan and Mark
//! 1984), or one drawn at random among the strictly lower neighbours with probabilities in
//! proportion to their slopes, drawn anew every time step from a hash of the seed, the step
//! and the cell. The draw is the single-receiver form of the multiple-flow-direction
//! partition of Freeman (1991), "Calculating catchment area with divergent flow based on a
//! regular grid", Computers & Geosciences 17(3), and Quinn et al. (1991), with slope
//! exponent 1: the expected flow direction follows the surface's gradient at any angle,
//! where the steepest of 8 neighbours locks it to the 8 grid directions (the randomised
//! single direction of Fairfield and Leymarie 1991, "Drainage networks from grid digital
//! elevation models", Water Resources Research 27(5), with Freeman's weights). The implicit
//! solver keeps one receiver a cell, and since the draw changes every step, the channels
//! the steps carve together follow the land, not the grid.
//!
//! Receivers are stored as a D8 direction code per cell (1 byte; [`NONE`] for
//! base-level cells and pits), not as indices, and the donors of each cell as a
//! bitmask of D8 directions (1 byte), so the depth-first walk ([`super::stack`]) needs no
//! donor lists.

use std::ops::Range;

use super::fill;
use super::grid::{D8_DIST, Grid};
use super::stack::TreeWalk;
use crate::parallel;

/// Code of a cell without receiver (base level, pit or flat).
pub(super) const NONE: u8 = 8;

/// How a cell picks its receiver among its strictly lower neighbours (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pick {
    /// The steepest descent, ties to the first in D8 order.
    Steepest,
    /// One drawn in proportion to the slopes, with this routing's key ([`step_key`]), each
    /// cell's draw keyed on its place in the [`Frame`].
    Random(u32, Frame),
}

/// Where a grid lies in a larger one whose cells key the random draws: a window of a world
/// built in tiles draws, at each cell, what the whole world would draw there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Frame {
    /// The grid's first column and row in the larger grid.
    pub(super) x0: usize,
    pub(super) y0: usize,
    /// The larger grid's width.
    pub(super) stride: usize,
}

impl Frame {
    /// The grid as its own frame (`width` cells a row).
    pub(super) fn own(width: usize) -> Self {
        Self {
            x0: 0,
            y0: 0,
            stride: width,
        }
    }

    /// Cell (`x`, `y`) of the grid's index in the larger grid.
    #[inline(always)]
    fn index(self, x: usize, y: usize) -> usize {
        (y + self.y0) * self.stride + x + self.x0
    }
}

/// The key of the random receivers of time step `step` of a run seeded with `seed`.
pub(super) fn step_key(seed: u64, step: u32) -> u32 {
    hash32(seed as u32 ^ hash32((seed >> 32) as u32 ^ hash32(step.wrapping_add(1))))
}

/// Chris Wellons' `lowbias32` integer hash: every input bit moves every output bit; the same
/// bits in `shaders/erosion.wgsl`.
pub(super) fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The uniform number in `[0, 1)` of cell `i` under routing key `key` (24 bits).
#[inline(always)]
fn draw(key: u32, i: usize) -> f32 {
    (hash32(i as u32 ^ key) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Receiver codes, donor bitmasks and the stack of one surface.
pub(super) struct Network {
    /// D8 receiver code per cell ([`NONE`]: no receiver).
    pub(super) dir: Vec<u8>,
    /// Bit `d` set: the neighbour in direction `d` drains into this cell.
    pub(super) donors: Vec<u8>,
    /// Cell indices, every receiver before its donors.
    pub(super) stack: Vec<u32>,
    /// Where each base-level cell's tree starts in the stack, in increasing order: no cell
    /// drains across one of these, so the runs between them can be computed at once.
    pub(super) roots: Vec<u32>,
    /// The stack's walk, one a thread ([`super::stack`]), kept for their buffers.
    pub(super) walks: Vec<TreeWalk>,
    /// Index offset of each receiver code ([`NONE`]: 0).
    pub(super) off: [isize; 9],
    /// How the next routing picks receivers.
    pub(super) pick: Pick,
    /// Guided receivers ([`super::guide`]): a cell with a code here drains that way whatever
    /// the heights ([`NONE`]: picked as above); empty: none.
    pub(super) guide: Vec<u8>,
}

impl Network {
    pub(super) fn new(grid: Grid) -> Self {
        let n = grid.len();
        let off = grid.offsets();
        Network {
            dir: vec![NONE; n],
            donors: vec![0; n],
            stack: Vec::with_capacity(n),
            roots: Vec::new(),
            walks: Vec::new(),
            off: std::array::from_fn(|k| if k < 8 { off[k] } else { 0 }),
            pick: Pick::Steepest,
            guide: Vec::new(),
        }
    }

    /// The receiver code of free cell `(x, y)`: its guided one if it has one, else the one
    /// [`Pick`] chooses among its lower neighbours.
    #[inline]
    fn receiver_of(&self, grid: Grid, h: &[f32], x: usize, y: usize) -> u8 {
        guided_or_picked(&self.guide, (grid, h), x, y, (&self.off, self.pick))
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
    /// Receivers come first; then, if there are pits, their lakes are filled one by one
    /// (or, where pits are many, all unrouted cells are flooded at once: see [`fill`]);
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
                    .saturating_add(rows_per(
                        cells.saturating_mul(parallel::threads()),
                        grid.width,
                    ))
                    .min(grid.height);
                *row = rows.end;
                self.receivers(grid, h, base, rows, pits);
                if *row == grid.height {
                    let pits = std::mem::take(pits);
                    // Many pits (a rough first surface): one flood of every unrouted cell
                    // costs less than lakes filled one by one, which spill into each other.
                    // A test's cap on the local fills keeps them.
                    let flood_all = route.max_fills.is_none()
                        && pits.len() > grid.len() / fill::PITS_FOR_ONE_FLOOD;
                    route.stage = if route.fell_back || pits.is_empty() || flood_all {
                        self.start_stack(grid);
                        RouteStage::Stack
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
                    self.start_stack(grid);
                    route.stage = RouteStage::Stack;
                }
            }
            RouteStage::Stack => {
                if self.walk_stack(base, cells) {
                    route.stage = if self.stack.len() < grid.len() && !route.fell_back {
                        // Pits were many, or the local fills gave up (work budget): flood
                        // all unrouted cells.
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
    /// [`start_area`]; O(cells of the run). The run's independent parts
    /// ([`independent_runs`](Self::independent_runs)) go to the threads: the same bits.
    pub(super) fn accumulate_area(&self, area: &mut [f32], run: Range<usize>) {
        let runs = self.independent_runs(run);
        if let [run] = &runs[..] {
            self.add_area(run.clone(), area);
            return;
        }
        let shared = parallel::SharedField::new(area);
        parallel::for_each_item(runs, |part| self.add_area(part, &mut &shared));
    }

    /// [`accumulate_area`](Self::accumulate_area) of one run on one thread.
    fn add_area<C: parallel::Cells + ?Sized>(&self, run: Range<usize>, area: &mut C) {
        for &i in self.stack[run].iter().rev() {
            let i = i as usize;
            let code = usize::from(self.dir[i]);
            if code != usize::from(NONE) {
                let to = i.wrapping_add_signed(self.off[code]);
                area.set(to, area.get(to) + area.get(i));
            }
        }
    }

    /// Receiver index of every cell (itself when it has none).
    pub(super) fn receiver_indices(&self) -> Vec<u32> {
        let off = self.off;
        let to = |(i, &code): (usize, &u8)| i.wrapping_add_signed(off[usize::from(code)]) as u32;
        self.dir.iter().enumerate().map(to).collect()
    }

    /// Receiver code of every cell of `rows` by [`Network::pick`]: slopes are
    /// `dh / distance`, diagonals at `sqrt(2)` cells; the steepest takes ties to the first
    /// direction in `D8` order. Base-level cells and free cells without a strictly lower neighbour (pits,
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
        let (w, off, pick) = (grid.width, self.off, self.pick);
        let cells = rows.start * w..rows.end * w;
        // Each cell's code depends only on the heights: bands of rows at the same time.
        let per = rows.len().div_ceil(parallel::bands(w, rows.len())).max(1);
        let guide = &self.guide;
        parallel::for_each_band(&mut self.dir[cells.clone()], per * w, |k, codes| {
            let first = rows.start + k * per;
            for (y, row) in (first..).zip(codes.chunks_mut(w)) {
                for (x, code) in row.iter_mut().enumerate() {
                    *code = if base[y * w + x] {
                        NONE
                    } else {
                        guided_or_picked(guide, (grid, h), x, y, (&off, pick))
                    };
                }
            }
        });
        for i in cells {
            let code = self.dir[i];
            if code != NONE {
                let d = usize::from(code);
                self.donors[i.wrapping_add_signed(off[d])] |= 1 << (7 - d);
            } else if !base[i] {
                pits.push(i);
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
        let new = self.receiver_of(grid, h, x, y);
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
}

/// The receiver code of free cell `(x, y)`: its guided one (`guide`, empty: none) if it has
/// one, else the one `pick` chooses among its lower neighbours.
#[inline]
fn guided_or_picked(
    guide: &[u8],
    (grid, h): (Grid, &[f32]),
    x: usize,
    y: usize,
    (off, pick): (&[isize; 9], Pick),
) -> u8 {
    match guide.get(y * grid.width + x) {
        Some(&code) if code != NONE => code,
        _ => receiver(grid, h, x, y, off, pick),
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
    /// Cap on the local lake fills (`None`: [`fill::LOCAL_FILLS_PER_PIT`] per pit, + 64, and
    /// one flood of all unrouted cells instead where pits are many; `Some`: lakes always).
    max_fills: Option<usize>,
    /// Whether the fallback flood ran (the second stack is then complete).
    fell_back: bool,
}

impl Route {
    /// Whether every cell the receivers and lakes left unrouted was flooded at once (many
    /// pits, or the local fills' budget ran out).
    #[cfg(test)]
    pub(super) fn flooded_all(&self) -> bool {
        self.fell_back
    }

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
    Stack,
    Unrouted(Box<fill::Unrouted>),
    Done,
}

/// `1 / distance` of each D8 step, in cells.
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

/// The slope `dh / distance` (`f32`) to each D8 neighbour of `(x, y)`, 0 off the map.
#[inline(always)]
fn slopes(grid: Grid, h: &[f32], x: usize, y: usize, off: &[isize; 9]) -> [f32; 8] {
    debug_assert!(
        INV.iter()
            .zip(D8_DIST)
            .all(|(a, d)| (a * d as f32 - 1.0).abs() < 1e-6)
    );
    let i = y * grid.width + x;
    let hi = h[i];
    let interior = grid.interior(x, y);
    std::array::from_fn(|d| {
        let j = if interior {
            i.wrapping_add_signed(off[d])
        } else {
            match grid.neighbour(x, y, d) {
                Some(j) => j,
                None => return 0.0,
            }
        };
        (hi - h[j]) * INV[d]
    })
}

/// D8 code of the receiver of `(x, y)` by `pick`, or [`NONE`] where no neighbour is
/// strictly lower.
#[inline(always)]
fn receiver(grid: Grid, h: &[f32], x: usize, y: usize, off: &[isize; 9], pick: Pick) -> u8 {
    let s = slopes(grid, h, x, y, off);
    match pick {
        Pick::Steepest => steepest(&s),
        Pick::Random(key, frame) => drawn(&s, draw(key, frame.index(x, y))),
    }
}

/// The steepest positive slope's code (ties to the first), or [`NONE`].
#[inline(always)]
fn steepest(s: &[f32; 8]) -> u8 {
    let (mut best, mut steepest) = (NONE, 0.0f32);
    for (d, &s) in s.iter().enumerate() {
        let better = s > steepest;
        steepest = if better { s } else { steepest };
        best = if better { d as u8 } else { best };
    }
    best
}

/// The code whose share of the positive slopes' sum holds `u * sum` (`u` in `[0, 1)`): each
/// lower neighbour with probability `slope / sum`. [`NONE`] without a positive slope.
///
/// The running sums are taken once, as `max(s, 0)` added in D8 order, and compared with
/// `u * sum`: the WGSL kernel does exactly these operations (a `max` between the slope's
/// product and the add, so no GPU fuses them), so the same heights draw the same neighbour.
/// The kernel returns the first lower neighbour whose running sum exceeds `u * sum`; as the
/// sums never decrease, and rise only at lower neighbours, that is the count of sums not
/// above `u * sum`, which this counts without branches.
#[inline(always)]
fn drawn(s: &[f32; 8], u: f32) -> u8 {
    let mut running = [0.0f32; 8];
    let mut total = 0.0f32;
    for (sum, &s) in running.iter_mut().zip(s) {
        total += s.max(0.0);
        *sum = total;
    }
    let target = u * total;
    let below = running.iter().map(|&r| u8::from(r <= target)).sum::<u8>();
    if below < 8 {
        return below;
    }
    // No lower neighbour, or `u * sum` rounded up to the sum: the last lower neighbour.
    s.iter().rposition(|&s| s > 0.0).map_or(NONE, |d| d as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel's loop (`shaders/erosion.wgsl`): the first lower neighbour whose running
    /// sum exceeds `u * sum`, else the last lower neighbour.
    fn drawn_as_the_kernel(s: &[f32; 8], u: f32) -> u8 {
        let mut running = [0.0f32; 8];
        let mut total = 0.0f32;
        for (sum, &s) in running.iter_mut().zip(s) {
            total += s.max(0.0);
            *sum = total;
        }
        let target = u * total;
        let mut last = NONE;
        for (d, &s) in s.iter().enumerate() {
            if s > 0.0 {
                last = d as u8;
                if target < running[d] {
                    return last;
                }
            }
        }
        last
    }

    #[test]
    fn the_count_of_sums_draws_what_the_kernel_draws() {
        let mut key = 7u32;
        let mut next = || {
            key = hash32(key);
            (key >> 8) as f32 / 16_777_216.0
        };
        let edges = [0.0, 0.5, 1.0 - 1.0 / 16_777_216.0];
        for case in 0..20_000 {
            // Slopes of either sign, some exactly zero, some tiny beside large ones.
            let s: [f32; 8] = std::array::from_fn(|_| {
                let v = next();
                match (v * 8.0) as u32 {
                    0 => 0.0,
                    1 => -v,
                    2 => v * 1e-7,
                    _ => (v - 0.3) * 100.0,
                }
            });
            let u = edges.get(case % 7).copied().unwrap_or_else(&mut next);
            assert_eq!(drawn(&s, u), drawn_as_the_kernel(&s, u), "{s:?} {u}");
        }
    }

    /// Over uniform draws, each lower neighbour is picked in proportion to its slope; higher
    /// neighbours and neighbours off the map (slope 0) never.
    #[test]
    fn draws_follow_the_slopes() {
        let s = [0.5, -1.0, 0.0, 1.5, 0.0, 2.0, -0.2, 0.0];
        let mut counts = [0usize; 9];
        let draws = 40_000;
        for k in 0..draws {
            counts[usize::from(drawn(&s, draw(step_key(9, 0), k)))] += 1;
        }
        for (d, &slope) in s.iter().enumerate() {
            let expected = f64::from(slope.max(0.0)) / 4.0;
            let got = counts[d] as f64 / draws as f64;
            assert!(
                (got - expected).abs() < 0.01,
                "direction {d}: {got} vs {expected}"
            );
        }
        assert_eq!(counts[usize::from(NONE)], 0);
        assert_eq!(drawn(&[0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 0.5), NONE);
        assert_eq!(steepest(&s), 5);
    }

    /// A window of a larger grid keyed on it ([`Frame`]) picks, at every cell whose
    /// neighbours are all inside it, the receiver the whole grid picks there: overlapping
    /// windows of a world draw alike.
    #[test]
    fn a_window_in_its_frame_draws_what_the_whole_grid_draws() {
        let (n, x0, y0, w, h) = (40, 7, 11, 20, 16);
        let heights: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                0.3 * x + 0.2 * y + (x * 0.7).sin() * (y * 0.3).cos()
            })
            .collect();
        let window: Vec<f32> = (0..w * h)
            .map(|i| heights[(y0 + i / w) * n + x0 + i % w])
            .collect();
        let whole = Grid {
            width: n,
            height: n,
            cell: 1.0,
        };
        let part = Grid {
            width: w,
            height: h,
            cell: 1.0,
        };
        let key = step_key(5, 0);
        let frame = Frame { x0, y0, stride: n };
        let (a, b) = (Network::new(whole).off, Network::new(part).off);
        let (mut same, mut other) = (0, 0);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let full = receiver(
                    whole,
                    &heights,
                    x0 + x,
                    y0 + y,
                    &a,
                    Pick::Random(key, Frame::own(n)),
                );
                let windowed = receiver(part, &window, x, y, &b, Pick::Random(key, frame));
                let own = receiver(part, &window, x, y, &b, Pick::Random(key, Frame::own(w)));
                assert_eq!(full, windowed, "({x}, {y})");
                same += usize::from(own == full);
                other += 1;
            }
        }
        assert!(
            same < other,
            "the window's own keys draw otherwise somewhere"
        );
    }

    /// The draws change with the step and the seed, and are the same for the same ones.
    #[test]
    fn keys_depend_on_seed_and_step() {
        assert_eq!(step_key(1, 2), step_key(1, 2));
        assert_ne!(step_key(1, 2), step_key(1, 3));
        assert_ne!(step_key(1, 2), step_key(2, 2));
        assert_ne!(step_key(1 << 40, 2), step_key(0, 2));
    }
}
