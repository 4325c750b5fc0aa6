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
/// [`Self::sweeps`] sweeps of two colours each ([`Self::rows`]).
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
        let omega = self.over_relaxed(half.sweep).then_some(self.omega);
        for k in 0..cells.len() / w {
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
            let start = (y + half.colour) % 2;
            self.row(row, (up, down), (&base[at.clone()], &rhs[at]), start, omega);
        }
    }

    /// One colour of one row `row` (its cells from `start`, every other one), `up` and
    /// `down` the rows beside it; the Gauss-Seidel value sums the neighbours above, left,
    /// right and below, in that order, over-relaxed by `omega` where given.
    fn row(
        &self,
        row: &mut [f32],
        (up, down): (Option<&[f32]>, Option<&[f32]>),
        (base, rhs): (&[bool], &[f32]),
        start: usize,
        omega: Option<f32>,
    ) {
        let (r, w) = (self.r, row.len());
        // Diagonal weights for 4, 3 and 2 neighbours (interior, edge, corner).
        let inv = |k: usize| 1.0 / (1.0 + r * k as f32);
        let inv4 = inv(4);
        let mut x = start;
        while x < w {
            if !base[x] {
                let gauss_seidel = match (up, down) {
                    (Some(u), Some(d)) if x > 0 && x + 1 < w => {
                        (rhs[x] + r * (u[x] + row[x - 1] + row[x + 1] + d[x])) * inv4
                    }
                    _ => {
                        let left = x.checked_sub(1).map(|l| row[l]);
                        let right = (x + 1 < w).then(|| row[x + 1]);
                        let nbs = [up.map(|u| u[x]), left, right, down.map(|d| d[x])];
                        let (mut sum, mut k) = (0.0, 0);
                        for v in nbs.into_iter().flatten() {
                            sum += v;
                            k += 1;
                        }
                        (rhs[x] + r * sum) * inv(k)
                    }
                };
                row[x] = match omega {
                    Some(omega) => row[x] + omega * (gauss_seidel - row[x]),
                    None => gauss_seidel,
                };
            }
            x += 2;
        }
    }
}

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
