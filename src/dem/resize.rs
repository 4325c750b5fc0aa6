//! Resampling for export size presets, vertex-registered (the four corner cells keep their
//! heights, as a map coordinate maps to `u * (n - 1)`):
//! - [`resample_corners`]: bilinear, O(output cells);
//! - [`resample_filtered`]: a separable triangle (tent) filter whose support widens with the
//!   reduction (Pillow's antialiased "bilinear"; Wolberg 1990, "Digital Image Warping",
//!   sec. 5.3): bilinear when enlarging, an average over the cells each output cell covers
//!   when shrinking, so a 4096^2 terrain written at 1009^2 keeps its mean slopes instead of
//!   aliasing its ridges. O(input cells).
//!
//! A cell whose stencil touches no-data is no-data.

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// `field` resampled to `width` x `height` cells (each at least 1).
pub fn resample_corners(field: &Heightfield, width: usize, height: usize) -> Heightfield {
    let (w, h) = (field.width(), field.height());
    let axis = |i: usize, n: usize, src: usize| {
        if n <= 1 || src <= 1 {
            return (0, 0, 0.0f32);
        }
        let u = i as f64 * (src - 1) as f64 / (n - 1) as f64;
        let i0 = (u.floor() as usize).min(src - 2);
        (i0, i0 + 1, (u - i0 as f64) as f32)
    };
    let xs: Vec<_> = (0..width.max(1)).map(|x| axis(x, width, w)).collect();
    let d = field.data();
    let mut out = Vec::with_capacity(width.max(1) * height.max(1));
    for y in 0..height.max(1) {
        let (y0, y1, fy) = axis(y, height, h);
        for &(x0, x1, fx) in &xs {
            let tap = |x: usize, y: usize, wgt: f32| {
                if wgt == 0.0 { 0.0 } else { d[y * w + x] * wgt }
            };
            out.push(
                tap(x0, y0, (1.0 - fx) * (1.0 - fy))
                    + tap(x1, y0, fx * (1.0 - fy))
                    + tap(x0, y1, (1.0 - fx) * fy)
                    + tap(x1, y1, fx * fy),
            );
        }
    }
    Heightfield::from_vec(width.max(1), height.max(1), out).expect("non-empty output")
}

/// The taps `(first source index, weights)` of every output index along one axis. The first
/// index may be negative and the last beyond the edge: [`reflected`] reads those.
fn tent_taps(n: usize, src: usize) -> Vec<(isize, Vec<f64>)> {
    (0..n)
        .map(|i| {
            if n <= 1 || src <= 1 {
                return (0, vec![1.0]);
            }
            let step = (src - 1) as f64 / (n - 1) as f64;
            let u = i as f64 * step;
            let support = step.max(1.0);
            let first = (u - support).floor() as isize + 1;
            let last = (u + support).ceil() as isize - 1;
            let mut weights: Vec<f64> = (first..=last.max(first))
                .map(|j| (1.0 - (j as f64 - u).abs() / support).max(0.0))
                .collect();
            let sum: f64 = weights.iter().sum();
            weights.iter_mut().for_each(|w| *w /= sum);
            (first, weights)
        })
        .collect()
}

/// Sample `j` of a line of `len` samples read by `at`, continued beyond its ends by odd
/// reflection (`h(-k) = 2 h(0) - h(k)`), which keeps a plane a plane and the end values.
fn reflected(j: isize, len: usize, at: &dyn Fn(usize) -> f64) -> f64 {
    let last = len as isize - 1;
    let clamp = |k: isize| k.clamp(0, last) as usize;
    if j < 0 {
        2.0 * at(0) - at(clamp(-j))
    } else if j > last {
        2.0 * at(last as usize) - at(clamp(2 * last - j))
    } else {
        at(j as usize)
    }
}

/// `field` resampled to `width` x `height` cells by the tent filter (see the module).
pub fn resample_filtered(field: &Heightfield, width: usize, height: usize) -> Heightfield {
    crate::jobs::finish_inline(|ctx| async move {
        resample_filtered_in(field, width, height, &ctx).await
    })
}

/// [`resample_filtered`] in a job: a tick after each row, so the page paints meanwhile.
pub async fn resample_filtered_in(
    field: &Heightfield,
    width: usize,
    height: usize,
    ctx: &JobCtx,
) -> Result<Heightfield, Cancelled> {
    const WHAT: &str = "resampling";
    let (w, h) = (field.width(), field.height());
    let (width, height) = (width.max(1), height.max(1));
    let xs = tent_taps(width, w);
    let ys = tent_taps(height, h);
    let d = field.data();
    let tap = |(first, weights): &(isize, Vec<f64>), len: usize, at: &dyn Fn(usize) -> f64| {
        weights
            .iter()
            .enumerate()
            .filter(|(_, wgt)| **wgt > 0.0)
            .map(|(k, wgt)| reflected(first + k as isize, len, at) * wgt)
            .sum::<f64>()
    };
    // Rows first (every source row at the output width), then columns.
    let mut rows = Vec::with_capacity(h * width);
    for y in 0..h {
        ctx.tick_of(y, 2 * h, WHAT).await?;
        let row = &d[y * w..(y + 1) * w];
        rows.extend(xs.iter().map(|t| tap(t, w, &|x| f64::from(row[x]))));
    }
    let mut out = Vec::with_capacity(width * height);
    for (y, t) in ys.iter().enumerate() {
        ctx.tick_of(height + y, 2 * height, WHAT).await?;
        for x in 0..width {
            out.push(tap(t, h, &|y| rows[y * width + x]) as f32);
        }
    }
    Ok(Heightfield::from_vec(width, height, out).expect("non-empty output"))
}

/// `field` with its rows in reverse order.
pub fn flipped_y(field: &Heightfield) -> Heightfield {
    let w = field.width();
    let data: Vec<f32> = field.data().chunks(w).rev().flatten().copied().collect();
    Heightfield::from_vec(w, field.height(), data).expect("same size")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shrinking averages: a checkerboard (the finest ridge pattern a grid holds) shrunk by
    /// the tent filter keeps its mean with a small ripple, where bilinear picks cells.
    #[test]
    fn shrinking_averages_instead_of_aliasing() {
        let n = 65;
        let data: Vec<f32> = (0..n * n)
            .map(|i| if (i % n + i / n) % 2 == 0 { 10.0 } else { 0.0 })
            .collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let out = resample_filtered(&field, 17, 17);
        let inner: Vec<f32> = (2..15)
            .flat_map(|y| (2..15).map(move |x| (x, y)))
            .map(|(x, y)| out.get(x, y).unwrap())
            .collect();
        assert!(inner.iter().all(|z| (z - 5.0).abs() < 1.0), "{inner:?}");
        let picked = resample_corners(&field, 17, 17);
        assert!(picked.data().iter().all(|z| *z == 10.0));
    }

    #[test]
    fn corners_are_kept_and_a_plane_stays_a_plane() {
        let (w, h) = (9, 5);
        let plane: Vec<f32> = (0..w * h)
            .map(|i| (i % w) as f32 * 2.0 + (i / w) as f32)
            .collect();
        let field = Heightfield::from_vec(w, h, plane).unwrap();
        let out = resample_corners(&field, 17, 17);
        assert_eq!(out.get(0, 0), field.get(0, 0));
        assert_eq!(out.get(16, 16), field.get(8, 4));
        for y in 0..17 {
            for x in 0..17 {
                let expect = x as f32 * 0.5 * 2.0 + y as f32 * 0.25;
                assert!((out.get(x, y).unwrap() - expect).abs() < 1e-4);
            }
        }
        assert_eq!(resample_corners(&field, 9, 5), field);
        // The tent filter keeps a plane a plane at any size, and its corners.
        for (ow, oh) in [(17, 17), (5, 3), (3, 2), (9, 5)] {
            let out = resample_filtered(&field, ow, oh);
            assert_eq!(out.get(0, 0), field.get(0, 0));
            for y in 0..oh {
                for x in 0..ow {
                    let (u, v) = (
                        x as f32 * 8.0 / (ow - 1) as f32,
                        y as f32 * 4.0 / (oh - 1) as f32,
                    );
                    let expect = u * 2.0 + v;
                    assert!((out.get(x, y).unwrap() - expect).abs() < 1e-4, "{ow}x{oh}");
                }
            }
        }
        assert_eq!(flipped_y(&flipped_y(&field)), field);
    }
}
