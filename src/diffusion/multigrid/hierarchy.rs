//! The grid hierarchy: each level halves the previous one (rounding up), down to a few cells.

use std::ops::Range;

use crate::diffusion::{Constraints, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// Stop coarsening once both sides are at most this many cells.
pub(crate) const COARSEST_SIDE: usize = 4;

/// One level of the hierarchy: its fixed cells, its unknowns and its right-hand side.
pub struct Level {
    pub w: usize,
    pub h: usize,
    pub fixed: FixedMask,
    /// Unknowns: the solution on the finest level, the error correction below it.
    pub u: Vec<f32>,
    /// Right-hand side of `A u = b` (all zero on the finest level of a Laplace problem).
    pub b: Vec<f32>,
}

impl Level {
    pub fn dims(&self) -> (usize, usize) {
        (self.w, self.h)
    }

    pub fn cells(&self) -> usize {
        self.w * self.h
    }
}

/// The levels of a problem. The finest level's `b` stays empty for a Laplace problem (no
/// `rhs`), saving a full-size buffer; every coarser level has one. Each level is one O(cells)
/// step; the job may yield between them ([`JobCtx::tick`]).
pub async fn for_problem(
    problem: &Constraints,
    rhs: Option<&Heightfield>,
    ctx: &JobCtx,
) -> Result<Vec<Level>, Cancelled> {
    let (w, h) = (problem.width(), problem.height());
    let finest = Level {
        w,
        h,
        fixed: problem.fixed().clone(),
        u: problem.initial().data().to_vec(),
        // Building reads b on every level: a zero one for Laplace, dropped afterwards.
        b: rhs.map_or_else(|| vec![0.0; w * h], |r| r.data().to_vec()),
    };
    let mut levels = vec![finest];
    while let Some(mut coarse) = next_coarser(&levels[levels.len() - 1]) {
        let fine = &levels[levels.len() - 1];
        // Bands of about 2^16 coarse cells, with the job's ticks between them.
        let (rows, h) = (((1usize << 16) / coarse.w).max(1), coarse.h);
        for start in (0..h).step_by(rows) {
            restrict_rows(fine, &mut coarse, start..(start + rows).min(h));
            ctx.tick(0.0, "multigrid: building the levels").await?;
        }
        levels.push(coarse);
    }
    if rhs.is_none() {
        levels[0].b = Vec::new();
    }
    Ok(levels)
}

/// The sides of every level of a `w` x `h` problem, finest first: each half the previous
/// one (rounded up) until both sides are at most [`COARSEST_SIDE`]. O(log(max(w, h))).
pub fn dims(w: usize, h: usize) -> Vec<(usize, usize)> {
    let mut dims = vec![(w, h)];
    while let Some(next) = coarser_dims(dims[dims.len() - 1]) {
        dims.push(next);
    }
    dims
}

/// The sides of the level below one of sides `(w, h)`; `None` for the coarsest.
fn coarser_dims((w, h): (usize, usize)) -> Option<(usize, usize)> {
    (w > COARSEST_SIDE || h > COARSEST_SIDE).then(|| (w.div_ceil(2), h.div_ceil(2)))
}

/// The next coarser level of `fine` (half its size, rounded up), still empty; `None` once
/// `fine` is the coarsest.
fn next_coarser(fine: &Level) -> Option<Level> {
    let (w, h) = coarser_dims(fine.dims())?;
    Some(Level {
        w,
        h,
        fixed: FixedMask::new(w, h),
        u: vec![0.0; w * h],
        b: vec![0.0; w * h],
    })
}

/// Fills rows `rows` of `coarse` from `fine`. Constraint-aware restriction of the problem:
/// a coarse cell is fixed when any of its 2 x 2 children is, and then holds the mean of the
/// fixed children's heights (so rivers and ridges stay connected lines on every level); its
/// right-hand side is the sum of its free children's (see `ops::restrict_residual`).
fn restrict_rows(fine: &Level, coarse: &mut Level, rows: Range<usize>) {
    let cw = coarse.w;
    for cy in rows {
        for cx in 0..cw {
            let (mut fixed_sum, mut fixed_n) = (0.0f32, 0u32);
            let (mut free_sum, mut free_n) = (0.0f32, 0u32);
            let mut rhs = 0.0f32;
            for y in 2 * cy..(2 * cy + 2).min(fine.h) {
                for x in 2 * cx..(2 * cx + 2).min(fine.w) {
                    let i = y * fine.w + x;
                    if fine.fixed.is_fixed_index(i) {
                        fixed_sum += fine.u[i];
                        fixed_n += 1;
                    } else {
                        free_sum += fine.u[i];
                        free_n += 1;
                        rhs += fine.b[i];
                    }
                }
            }
            let c = cy * cw + cx;
            if fixed_n > 0 {
                coarse.fixed.fix(cx, cy);
                coarse.u[c] = fixed_sum / fixed_n as f32;
            } else {
                coarse.u[c] = free_sum / free_n.max(1) as f32;
                coarse.b[c] = rhs;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_down_to_a_few_cells_and_keeps_constraints() {
        let (w, h) = (37, 10);
        let mut fixed = FixedMask::new(w, h);
        fixed.fix(36, 9);
        let mut u = vec![0.0; w * h];
        u[w * h - 1] = 7.0;
        let mut levels = vec![Level {
            w,
            h,
            fixed,
            u,
            b: vec![0.0; w * h],
        }];
        while let Some(mut coarse) = next_coarser(&levels[levels.len() - 1]) {
            let h = coarse.h;
            restrict_rows(&levels[levels.len() - 1], &mut coarse, 0..h);
            levels.push(coarse);
        }
        let sides: Vec<_> = levels.iter().map(Level::dims).collect();
        assert_eq!(sides, vec![(37, 10), (19, 5), (10, 3), (5, 2), (3, 1)]);
        assert_eq!(dims(w, h), sides);
        for level in &levels {
            // The corner constraint survives on every level with its height.
            let i = level.cells() - 1;
            assert!(level.fixed.is_fixed_index(i));
            assert_eq!(level.u[i], 7.0);
            assert_eq!(level.fixed.count(), 1);
        }
    }
}
