//! Does the terrain drain along its rivers? D8 steepest descent on the final heights, and
//! the depression filling that makes it drain (on the CPU here, on the GPU in [`gpu`]).

pub mod gpu;

use std::ops::Range;

use serde::Serialize;

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::parallel;
use crate::radix_heap::{RadixHeap, ordered_key};
use crate::skeleton::CellKind;

/// Drainage measures of a terrain (`strahler generate --report`, tests).
#[derive(Clone, Debug, Default, Serialize, serde::Deserialize)]
pub struct Drainage {
    /// Cells of the drawn rivers: the strokes, sketched valleys, and, where the erosion did
    /// not shape them, the branches the L-system grew.
    pub river_cells: usize,
    /// River cells whose steepest descent leads to a river cell or off the map.
    pub river_cells_draining: usize,
    pub river_fraction: f64,
    /// Cells of the grown branches the erosion shaped ([`CellKind::Grown`]): their course is
    /// kept, their heights come from the law, so on steep small branches the steepest descent
    /// may cut a corner beside the branch.
    pub branch_cells: usize,
    /// Branch cells whose steepest descent leads to a river or branch cell or off the map.
    pub branch_cells_draining: usize,
    /// `branch_cells_draining / branch_cells`, 1 without branches.
    pub branch_fraction: f64,
    /// Cells whose descent path reaches the map border (an outlet).
    pub cells_to_outlet: usize,
    pub outlet_fraction: f64,
    /// Interior cells with no lower neighbour (pits).
    pub pit_cells: usize,
    pub pit_fraction: f64,
}

const NEIGHBOURS: [(i64, i64, f32); 8] = [
    (-1, 0, 1.0),
    (1, 0, 1.0),
    (0, -1, 1.0),
    (0, 1, 1.0),
    (-1, -1, std::f32::consts::SQRT_2),
    (1, -1, std::f32::consts::SQRT_2),
    (-1, 1, std::f32::consts::SQRT_2),
    (1, 1, std::f32::consts::SQRT_2),
];

impl Drainage {
    /// How the grown branches drain, for a report line after the rivers' share: `", 87.0% of
    /// the grown branches' cells"`, empty without branches.
    pub fn branches_note(&self) -> String {
        if self.branch_cells == 0 {
            return String::new();
        }
        format!(
            ", {:.1}% of the grown branches' cells",
            self.branch_fraction * 100.0
        )
    }
}

/// `part / whole`, 1 for no cells at all (nothing failed to drain).
fn share(part: usize, whole: usize) -> f64 {
    if whole == 0 {
        1.0
    } else {
        part as f64 / whole as f64
    }
}

/// D8 receivers of the cells of `rows`: the neighbour of steepest descent, `None` for a cell
/// with no lower neighbour. Border cells drain off the map when nothing inside is lower.
fn receivers_of_rows(field: &Heightfield, rows: Range<usize>, out: &mut Vec<Option<u32>>) {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    let cells = rows.start as i64 * w..rows.end as i64 * w;
    out.extend(cells.map(|i| {
        let (x, y) = (i % w, i / w);
        let mut best = None;
        let mut steepest = 0.0f32;
        for (dx, dy, dist) in NEIGHBOURS {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let j = ny * w + nx;
            let slope = (z[i as usize] - z[j as usize]) / dist;
            if slope > steepest {
                steepest = slope;
                best = Some(j as u32);
            }
        }
        best
    }));
}

/// Whether any interior cell of `rows` has no strictly lower neighbour (a pit or a flat).
fn rows_have_pits(field: &Heightfield, rows: Range<usize>) -> bool {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    let rows = (rows.start as i64).max(1)..(rows.end as i64).min(h - 1);
    rows.into_iter().any(|y| {
        (1..w - 1).any(|x| {
            let c = z[(y * w + x) as usize];
            !NEIGHBOURS
                .iter()
                .any(|(dx, dy, _)| z[((y + dy) * w + x + dx) as usize] < c)
        })
    })
}

/// No D8 receiver (a pit, a flat or a border cell that drains off the map).
const NO_RECEIVER: u32 = u32::MAX;

/// D8 receiver of cell `i`, [`NO_RECEIVER`] where [`receivers_of_rows`] gives `None`: the
/// same neighbours in the same order, so ties go the same way.
#[inline]
fn receiver_at(z: &[f32], w: usize, h: usize, i: usize) -> u32 {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    let c = z[i];
    let mut best = NO_RECEIVER;
    let mut steepest = 0.0f32;
    for (dx, dy, dist) in NEIGHBOURS {
        let (nx, ny) = (x + dx, y + dy);
        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            continue;
        }
        let j = ny as usize * w + nx as usize;
        let slope = (c - z[j]) / dist;
        if slope > steepest {
            steepest = slope;
            best = j as u32;
        }
    }
    best
}

/// Whether each cell of row `y` has a strictly lower neighbour, into `out` (`w` entries):
/// exactly where [`receiver_at`] gives a receiver (a lower neighbour's slope is positive for
/// any heights, infinities included, and a NaN never compares lower either way). The
/// interior cells go direction by direction along the row over contiguous slices, with no
/// division: the drainage count only needs the receivers of river cells.
fn lower_neighbours_of_row(z: &[f32], w: usize, h: usize, y: usize, out: &mut [bool]) {
    let row = y * w;
    if y == 0 || y + 1 == h || w < 3 {
        for (x, lower) in out.iter_mut().enumerate() {
            *lower = receiver_at(z, w, h, row + x) != NO_RECEIVER;
        }
        return;
    }
    out[0] = receiver_at(z, w, h, row) != NO_RECEIVER;
    out[w - 1] = receiver_at(z, w, h, row + w - 1) != NO_RECEIVER;
    let centre = &z[row + 1..row + w - 1];
    let lower = &mut out[1..w - 1];
    lower.fill(false);
    for (dx, dy, _) in NEIGHBOURS {
        // The neighbour of the row's second cell.
        let start = (row + 1).wrapping_add_signed(dy as isize * w as isize + dx as isize);
        let neighbours = &z[start..start + w - 2];
        for (l, (&c, &n)) in lower.iter_mut().zip(centre.iter().zip(neighbours)) {
            *l |= n < c;
        }
    }
}

/// Rows per step of [`condition_and_measure`]: about 2^16 cells a thread (a few
/// milliseconds), so one thread (wasm) yields every 2^16 cells.
fn parallel_steps(w: usize, h: usize) -> impl Iterator<Item = Range<usize>> {
    let rows = ((1usize << 16) / w.max(1)).max(1) * parallel::threads();
    (0..h)
        .step_by(rows)
        .map(move |start| start..(start + rows).min(h))
}

/// The drainage counts (no fates: see [`condition_and_measure`]) and the pits.
#[derive(Default)]
struct Counts {
    river_cells: usize,
    river_cells_draining: usize,
    branch_cells: usize,
    branch_cells_draining: usize,
    pit_cells: usize,
    /// Interior cells without receiver (filled by [`count_rows`] only).
    pits: Vec<u32>,
}

impl Counts {
    /// Adds (`sign` true) or removes cell `i` with receiver `r`.
    #[inline]
    fn cell(&mut self, kinds: &[CellKind], i: usize, border: bool, r: u32, sign: bool) {
        let step = |v: &mut usize| {
            if sign {
                *v += 1;
            } else {
                *v -= 1;
            }
        };
        if r == NO_RECEIVER && !border {
            step(&mut self.pit_cells);
        }
        let Some((cells, draining)) = self.along(kinds[i]) else {
            return;
        };
        step(cells);
        let ok = if r == NO_RECEIVER {
            border
        } else {
            kinds[r as usize].is_river()
        };
        if ok {
            step(draining);
        }
    }

    /// The counts of cells of `kind` and of those draining along their river, for a river
    /// or branch cell.
    fn along(&mut self, kind: CellKind) -> Option<(&mut usize, &mut usize)> {
        match kind {
            CellKind::River => Some((&mut self.river_cells, &mut self.river_cells_draining)),
            CellKind::Grown => Some((&mut self.branch_cells, &mut self.branch_cells_draining)),
            _ => None,
        }
    }

    /// The drainage of a map of `n` cells these counts found no pit in: every cell drains to
    /// the border (descent paths strictly descend, so they end, and only there).
    fn drainage(&self, n: usize) -> Drainage {
        Drainage {
            river_cells: self.river_cells,
            river_cells_draining: self.river_cells_draining,
            river_fraction: share(self.river_cells_draining, self.river_cells),
            branch_cells: self.branch_cells,
            branch_cells_draining: self.branch_cells_draining,
            branch_fraction: share(self.branch_cells_draining, self.branch_cells),
            cells_to_outlet: n,
            outlet_fraction: 1.0,
            pit_cells: 0,
            pit_fraction: 0.0,
        }
    }

    fn add(&mut self, other: Counts) {
        self.river_cells += other.river_cells;
        self.river_cells_draining += other.river_cells_draining;
        self.branch_cells += other.branch_cells;
        self.branch_cells_draining += other.branch_cells_draining;
        self.pit_cells += other.pit_cells;
        self.pits.extend(other.pits);
    }
}

/// Counts of `rows`: pits from whether each cell has a lower neighbour, computed row by row;
/// the D8 receiver only of river cells (whether they drain along the river).
fn count_rows(
    field: &Heightfield,
    kinds: &[CellKind],
    outlets: Outlets<'_>,
    rows: Range<usize>,
) -> Counts {
    let (w, h) = (field.width(), field.height());
    let z = field.data();
    let mut lower = vec![false; w];
    let mut c = Counts::default();
    for y in rows {
        lower_neighbours_of_row(z, w, h, y, &mut lower);
        let row = &kinds[y * w..(y + 1) * w];
        for (x, (&has_lower, &kind)) in lower.iter().zip(row).enumerate() {
            let outlet = !has_lower && outlets.contains(y * w + x);
            if !has_lower && !outlet {
                c.pit_cells += 1;
                c.pits.push((y * w + x) as u32);
            }
            if let Some((cells, draining)) = c.along(kind) {
                *cells += 1;
                let ok = if has_lower {
                    kinds[receiver_at(z, w, h, y * w + x) as usize].is_river()
                } else {
                    outlet
                };
                *draining += usize::from(ok);
            }
        }
    }
    c
}

/// Cells of work between two ticks of [`condition_and_measure`] where it works on one
/// thread (a few milliseconds).
const STEP_CELLS: usize = 1 << 14;

/// Grows, from each of `pits` not yet in a region, the cells a flood of that pit could
/// raise: lowest rim cell first (a priority queue of the region's neighbours), until the
/// cell taken has a strictly lower neighbour outside every region (the water spills there)
/// or lies on the border. Taken cells are marked in `in_region` and appended to `region`;
/// border cells never are. `queued` is all false on entry and on return. O(r log r) for the r
/// cells taken, a small part of the pits' basins: those below their spill levels; the job
/// ticks between pits every [`STEP_CELLS`] cells taken.
async fn grow_regions(
    z: &[f32],
    outlets: Outlets<'_>,
    pits: &[u32],
    in_region: &mut [bool],
    queued: &mut [bool],
    region: &mut Vec<u32>,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    use std::cmp::Reverse;
    let w = outlets.w;
    let mut rim = std::collections::BinaryHeap::new();
    let mut seen = Vec::new();
    let mut since_tick = region.len();
    for &pit in pits {
        if in_region[pit as usize] {
            continue;
        }
        if region.len() - since_tick >= STEP_CELLS {
            ctx.tick(0.95, "filling depressions").await?;
            since_tick = region.len();
        }
        rim.push(Reverse((ordered_key(z[pit as usize]), pit)));
        queued[pit as usize] = true;
        seen.push(pit);
        while let Some(Reverse((_, i))) = rim.pop() {
            let i = i as usize;
            if outlets.contains(i) {
                break;
            }
            // Interior (mouths are outlets too): all eight neighbours exist.
            let neighbour = |dx: i64, dy: i64| (i as i64 + dy * w as i64 + dx) as usize;
            let spills = NEIGHBOURS.iter().any(|&(dx, dy, _)| {
                let j = neighbour(dx, dy);
                !in_region[j] && z[j] < z[i]
            });
            if spills {
                break;
            }
            in_region[i] = true;
            region.push(i as u32);
            for (dx, dy, _) in NEIGHBOURS {
                let j = neighbour(dx, dy);
                if !in_region[j] && !queued[j] {
                    queued[j] = true;
                    seen.push(j as u32);
                    rim.push(Reverse((ordered_key(z[j]), j as u32)));
                }
            }
        }
        rim.clear();
        for j in seen.drain(..) {
            queued[j as usize] = false;
        }
    }
    Ok(())
}

/// The interior cells next to `round` (or in it, only at NaN heights) left without a
/// strictly lower neighbour: pits a flood of the round made, e.g. an earlier region's cell
/// whose lower neighbour was raised. A pit may be listed more than once (the next round
/// grows from it once). O(round).
fn rim_pits(z: &[f32], outlets: Outlets<'_>, round: &[u32]) -> Vec<u32> {
    let (w, h) = (outlets.w, outlets.h);
    round
        .iter()
        .flat_map(|&i| {
            NEIGHBOURS
                .iter()
                .map(move |&(dx, dy, _)| (i64::from(i) + dy * w as i64 + dx) as usize)
                .chain(std::iter::once(i as usize))
        })
        .filter(|&j| !outlets.contains(j) && receiver_at(z, w, h, j) == NO_RECEIVER)
        .map(|j| j as u32)
        .collect()
}

/// Whether any interior cell has no strictly lower neighbour (a pit or a flat). O(cells).
/// A harmonic fill obeys the maximum principle, so pits can only sit on fixed cells; most
/// terrains have none and skip the flooding below.
pub fn has_pits(field: &Heightfield) -> bool {
    rows_have_pits(field, 0..field.height())
}

/// What [`fill_depressions`] changed.
#[derive(Clone, Copy, Debug, Default, Serialize, serde::Deserialize)]
pub struct Conditioning {
    /// Cells raised out of a depression.
    pub raised_cells: usize,
    /// Largest raise in metres.
    pub max_raise: f32,
}

/// Priority-Flood with epsilon (Barnes, Lehman and Mulla 2014): floods the terrain inward
/// from the map border in order of height; a cell reached from a higher one is raised just
/// above it (the next representable `f32`), so every cell then has a strictly descending
/// path to the border and no pit remains. Only depressions are touched (rivers, which
/// already descend to their estuaries, are not). O(cells log range) with a radix heap.
///
/// Runs in steps ([`Flood::run`]) so a caller can yield between them.
pub struct Flood {
    closed: Vec<bool>,
    heap: RadixHeap,
    result: Conditioning,
}

impl Flood {
    /// Seeds the flood with the border cells of `field` and the river `mouths` inside it
    /// (ascending; see `Outlets`).
    pub fn new(field: &Heightfield, mouths: &[u32]) -> Self {
        let (w, h) = (field.width(), field.height());
        let z = field.data();
        let mut closed = vec![false; z.len()];
        // Heights pop in non-decreasing order (a raised cell sits just above the level that
        // reached it), so a monotone radix heap replaces the binary heap of the paper.
        let mut heap = RadixHeap::new();
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                closed[i] = true;
                heap.push(ordered_key(z[i]), i as u32);
            }
        }
        for &i in mouths {
            if !std::mem::replace(&mut closed[i as usize], true) {
                heap.push(ordered_key(z[i as usize]), i);
            }
        }
        Self {
            closed,
            heap,
            result: Conditioning::default(),
        }
    }

    /// Seeds a flood of the cells of `inside` only (interior cells), from the cells around
    /// them: it ends with the least `z' >= z` that keeps every other cell's height and gives
    /// each cell of `inside` a strictly lower neighbour (see `flood_depressions`).
    /// `closed` is all true, one entry per cell, and is all true again once the flood has
    /// run to its end ([`Flood::into_closed`] hands it back for the next flood): O(inside)
    /// work, not O(cells).
    pub fn around(field: &Heightfield, inside: &[u32], mut closed: Vec<bool>) -> Self {
        let w = field.width();
        let z = field.data();
        for &i in inside {
            closed[i as usize] = false;
        }
        let mut seeds = Vec::new();
        for &i in inside {
            debug_assert!(!is_border(i as usize, w, field.height()));
            for (dx, dy, _) in NEIGHBOURS {
                let j = (i64::from(i) + dy * w as i64 + dx) as usize;
                if closed[j] {
                    seeds.push(j as u32);
                }
            }
        }
        seeds.sort_unstable();
        seeds.dedup();
        let mut heap = RadixHeap::new();
        for j in seeds {
            heap.push(ordered_key(z[j as usize]), j);
        }
        Self {
            closed,
            heap,
            result: Conditioning::default(),
        }
    }

    /// Pops at most `max_pops` cells; true once the flood has reached every cell.
    pub fn run(&mut self, field: &mut Heightfield, max_pops: usize) -> bool {
        let (w, h) = (field.width() as i64, field.height() as i64);
        let z = field.data_mut();
        let Self {
            closed,
            heap,
            result,
        } = self;
        for _ in 0..max_pops {
            let Some((_, i)) = heap.pop() else {
                return true;
            };
            let level = z[i as usize];
            let (x, y) = (i64::from(i) % w, i64::from(i) / w);
            for (dx, dy, _) in NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = (ny * w + nx) as usize;
                if closed[j] {
                    continue;
                }
                closed[j] = true;
                if z[j] <= level {
                    let raised = level.next_up();
                    result.raised_cells += 1;
                    result.max_raise = result.max_raise.max(raised - z[j]);
                    z[j] = raised;
                }
                heap.push(ordered_key(z[j]), j as u32);
            }
        }
        heap.is_empty()
    }

    pub fn result(&self) -> Conditioning {
        self.result
    }

    /// The flood's closed flags, all true after a flood of [`Flood::around`] has ended.
    pub fn into_closed(self) -> Vec<bool> {
        self.closed
    }
}

/// [`Flood`] in one go, from the map's border (the reference the GPU's flood matches).
pub fn fill_depressions(field: &mut Heightfield) -> Conditioning {
    let mut flood = Flood::new(field, &[]);
    flood.run(field, usize::MAX);
    flood.result()
}

/// Whether cell `i` of a `w` x `h` grid is on the map border.
fn is_border(i: usize, w: usize, h: usize) -> bool {
    let (x, y) = (i % w, i / w);
    x == 0 || y == 0 || x + 1 == w || y + 1 == h
}

/// Where water leaves a `w` x `h` map: its border, and the mouths of rivers that end inside
/// it ([`crate::skeleton::Skeleton::mouths`]: a river drawn to a point inside the map flows
/// out there, into a sea or a lake the map does not show, rather than filling its whole
/// catchment up to the lowest pass on the map's edge).
#[derive(Clone, Copy)]
struct Outlets<'a> {
    w: usize,
    h: usize,
    /// Interior cells, ascending.
    mouths: &'a [u32],
}

impl<'a> Outlets<'a> {
    fn new(w: usize, h: usize, mouths: &'a [u32]) -> Self {
        debug_assert!(mouths.is_sorted());
        Self { w, h, mouths }
    }

    /// Whether water leaves the map at cell `i`.
    #[inline]
    fn contains(&self, i: usize) -> bool {
        is_border(i, self.w, self.h)
            || (!self.mouths.is_empty() && self.mouths.binary_search(&(i as u32)).is_ok())
    }
}

/// Drainage measured in passes over ranges of cells (receivers by rows, then each cell's
/// fate, then the counts), so a caller can yield between ranges. O(cells): each cell's
/// outlet is resolved once along its descent path.
struct Measuring<'a> {
    outlets: Outlets<'a>,
    recv: Vec<Option<u32>>,
    /// 0 = unknown, 1 = reaches an outlet, 2 = ends in a pit.
    fate: Vec<u8>,
    path: Vec<usize>,
    drainage: Drainage,
}

impl<'a> Measuring<'a> {
    fn new(field: &Heightfield, mouths: &'a [u32]) -> Self {
        let (w, h) = (field.width(), field.height());
        Self {
            outlets: Outlets::new(w, h, mouths),
            recv: Vec::with_capacity(w * h),
            fate: vec![0; w * h],
            path: Vec::new(),
            drainage: Drainage::default(),
        }
    }

    /// Follows the descent from every cell of `starts` (all receivers known).
    fn resolve(&mut self, starts: Range<usize>) {
        let border = |i: usize| self.outlets.contains(i);
        let (recv, fate, path) = (&self.recv, &mut self.fate, &mut self.path);
        let n = fate.len();
        for start in starts {
            let mut i = start;
            while fate[i] == 0 {
                path.push(i);
                match recv[i] {
                    Some(j) => i = j as usize,
                    None => {
                        fate[i] = if border(i) { 1 } else { 2 };
                        break;
                    }
                }
                if path.len() > n {
                    break; // cannot happen with strict descent; guards against NaN heights
                }
            }
            let result = if fate[i] == 0 { 2 } else { fate[i] };
            for &p in path.iter() {
                fate[p] = result;
            }
            path.clear();
        }
    }

    /// Counts the cells of `cells` (all fates known).
    fn tally(&mut self, kinds: &[CellKind], cells: Range<usize>) {
        let outlets = self.outlets;
        let border = |i: usize| outlets.contains(i);
        let d = &mut self.drainage;
        for i in cells {
            if self.fate[i] == 1 {
                d.cells_to_outlet += 1;
            }
            if self.recv[i].is_none() && !border(i) {
                d.pit_cells += 1;
            }
            let (cells, draining) = match kinds[i] {
                CellKind::River => (&mut d.river_cells, &mut d.river_cells_draining),
                CellKind::Grown => (&mut d.branch_cells, &mut d.branch_cells_draining),
                _ => continue,
            };
            *cells += 1;
            let ok = match self.recv[i] {
                Some(j) => kinds[j as usize].is_river(),
                None => border(i),
            };
            *draining += usize::from(ok);
        }
    }

    fn finish(self) -> Drainage {
        let mut d = self.drainage;
        let n = self.fate.len();
        d.river_fraction = share(d.river_cells_draining, d.river_cells);
        d.branch_fraction = share(d.branch_cells_draining, d.branch_cells);
        d.outlet_fraction = d.cells_to_outlet as f64 / n as f64;
        d.pit_fraction = d.pit_cells as f64 / n as f64;
        d
    }
}

/// Measures drainage, with water leaving the map at its border and the river `mouths`
/// inside it (ascending). O(cells).
pub fn measure(field: &Heightfield, kinds: &[CellKind], mouths: &[u32]) -> Drainage {
    let mut m = Measuring::new(field, mouths);
    let n = field.width() * field.height();
    receivers_of_rows(field, 0..field.height(), &mut m.recv);
    m.resolve(0..n);
    m.tally(kinds, 0..n);
    m.finish()
}

/// [`count_rows`] of the whole field, rows on all threads, in steps.
async fn count_in_steps(
    field: &Heightfield,
    kinds: &[CellKind],
    outlets: Outlets<'_>,
    ctx: &JobCtx,
) -> Result<Counts, Cancelled> {
    let (w, h) = (field.width(), field.height());
    let threads = parallel::threads();
    let mut total = Counts::default();
    for rows in parallel_steps(w, h) {
        let band = rows.len().div_ceil(threads).max(1);
        let mut parts: Vec<(Range<usize>, Counts)> = rows
            .clone()
            .step_by(band)
            .map(|s| (s..(s + band).min(rows.end), Counts::default()))
            .collect();
        parallel::for_each_item(parts.iter_mut().collect(), |(rows, c)| {
            *c = count_rows(field, kinds, outlets, rows.clone());
        });
        for (_, c) in parts {
            total.add(c);
        }
        ctx.tick(0.96, "checking drainage").await?;
    }
    Ok(total)
}

/// Floods the depressions around `pits`, in rounds: grows the regions a flood could raise
/// from the pits ([`grow_regions`]), floods them from the cells around them on the heights
/// as they are ([`Flood::around`]), and goes on with the pits that flood left around the
/// regions (a region that spilt into a neighbouring depression, a rim cell left under its
/// raised neighbours), until none is left. Pits at NaN heights are left alone (no flood
/// drains them). Returns every cell a round flooded (each once, marked) with its height
/// before the first round, and what the floods raised. A round that raises nothing ends them
/// (pits walled in by NaN heights).
///
/// Why the bits are the reference's: Priority-Flood's result `z*` is the least surface
/// `>= z` in which every interior cell has a strictly lower neighbour (such surfaces are
/// closed under the pointwise minimum, so there is a least one). A round's flood is the
/// least surface above the heights it starts from that keeps the other cells' heights and
/// gives its region lower neighbours; started below `z*`, it stays below `z*` (its minimum
/// with `z*` is such a surface too), so every round stays at or below `z*`. The last round
/// leaves no pit, so its surface is one of those surfaces `>= z`, hence at least `z*`: it is
/// `z*`. Each round raises its pits, so the rounds end. O(r log r) per round for its r
/// cells; an eroded 4096^2 map takes about 170 rounds of a few hundred cells after a first
/// one of 60 000.
///
/// A depression that holds most of the map (a river whose mouth lies inside the map drains
/// its whole catchment into it) takes a round per rim level, each over the whole region:
/// over ten minutes at 128^2. Once the rounds have taken `budget` cells in all, the field is
/// put back as it was and `None` returned; the caller floods the whole map instead
/// ([`Flood::new`], the same `z*`).
async fn flood_depressions(
    field: &mut Heightfield,
    outlets: Outlets<'_>,
    mut pits: Vec<u32>,
    budget: usize,
    ctx: &JobCtx,
) -> Result<Option<Flooded>, Cancelled> {
    let n = outlets.w * outlets.h;
    let (mut in_round, mut queued) = (vec![false; n], vec![false; n]);
    let mut closed = vec![true; n];
    let mut flooded = vec![false; n];
    let (mut cells, mut original) = (Vec::new(), Vec::new());
    let mut round = Vec::new();
    let mut taken = 0usize;
    pits.retain(|&p| !field.data()[p as usize].is_nan());
    while !pits.is_empty() {
        grow_regions(
            field.data(),
            outlets,
            &pits,
            &mut in_round,
            &mut queued,
            &mut round,
            ctx,
        )
        .await?;
        for &i in &round {
            if !std::mem::replace(&mut flooded[i as usize], true) {
                cells.push(i);
                original.push(field.data()[i as usize]);
            }
        }
        taken += round.len();
        if taken > budget {
            let z = field.data_mut();
            for (&i, &before) in cells.iter().zip(&original) {
                z[i as usize] = before;
            }
            return Ok(None);
        }
        ctx.tick(0.95, "filling depressions").await?;
        let mut flood = Flood::around(field, &round, closed);
        while !flood.run(field, STEP_CELLS) {
            ctx.tick(0.95, "filling depressions").await?;
        }
        let raised = flood.result().raised_cells;
        closed = flood.into_closed();
        pits = rim_pits(field.data(), outlets, &round);
        pits.retain(|&p| !field.data()[p as usize].is_nan());
        for i in round.drain(..) {
            in_round[i as usize] = false;
        }
        if raised == 0 {
            // Nothing moved, so the next round would find the same pits: they are cells no
            // flood drains (walled in by NaN heights), left as the reference leaves them.
            break;
        }
    }
    let z = field.data();
    let mut result = Conditioning::default();
    for (&i, &before) in cells.iter().zip(&original) {
        let after = z[i as usize];
        if after != before {
            result.raised_cells += 1;
            result.max_raise = result.max_raise.max(after - before);
        }
    }
    Ok(Some(Flooded {
        cells,
        original,
        flooded,
        result,
    }))
}

/// How many times the map's cells the rounds of `flood_depressions` may take before the
/// whole map is flooded instead.
const ROUND_BUDGET: usize = 4;

/// What [`flood_depressions`] changed.
struct Flooded {
    /// Every cell a round flooded, once.
    cells: Vec<u32>,
    /// Their heights before the first round.
    original: Vec<f32>,
    /// One flag per cell of the map: set on `cells`.
    flooded: Vec<bool>,
    result: Conditioning,
}

/// The cells whose receivers a flood of `region` can change: its cells and their
/// neighbours, each once (`listed` marks `region` on entry). O(region), in steps with the
/// job's ticks between them.
async fn touched_by(
    region: &[u32],
    w: usize,
    mut listed: Vec<bool>,
    ctx: &JobCtx,
) -> Result<Vec<u32>, Cancelled> {
    let mut touched = region.to_vec();
    for part in region.chunks(STEP_CELLS) {
        ctx.tick(0.95, "filling depressions").await?;
        for &i in part {
            for (dx, dy, _) in NEIGHBOURS {
                let j = (i64::from(i) + dy * w as i64 + dx) as usize;
                if !std::mem::replace(&mut listed[j], true) {
                    touched.push(j as u32);
                }
            }
        }
    }
    Ok(touched)
}

/// Takes the `touched` cells out of `counts` (`sign` false) or puts them back in with their
/// receivers now (`sign` true), in steps with the job's ticks between them.
async fn recount(
    counts: &mut Counts,
    field: &Heightfield,
    kinds: &[CellKind],
    outlets: Outlets<'_>,
    touched: &[u32],
    sign: bool,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    let (w, h) = (field.width(), field.height());
    for part in touched.chunks(STEP_CELLS) {
        ctx.tick(0.95, "filling depressions").await?;
        for &i in part {
            let r = receiver_at(field.data(), w, h, i as usize);
            counts.cell(kinds, i as usize, outlets.contains(i as usize), r, sign);
        }
    }
    Ok(())
}

/// Floods the depressions of `field` if it has pits, then measures its drainage: the same
/// results as [`has_pits`], [`fill_depressions`] and [`measure`], computed in steps (about
/// 2^16 cells a thread for the receivers, `STEP_CELLS` (2^14) for the regions, their flood and
/// their counts) with [`JobCtx::tick`] between them, so the browser keeps painting while a
/// large terrain is checked.
///
/// The same bits as the reference, faster: one pass of D8 receivers (rows on all threads)
/// counts and finds the pits; only the cells below the pits' spill levels are flooded
/// (`flood_depressions`), and only the cells whose receivers that can change (those and
/// their neighbours) are counted again. A terrain whose interior cells all have a receiver
/// drains every cell to the border (descent paths strictly descend, so they end, and only
/// at the border), so the measure needs no fates. O(cells) plus O(r log r) for the r cells
/// below spill levels (an eroded 4096^2 map: about 1% of its cells, where the pits' whole
/// basins held 75%).
pub async fn condition_and_measure(
    field: &mut Heightfield,
    kinds: &[CellKind],
    mouths: &[u32],
    ctx: &JobCtx,
) -> Result<(Conditioning, Drainage), Cancelled> {
    let (w, h) = (field.width(), field.height());
    let n = w * h;
    let outlets = Outlets::new(w, h, mouths);
    let mut counts = count_in_steps(field, kinds, outlets, ctx).await?;
    let mut conditioning = Conditioning::default();
    if counts.pit_cells > 0 {
        let Some(Flooded {
            cells: region,
            original,
            flooded,
            result,
        }) = flood_depressions(
            field,
            outlets,
            std::mem::take(&mut counts.pits),
            ROUND_BUDGET * n,
            ctx,
        )
        .await?
        else {
            // One depression holds most of the map: flood it whole and count again.
            let mut flood = Flood::new(field, mouths);
            while !flood.run(field, STEP_CELLS) {
                ctx.tick(0.95, "filling depressions").await?;
            }
            let conditioning = flood.result();
            let counts = count_in_steps(field, kinds, outlets, ctx).await?;
            if counts.pit_cells > 0 {
                return Ok((conditioning, measure(field, kinds, mouths)));
            }
            return Ok((conditioning, counts.drainage(n)));
        };
        conditioning = result;
        // The cells whose receivers the flood can change (the regions and their neighbours)
        // are counted out on the heights before the flood and back in on those after it (in
        // any order: the counts are sums).
        let touched = touched_by(&region, w, flooded, ctx).await?;
        let swap = |field: &mut Heightfield, values: &mut [f32]| {
            let z = field.data_mut();
            for (&i, v) in region.iter().zip(values.iter_mut()) {
                std::mem::swap(&mut z[i as usize], v);
            }
        };
        let mut values = original;
        swap(field, &mut values);
        recount(&mut counts, field, kinds, outlets, &touched, false, ctx).await?;
        swap(field, &mut values);
        recount(&mut counts, field, kinds, outlets, &touched, true, ctx).await?;
    }
    if counts.pit_cells > 0 {
        // Only NaN heights leave pits after the flood: measure them the long way.
        return Ok((conditioning, measure(field, kinds, mouths)));
    }
    Ok((conditioning, counts.drainage(n)))
}

/// [`condition_and_measure`] with the flood on `backend`'s GPU when it runs the heavy stages
/// there and holds the field ([`gpu::fill_depressions`], the same bits); the D8 measure then
/// finds nothing left to flood. On a CPU backend, a software GPU, a field with no-data
/// cells, a map with river `mouths` inside it (the GPU's flood starts from the border only)
/// or a GPU failure the CPU floods it.
pub async fn condition_and_measure_on(
    backend: &crate::compute::Backend,
    field: &mut Heightfield,
    kinds: &[CellKind],
    mouths: &[u32],
    ctx: &JobCtx,
) -> Result<(Conditioning, Drainage), Cancelled> {
    let mut on_gpu = None;
    if let crate::compute::Backend::Gpu(context) = backend
        && context.runs_heavy_stages()
        && mouths.is_empty()
        && gpu::fits(context, field.width(), field.height())
    {
        match gpu::fill_depressions(context, field, ctx).await {
            Ok(result) => on_gpu = Some(result),
            Err(gpu::GpuFloodError::Cancelled(c)) => return Err(c),
            Err(err) => log::info!("depression filling on the CPU: {err}"),
        }
    }
    let (conditioning, drainage) = condition_and_measure(field, kinds, mouths, ctx).await?;
    Ok((merge(on_gpu, conditioning), drainage))
}

/// The conditioning of a surface flooded first on the GPU (`first`, if it was) and then on
/// the CPU (`then`, which finds nothing left unless the GPU's flood could not finish).
pub fn merge(first: Option<Conditioning>, then: Conditioning) -> Conditioning {
    match first {
        Some(first) => Conditioning {
            raised_cells: first.raised_cells + then.raised_cells,
            max_raise: first.max_raise.max(then.max_raise),
        },
        None => then,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A measure's cell counts (river cells, those draining, cells reaching an outlet, pits).
    fn counts(d: &Drainage) -> (usize, usize, usize, usize) {
        (
            d.river_cells,
            d.river_cells_draining,
            d.cells_to_outlet,
            d.pit_cells,
        )
    }

    #[test]
    fn a_tilted_plane_drains_and_a_bowl_has_one_pit() {
        let n = 9;
        let plane: Vec<f32> = (0..n * n).map(|i| (i % n) as f32).collect();
        let kinds = vec![CellKind::Free; n * n];
        let d = measure(&Heightfield::from_vec(n, n, plane).unwrap(), &kinds, &[]);
        assert_eq!(d.outlet_fraction, 1.0);
        assert_eq!(d.pit_cells, 0);
        let bowl: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 4.0, (i / n) as f32 - 4.0);
                x * x + y * y
            })
            .collect();
        let mut bowl = Heightfield::from_vec(n, n, bowl).unwrap();
        let d = measure(&bowl, &kinds, &[]);
        assert!(has_pits(&bowl));
        assert_eq!(d.pit_cells, 1);
        assert_eq!(d.cells_to_outlet, 0);
        // Flooding the bowl leaves no pit and every cell draining out.
        let c = fill_depressions(&mut bowl);
        assert!(c.raised_cells > 0);
        let d = measure(&bowl, &kinds, &[]);
        assert_eq!((d.pit_cells, d.outlet_fraction), (0, 1.0));
        assert!(!has_pits(&bowl));
    }

    /// A river mouth inside the map is an outlet: a bowl around it drains there as it is (no
    /// cell raised, every cell reaching an outlet, the mouth not a pit), where without it
    /// the whole bowl is flooded to the rim. A pit elsewhere is still flooded, to the mouth.
    #[test]
    fn a_river_mouth_inside_the_map_drains_its_bowl() {
        let n = 33;
        let centre = (16 * n + 16) as u32;
        let mut kinds = vec![CellKind::Free; n * n];
        kinds[centre as usize] = CellKind::River;
        let mut bowl: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 16.0, (i / n) as f32 - 16.0);
                x.hypot(y)
            })
            .collect();
        // A dimple on the bowl's flank: a pit that must still be flooded, down to the mouth.
        let dimple = 16 * n + 24;
        bowl[dimple] -= 1.5;
        let bowl = Heightfield::from_vec(n, n, bowl).unwrap();
        let ctx = JobCtx::detached();
        let mouths = [centre];
        for stepped in [false, true] {
            let mut field = bowl.clone();
            let (c, d) = if stepped {
                pollster::block_on(condition_and_measure(&mut field, &kinds, &mouths, &ctx))
                    .unwrap()
            } else {
                let mut flood = Flood::new(&field, &mouths);
                flood.run(&mut field, usize::MAX);
                (flood.result(), measure(&field, &kinds, &mouths))
            };
            assert_eq!(c.raised_cells, 1, "only the dimple is raised");
            assert!(field.data()[dimple] > field.data()[dimple - 1]);
            assert_eq!((d.pit_cells, d.outlet_fraction), (0, 1.0), "{d:?}");
            assert_eq!((d.river_cells, d.river_cells_draining), (1, 1));
            assert_eq!(field.data()[centre as usize], 0.0, "the mouth stays");
        }
        let mut field = bowl;
        let (c, _) =
            pollster::block_on(condition_and_measure(&mut field, &kinds, &[], &ctx)).unwrap();
        assert!(
            c.raised_cells > 500,
            "without the mouth the bowl fills: {c:?}"
        );
    }

    /// Terrains with pits, flats and ties: pseudo-random heights on a few levels, plateaus,
    /// bowls and planes.
    fn test_terrains() -> Vec<Heightfield> {
        let mut rng = 987654321u64;
        let mut next = move || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut fields = Vec::new();
        for (w, h) in [
            (1, 1),
            (1, 6),
            (2, 2),
            (3, 3),
            (4, 7),
            (9, 5),
            (64, 48),
            (257, 130),
        ] {
            let cells = w * h;
            // Few levels: ties and flats everywhere.
            let levels: Vec<f32> = (0..cells).map(|_| (next() * 4.0).floor()).collect();
            // A tilted plane with quantised noise: depressions and plateaus, many ties.
            let tilted: Vec<f32> = (0..cells)
                .map(|i| ((i % w) as f32 * 0.25).floor() + (next() * 3.0).floor())
                .collect();
            // A flat field: every interior cell is a flat.
            let flat = vec![1.5f32; cells];
            // Bowls on a ramp, rim cells tied with the border.
            let bowls: Vec<f32> = (0..cells)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    let b = ((x * 0.7).sin() * (y * 0.5).cos() * 3.0).round();
                    b + y * 0.01
                })
                .collect();
            // Smooth noise, a few f32 steps apart: raises of one ulp meet existing heights.
            let ulps: Vec<f32> = (0..cells)
                .map(|_| f32::from_bits(1000.0f32.to_bits() + (next() * 6.0) as u32))
                .collect();
            for data in [levels, tilted, flat, bowls, ulps] {
                fields.push(Heightfield::from_vec(w, h, data).unwrap());
            }
        }
        fields
    }

    /// A rough cone falling to the middle of the map: the whole map is one depression with
    /// pits nested in it (a river mouth inside the map). Rounds that run out of budget give
    /// up with the field put back as it was, and the whole-map flood gives the reference's
    /// bits.
    #[test]
    fn a_depression_holding_the_map_is_flooded_whole() {
        let n = 96;
        let mut seed = 7u64;
        let cone: Vec<f32> = (0..n * n)
            .map(|i| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let (x, y) = ((i % n) as f32 - 48.0, (i / n) as f32 - 48.0);
                x.hypot(y) * 0.5 + (seed >> 40) as f32 / (1u64 << 24) as f32 * 4.0
            })
            .collect();
        let field = Heightfield::from_vec(n, n, cone).unwrap();
        let kinds = vec![CellKind::Free; n * n];
        let mut rounds = field.clone();
        let outlets = Outlets::new(n, n, &[]);
        let ctx = JobCtx::detached();
        let pits = pollster::block_on(count_in_steps(&rounds, &kinds, outlets, &ctx))
            .unwrap()
            .pits;
        let gave_up = pollster::block_on(flood_depressions(&mut rounds, outlets, pits, n, &ctx))
            .unwrap()
            .is_none();
        assert!(gave_up, "the rounds finished within a budget of one map");
        assert_eq!(rounds.data(), field.data(), "put back as it was");
        let mut reference = field.clone();
        let c1 = fill_depressions(&mut reference);
        let mut fast = field;
        let (c2, d2) = pollster::block_on(condition_and_measure(
            &mut fast,
            &kinds,
            &[],
            &JobCtx::detached(),
        ))
        .unwrap();
        assert_eq!(reference.data(), fast.data());
        assert_eq!(c1.raised_cells, c2.raised_cells);
        assert_eq!((d2.pit_cells, d2.outlet_fraction), (0, 1.0));
    }

    /// The fast path (receivers, basins, a flood of the basins only, counts) gives the
    /// reference Priority-Flood's heights bit for bit and the reference measure's counts.
    #[test]
    fn fast_conditioning_equals_the_reference_priority_flood_bit_for_bit() {
        let mut flooded = 0;
        for reference in test_terrains() {
            let (w, h) = (reference.width(), reference.height());
            let kinds: Vec<CellKind> = (0..w * h)
                .map(|i| {
                    if i % 7 < 2 {
                        CellKind::River
                    } else {
                        CellKind::Free
                    }
                })
                .collect();
            let mut reference = reference;
            let mut fast = reference.clone();
            let c1 = fill_depressions(&mut reference);
            let d1 = measure(&reference, &kinds, &[]);
            let (c2, d2) = pollster::block_on(condition_and_measure(
                &mut fast,
                &kinds,
                &[],
                &JobCtx::detached(),
            ))
            .unwrap();
            let bits = |f: &Heightfield| f.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&reference), bits(&fast), "{w}x{h}");
            assert_eq!(c1.raised_cells, c2.raised_cells, "{w}x{h}");
            assert_eq!(c1.max_raise.to_bits(), c2.max_raise.to_bits(), "{w}x{h}");
            assert_eq!(counts(&d1), counts(&d2), "{w}x{h}");
            // The guarantees: no pit, every cell reaches an outlet.
            assert_eq!((d2.pit_cells, d2.cells_to_outlet), (0, w * h), "{w}x{h}");
            assert!(!has_pits(&fast));
            flooded += usize::from(c2.raised_cells > 0);
        }
        assert!(flooded >= 20, "{flooded}");
    }

    /// No-data (NaN) cells cannot be drained: the flood leaves them and still ends, with the
    /// reference's heights everywhere.
    #[test]
    fn conditioning_ends_around_nan_cells_with_the_reference_heights() {
        let (w, h) = (40, 30);
        let data = bowls_with_holes(w, h, |i, _, _| i % 37 == 5);
        let kinds = vec![CellKind::Free; w * h];
        let mut reference = Heightfield::from_vec(w, h, data).unwrap();
        let mut fast = reference.clone();
        fill_depressions(&mut reference);
        pollster::block_on(condition_and_measure(
            &mut fast,
            &kinds,
            &[],
            &JobCtx::detached(),
        ))
        .unwrap();
        let bits = |f: &Heightfield| f.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&reference), bits(&fast));
    }

    /// Cells walled in by NaN heights can never drain: the rounds stop once a flood raises
    /// nothing (no endless loop), the cells stay pits, and every other cell drains.
    #[test]
    fn conditioning_ends_with_cells_walled_in_by_nan() {
        let (w, h) = (40, 30);
        let ring = |x: usize, y: usize, (cx, cy, r): (usize, usize, usize)| {
            x.abs_diff(cx).max(y.abs_diff(cy)) == r
        };
        let (cell, bowl) = ((8, 8, 1), (25, 15, 3));
        let data = bowls_with_holes(w, h, |_, x, y| ring(x, y, cell) || ring(x, y, bowl));
        let kinds = vec![CellKind::Free; w * h];
        let original = Heightfield::from_vec(w, h, data).unwrap();
        let mut field = original.clone();
        let (_, drainage) = pollster::block_on(condition_and_measure(
            &mut field,
            &kinds,
            &[],
            &JobCtx::detached(),
        ))
        .unwrap();
        assert!(drainage.pit_cells > 0, "the walled-in cells stay pits");
        let inside = |x: usize, y: usize, (cx, cy, r): (usize, usize, usize)| {
            x.abs_diff(cx).max(y.abs_diff(cy)) < r
        };
        let z = field.data();
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                if z[i].is_nan() || inside(x, y, cell) || inside(x, y, bowl) {
                    continue;
                }
                assert!(z[i] >= original.data()[i], "({x}, {y}) only rises");
                assert_ne!(receiver_at(z, w, h, i), NO_RECEIVER, "({x}, {y}) drains");
            }
        }
    }

    /// Bowls on a ramp with NaN where `hole(i, x, y)`.
    fn bowls_with_holes(
        w: usize,
        h: usize,
        hole: impl Fn(usize, usize, usize) -> bool,
    ) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if hole(i, x, y) {
                    f32::NAN
                } else {
                    let (x, y) = (x as f32, y as f32);
                    ((x * 0.7).sin() * (y * 0.5).cos() * 3.0).round() + y * 0.01
                }
            })
            .collect()
    }

    /// The row-wise (vectorised) lower-neighbour test says where the reference has a
    /// receiver, on terrains with flats, voids and infinities.
    #[test]
    fn row_lower_neighbours_are_where_the_reference_has_receivers() {
        let mut terrains = test_terrains();
        let mut extreme = terrains.last().expect("terrains").clone();
        let w = extreme.width();
        for (i, v) in extreme.data_mut().iter_mut().enumerate() {
            match i % 17 {
                3 => *v = f32::INFINITY,
                7 => *v = f32::NEG_INFINITY,
                11 => *v = f32::MIN_POSITIVE * 1e-6,
                13 => *v = 0.0,
                _ => {}
            }
        }
        extreme.data_mut()[w + 1] = f32::from_bits(1);
        terrains.push(extreme);
        for field in terrains {
            let (w, h) = (field.width(), field.height());
            let mut reference = Vec::new();
            receivers_of_rows(&field, 0..h, &mut reference);
            let mut row = vec![false; w];
            for y in 0..h {
                lower_neighbours_of_row(field.data(), w, h, y, &mut row);
                for (x, &lower) in row.iter().enumerate() {
                    assert_eq!(reference[y * w + x].is_some(), lower, "({x}, {y})");
                }
            }
        }
    }

    /// The stepped version gives what the one-shot functions give, pits and all.
    #[test]
    fn stepped_conditioning_and_measuring_match_the_one_shot_functions() {
        let (w, h) = (300, 700);
        let mut rng = 12345u64;
        let heights: Vec<f32> = (0..w * h)
            .map(|i| {
                rng = rng
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = (rng >> 40) as f32 / (1u64 << 24) as f32;
                ((i % w) as f32 * 0.3 + (i / w) as f32 * 0.1) + 20.0 * noise
            })
            .collect();
        let kinds: Vec<CellKind> = (0..w * h)
            .map(|i| {
                if i % w == 150 {
                    CellKind::River
                } else {
                    CellKind::Free
                }
            })
            .collect();
        let mut one_shot = Heightfield::from_vec(w, h, heights).unwrap();
        let mut stepped = one_shot.clone();
        assert!(has_pits(&one_shot));
        let c1 = fill_depressions(&mut one_shot);
        let d1 = measure(&one_shot, &kinds, &[]);
        let (c2, d2) = pollster::block_on(condition_and_measure(
            &mut stepped,
            &kinds,
            &[],
            &JobCtx::detached(),
        ))
        .unwrap();
        assert_eq!(one_shot.checksum(), stepped.checksum());
        assert!(c1.raised_cells > 0);
        assert_eq!(
            (c1.raised_cells, c1.max_raise),
            (c2.raised_cells, c2.max_raise)
        );
        assert_eq!(counts(&d1), counts(&d2));
        assert_eq!((d2.pit_cells, d2.outlet_fraction), (0, 1.0));
    }
}
