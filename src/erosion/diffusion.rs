//! Linear hillslope diffusion `dh/dt = kappa * lap(h)`, backward Euler.
//!
//! Choice: implicit (backward Euler) on the 5-point Laplacian,
//! `(1 + r k_i) h_i' - r * sum_nb h_nb' = h_i` with `r = kappa dt / cell^2` and `k_i` the
//! number of in-grid 4-neighbours (zero flux across the map edge), solved with
//! red-black successive over-relaxation sweeps started from `h`.
//!
//! Why red-black successive over-relaxation (SOR): each colour's update
//! `h_i <- h_i + omega (g_i - h_i)`, with `g_i = (h_i0 + r sum_nb h_nb) / (1 + r k_i)` the
//! Gauss-Seidel value, reads only the other colour, so any split into rows (or GPU
//! threads) gives the same bits, and the system is symmetric positive definite, so SOR
//! converges for any `dt` (`0 < omega < 2`). Explicit sub-stepping would need
//! `dt / (cell^2 / 4 kappa)` passes, unbounded for long steps on fine grids.
//!
//! How many sweeps: plain Gauss-Seidel removes the error of a smooth mode by only
//! `~1 / 2r` per sweep (the Jacobi radius of the shifted operator is
//! `rho = 4r / (1 + 4r)`), so a fixed handful of sweeps (this module's first version:
//! `ceil(sqrt r)`, at most 8) did only a share of the step that fell with the grid,
//! measured on a 390 m wave on a 10 km map: 45% / 28% / 16% of the exact step at 256^2 /
//! 512^2 / 1024^2 for `kappa` 0.05; the creep a preset asked for was weaker on finer grids
//! (old hills' median slope 47 / 59 / 67 degrees at 512^2 / 1024^2 / 2048^2 on a 10 km
//! map with the default design's uplift). With Young's optimal relaxation factor for
//! red-black ordering, `omega = 2 / (1 + sqrt(1 - rho^2))` (Young 1971; Saad, *Iterative
//! Methods for Sparse Linear Systems*, 2003, sec. 4.2.5), every mode's error falls by about
//! `omega - 1 ~ 1 - 2 / sqrt(2r)` per sweep, the smooth ones included, so `ceil(2 sqrt r)`
//! over-relaxed sweeps, then two of plain Gauss-Seidel, leave at most 5% of the step's change
//! undone at every `r`: the same creep at every resolution, at a cost of `O(sqrt r)` sweeps
//! per step, which grows with the grid (a multigrid solve would be `O(1)`; it is not done).
//! The over-relaxed sweeps are capped at [`MAX_RELAXED`] (`r` up to ~1000: 4096^2 at `kappa`
//! 0.05 on a 10 km map).
//!
//! Why the last two sweeps are plain Gauss-Seidel: over-relaxation damps the short waves no
//! faster than the long ones, so it left a cell-scale residue that made the steepest slopes
//! steeper than the exact step's (on a rough periodic red-noise field, 1.7 times the exact
//! step's steepest difference at `r` = 52 and 3.5 times at 208, against 1.01 and 1.3 with
//! the two sweeps); Gauss-Seidel removes short waves in a sweep or two.
//!
//! Measured on the unit test's field (waves of 3 to 48 cells and a speckle on 64^2, one
//! column fixed) against the exact step, the share of the step's change left undone:
//!
//! | `r` | 0.5 | 1.3 | 5 | 13 | 52 | 200 | 800 |
//! |---|---|---|---|---|---|---|---|
//! | first solver (`ceil(sqrt r)` Gauss-Seidel, 2 to 8) | 12% | 32% | 53% | 65% | 69% | 80% | 85% |
//! | sweeps now | 4 | 5 | 7 | 10 | 17 | 31 | 59 |
//! | undone now | 0.5% | 1.5% | 3.4% | 4.1% | 4.7% | 4.8% | 4.2% |
//!
//! Over-relaxed iterates are not convex combinations, so an unfinished solve can overshoot
//! its neighbours slightly; the converged backward-Euler solution obeys the maximum
//! principle (the matrix is an M-matrix), and 5% of a step's change is far below a cell's
//! relief. Measured on a unit step: no value outside `[0, 1]` by more than `1e-4`.
//! Base-level cells are fixed (Dirichlet).
//!
//! **The run ends on half a step of creep** ([`Creep`]). The solver splits each step into
//! the incision, then the creep (Lie splitting), and a run that ends on a whole step of
//! creep leaves the channels the last incision cut smoothed over `sqrt(kappa dt)` (22 m
//! for the young mountains' 100 kyr steps) with nothing cutting them again: the D8 paths
//! along those rounded troughs ran straight for many cells. Strang's symmetric splitting (Strang
//! 1968, "On the construction and comparison of difference schemes", SIAM J. Numer. Anal.
//! 5(3)) runs half a step of creep on each side of each incision, `C/2 I C/2`; its steps
//! in a row are `C/2 I C I C ... I C/2`: whole steps of creep between the incisions, half a
//! step at each end. The run here keeps the whole steps and ends on the half; the first
//! half step, on the design before any incision, is left out. Measured on the default
//! scene at 1024^2 on a 10 km map, the straight channel runs of the realism report:
//!
//! | steps of the run (same 2 Myr) | 20 | 40 | 100 |
//! |---|---|---|---|
//! | ending on a whole step of creep | 19.6% | 17.7% | 15.3% |
//! | ending on half a step | 17.6% | 15.3% | 13.5% |
//!
//! so 20 steps ending on the half measure as 40 do without it, and 40 as 100. Every run of
//! the solver ends so, the coarse-to-fine refinement's one step and the world's refinement
//! included. It costs nothing: the last step's sweeps are fewer.
//!
//! The sweeps run in passes of up to [`BLOCK`] half sweeps each, one pass over the map's
//! memory doing them all in a wavefront ([`Diffusion::block`]), with the same bits as one
//! half sweep after the other: the creep waited on memory, not arithmetic. Measured on this
//! project's 2-core machine, release build (`strahler bench erosion --backend cpu`, best of
//! two, young mountains on a 10 km map), the whole erosion run went from 2014-2064 ms to
//! 1838-1858 ms at 1024^2 and from 8485-8890 ms to 7231-7506 ms at 2048^2; on a 2 km map at
//! 1024^2 (`r` = 131, 25 sweeps) the stage from 2423-2460 ms to 2136-2256 ms.

use std::ops::Range;

use super::grid::Grid;
use crate::parallel;

/// Most over-relaxed sweeps per time step (two Gauss-Seidel sweeps follow them).
const MAX_RELAXED: usize = 64;

/// One colour (0: `x + y` even) of sweep `sweep` (from 0) of a step.
#[derive(Clone, Copy, Debug)]
pub(super) struct HalfSweep {
    pub(super) sweep: usize,
    pub(super) colour: usize,
}

/// One backward-Euler diffusion step with ratio `r = kappa dt / cell^2`, run as
/// [`Self::sweeps`] sweeps of two colours each, in passes over the map ([`Self::block`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Diffusion {
    r: f32,
    omega: f32,
    sweeps: usize,
}

impl Diffusion {
    pub(super) fn new(r: f64) -> Self {
        // Young's optimal factor from the Jacobi radius of `(1 + 4r) I - r sum_nb`.
        let rho = 4.0 * r / (1.0 + 4.0 * r);
        let omega = 2.0 / (1.0 + (1.0 - rho * rho).sqrt());
        Diffusion {
            r: r as f32,
            omega: omega as f32,
            sweeps: ((2.0 * r.sqrt()).ceil() as usize).clamp(1, MAX_RELAXED) + 2,
        }
    }

    /// `r = kappa dt / cell^2`.
    pub(super) fn r(&self) -> f32 {
        self.r
    }

    /// The over-relaxation factor `omega` (1 is Gauss-Seidel).
    pub(super) fn omega(&self) -> f32 {
        self.omega
    }

    /// Red-black sweeps of the step: over-relaxed ones, then two of Gauss-Seidel.
    pub(super) fn sweeps(&self) -> usize {
        self.sweeps
    }

    /// Whether sweep `sweep` (from 0) is over-relaxed, not one of the last two.
    pub(super) fn over_relaxed(&self, sweep: usize) -> bool {
        sweep + 2 < self.sweeps
    }

    /// Half sweeps of the step: two a sweep, half sweep `j` being colour `j % 2` of sweep
    /// `j / 2`.
    pub(super) fn halves(&self) -> usize {
        2 * self.sweeps
    }

    /// Half sweep `j` of the step.
    fn half(&self, j: usize) -> HalfSweep {
        HalfSweep {
            sweep: j / 2,
            colour: j % 2,
        }
    }

    /// Half sweeps `halves` of the step (at most [`BLOCK`] make one pass) over the whole
    /// grid, in one pass over its memory: the same bits as running them one after the other
    /// ([`Self::rows`]), as each cell is updated from the same values.
    ///
    /// Why: a half sweep does little arithmetic per cell and reads the heights, the
    /// right-hand side and the base mask, so it waits on memory, and two cores sharing it
    /// were barely faster than one (the creep 30% of a 2 km map's erosion at 1024^2, where
    /// `r` = 131 asks for 25 sweeps). Here half sweep `j` of the pass updates row `y - j`
    /// while the first updates row `y` (a wavefront: half sweep `j` at a row needs `j - 1`
    /// done on the rows beside it, and `j + 1` not yet), so the rows a pass works on stay in
    /// the cache for all its half sweeps.
    ///
    /// Threads: the rows are split into bands, each at least `2 n` rows for `n` half sweeps.
    /// Each band first does what it can alone, half sweep `j` on its rows but the `j` nearest
    /// each inner band boundary (a trapezoid; its first half sweep reads copies of the rows
    /// beside it), all bands at once; then, at each boundary `m`, half sweep `j` on the rows
    /// `m - j .. m + j` it left, in order of `j` (the triangles: some `n^2` rows in all).
    /// The diamond tiling of stencil sweeps (e.g. Bondhugula et al. 2017, "Diamond tiling:
    /// tiling techniques to maximize parallelism for stencil computations", IEEE TPDS 28(5)).
    /// O(cells x halves).
    pub(super) fn block(
        &self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        rhs: &[f32],
        halves: Range<usize>,
    ) {
        let bands = parallel::bands(grid.width, grid.height);
        self.block_in_bands(grid, h, (base, rhs), halves, bands);
    }

    /// [`Self::block`] in up to `bands` bands (fewer where a band would be shorter than
    /// `2 n` rows).
    fn block_in_bands(
        &self,
        grid: Grid,
        h: &mut [f32],
        (base, rhs): (&[bool], &[f32]),
        halves: Range<usize>,
        bands: usize,
    ) {
        let (w, height) = (grid.width, grid.height);
        let n = halves.len();
        if n == 0 || height == 0 {
            return;
        }
        let bands = bands.min(height / (2 * n)).max(1);
        let edges: Vec<usize> = (0..=bands).map(|k| k * height / bands).collect();
        let halos: Vec<_> = edges
            .windows(2)
            .map(|e| {
                let above = e[0].checked_sub(1).map(|y| h[y * w..][..w].to_vec());
                let below = (e[1] < height).then(|| h[e[1] * w..][..w].to_vec());
                (above, below)
            })
            .collect();
        let mut pieces = Vec::with_capacity(bands);
        let mut rest = &mut h[..];
        for (k, e) in edges.windows(2).enumerate() {
            let (piece, after) = rest.split_at_mut((e[1] - e[0]) * w);
            pieces.push((k, piece));
            rest = after;
        }
        parallel::for_each_item(pieces, |(k, cells)| {
            let (above, below) = &halos[k];
            let around = (above.as_deref(), below.as_deref());
            self.trapezoid(cells, edges[k], around, (base, rhs), halves.clone(), w);
        });
        for &m in &edges[1..bands] {
            for (j, half) in halves.clone().enumerate() {
                self.rows(grid, h, base, rhs, self.half(half), m - j..m + j);
            }
        }
    }

    /// A band's part of [`Self::block`]: `cells` are its rows, the first of them row
    /// `first`; `above` and `below` copies of the rows beside it (`None` at the map's edge).
    /// Half sweep `j` of `halves` updates the band's rows but the `j` nearest each
    /// neighbouring band, row `y - j` after row `y` of the first.
    fn trapezoid(
        &self,
        cells: &mut [f32],
        first: usize,
        (above, below): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        halves: Range<usize>,
        w: usize,
    ) {
        let (len, n) = (cells.len() / w, halves.len());
        let lo = |j: usize| if above.is_some() { j } else { 0 };
        let hi = |j: usize| {
            if below.is_some() {
                len.saturating_sub(j)
            } else {
                len
            }
        };
        for y in 0..len + n {
            for j in 0..n.min(y + 1) {
                let k = y - j;
                if k < lo(j) || k >= hi(j) {
                    continue;
                }
                // Only half sweep 0 reaches a band's first or last row beside another band.
                let half = self.half(halves.start + j);
                self.band_row(cells, (first, k), (above, below), (base, rhs), half, w);
            }
        }
    }

    /// One colour of a sweep ([`Self::over_relaxed`] or Gauss-Seidel) over the cells of
    /// `rows`; `rhs` holds the heights before the step (copied before the first sweep). A
    /// colour's cells only read the other colour, so the rows are split into bands run at
    /// the same time ([`parallel`]) and any split gives the same bits. O(cells of the rows).
    pub(super) fn rows(
        &self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        rhs: &[f32],
        half: HalfSweep,
        rows: Range<usize>,
    ) {
        let w = grid.width;
        if rows.is_empty() {
            return;
        }
        let per = rows.len().div_ceil(parallel::bands(w, rows.len()));
        // Each band reads the row above its first and below its last, which the bands
        // beside it own: copies of them, taken first (their cells that this colour reads are
        // of the other colour, which this half sweep leaves as they are).
        let halo = |y: Option<usize>| {
            y.filter(|y| *y < grid.height)
                .map(|y| h[y * w..][..w].to_vec())
        };
        let halos: Vec<_> = rows
            .clone()
            .step_by(per)
            .map(|y0| {
                let y1 = (y0 + per).min(rows.end);
                (halo(y0.checked_sub(1)), halo(Some(y1)))
            })
            .collect();
        let body = &mut h[rows.start * w..rows.end * w];
        parallel::for_each_band(body, per * w, |k, cells| {
            let first = rows.start + k * per;
            let (above, below) = &halos[k];
            self.band(
                cells,
                first,
                (above.as_deref(), below.as_deref()),
                (base, rhs),
                half,
                w,
            );
        });
    }

    /// [`Self::rows`] for one band: `cells` are its rows, the first of them row `first`;
    /// `above` and `below` the rows beside it (`None` at the map's edge).
    fn band(
        &self,
        cells: &mut [f32],
        first: usize,
        (above, below): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        half: HalfSweep,
        w: usize,
    ) {
        for k in 0..cells.len() / w {
            self.band_row(cells, (first, k), (above, below), (base, rhs), half, w);
        }
    }

    /// Half sweep `half` on row `k` of a band: `cells` are the band's rows, the first of
    /// them row `first` of the map; `above` and `below` the rows beside the band (`None` at
    /// the map's edge).
    fn band_row(
        &self,
        cells: &mut [f32],
        (first, k): (usize, usize),
        (above, below): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        half: HalfSweep,
        w: usize,
    ) {
        let (before, rest) = cells.split_at_mut(k * w);
        let (row, after) = rest.split_at_mut(w);
        let up = if k > 0 {
            Some(&before[(k - 1) * w..])
        } else {
            above
        };
        let down = if after.is_empty() {
            below
        } else {
            Some(&after[..w])
        };
        let y = first + k;
        let at = y * w..(y + 1) * w;
        let omega = self.over_relaxed(half.sweep).then_some(self.omega);
        let start = (y + half.colour) % 2;
        self.row(row, (up, down), (&base[at.clone()], &rhs[at]), start, omega);
    }

    /// One colour of one row `row` (its cells from `start`, every other one), `up` and
    /// `down` the rows beside it; the Gauss-Seidel value sums the neighbours above, left,
    /// right and below, in that order, over-relaxed by `omega` where given. A row with both
    /// neighbours has its inner cells done in chunks ([`Self::interior`]), its two end cells
    /// one by one ([`Self::cell`]); the same arithmetic either way.
    fn row(
        &self,
        row: &mut [f32],
        (up, down): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        start: usize,
        omega: Option<f32>,
    ) {
        let w = row.len();
        match (up, down) {
            (Some(u), Some(d)) if w >= 3 => {
                if start == 0 {
                    self.cell(row, (up, down), (base, rhs), 0, omega);
                }
                self.interior(row, (u, d), (base, rhs), start, omega);
                if (w - 1) % 2 == start {
                    self.cell(row, (up, down), (base, rhs), w - 1, omega);
                }
            }
            _ => {
                for x in (start..w).step_by(2) {
                    self.cell(row, (up, down), (base, rhs), x, omega);
                }
            }
        }
    }

    /// The cells `1..w-1` of one colour of a row with both neighbour rows, in chunks of
    /// [`CHUNK`]: the update of every cell of the chunk is computed at once and kept on the
    /// colour's cells that are not base level, the others keeping their value (no stride, no
    /// branch: the loop vectorises). The cells these updates read (the neighbours, of the
    /// other colour, and the cell's own value) do not change during the half sweep, so this
    /// is exactly the cell-by-cell update, the same sums in the same order.
    fn interior(
        &self,
        row: &mut [f32],
        (up, down): (&[f32], &[f32]),
        (base, rhs): (&[bool], &[f32]),
        start: usize,
        omega: Option<f32>,
    ) {
        let w = row.len();
        let (r, inv4) = (self.r, 1.0 / (1.0 + self.r * 4.0));
        let mut next = [0.0f32; CHUNK];
        let mut x0 = 1;
        while x0 + 1 < w {
            let n = (w - 1 - x0).min(CHUNK);
            let (left, right) = (&row[x0 - 1..x0 - 1 + n], &row[x0 + 1..x0 + 1 + n]);
            let (centre, rhs) = (&row[x0..x0 + n], &rhs[x0..x0 + n]);
            let (up, down) = (&up[x0..x0 + n], &down[x0..x0 + n]);
            // The colour's cells are those at `k` of the parity `own`; base cells keep
            // their height. A select, not a branch, so that the loop vectorises.
            let own = (x0 + start) % 2;
            let base = &base[x0..x0 + n];
            let keep = |k: usize, value: f32| {
                if (k % 2 == own) & !base[k] {
                    value
                } else {
                    centre[k]
                }
            };
            match omega {
                Some(omega) => {
                    for k in 0..n {
                        let gs = (rhs[k] + r * (((up[k] + left[k]) + right[k]) + down[k])) * inv4;
                        next[k] = keep(k, centre[k] + omega * (gs - centre[k]));
                    }
                }
                None => {
                    for k in 0..n {
                        let gs = (rhs[k] + r * (((up[k] + left[k]) + right[k]) + down[k])) * inv4;
                        next[k] = keep(k, gs);
                    }
                }
            }
            row[x0..x0 + n].copy_from_slice(&next[..n]);
            x0 += n;
        }
    }

    /// One cell `x` of a row with whatever neighbours it has (the general case, at the
    /// map's edge).
    fn cell(
        &self,
        row: &mut [f32],
        (up, down): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        x: usize,
        omega: Option<f32>,
    ) {
        if base[x] {
            return;
        }
        let (r, w) = (self.r, row.len());
        let left = x.checked_sub(1).map(|l| row[l]);
        let right = (x + 1 < w).then(|| row[x + 1]);
        let nbs = [up.map(|u| u[x]), left, right, down.map(|d| d[x])];
        let (mut sum, mut k) = (0.0, 0);
        for v in nbs.into_iter().flatten() {
            sum += v;
            k += 1;
        }
        // Diagonal weights for 4, 3 and 2 neighbours (interior, edge, corner).
        let gauss_seidel = (rhs[x] + r * sum) * (1.0 / (1.0 + r * k as f32));
        row[x] = match omega {
            Some(omega) => row[x] + omega * (gauss_seidel - row[x]),
            None => gauss_seidel,
        };
    }
}

/// The creep of each step of a run: a whole step's, but half a step's on the last (see
/// "The run ends on half a step of creep" in the module docs).
#[derive(Clone, Copy, Debug)]
pub(super) struct Creep {
    whole: Diffusion,
    half: Diffusion,
    steps: u32,
}

impl Creep {
    /// The creep of a run of `steps` steps of ratio `r = kappa dt / cell^2` each.
    pub(super) fn new(r: f64, steps: u32) -> Self {
        Creep {
            whole: Diffusion::new(r),
            half: Diffusion::new(r / 2.0),
            steps,
        }
    }

    /// The creep of step `step` (from 0).
    pub(super) fn of_step(&self, step: u32) -> Diffusion {
        if step + 1 >= self.steps {
            self.half
        } else {
            self.whole
        }
    }
}

/// Cells of a row updated at once by [`Diffusion::interior`].
const CHUNK: usize = 64;

/// Most half sweeps in one pass over the map ([`Diffusion::block`]): a pass keeps some
/// `BLOCK + 2` rows in the cache.
pub(super) const BLOCK: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;

    /// A rough field (waves of 3 to 48 cells and a cell-scale speckle) with its first column
    /// fixed, as a river's cells are.
    fn rough(n: usize) -> (Vec<f32>, Vec<bool>) {
        let mut state = 0x9e37_79b9_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32 - 0.5
        };
        let waves: Vec<(f32, f32, f32, f32)> = [48.0f32, 24.0, 12.0, 6.0, 3.0]
            .iter()
            .map(|l| (std::f32::consts::TAU / l, next() * 6.0, next() * 6.0, *l))
            .collect();
        let h = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                let smooth: f32 = waves
                    .iter()
                    .map(|(k, px, py, l)| l * (k * x + px).sin() * (0.7 * k * y + py).cos())
                    .sum();
                smooth + 4.0 * next()
            })
            .collect();
        (h, (0..n * n).map(|i| i % n == 0).collect())
    }

    /// An `n` x `n` grid of 1 m cells.
    fn unit_grid(n: usize) -> Grid {
        Grid {
            width: n,
            height: n,
            cell: 1.0,
        }
    }

    /// A half sweep over many rows at once, split into bands run at the same time (a
    /// 256^2 grid: two or more bands where there are threads), gives the bits of the same
    /// half sweep a row at a time, over-relaxed or not.
    #[test]
    fn bands_give_the_bits_of_single_rows() {
        let n = 256;
        let grid = unit_grid(n);
        let (start, base) = rough(n);
        let step = Diffusion::new(13.0);
        let (mut whole, mut by_row) = (start.clone(), start.clone());
        for sweep in [0, step.sweeps() - 1] {
            for colour in 0..2 {
                let half = HalfSweep { sweep, colour };
                step.rows(grid, &mut whole, &base, &start, half, 0..n);
                for y in 0..n {
                    step.rows(grid, &mut by_row, &base, &start, half, y..y + 1);
                }
            }
        }
        let bits = |h: &[f32]| h.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
        assert_ne!(bits(&whole), bits(&start));
        assert_eq!(bits(&whole), bits(&by_row));
    }

    /// A step's half sweeps done in passes of [`BLOCK`] ([`Diffusion::block`]: wavefronts in
    /// bands, then the triangles at the bands' boundaries) give the bits of the same half
    /// sweeps one after the other, a row at a time, cell by cell: in 1 to 5 bands (and 3 on
    /// 9 rows, too few for two), with base cells inside, for over-relaxed and Gauss-Seidel
    /// sweeps, and a last pass shorter than `BLOCK`. Fails if a band skipped a row or read
    /// one too early or too late.
    #[test]
    fn passes_give_the_bits_of_half_sweeps_one_by_one() {
        for (w, h, bands) in [
            (64, 256, 1),
            (96, 256, 2),
            (33, 200, 3),
            (50, 170, 5),
            (40, 9, 3),
        ] {
            let n = w.max(h);
            let (field, _) = rough(n);
            let start: Vec<f32> = (0..w * h).map(|i| field[(i / w) * n + i % w]).collect();
            let base: Vec<bool> = (0..w * h)
                .map(|i| i % w == 0 || (i * 7 + i / w * 13) % 31 == 0)
                .collect();
            let grid = Grid {
                width: w,
                height: h,
                cell: 1.0,
            };
            let step = Diffusion::new(13.0);
            assert!(
                !step.halves().is_multiple_of(BLOCK),
                "a short last pass is tested"
            );
            let mut reference = start.clone();
            for j in 0..step.halves() {
                for y in 0..h {
                    step.rows(grid, &mut reference, &base, &start, step.half(j), y..y + 1);
                }
            }
            let mut passes = start.clone();
            for first in (0..step.halves()).step_by(BLOCK) {
                let halves = first..(first + BLOCK).min(step.halves());
                step.block_in_bands(grid, &mut passes, (&base, &start), halves, bands);
            }
            let bits = |h: &[f32]| h.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
            assert_ne!(bits(&reference), bits(&start));
            assert_eq!(
                bits(&passes),
                bits(&reference),
                "{w} x {h} in {bands} bands"
            );
        }
    }

    /// Issue 32's "the same landforms at every resolution" needs the same creep at every
    /// `r = kappa dt / cell^2`: the step's sweeps leave at most 6% of its change undone
    /// against the exact backward-Euler step (the same equations relaxed to convergence), from
    /// `r` = 0.5 to 200 (a 2048^2 map of the old hills), and stay
    /// within the start's range (the maximum principle: no overshoot). The first solver's
    /// `ceil(sqrt r)` Gauss-Seidel sweeps, at most 8, left 69% undone at `r` = 52.
    #[test]
    fn a_step_is_solved_alike_at_every_ratio() {
        let n = 64;
        let grid = unit_grid(n);
        let (start, base) = rough(n);
        let (lo, hi) = start
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), z| (l.min(*z), h.max(*z)));
        for r in [0.5, 1.3, 5.0, 13.0, 52.0, 200.0] {
            let step = Diffusion::new(r);
            let solve = |sweeps: usize, sweep_index: fn(usize) -> usize| {
                let mut h = start.clone();
                for sweep in 0..sweeps {
                    for colour in 0..2 {
                        let half = HalfSweep {
                            sweep: sweep_index(sweep),
                            colour,
                        };
                        step.rows(grid, &mut h, &base, &start, half, 0..n);
                    }
                }
                h
            };
            let swept = solve(step.sweeps(), |sweep| sweep);
            // The exact step: the first sweep's rule (over-relaxed where the step
            // over-relaxes), run until nothing moves.
            let exact = solve(2_000, |_| 0);
            let norm = |a: &[f32], b: &[f32]| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| f64::from(x - y).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let undone = norm(&swept, &exact) / norm(&start, &exact);
            assert!(
                undone <= 0.06,
                "r {r}: {} sweeps left {undone:.3} of the step undone",
                step.sweeps()
            );
            let (l, h) = swept
                .iter()
                .fold((f32::MAX, f32::MIN), |(l, h), z| (l.min(*z), h.max(*z)));
            assert!(
                l >= lo - 1e-3 && h <= hi + 1e-3,
                "r {r}: {l}..{h} out of {lo}..{hi}"
            );
        }
    }
}
