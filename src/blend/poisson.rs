//! Solving one block by the discrete Poisson equation (seed paper 000, Sec. VI-A, eq. 9).
//!
//! Unknowns: the cells T of the block that are not on its frame. Boundary B_s: the block's
//! frame cells, which keep the source (synthetic) terrain S. Guidance: the divergence of the
//! reference R's gradient field, taken with the same 5-point operator as the matrix
//! (eq. 7, `A x = 4 x(i,j) - x(i±1,j) - x(i,j±1)`), so on every unknown cell
//!
//! ```text
//!     A T = A R        (eq. 9 with b = A R, boundary terms moved to b as the paper does)
//!     T   = S          on the frame B_s
//! ```
//!
//! and where the block touches the map edge the frame cell is unknown too and its missing
//! neighbours are left out of both sides (zero flux), as in diffusion. Because A is linear,
//! `C = T - R` satisfies `A C = 0` with `C = S - R` on the frame: the Poisson problem is the
//! diffusion stage's Laplace problem for the correction C, so the same multigrid solvers (CPU
//! and WGSL) solve it, and `T = R + C`. A reference equal to S plus a constant gives a
//! constant C and so S back exactly.
//!
//! Cost: one multigrid solve on the block, O(block cells), plus O(block cells) set-up.

use web_time::Instant;

use crate::compute::Backend;
use crate::diffusion::{self, Constraints, FixedMask, Method, MultigridParams};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

use super::{BlendError, BlockRect};

/// How one block's solve went.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BlockSolve {
    /// Cells solved (the block minus its fixed frame).
    pub unknowns: usize,
    /// Multigrid V-cycles (0 when the correction is constant and needs no solve).
    pub cycles: u32,
    /// Final residual over the block's height range.
    pub relative_residual: f32,
    pub converged: bool,
    pub millis: f64,
}

/// Replaces `rect` of `target` by the Poisson solution guided by `guide` (the transformed
/// reference, `rect`'s size). `rect` must lie inside `target` and `guide` must be finite.
pub async fn solve_block(
    backend: &Backend,
    target: &mut Heightfield,
    rect: BlockRect,
    guide: &Heightfield,
    params: &MultigridParams,
    ctx: &JobCtx,
) -> Result<BlockSolve, BlendError> {
    let start = Instant::now();
    rect.check_inside(target.width(), target.height())?;
    if (guide.width(), guide.height()) != (rect.width, rect.height) {
        return Err(BlendError::GuideSize {
            guide: (guide.width(), guide.height()),
            block: (rect.width, rect.height),
        });
    }
    if let Some(i) = guide.data().iter().position(|v| !v.is_finite()) {
        return Err(BlendError::ReferenceVoid {
            row: i / rect.width,
            col: i % rect.width,
        });
    }
    let (tw, th) = (target.width(), target.height());
    let (w, h) = (rect.width, rect.height);
    // A frame cell is fixed when it lies on a side of the block that has terrain beyond it;
    // on sides along the map edge the frame is unknown (zero flux). So every neighbour of an
    // unknown cell is either in the block or off the map.
    let on_frame = |x: usize, y: usize| {
        let (gx, gy) = (rect.col + x, rect.row + y);
        (x == 0 && gx > 0)
            || (y == 0 && gy > 0)
            || (x + 1 == w && gx + 1 < tw)
            || (y + 1 == h && gy + 1 < th)
    };

    let mut fixed = FixedMask::new(w, h);
    let mut correction = vec![0.0f32; w * h];
    let (mut lo, mut hi, mut sum, mut n) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f64, 0usize);
    let (mut s_lo, mut s_hi, mut r_lo, mut r_hi) = (
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    );
    for y in 0..h {
        for x in 0..w {
            let s = target.data()[(rect.row + y) * tw + rect.col + x];
            let r = guide.data()[y * w + x];
            if s.is_finite() {
                (s_lo, s_hi) = (s_lo.min(s), s_hi.max(s));
            }
            (r_lo, r_hi) = (r_lo.min(r), r_hi.max(r));
            if on_frame(x, y) {
                if !s.is_finite() {
                    return Err(BlendError::TargetVoid {
                        row: rect.row + y,
                        col: rect.col + x,
                    });
                }
                let c = s - r;
                fixed.fix(x, y);
                correction[y * w + x] = c;
                lo = lo.min(c);
                hi = hi.max(c);
                sum += f64::from(c);
                n += 1;
            }
        }
    }
    if n == 0 {
        return Err(BlendError::NoBoundary);
    }
    let unknowns = w * h - n;
    // Centre C on its boundary mean, so f32 keeps its significant digits.
    let mean = (sum / n as f64) as f32;
    for (i, c) in correction.iter_mut().enumerate() {
        *c = if fixed.is_fixed_index(i) {
            *c - mean
        } else {
            0.0
        };
    }
    // The scale errors are measured against: the larger of the terrain's and the
    // reference's height ranges over the block (their offsets do not matter).
    let block_range = (s_hi - s_lo).max(r_hi - r_lo).max(f32::MIN_POSITIVE);
    let c_range = hi - lo;

    let (cycles, relative_residual, converged) = if c_range <= block_range * 1e-7 {
        // The correction is constant to f32 precision: T = R + const, no solve needed.
        correction.iter_mut().for_each(|c| *c = 0.0);
        (0, 0.0, true)
    } else {
        // The multigrid's tolerances are relative to the fixed cells' range (C's range here);
        // rescale them so they mean the same fraction of the block's height range.
        let ratio = block_range / c_range;
        let params = MultigridParams {
            tolerance: (params.tolerance * ratio).min(1e-2),
            error_tolerance: (params.error_tolerance * ratio).min(1e-2),
            ..*params
        };
        let initial = Heightfield::from_vec(w, h, correction).expect("the block is not empty");
        let problem =
            Constraints::new(initial, fixed).expect("frame corrections are finite by construction");
        let filled = diffusion::fill(backend, &problem, Method::Multigrid(params), ctx).await?;
        correction = filled.field.into_vec();
        (
            filled.cycles,
            filled.relative_residual / ratio,
            filled.converged,
        )
    };

    let data = target.data_mut();
    for y in 0..h {
        let row = &mut data[(rect.row + y) * tw + rect.col..][..w];
        for (x, t) in row.iter_mut().enumerate() {
            if !on_frame(x, y) {
                *t = guide.data()[y * w + x] + mean + correction[y * w + x];
            }
        }
    }
    Ok(BlockSolve {
        unknowns,
        cycles,
        relative_residual,
        converged,
        millis: start.elapsed().as_secs_f64() * 1e3,
    })
}
