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
//! **Feathered edge** (departure from the paper). Eq. 9 holds the heights on the frame but
//! not the slopes: inside, T takes R's gradients, outside it keeps S's, so the slope jumps at
//! the frame and the block's outline shows as a crease, R's texture stopping sharply there.
//! So the block's change of the terrain, `E = T - S` (zero on the frame), is faded in from the
//! frame: `T' = S + w E`, `w` the product of smoothsteps across each side with terrain
//! beyond it, rising from 0 on the frame to 1 at `feather` times the block's shorter side.
//! Both E and w vanish on the frame and w's slope does too, so T' meets S with the same
//! height and slope, and R's features grow in over the band (the cross-fade of feathered
//! compositing, Szeliski 2010, "Computer Vision", Sec. 9.3.2, applied to the Poisson
//! solution's change rather than to the images). `feather` 0 is eq. 9 alone.
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

/// The largest `feather`: half the shorter side, where the fades from two sides meet.
pub const MAX_FEATHER: f32 = 0.5;

/// The feather of a new block: the change fades in over a quarter of the block's shorter
/// side (chosen by eye on SRTM blocks in 10 km terrains: an eighth still showed the outline
/// at 200 cells, a half left only the middle of the block at the reference's full strength).
pub const DEFAULT_FEATHER: f32 = 0.25;

/// Replaces `rect` of `target` by the Poisson solution guided by `guide` (the transformed
/// reference, `rect`'s size), its change of the terrain faded in over `feather` (0 to
/// [`MAX_FEATHER`]) of the block's shorter side from the frame (module docs). `rect` must lie
/// inside `target` and `guide` must be finite.
pub async fn solve_block(
    backend: &Backend,
    target: &mut Heightfield,
    rect: BlockRect,
    guide: &Heightfield,
    (params, feather): (&MultigridParams, f32),
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

    let fade = Fade::new(rect, (tw, th), feather);
    let data = target.data_mut();
    for y in 0..h {
        let row = &mut data[(rect.row + y) * tw + rect.col..][..w];
        for (x, t) in row.iter_mut().enumerate() {
            if !on_frame(x, y) {
                let solved = guide.data()[y * w + x] + mean + correction[y * w + x];
                // A void of the terrain inside the block takes the solution whole.
                let w = fade.at(x, y);
                *t = if w < 1.0 && t.is_finite() {
                    *t + w * (solved - *t)
                } else {
                    solved
                };
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

/// The weight `w` of a block's change ([`solve_block`]'s feathered edge): the product of a
/// smoothstep across the columns and one across the rows, each rising from 0 on the block's
/// sides that have terrain beyond them to 1 at `band` cells in.
struct Fade {
    band: f32,
    /// Whether the left, right, top and bottom sides have terrain beyond them.
    sides: [bool; 4],
    width: usize,
    height: usize,
}

impl Fade {
    /// The fade of `rect` on a `(width, height)` terrain over `feather` of its shorter side.
    fn new(rect: BlockRect, (width, height): (usize, usize), feather: f32) -> Self {
        let shorter = rect.width.min(rect.height).saturating_sub(1) as f32;
        Self {
            band: feather.clamp(0.0, MAX_FEATHER) * shorter,
            sides: [
                rect.col > 0,
                rect.col + rect.width < width,
                rect.row > 0,
                rect.row + rect.height < height,
            ],
            width: rect.width,
            height: rect.height,
        }
    }

    /// The weight at block cell (`x`, `y`), in [0, 1].
    fn at(&self, x: usize, y: usize) -> f32 {
        let across = |i: usize, n: usize, first: bool, last: bool| {
            let from_first = if first { i as f32 } else { f32::INFINITY };
            let from_last = if last {
                (n - 1 - i) as f32
            } else {
                f32::INFINITY
            };
            smoothstep(from_first.min(from_last) / self.band)
        };
        if self.band <= 0.0 {
            return 1.0;
        }
        let [left, right, top, bottom] = self.sides;
        across(x, self.width, left, right) * across(y, self.height, top, bottom)
    }
}

/// `3 t^2 - 2 t^3` of `t` clamped to [0, 1]: 0 and 1 with zero slope at both ends.
fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fade is 0 on the sides with terrain beyond them, 1 along the map's edge and beyond
    /// the band, symmetric, and rises smoothly: no step larger than the smoothstep's steepest
    /// (1.5 / band) between neighbours.
    #[test]
    fn the_fade_rises_from_the_frame_over_its_band() {
        let rect = BlockRect {
            row: 0,
            col: 10,
            height: 41,
            width: 41,
        };
        let fade = Fade::new(rect, (100, 100), 0.25);
        assert_eq!(fade.band, 10.0);
        assert_eq!(fade.at(0, 20), 0.0, "left side, terrain beyond");
        assert_eq!(fade.at(40, 20), 0.0, "right side, terrain beyond");
        assert_eq!(fade.at(20, 40), 0.0, "bottom side, terrain beyond");
        assert_eq!(fade.at(20, 0), 1.0, "top side on the map's edge");
        assert_eq!(fade.at(20, 20), 1.0);
        assert_eq!(fade.at(5, 20), 0.5);
        assert_eq!(fade.at(5, 20), fade.at(35, 20));
        for y in 0..41 {
            for x in 1..41 {
                assert!((fade.at(x, y) - fade.at(x - 1, y)).abs() <= 1.5 / 10.0 + 1e-6);
            }
        }
        let none = Fade::new(rect, (100, 100), 0.0);
        assert_eq!(none.at(0, 20), 1.0, "no feather: eq. 9 alone");
    }
}
