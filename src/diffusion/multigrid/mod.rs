//! Multigrid solver for the diffusion problem (CPU reference; `shaders/multigrid.wgsl` is
//! the GPU twin).
//!
//! Solves `A u = b` on free cells with `u` given on fixed cells, `A` the 5-point operator of
//! eq. 7 with zero flux at the border (`b = 0`: the Laplace fill of Sec. V-C, the exact fixed
//! point of the paper's 5500 Jacobi sweeps; `b = A g`: the Poisson blend of Sec. VI, eq. 9).
//!
//! Method: full multigrid (FMG) start, then V(2,2)-cycles until the residual test passes.
//! - Smoother: red-black Gauss-Seidel.
//! - Restriction: residual summed over 2 x 2 children; a coarse cell is fixed (zero
//!   correction) when any child is fixed, so constraint lines survive on every level.
//! - Prolongation: cell-centred bilinear interpolation, added to free cells only.
//! - Stopping rule, residual-based: `max_i |r_i| / n_i <= tolerance * range` (one more
//!   Jacobi sweep would move no cell by more than that; `range` is the fixed heights' range),
//!   and, because the error can be far larger than the residual where constraints are far
//!   apart, also `rho / (1 - rho) * max |e_1| <= error_tolerance * range`: `e_1` is the last
//!   coarse-grid correction (the smooth error it removed) and `rho` the ratio of the last
//!   two, so the left side estimates the error still left (a geometric tail).
//!
//! Cost: O(cells) per cycle (about 9 fine-grid sweeps of work), and the number of cycles does
//! not grow with the grid, so O(cells) per solve. Memory: the solution, the finest right-hand
//! side only for Poisson problems, the fixed-cell bits, and 1/3 of a field for coarse levels.

pub(crate) mod hierarchy;
pub mod ops;

mod stopping;

pub(crate) use stopping::Stopping;

use super::{Constraints, DiffusionError};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use hierarchy::Level;

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultigridParams {
    /// Stop when one Jacobi sweep would move no free cell by more than this fraction of the
    /// fixed cells' height range.
    pub tolerance: f32,
    /// Also stop only once the estimated remaining error is below this fraction of the range.
    pub error_tolerance: f32,
    /// Give up (reporting `converged: false`) after this many V-cycles.
    pub max_cycles: u32,
    /// Red-black Gauss-Seidel sweeps before and after each coarse-grid correction.
    pub pre_sweeps: u32,
    pub post_sweeps: u32,
}

impl Default for MultigridParams {
    fn default() -> Self {
        Self {
            tolerance: 1e-6,
            error_tolerance: 1e-5,
            max_cycles: 60,
            pre_sweeps: 2,
            post_sweeps: 2,
        }
    }
}

/// A solved field and how the solve went (`F`: the field, or where it is).
#[derive(Clone, Debug)]
pub struct Solved<F = Heightfield> {
    pub field: F,
    /// V-cycles on the finest level after the FMG start.
    pub cycles: u32,
    /// Relaxation sweeps on the finest level.
    pub fine_sweeps: u32,
    /// All relaxation work in finest-level sweep equivalents.
    pub work_sweeps: f32,
    /// Final `max |r_i| / n_i` in height units.
    pub residual: f32,
    /// `residual` divided by the height range of the fixed cells.
    pub relative_residual: f32,
    /// Estimated remaining error over the height range (see the stopping rule).
    pub estimated_error: f32,
    pub converged: bool,
}

impl<F> Solved<F> {
    /// The same solve with its field replaced by `f(field)`.
    pub fn map_field<G>(self, f: impl FnOnce(F) -> G) -> Solved<G> {
        Solved {
            field: f(self.field),
            cycles: self.cycles,
            fine_sweeps: self.fine_sweeps,
            work_sweeps: self.work_sweeps,
            residual: self.residual,
            relative_residual: self.relative_residual,
            estimated_error: self.estimated_error,
            converged: self.converged,
        }
    }
}

/// The job and what it reports at each [`JobCtx::tick`] between operators.
struct Slicer<'a> {
    ctx: &'a JobCtx,
    progress: f32,
    message: String,
}

impl Slicer<'_> {
    async fn tick(&mut self) -> Result<(), DiffusionError> {
        Ok(self.ctx.tick(self.progress, &self.message).await?)
    }
}

/// Solves `problem` (and `A u = rhs` on free cells when `rhs` is given) by multigrid.
pub async fn solve(
    problem: &Constraints,
    rhs: Option<&Heightfield>,
    params: &MultigridParams,
    ctx: &JobCtx,
) -> Result<Solved, DiffusionError> {
    let (w, h) = (problem.width(), problem.height());
    if problem.fixed().count() == 0 {
        return Err(DiffusionError::NoFixedCells);
    }
    check_rhs(problem, rhs)?;
    let scale = super::fixed_height_range(problem).max(f32::MIN_POSITIVE);
    let mut levels = hierarchy::for_problem(problem, rhs, ctx).await?;
    // Building the levels is one O(cells) step: let the browser paint after it.
    ctx.checkpoint(0.0, "multigrid: full-multigrid start")
        .await?;

    let mut slicer = Slicer {
        ctx,
        progress: 0.0,
        message: "multigrid: full-multigrid start".to_owned(),
    };
    let mut stats = Work::default();

    // Full multigrid: exact-ish solve on the coarsest level, then at each finer level
    // interpolate the coarser solution as the start and run one V-cycle.
    let last = levels.len() - 1;
    relax_coarsest(&mut levels[last], &mut stats, w * h);
    let mut last_correction = f32::INFINITY;
    for l in (0..last).rev() {
        let (fine, coarse) = levels.split_at_mut(l + 1);
        let (fine, coarse) = (&mut fine[l], &coarse[0]);
        let dims = fine.dims();
        ops::prolong_replace(&mut fine.u, &fine.fixed, dims, &coarse.u, coarse.dims());
        slicer.tick().await?;
        last_correction = v_cycle(&mut levels, l, params, &mut stats, w * h, &mut slicer).await?;
    }

    let b = rhs.map(Heightfield::data);
    let residual = ops::max_scaled_residual(&levels[0].u, b, &levels[0].fixed, w, h);
    let mut stop = Stopping::new(params, scale, residual, last_correction);
    while stop.keep_going() {
        slicer.progress = stop.progress();
        slicer.message = format!("multigrid {}", stop.describe());
        ctx.checkpoint(slicer.progress, &slicer.message).await?;
        let correction = v_cycle(&mut levels, 0, params, &mut stats, w * h, &mut slicer).await?;
        let residual = ops::max_scaled_residual(&levels[0].u, b, &levels[0].fixed, w, h);
        stop.record(residual, correction);
    }
    let u = std::mem::take(&mut levels[0].u);
    ctx.set_progress(1.0, "multigrid: done");
    Ok(Solved {
        field: Heightfield::from_vec(w, h, u).expect("finest level has the problem's size"),
        cycles: stop.cycles,
        fine_sweeps: stats.fine_sweeps,
        work_sweeps: stats.work_sweeps,
        residual: stop.residual,
        relative_residual: stop.relative_residual(),
        estimated_error: stop.relative_estimate(),
        converged: stop.converged(),
    })
}

/// Fails unless `rhs` (if any) has the problem's size.
fn check_rhs(problem: &Constraints, rhs: Option<&Heightfield>) -> Result<(), DiffusionError> {
    match rhs {
        Some(rhs) if (rhs.width(), rhs.height()) != (problem.width(), problem.height()) => {
            Err(DiffusionError::RhsSize {
                rhs: (rhs.width(), rhs.height()),
                field: (problem.width(), problem.height()),
            })
        }
        _ => Ok(()),
    }
}

/// Relaxation work done, for the report.
#[derive(Default)]
pub(crate) struct Work {
    pub fine_sweeps: u32,
    pub work_sweeps: f32,
}

impl Work {
    pub(crate) fn add(&mut self, cells: usize, finest_cells: usize, sweeps: u32) {
        if cells == finest_cells {
            self.fine_sweeps += sweeps;
        }
        self.work_sweeps += sweeps as f32 * cells as f32 / finest_cells as f32;
    }
}

/// Red-black sweeps on the coarsest level (at most 4 x 4 cells): enough to solve it to
/// rounding error.
pub(crate) const COARSEST_SWEEPS: u32 = 100;

/// The coarsest level has at most 16 cells: relax it to convergence.
fn relax_coarsest(level: &mut Level, stats: &mut Work, finest_cells: usize) {
    let b = (!level.b.is_empty()).then_some(level.b.as_slice());
    for _ in 0..COARSEST_SWEEPS {
        ops::relax_red_black(&mut level.u, b, &level.fixed, level.w, level.h);
    }
    stats.add(level.cells(), finest_cells, COARSEST_SWEEPS);
}

/// One V-cycle from level `top` down to the coarsest and back (correction scheme).
/// Iterative rather than recursive so it can yield between operators. Returns the largest
/// coarse-grid correction applied to level `top` (0 if it is the coarsest).
async fn v_cycle(
    levels: &mut [Level],
    top: usize,
    params: &MultigridParams,
    stats: &mut Work,
    finest_cells: usize,
    slicer: &mut Slicer<'_>,
) -> Result<f32, DiffusionError> {
    let last = levels.len() - 1;
    let mut correction = 0.0f32;
    // Down: smooth, restrict the residual, zero the coarse correction.
    for l in top..last {
        let (fine, coarse) = levels.split_at_mut(l + 1);
        let (fine, coarse) = (&mut fine[l], &mut coarse[0]);
        let b = (!fine.b.is_empty()).then_some(fine.b.as_slice());
        for _ in 0..params.pre_sweeps {
            ops::relax_red_black(&mut fine.u, b, &fine.fixed, fine.w, fine.h);
            slicer.tick().await?;
        }
        stats.add(fine.cells(), finest_cells, params.pre_sweeps);
        let coarse_dims = coarse.dims();
        ops::restrict_residual(
            &fine.u,
            b,
            &fine.fixed,
            fine.dims(),
            &mut coarse.b,
            coarse_dims,
        );
        coarse.u.fill(0.0);
        slicer.tick().await?;
    }
    relax_coarsest(&mut levels[last], stats, finest_cells);
    // Up: interpolate the correction, smooth.
    for l in (top..last).rev() {
        let (fine, coarse) = levels.split_at_mut(l + 1);
        let (fine, coarse) = (&mut fine[l], &coarse[0]);
        if l == top {
            correction = coarse.u.iter().fold(0.0, |m, v| m.max(v.abs()));
        }
        let dims = fine.dims();
        ops::prolong_add(&mut fine.u, &fine.fixed, dims, &coarse.u, coarse.dims());
        slicer.tick().await?;
        let b = (!fine.b.is_empty()).then_some(fine.b.as_slice());
        for _ in 0..params.post_sweeps {
            ops::relax_red_black(&mut fine.u, b, &fine.fixed, fine.w, fine.h);
            slicer.tick().await?;
        }
        stats.add(fine.cells(), finest_cells, params.post_sweeps);
    }
    Ok(correction)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diffusion::{FixedMask, demo};

    fn solve_now(problem: &Constraints, rhs: Option<&Heightfield>) -> Solved {
        pollster::block_on(solve(
            problem,
            rhs,
            &MultigridParams::default(),
            &JobCtx::detached(),
        ))
        .unwrap()
    }

    /// Dense Gaussian elimination of the same equations (small grids only): the exact
    /// discrete solution in f64.
    fn direct_solve(problem: &Constraints, rhs: Option<&Heightfield>) -> Vec<f64> {
        let (w, h) = (problem.width(), problem.height());
        let n = w * h;
        let mut a = vec![0.0f64; n * n];
        let mut b = vec![0.0f64; n];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if problem.fixed().is_fixed_index(i) {
                    a[i * n + i] = 1.0;
                    b[i] = f64::from(problem.initial().data()[i]);
                    continue;
                }
                let mut nbrs = Vec::new();
                if x > 0 {
                    nbrs.push(i - 1);
                }
                if x + 1 < w {
                    nbrs.push(i + 1);
                }
                if y > 0 {
                    nbrs.push(i - w);
                }
                if y + 1 < h {
                    nbrs.push(i + w);
                }
                a[i * n + i] = nbrs.len() as f64;
                for j in nbrs {
                    a[i * n + j] -= 1.0;
                }
                b[i] = rhs.map_or(0.0, |r| f64::from(r.data()[i]));
            }
        }
        // Gaussian elimination with partial pivoting.
        for col in 0..n {
            let pivot = (col..n)
                .max_by(|&p, &q| a[p * n + col].abs().total_cmp(&a[q * n + col].abs()))
                .unwrap();
            if pivot != col {
                for k in 0..n {
                    a.swap(col * n + k, pivot * n + k);
                }
                b.swap(col, pivot);
            }
            for row in col + 1..n {
                let f = a[row * n + col] / a[col * n + col];
                if f != 0.0 {
                    for k in col..n {
                        a[row * n + k] -= f * a[col * n + k];
                    }
                    b[row] -= f * b[col];
                }
            }
        }
        let mut x = vec![0.0f64; n];
        for row in (0..n).rev() {
            let mut s = b[row];
            for k in row + 1..n {
                s -= a[row * n + k] * x[k];
            }
            x[row] = s / a[row * n + row];
        }
        x
    }

    fn max_rel_error(got: &Heightfield, exact: &[f64]) -> f64 {
        let lo = exact.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = exact.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        got.data()
            .iter()
            .zip(exact)
            .map(|(&g, &e)| (f64::from(g) - e).abs())
            .fold(0.0, f64::max)
            / (hi - lo).max(1e-12)
    }

    #[test]
    fn matches_a_direct_solve_on_small_grids() {
        for (w, h) in [(24, 24), (31, 17), (9, 40)] {
            let (problem, _) = scattered_problem(w, h, 7);
            let exact = direct_solve(&problem, None);
            let solved = solve_now(&problem, None);
            assert!(solved.converged);
            let err = max_rel_error(&solved.field, &exact);
            assert!(err < 1e-4, "{w}x{h}: error {err:e} of the range");
        }
    }

    #[test]
    fn solves_poisson_problems_too() {
        let (problem, rhs) = scattered_problem(20, 28, 3);
        let exact = direct_solve(&problem, Some(&rhs));
        let solved = solve_now(&problem, Some(&rhs));
        assert!(solved.converged);
        let err = max_rel_error(&solved.field, &exact);
        assert!(err < 1e-4, "error {err:e} of the range");
    }

    #[test]
    fn converges_on_the_demo_in_few_cycles_independent_of_size() {
        let mut cycles = Vec::new();
        for n in [65, 129, 257] {
            let problem = demo::valley_and_peaks(n);
            let solved = solve_now(&problem, None);
            assert!(
                solved.converged,
                "n={n}: residual {}",
                solved.relative_residual
            );
            assert!(solved.relative_residual <= 1e-6);
            // Fixed cells untouched.
            for (i, (&a, &b)) in solved
                .field
                .data()
                .iter()
                .zip(problem.initial().data())
                .enumerate()
            {
                if problem.fixed().is_fixed_index(i) {
                    assert_eq!(a, b);
                }
            }
            cycles.push(solved.cycles);
        }
        // Multigrid: cycle counts stay flat as the grid grows (Jacobi's would quadruple).
        assert!(cycles.iter().all(|&c| c <= 15), "{cycles:?}");
    }

    #[test]
    fn reaches_a_known_discrete_harmonic_field_at_size() {
        // u = x^3 - 3 x y^2 has a zero 5-point Laplacian (the stencil is exact for cubics).
        // Fix it on the border and on scattered interior cells; the exact discrete solution is
        // u everywhere, so the error is measured against the truth, not another solve.
        let n = 257;
        let s = (n - 1) as f64;
        let exact = |x: usize, y: usize| {
            let (x, y) = (x as f64 - s / 2.0, y as f64 - s / 3.0);
            ((x * x * x - 3.0 * x * y * y) / (s * s)) as f32
        };
        let mut fixed = FixedMask::new(n, n);
        let mut initial = Heightfield::filled(n, n, 0.0).unwrap();
        for y in 0..n {
            for x in 0..n {
                let border = x == 0 || y == 0 || x == n - 1 || y == n - 1;
                if border || (x * 7 + y * 13) % 97 == 0 {
                    fixed.fix(x, y);
                    let i = initial.index(x, y);
                    initial.data_mut()[i] = exact(x, y);
                }
            }
        }
        let problem = Constraints::new(initial, fixed).unwrap();
        let solved = solve_now(&problem, None);
        assert!(solved.converged);
        let truth: Vec<f64> = (0..n * n).map(|i| f64::from(exact(i % n, i / n))).collect();
        let err = max_rel_error(&solved.field, &truth);
        assert!(err < 1e-4, "error {err:e} of the range");
    }

    #[test]
    fn refuses_a_problem_without_fixed_cells() {
        let problem = Constraints::new(
            Heightfield::filled(8, 8, 0.0).unwrap(),
            FixedMask::new(8, 8),
        )
        .unwrap();
        let err = pollster::block_on(solve(
            &problem,
            None,
            &MultigridParams::default(),
            &JobCtx::detached(),
        ))
        .unwrap_err();
        assert!(matches!(err, DiffusionError::NoFixedCells));
    }

    /// A few fixed cells with pseudo-random heights plus a smooth right-hand side.
    fn scattered_problem(w: usize, h: usize, seed: u32) -> (Constraints, Heightfield) {
        let mut state = seed.wrapping_mul(2_654_435_761).max(1);
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let mut fixed = FixedMask::new(w, h);
        let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
        for _ in 0..(w * h / 40).max(2) {
            let (x, y) = (next() as usize % w, next() as usize % h);
            fixed.fix(x, y);
            let i = initial.index(x, y);
            initial.data_mut()[i] = (next() % 1000) as f32;
        }
        let rhs: Vec<f32> = (0..w * h)
            .map(|i| ((i % w) as f32 * 0.3).sin() * 2.0 + ((i / w) as f32 * 0.2).cos())
            .collect();
        (
            Constraints::new(initial, fixed).unwrap(),
            Heightfield::from_vec(w, h, rhs).unwrap(),
        )
    }
}
