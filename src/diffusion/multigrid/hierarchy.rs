//! The grid hierarchy: each level halves the previous one (rounding up), down to a few cells.

use crate::diffusion::{Constraints, FixedMask};
use crate::heightfield::Heightfield;

/// Stop coarsening once both sides are at most this many cells.
const COARSEST_SIDE: usize = 4;

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
/// `rhs`), saving a full-size buffer; every coarser level has one.
pub fn for_problem(problem: &Constraints, rhs: Option<&Heightfield>) -> Vec<Level> {
    let (w, h) = (problem.width(), problem.height());
    let finest = Level {
        w,
        h,
        fixed: problem.fixed().clone(),
        u: problem.initial().data().to_vec(),
        // Building reads b on every level: a zero one for Laplace, dropped afterwards.
        b: rhs.map_or_else(|| vec![0.0; w * h], |r| r.data().to_vec()),
    };
    let mut levels = build(finest);
    if rhs.is_none() {
        levels[0].b = Vec::new();
    }
    levels
}

/// Builds the coarse levels below `finest`. Constraint-aware restriction of the problem:
/// a coarse cell is fixed when any of its 2 x 2 children is, and then holds the mean of the
/// fixed children's heights (so rivers and ridges stay connected lines on every level); its
/// right-hand side is the sum of its free children's (see `ops::restrict_residual`).
pub fn build(finest: Level) -> Vec<Level> {
    let mut levels = vec![finest];
    loop {
        let fine = &levels[levels.len() - 1];
        if fine.w <= COARSEST_SIDE && fine.h <= COARSEST_SIDE {
            break;
        }
        let (cw, ch) = (fine.w.div_ceil(2), fine.h.div_ceil(2));
        let mut fixed = FixedMask::new(cw, ch);
        let mut u = vec![0.0f32; cw * ch];
        let mut b = vec![0.0f32; cw * ch];
        for cy in 0..ch {
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
                    fixed.fix(cx, cy);
                    u[c] = fixed_sum / fixed_n as f32;
                } else {
                    u[c] = free_sum / free_n.max(1) as f32;
                    b[c] = rhs;
                }
            }
        }
        levels.push(Level {
            w: cw,
            h: ch,
            fixed,
            u,
            b,
        });
    }
    levels
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
        let levels = build(Level {
            w,
            h,
            fixed,
            u,
            b: vec![0.0; w * h],
        });
        let dims: Vec<_> = levels.iter().map(Level::dims).collect();
        assert_eq!(dims, vec![(37, 10), (19, 5), (10, 3), (5, 2), (3, 1)]);
        for level in &levels {
            // The corner constraint survives on every level with its height.
            let i = level.cells() - 1;
            assert!(level.fixed.is_fixed_index(i));
            assert_eq!(level.u[i], 7.0);
            assert_eq!(level.fixed.count(), 1);
        }
    }
}
