//! CPU reference of the Jacobi sweep (eq. 7): the fallback in browsers without WebGPU and
//! the yardstick the WGSL kernel is tested against.

use web_time::{Duration, Instant};

use super::constraints::{Constraints, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// Longest stretch of work between two checkpoints. On the web each checkpoint yields to the
/// browser, so this bounds how long a frame can wait for the CPU path (frames < 50 ms).
const SLICE: Duration = Duration::from_millis(20);

/// One Jacobi sweep: every free cell of `dst` becomes the mean of its in-grid 4-neighbours
/// in `src` (eq. 7 set to zero; missing border neighbours are left out, i.e. zero flux);
/// fixed cells are copied. O(cells).
///
/// The neighbours are summed in the order left, right, up, down and then divided by their
/// count, exactly as `shaders/jacobi.wgsl` does, so both backends round alike.
pub fn jacobi_sweep(src: &[f32], dst: &mut [f32], width: usize, height: usize, fixed: &FixedMask) {
    for y in 0..height {
        let row = y * width;
        for x in 0..width {
            let i = row + x;
            dst[i] = if fixed.is_fixed_index(i) {
                src[i]
            } else {
                neighbour_mean(src, width, height, x, y)
            };
        }
    }
}

#[inline]
fn neighbour_mean(u: &[f32], width: usize, height: usize, x: usize, y: usize) -> f32 {
    let i = y * width + x;
    let mut sum = 0.0f32;
    let mut count = 0.0f32;
    if x > 0 {
        sum += u[i - 1];
        count += 1.0;
    }
    if x + 1 < width {
        sum += u[i + 1];
        count += 1.0;
    }
    if y > 0 {
        sum += u[i - width];
        count += 1.0;
    }
    if y + 1 < height {
        sum += u[i + width];
        count += 1.0;
    }
    if count == 0.0 { u[i] } else { sum / count }
}

/// The largest change one more sweep would make to a free cell: `max |mean(nbrs) - u|`,
/// i.e. the max-norm of the eq. 7 residual divided by the neighbour count. Zero exactly at
/// the discrete harmonic solution.
pub fn max_update(field: &Heightfield, fixed: &FixedMask) -> f32 {
    let (w, h) = (field.width(), field.height());
    let u = field.data();
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !fixed.is_fixed_index(i) {
                worst = worst.max((neighbour_mean(u, w, h, x, y) - u[i]).abs());
            }
        }
    }
    worst
}

/// `sweeps` Jacobi sweeps from the problem's initial heights, ping-ponging two buffers.
pub(super) async fn jacobi(
    problem: &Constraints,
    sweeps: u32,
    ctx: &JobCtx,
) -> Result<Heightfield, Cancelled> {
    let (w, h) = (problem.width(), problem.height());
    let mut a = problem.initial().data().to_vec();
    let mut b = a.clone();
    let mut slice_start = Instant::now();
    for sweep in 0..sweeps {
        jacobi_sweep(&a, &mut b, w, h, problem.fixed());
        std::mem::swap(&mut a, &mut b);
        if slice_start.elapsed() >= SLICE {
            let done = (sweep + 1) as f32 / sweeps as f32;
            ctx.checkpoint(
                done,
                &format!("Jacobi sweep {} of {sweeps} (CPU)", sweep + 1),
            )
            .await?;
            slice_start = Instant::now();
        }
    }
    ctx.set_progress(1.0, "done");
    Ok(Heightfield::from_vec(w, h, a).expect("same size as the problem"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane u = a + b x + c y is discrete-harmonic in the interior; with all four border
    /// rows and columns fixed the Jacobi iteration must converge to it from any start.
    #[test]
    fn converges_to_a_fixed_plane() {
        let (w, h) = (24, 17);
        let plane = |x: usize, y: usize| 10.0 + 2.0 * x as f32 - 3.0 * y as f32;
        let mut fixed = FixedMask::new(w, h);
        let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
        for y in 0..h {
            for x in 0..w {
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    fixed.fix(x, y);
                    let i = initial.index(x, y);
                    initial.data_mut()[i] = plane(x, y);
                }
            }
        }
        let problem = Constraints::new(initial, fixed).unwrap();
        let out = pollster::block_on(jacobi(&problem, 3000, &JobCtx::detached())).unwrap();
        for y in 0..h {
            for x in 0..w {
                let err = (out.get(x, y).unwrap() - plane(x, y)).abs();
                assert!(err < 1e-3, "({x},{y}) off by {err}");
            }
        }
        assert!(max_update(&out, problem.fixed()) < 1e-4);
    }

    #[test]
    fn fixed_cells_never_move_and_neumann_border_keeps_constants() {
        // One fixed cell in a free field: the harmonic solution with zero-flux borders is the
        // constant equal to it.
        let (w, h) = (9, 7);
        let mut fixed = FixedMask::new(w, h);
        fixed.fix(4, 3);
        let mut initial = Heightfield::filled(w, h, 0.0).unwrap();
        let i = initial.index(4, 3);
        initial.data_mut()[i] = 5.0;
        let problem = Constraints::new(initial, fixed).unwrap();
        let out = pollster::block_on(jacobi(&problem, 2000, &JobCtx::detached())).unwrap();
        assert_eq!(out.get(4, 3), Some(5.0));
        for v in out.data() {
            assert!((v - 5.0).abs() < 1e-3, "{v}");
        }
    }

    #[test]
    fn rejects_mismatched_mask_and_nan_sources() {
        let field = Heightfield::filled(4, 4, f32::NAN).unwrap();
        assert!(matches!(
            Constraints::new(field.clone(), FixedMask::new(4, 5)),
            Err(super::super::ConstraintsError::SizeMismatch { .. })
        ));
        let mut fixed = FixedMask::new(4, 4);
        fixed.fix(1, 2);
        assert_eq!(
            Constraints::new(field, fixed).unwrap_err(),
            super::super::ConstraintsError::NonFiniteFixed { x: 1, y: 2 }
        );
    }
}
